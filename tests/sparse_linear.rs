//! The implicit methods' sparse path (src/integrator/linear.rs) on a large stiff multibody
//! system: a row of steel spheres resting on a steel plate and pressed lightly against their
//! neighbours (Hertz contact with Lankarani-Nikravesh damping), integrated directly on the
//! model's right-hand side with every contact active. The sparse path agrees with the dense
//! one where both run, and runs alone at n in the thousands.

use contact_fmu::compile::compile;
use contact_fmu::forward::Rhs;
use contact_fmu::integrator::linear::LinearStats;
use contact_fmu::integrator::radau::Radau5;
use contact_fmu::integrator::sdirk::Sdirk;
use contact_fmu::integrator::Integrator;
use contact_fmu::model::{Data, Model};
use contact_fmu::scene::{BodySpec, ContactSpec, Law, Method, GROUND};
use contact_fmu::scene_builder::{Plane, SceneBuilder, Sphere};

const R: f64 = 0.01;
const MASS: f64 = 0.033;

/// `count` spheres in a row on a plate, neighbours overlapping by 1 µm, each touching the
/// plate about at its static penetration, with small alternating vertical velocities.
fn resting_row(count: usize) -> (Model, Data) {
    let mut b = SceneBuilder::new("resting_row")
        .gravity([0.0, 0.0, -9.81])
        .experiment(0.01, 1e-3)
        .solver(Method::Sdirk, 1e-6, 1e-9, 0.0)
        .steel();
    let x = |i: usize| i as f64 * (2.0 * R - 1e-6);
    let z = R - 2e-7;
    for i in 0..count {
        let v = if i % 2 == 0 { 1e-3 } else { -1e-3 };
        b = b.body(BodySpec::sphere(&format!("s{i}"), MASS, R, [x(i), 0.0, z]).velocity([0.0, 0.0, v]));
    }
    for i in 0..count {
        let me = || Sphere::new(&format!("s{i}"), [x(i), 0.0, z], R);
        b = b.contact(
            ContactSpec::sphere_plane(
                &format!("floor{i}"),
                Law::HertzLn,
                me(),
                GROUND,
                Plane::horizontal([x(count) / 2.0, 0.0, 0.0], [x(count) + 1.0, 1.0]),
            )
            .restitution(0.5)
            .materials("steel", "steel"),
        );
        if i + 1 < count {
            let next = Sphere::new(&format!("s{}", i + 1), [x(i + 1), 0.0, z], R);
            b = b.contact(
                ContactSpec::sphere_sphere(&format!("pair{i}"), Law::HertzLn, me(), next)
                    .restitution(0.5)
                    .materials("steel", "steel"),
            );
        }
    }
    let scene = b.build();
    let (m, mut d) = compile(&scene, "resting_row").expect("compiles");
    for mem in d.contact_memory.iter_mut() {
        mem.active = true;
        mem.impact_velocity = 0.01;
    }
    (m, d)
}

/// Integrates the row of `count` spheres to `t_end` with `method`; the final state, the step
/// counters and the linear-algebra counters.
fn run(count: usize, method: Method, sparse: bool, t_end: f64) -> (Vec<f64>, u64, u64, LinearStats) {
    let (m, mut d) = resting_row(count);
    let y0 = d.state.clone();
    let n = y0.len();
    let (rtol, atol) = (1e-6, 1e-9);
    let mut integ: Box<dyn Integrator> = match method {
        Method::Radau5 => Box::new(Radau5::with_linear(n, rtol, atol, 0.0, sparse)),
        _ => Box::new(Sdirk::with_linear(n, rtol, atol, 0.0, sparse)),
    };
    let mut sys = Rhs { model: &m, data: &mut d };
    integ.reset(&mut sys, 0.0, &y0, 0.0);
    while integ.t() < t_end {
        integ.step(&mut sys, t_end).expect("step");
    }
    let s = integ.stats();
    (integ.y().to_vec(), s.steps, s.jac_evals, integ.linear_stats().expect("implicit"))
}

#[test]
fn sparse_path_agrees_with_the_dense_path() {
    let count = 16; // n = 208
    for method in [Method::Sdirk, Method::Radau5] {
        let (yd, steps_d, jac_d, ld) = run(count, method, false, 0.01);
        let (ys, steps_s, jac_s, ls) = run(count, method, true, 0.01);
        assert!(!ld.sparse && ld.sparse_factorisations == 0, "{method:?}: {ld:?}");
        assert!(ls.sparse && ls.sparse_factorisations > 0, "{method:?}: {ls:?}");
        assert!(ls.probes >= 1 && ls.colours < 13 * count / 4, "{method:?}: {ls:?}");
        let worst = yd.iter().zip(&ys).map(|(a, b)| (a - b).abs() / (1e-3 + a.abs())).fold(0.0, f64::max);
        println!(
            "{method:?}: dense {steps_d} steps {jac_d} Jacobians, sparse {steps_s} steps {jac_s} Jacobians {ls:?}; largest relative difference {worst:e}"
        );
        assert!(worst < 1e-5, "{method:?}: dense and sparse differ by {worst:e}");
    }
}

#[test]
fn sparse_path_runs_a_large_stiff_system() {
    let count = 200; // n = 2600
    for method in [Method::Sdirk, Method::Radau5] {
        let (y, steps, jac, ls) = run(count, method, true, 0.005);
        println!("{method:?}: n = {}, {steps} steps, {jac} Jacobians, {ls:?}", y.len());
        assert!(y.iter().all(|v| v.is_finite()));
        assert!(ls.sparse && ls.sparse_factorisations > 0 && ls.colours < 100, "{method:?}: {ls:?}");
        assert!(jac >= 1);
    }
}
