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

/// Integrates the row of `count` spheres to `t_end` with `method` at tolerance `tol`; the
/// final state, the step counters and the linear-algebra counters.
fn run(count: usize, method: Method, sparse: bool, t_end: f64, tol: f64) -> (Vec<f64>, u64, u64, LinearStats) {
    let (m, mut d) = resting_row(count);
    let y0 = d.state.clone();
    let n = y0.len();
    let (rtol, atol) = (tol, 1e-3 * tol);
    let mut integ: Box<dyn Integrator> = match method {
        Method::Radau5 => Box::new(Radau5::with_linear(n, rtol, atol, 0.0, sparse)),
        _ => Box::new(Sdirk::with_linear(n, rtol, atol, 0.0, sparse)),
    };
    let mut sys = Rhs {
        model: &m,
        data: &mut d,
    };
    integ.reset(&mut sys, 0.0, &y0, 0.0);
    while integ.t() < t_end {
        integ.step(&mut sys, t_end).expect("step");
    }
    let s = integ.stats();
    (
        integ.y().to_vec(),
        s.steps,
        s.jac_evals,
        integ.linear_stats().expect("implicit"),
    )
}

/// Largest difference relative to 1 mm (or m/s) plus the value.
fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / (1e-3 + x.abs()))
        .fold(0.0, f64::max)
}

#[test]
fn sparse_path_agrees_with_the_dense_path() {
    let count = 16; // n = 209 (13 per sphere and the dissipated energy)
    let t_end = 0.01;
    let reference = run(count, Method::Radau5, false, t_end, 1e-10).0;
    for method in [Method::Sdirk, Method::Radau5] {
        let (yd, steps_d, jac_d, ld) = run(count, method, false, t_end, 1e-6);
        let (ys, steps_s, jac_s, ls) = run(count, method, true, t_end, 1e-6);
        assert!(!ld.sparse && ld.sparse_factorisations == 0, "{method:?}: {ld:?}");
        assert!(ls.sparse && ls.sparse_factorisations > 0, "{method:?}: {ls:?}");
        assert!(
            ls.probes >= 1 && ls.coloured >= 1 && ls.colours <= 3 * 13,
            "{method:?}: {ls:?}"
        );
        let (err_d, err_s, between) = (rel_diff(&reference, &yd), rel_diff(&reference, &ys), rel_diff(&yd, &ys));
        println!(
            "{method:?}: dense {steps_d} steps {jac_d} Jacobians, error {err_d:.2e}; sparse {steps_s} steps {jac_s} Jacobians, error {err_s:.2e}, {ls:?}; dense - sparse {between:.2e}"
        );
        // both paths solve the same equations to the same tolerance: equally accurate
        assert!(
            err_s <= 2.0 * err_d + 1e-7,
            "{method:?}: sparse error {err_s:e}, dense {err_d:e}"
        );
        assert!(between <= 2.0 * err_d.max(err_s) + 1e-7, "{method:?}: {between:e}");
    }
}

#[test]
fn sparse_path_runs_a_large_stiff_system() {
    let count = 200; // n = 2601
    for method in [Method::Sdirk, Method::Radau5] {
        let (y, steps, jac, ls) = run(count, method, true, 0.002, 1e-6);
        println!("{method:?}: n = {}, {steps} steps, {jac} Jacobians, {ls:?}", y.len());
        assert!(y.iter().all(|v| v.is_finite()));
        assert!(
            ls.sparse && ls.sparse_factorisations > 0 && ls.colours < 100,
            "{method:?}: {ls:?}"
        );
        assert!(jac >= 1);
    }
}

/// A state saved on the sparse path (its Jacobian's pattern and values, no factors) continues
/// bit for bit in a fresh integrator, which analyses and factors again on load.
#[test]
fn a_sparse_state_continues_bit_for_bit() {
    let count = 16;
    for method in [Method::Sdirk, Method::Radau5] {
        let (m, mut d) = resting_row(count);
        let y0 = d.state.clone();
        let n = y0.len();
        let make = || -> Box<dyn Integrator> {
            match method {
                Method::Radau5 => Box::new(Radau5::with_linear(n, 1e-6, 1e-9, 0.0, true)),
                _ => Box::new(Sdirk::with_linear(n, 1e-6, 1e-9, 0.0, true)),
            }
        };
        let mut a = make();
        let mut sys = Rhs {
            model: &m,
            data: &mut d,
        };
        a.reset(&mut sys, 0.0, &y0, 0.0);
        let mut saved_with_coloured = false;
        let mut checked = 0;
        for k in 0..400 {
            a.step(&mut sys, 1.0).expect("step");
            let ls = a.linear_stats().unwrap();
            // save after the first Jacobian, and once a coloured Jacobian is held
            if (k == 40 && ls.probes >= 1) || (!saved_with_coloured && ls.coloured >= 1) {
                saved_with_coloured |= ls.coloured >= 1;
                let mut state = Vec::new();
                a.save_state(&mut state);
                let mut b = make();
                b.load_state(&state).expect("loads");
                let mut again = Vec::new();
                b.save_state(&mut again);
                assert_eq!(state.len(), again.len());
                assert!(state.iter().zip(&again).all(|(x, y)| x.to_bits() == y.to_bits()));
                let mut a2 = make();
                a2.load_state(&state).expect("loads");
                for _ in 0..60 {
                    a2.step(&mut sys, 1.0).expect("step");
                    b.step(&mut sys, 1.0).expect("step");
                    assert_eq!(a2.t().to_bits(), b.t().to_bits());
                    assert!(a2.y().iter().zip(b.y()).all(|(x, y)| x.to_bits() == y.to_bits()));
                }
                // and the original, continued, is the same run
                let mut b_state = Vec::new();
                b.save_state(&mut b_state);
                for _ in 0..60 {
                    a.step(&mut sys, 1.0).expect("step");
                }
                let mut a_state = Vec::new();
                a.save_state(&mut a_state);
                assert!(
                    a_state.iter().zip(&b_state).all(|(x, y)| x.to_bits() == y.to_bits()),
                    "{method:?}: the loaded run left the original"
                );
                checked += 1;
            }
        }
        assert!(saved_with_coloured && checked >= 1, "{method:?}: {checked} checks");
    }
}
