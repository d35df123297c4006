//! The paper's two numerical examples as bundled scenes (`fmu/rail_vehicle`, `fmu/slider_crank`),
//! checked against physics computed independently here from the scene data: the static
//! equilibrium of the rail vehicle on its suspension and its Hertz contacts, conservation of the
//! vehicle's forward momentum, the slider-crank's loop closure, and the convergence of the
//! continuous contact analysis to the piecewise (impulsive) one as the contact stiffens.

use crate::common;

use common::{get, rk4_step};
use contact_fmu::bench::work_precision::trajectory_error;
use contact_fmu::bench::{record, RunSpec, Trajectory};
use contact_fmu::scene::{Law, Method, Scene};
use contact_fmu::simulation::Simulation;

fn load(name: &str) -> Simulation {
    Simulation::from_file(&common::bundled(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The bundled rail vehicle with its wheel-rail friction switched off (the paper's example is
/// frictionless; with friction the wheels' spin exchanges momentum with the translation:
/// tests/integration/friction.rs checks the vehicle with friction, braking through its wheels).
fn frictionless_rail_vehicle() -> Simulation {
    let mut sim = load("rail_vehicle");
    let contacts: Vec<String> = sim.scene().contact.iter().map(|c| c.name.clone()).collect();
    for c in contacts {
        for key in ["friction", "static_friction"] {
            sim.set_by_name(&format!("{c}.{key}"), 0.0).expect("friction parameter");
        }
    }
    sim
}

/// Hertz stiffness of a sphere on a plane, eq. (22) with the square-root radius term.
fn hertz_sphere_plane(e1: f64, nu1: f64, e2: f64, nu2: f64, radius: f64) -> f64 {
    let h = |e: f64, nu: f64| (1.0 - nu * nu) / (std::f64::consts::PI * e);
    4.0 / (3.0 * std::f64::consts::PI * (h(e1, nu1) + h(e2, nu2))) * radius.sqrt()
}

fn body<'a>(scene: &'a Scene, name: &str) -> &'a contact_fmu::scene::BodySpec {
    scene.body.iter().find(|b| b.name == name).expect("body exists")
}

fn material(scene: &Scene, name: &Option<String>) -> (f64, f64) {
    let m = scene
        .material
        .iter()
        .find(|m| Some(&m.name) == name.as_ref())
        .expect("material exists");
    (m.youngs_modulus, m.poisson_ratio)
}

/// Runs the rail vehicle's default experiment and checks the settled state against the static
/// equilibrium implied by the scene data, and the vehicle's forward momentum throughout.
#[test]
fn rail_vehicle_settles_to_static_equilibrium_at_constant_speed() {
    let mut sim = frictionless_rail_vehicle();
    let scene = sim.scene().clone();
    let g = -scene.model.gravity[2];
    assert_eq!(scene.model.gravity[0], 0.0);
    assert_eq!(scene.body.len(), 13, "car body, 4 bogies, 8 wheels");
    assert_eq!(scene.contact.len(), 8);
    let total_mass: f64 = scene.body.iter().map(|b| b.mass).sum();
    let v0 = body(&scene, "car").velocity[0];
    assert!((v0 - 80.0 / 3.6).abs() < 1e-12, "80 km/h");
    for b in &scene.body {
        assert_eq!(b.velocity, [v0, 0.0, 0.0], "{} starts at the vehicle's speed", b.name);
    }

    // Forward speed of the whole vehicle's centre of mass: no force acts along X (frictionless
    // normal contacts on horizontal rails, gravity along Z, internal suspension forces).
    let com_vx = |sim: &mut Simulation| -> f64 {
        let names: Vec<(String, f64)> = sim.scene().body.iter().map(|b| (b.name.clone(), b.mass)).collect();
        names
            .iter()
            .map(|(n, m)| m * get(sim, &format!("{n}.v[1]")))
            .sum::<f64>()
            / total_mass
    };
    sim.initialize(0.0).expect("initialises");
    assert_eq!(get(&mut sim, "traction"), 0.0, "no traction by default");
    let stop = scene.model.stop_time;
    let chunks = 50;
    for k in 1..=chunks {
        sim.step_to(stop * k as f64 / chunks as f64).expect("steps");
        let vx = com_vx(&mut sim);
        assert!(
            ((vx - v0) / v0).abs() < 1e-9,
            "t = {}: centre-of-mass speed {vx} m/s, expected {v0}",
            sim.time()
        );
    }

    // Sum of the wheel-rail forces = total weight; each penetration obeys Hertz for its own force.
    let mut sum = 0.0;
    for c in &scene.contact {
        let f = get(&mut sim, &format!("{}.force", c.name));
        let k = get(&mut sim, &format!("{}.stiffness", c.name));
        let delta = get(&mut sim, &format!("{}.delta", c.name));
        assert!(f > 0.0, "{} carries load", c.name);
        let hertz = (f / k).powf(2.0 / 3.0);
        assert!(
            ((delta - hertz) / hertz).abs() < 1e-4,
            "{}: delta {delta} m, (F/K)^(2/3) = {hertz} m",
            c.name
        );
        sum += f;
    }
    let weight = total_mass * g;
    assert!(
        ((sum - weight) / weight).abs() < 1e-4,
        "wheel forces {sum} N, weight {weight} N"
    );

    // Static equilibrium from the scene data. The layout is symmetric (checked), so each of the
    // suspension springs carries an equal share of the car body's weight and each wheel an equal
    // share of its bogie's load.
    let car = body(&scene, "car");
    let n_springs = scene.spring_damper.len() as f64;
    let mut car_heights = Vec::new();
    for s in &scene.spring_damper {
        assert_eq!(s.body_a, "car");
        assert_eq!(
            (s.point_a[0], s.point_a[1]),
            (s.point_b[0], s.point_b[1]),
            "{} is vertical",
            s.name
        );
        let bogie = body(&scene, &s.body_b);
        let spring_load = car.mass * g / n_springs;
        let wheels: Vec<_> = scene
            .joint
            .iter()
            .filter(|j| j.parent == bogie.name)
            .map(|j| body(&scene, &j.child))
            .collect();
        let wheel_mass: f64 = wheels.iter().map(|w| w.mass).sum();
        let x_mean = wheels.iter().map(|w| w.position[0]).sum::<f64>() / wheels.len() as f64;
        assert!(
            (x_mean - bogie.position[0]).abs() < 1e-12,
            "wheels symmetric about {}",
            bogie.name
        );
        let wheel_load = (spring_load + (bogie.mass + wheel_mass) * g) / wheels.len() as f64;
        for w in &wheels {
            let c = scene
                .contact
                .iter()
                .find(|c| c.sphere_body == w.name)
                .expect("wheel contact");
            let (e1, nu1) = material(&scene, &c.sphere_material);
            let (e2, nu2) = material(&scene, &c.material);
            assert_eq!(c.normal, Some([0.0, 0.0, 1.0]));
            let k = hertz_sphere_plane(e1, nu1, e2, nu2, c.radius);
            let delta = (wheel_load / k).powf(2.0 / 3.0);
            let rail_z = c.origin.expect("rail origin")[2];
            let wheel_z = rail_z + c.radius - delta;
            let sim_delta = get(&mut sim, &format!("{}.delta", c.name));
            assert!(
                ((sim_delta - delta) / delta).abs() < 1e-3,
                "{}: penetration {sim_delta} m, static {delta} m",
                c.name
            );
            // The wheel's centre and the bogie's are at fixed relative heights (revolute joint).
            let bogie_z = wheel_z + (bogie.position[2] - w.position[2]);
            let spring_bottom = bogie_z + (s.point_b[2] - bogie.position[2]);
            let length = s.free_length.expect("free length") - spring_load / s.stiffness;
            car_heights.push(spring_bottom + length + (car.position[2] - s.point_a[2]));
        }
    }
    let expected = car_heights.iter().sum::<f64>() / car_heights.len() as f64;
    for h in &car_heights {
        assert!((h - expected).abs() < 1e-12, "symmetric layout");
    }
    let z = get(&mut sim, "car.r[3]");
    eprintln!("wheel forces {sum} N, weight {weight} N; car height {z} m, static {expected} m");
    assert!(
        (z - expected).abs() < 5e-7,
        "car body height {z} m, static equilibrium {expected} m (difference {:e})",
        z - expected
    );
    assert!(get(&mut sim, "car.v[3]").abs() < 1e-5, "settled");
}

/// Effective restitution of the Lankarani-Nikravesh law with parameter `e`: the rebound speed
/// ratio of the one-degree-of-freedom impact `x'' = -x^1.5 (1 + 3(1-e²)/4 x')`, x'(0) = 1
/// (dimensionless; independent of stiffness, mass and impact speed), by RK4.
fn lankarani_nikravesh_restitution(e: f64) -> f64 {
    let chi = 0.75 * (1.0 - e * e);
    let acc = |x: f64, v: f64| -(x.max(0.0).powf(1.5) * (1.0 + chi * v)).max(0.0);
    let (mut x, mut v, h) = (0.0_f64, 1.0_f64, 2e-5);
    loop {
        let (xn, vn) = rk4_step(acc, x, v, h);
        if xn < 0.0 {
            // linear interpolation of the velocity at the crossing
            return -(v + (vn - v) * x / (x - xn));
        }
        (x, v) = (xn, vn);
    }
}

/// Block trajectory (x, v) of the slider-crank at every communication point, checking the loop
/// residual on the way.
fn slider_crank_run(law: Law, restitution: f64, modulus_scale: f64) -> (Vec<f64>, Vec<f64>) {
    let mut sim = load("slider_crank");
    let scene = sim.scene().clone();
    let modulus = scene.material[0].youngs_modulus;
    sim.set_by_name("impact.law", law as i64 as f64).expect("law");
    sim.set_by_name("impact.restitution", restitution).expect("restitution");
    sim.set_by_name("aluminium.youngs_modulus", modulus * modulus_scale)
        .expect("modulus");
    sim.initialize(0.0).expect("initialises");
    let n = 400;
    let (mut xs, mut vs) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let mut worst: f64 = 0.0;
    for k in 1..=n {
        sim.step_to(scene.model.stop_time * k as f64 / n as f64).expect("steps");
        xs.push(get(&mut sim, "block.r[1]"));
        vs.push(get(&mut sim, "block.v[1]"));
        worst = worst.max(sim.constraint_residual().expect("residual"));
    }
    eprintln!("{law:?} x{modulus_scale}: largest loop residual {worst:e}");
    assert!(worst < 1e-9, "{law:?} x{modulus_scale}: loop residual {worst:e}");
    assert_eq!(get(&mut sim, "impact.active"), 0.0, "the contact is over at the end");
    if law == Law::Impulse {
        assert_eq!(get(&mut sim, "impact.impacts"), 1.0, "one impact");
    }
    (xs, vs)
}

/// The loop stays closed through the impact and the crank's dead centres, and the continuous
/// (hertz_ln) analysis approaches the piecewise one as the stiffness grows, with a difference
/// proportional to the contact duration (∝ K^(-2/5)).
///
/// The piecewise run uses the restitution that the Lankarani-Nikravesh law actually produces
/// (computed above from its dimensionless equation): for e < 1 that law rebounds slightly
/// faster than `e` says, so with the same `e` the two analyses differ by that bias even in the
/// rigid limit (measured in docs/examples.md).
#[test]
fn slider_crank_continuous_converges_to_piecewise_as_stiffness_grows() {
    let e = load("slider_crank").scene().contact[0].restitution;
    let e_ln = lankarani_nikravesh_restitution(e);
    assert!(e_ln > e && e_ln < e + 0.05, "LN restitution {e_ln} for e = {e}");
    let (xp, vp) = slider_crank_run(Law::Impulse, e_ln, 1.0);
    // the block rebounds: it moved at -5 m/s and ends moving away from the slider
    assert!(vp[vp.len() - 1] > 0.5);
    let scales = [1e-4, 1e-3, 1e-2, 1e-1, 1.0];
    let mut dx = Vec::new();
    let mut dv = Vec::new();
    for &s in &scales {
        let (xc, vc) = slider_crank_run(Law::HertzLn, e, s);
        dx.push(xc.iter().zip(&xp).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max));
        dv.push((vc[vc.len() - 1] - vp[vp.len() - 1]).abs());
    }
    eprintln!("scales {scales:?}\nmax |x diff| {dx:?}\n|v diff| {dv:?}");
    for i in 1..scales.len() {
        assert!(dx[i] < dx[i - 1], "max |x diff| not shrinking: {dx:?}");
        assert!(dv[i] < dv[i - 1], "post-impact |v diff| not shrinking: {dv:?}");
        // first order in the contact duration: a decade of stiffness shrinks it by 10^(2/5)
        let ratio = dx[i - 1] / dx[i];
        assert!(
            (ratio - 10f64.powf(0.4)).abs() < 0.3,
            "x difference ratio per decade {ratio}, expected ~2.51: {dx:?}"
        );
    }
    assert!(dx[scales.len() - 1] < 1e-3, "stiff contact: {dx:?}");
}

/// The `traction` input accelerates the whole vehicle: the centre of mass gains F t / M along X
/// (the normal wheel-rail forces and gravity have no X component, the suspension is internal).
#[test]
fn rail_vehicle_traction_accelerates_the_centre_of_mass() {
    let mut sim = frictionless_rail_vehicle();
    // the bound (1e-9 of the speed) is below what the bundled tolerance (rtol 4e-6, about 1e-6
    // of the range of motion) resolves: this test sets its own
    sim.set_by_name("solver.rtol", 1e-8).expect("rtol");
    sim.set_by_name("solver.atol", 1e-10).expect("atol");
    let bodies: Vec<(String, f64)> = sim.scene().body.iter().map(|b| (b.name.clone(), b.mass)).collect();
    let total_mass: f64 = bodies.iter().map(|(_, m)| m).sum();
    let v0 = 80.0 / 3.6;
    let force = 2.0e4;
    sim.initialize(0.0).expect("initialises");
    sim.set_by_name("traction", force).expect("input");
    for k in 1..=10 {
        let t = 0.1 * k as f64;
        sim.step_to(t).expect("steps");
        let vx = bodies
            .iter()
            .map(|(n, m)| m * get(&mut sim, &format!("{n}.v[1]")))
            .sum::<f64>()
            / total_mass;
        let expected = v0 + force * t / total_mass;
        assert!(
            ((vx - expected) / expected).abs() < 1e-9,
            "t = {t}: centre-of-mass speed {vx} m/s, expected {expected}"
        );
    }
}

/// The outputs at the communication points come from the implicit method's dense output, also
/// on the stiff components (the wheels' spin under the regularised wheel-rail friction,
/// λ ≈ −6,100 s⁻¹): the bundled rail vehicle's friction forces and slip velocities at every
/// point of its default experiment against a run at rtol 1e-10, to 2 % of the friction
/// capacity μ F_n and of the stiction velocity. (Below the stiction velocity the force grows
/// at 1.6e6 N s/m per wheel, so the slip's error at the bundled rtol alone moves it by tens of
/// newtons: the collocation polynomial gave 0.7 % and 0.4 % at rtol 1e-5; an interpolant through `h·f`,
/// which carries `hλ` times the state's error, gave 19 % for the force.)
#[test]
fn the_rail_vehicles_friction_outputs_between_steps_follow_a_tight_run() {
    let wheels = ["contact_fl1", "contact_rr2"];
    let run = |tight: bool| -> Vec<Vec<f64>> {
        let mut s = load("rail_vehicle");
        if tight {
            s.set_by_name("solver.rtol", 1e-10).unwrap();
            s.set_by_name("solver.atol", 1e-12).unwrap();
        }
        s.initialize(0.0).unwrap();
        let (stop, interval) = (s.scene().model.stop_time, s.scene().model.interval);
        let mut rows = Vec::new();
        s.run(stop, interval, |s| {
            let mut row = Vec::new();
            for w in wheels {
                let capacity = get(s, &format!("{w}.friction")) * get(s, &format!("{w}.force"));
                row.push(get(s, &format!("{w}.friction_force[1]")) / capacity);
                row.push(get(s, &format!("{w}.slip_velocity")) / get(s, &format!("{w}.stiction_velocity")));
            }
            rows.push(row);
            Ok(())
        })
        .unwrap();
        rows
    };
    let (bundled, reference) = (run(false), run(true));
    for j in 0..2 * wheels.len() {
        let what = if j % 2 == 0 {
            "friction force / μ F_n"
        } else {
            "slip velocity / v_s"
        };
        let worst = bundled
            .iter()
            .zip(&reference)
            .map(|(a, b)| (a[j] - b[j]).abs())
            .fold(0.0, f64::max);
        println!("{} {what}: largest difference {worst:.2e}", wheels[j / 2]);
        assert!(worst < 0.02, "{} {what}: {worst:e} off a tight run", wheels[j / 2]);
    }
}

/// At rtol 1e-3 (atol 7.5e-5) the wheels' slip crosses the band of the regularised friction law
/// within radau5's long steps and its Newton iteration keeps failing (36,000 evaluations and
/// 580 Jacobians before `auto` measured the implicit method's cost). `auto` now switches back
/// to Dormand-Prince when the implicit method spends more than twice Dormand-Prince's cost at
/// its stability limit, and stays there while Dormand-Prince is cheaper; and radau5 bounds its
/// step after a Newton failure with a fresh Jacobian, growing the bound by 1.2 per accepted
/// step. Both take fewer evaluations than dopri5 (auto at most 1.3× in any case) and few
/// Jacobians; radau5's error is at most twice dopri5's, auto's below 5 rtol (positions of
/// every body at every communication point against a tight run, each relative to its range
/// of motion).
#[test]
fn implicit_methods_whose_newton_iteration_keeps_failing_do_not_thrash() {
    let scene = Scene::from_file(&common::bundled("rail_vehicle")).unwrap();
    let positions: Vec<String> = scene
        .body
        .iter()
        .flat_map(|b| (1..=3).map(move |k| format!("{}.r[{k}]", b.name)))
        .collect();
    let outputs: Vec<&str> = positions.iter().map(String::as_str).collect();
    // the work-precision benchmark's run and error (each position relative to its range)
    let run = |method: Method, rtol: f64, atol: f64| {
        let spec = RunSpec::new(scene.clone(), "rail_vehicle", 5.0, 0.01)
            .method(method)
            .with("solver.rtol", rtol)
            .with("solver.atol", atol);
        let out = record(&spec, &outputs).unwrap();
        assert!(out.failure.is_none(), "{method:?}: {:?}", out.failure);
        (out.counters, out.traj)
    };
    let (_, reference) = run(Method::Auto, 1e-9, 1e-11);
    let error = |traj: &Trajectory| trajectory_error(traj, &reference);
    let (auto, auto_rows) = run(Method::Auto, 1e-3, 7.5e-5);
    let (radau5, radau5_rows) = run(Method::Radau5, 1e-3, 7.5e-5);
    let (dopri5, dopri5_rows) = run(Method::Dopri5, 1e-3, 7.5e-5);
    let (ea, er, ed) = (error(&auto_rows), error(&radau5_rows), error(&dopri5_rows));
    println!("auto {auto:?} error {ea:.2e}\nradau5 {radau5:?} error {er:.2e}\ndopri5 {dopri5:?} error {ed:.2e}");
    assert!(
        auto.rhs_evals as f64 <= 1.3 * dopri5.rhs_evals as f64,
        "auto {auto:?}, dopri5 {dopri5:?}"
    );
    assert!(ea < 5e-3, "auto {ea:e}, dopri5 {ed:e}");
    // radau5 alone: the step-size bound after a Newton failure with a fresh Jacobian (it took
    // 31,344 evaluations and 510 Jacobians in 908 steps without it)
    // (the errors at this tolerance are erratic: auto's was 1.06e-3 with the cost rule alone,
    // 2.4e-3 with the bound and a ratio of 2, 4.3e-5 now; the work-precision sweep compares
    // the methods at equal error)
    for (name, c) in [("auto", auto), ("radau5", radau5)] {
        assert!(
            c.jac_evals <= 60 && c.rhs_evals <= dopri5.rhs_evals,
            "{name} {c:?}, dopri5 {dopri5:?}"
        );
    }
    assert!(er <= 2.0 * ed, "radau5 {er:e}, dopri5 {ed:e}");
}

/// The rattling pile (`pile_of_balls` at rtol 1e-3): Dormand-Prince sits at its stability
/// limit, but Radau IIA's steps are no longer (the collisions bound them), so a stint there
/// costs more than it saves (on 300 states a factorisation costs some 300 evaluations). auto
/// takes about dopri5's evaluations and few Jacobians: its stints end at their early check and
/// the hold passes to the islands formed anew (before: 1.29× dopri5's evaluations and 88
/// Jacobians at this tolerance; now 1.01× and 5).
#[test]
fn a_rattling_pile_does_not_pay_for_implicit_stints() {
    let scene = Scene::from_file(&common::bundled("pile_of_balls")).unwrap();
    let run = |method: Method| {
        let spec = RunSpec::new(scene.clone(), "pile_of_balls", 0.4, 1e-3)
            .method(method)
            .with("solver.rtol", 1e-3)
            .with("solver.atol", 1e-5);
        let out = record(&spec, &["ball1.r[3]"]).unwrap();
        assert!(out.failure.is_none(), "{method:?}: {:?}", out.failure);
        out.counters
    };
    let (auto, dopri5) = (run(Method::Auto), run(Method::Dopri5));
    println!("auto {auto:?}\ndopri5 {dopri5:?}");
    assert!(
        auto.rhs_evals as f64 <= 1.1 * dopri5.rhs_evals as f64,
        "auto {auto:?}, dopri5 {dopri5:?}"
    );
    assert!(auto.jac_evals <= 30, "auto {auto:?}");
}
