//! Motion inputs (`joint_motion`): a host drives a 1-DOF joint by its coordinate, rate and
//! acceleration and reads the force the drive exerts.
//!
//! - a crank driven at a prescribed speed with its loop closed (the slider-crank): the drive
//!   torque against the power balance, the block's impact still resolved;
//! - a ball bouncing (impulse law) on a table driven up and down: impact times, impulses and
//!   the ball's flight against the closed form;
//! - the energy balance `total + dissipated − input_work` with every kind of input driven;
//! - `static_friction` follows `friction` when only the latter is set: the closed-form onset of
//!   rolling of a sliding ball;
//! - bad input: a joint_motion on a 3-DOF, unknown, loop-closing or already driven joint, and
//!   non-finite values from a host.
//!
//! The base-excited oscillator (exact solution, transmissibility, Newton's law for the drive
//! force) runs through fmpy: `tests/python/test_motion.py`.

use crate::common;

use common::get;
use contact_fmu::model::ContactEventKind;
use contact_fmu::scene::{BodySpec, ContactSpec, InputSpec, JointSpec, JointType, Law, Method, GROUND};
use contact_fmu::scene_builder::{Plane, SceneBuilder, Sphere};
use contact_fmu::simulation::Simulation;

const G: f64 = 9.81;

/// `energy.total + energy.dissipated − energy.input_work`.
fn balance(s: &mut Simulation) -> f64 {
    get(s, "energy.total") + get(s, "energy.dissipated") - get(s, "energy.input_work")
}

/// The bundled slider-crank with its crank pivot driven by the input `motor`, at rtol 1e-9,
/// atol 1e-12: the energy balance is checked to 1e-6 of the kinetic energy, which the scene's
/// own tolerances (rtol 1e-6, chosen for 1e-6 of the range of motion) do not resolve over the
/// block's impacts (7e-6 already at rtol 1e-7).
fn driven_crank() -> Simulation {
    let text = std::fs::read_to_string(common::bundled("slider_crank")).unwrap();
    let text = format!("{text}\n[[input]]\nname = \"motor\"\ntype = \"joint_motion\"\njoint = \"crank_pivot\"\n");
    let mut s = Simulation::from_scene_str(&text, "driven_crank.toml").unwrap();
    s.set_by_name("solver.rtol", 1e-9).unwrap();
    s.set_by_name("solver.atol", 1e-12).unwrap();
    s.initialize(0.0).unwrap();
    s
}

#[test]
fn a_crank_driven_at_constant_speed_takes_the_torque_of_the_power_balance() {
    let mut s = driven_crank();
    let omega = -20.0; // rad/s about the pivot axis (y): the crank pin moves toward the block
    let e0 = balance(&mut s);
    s.set_by_name("motor.qd", omega).unwrap();
    // the host's jump of the rate counts as input work: the balance holds across it
    let jump = (balance(&mut s) - e0).abs();
    assert!(jump < 1e-12, "balance moved by {jump:e} J when the rate was set");
    let (h, steps) = (1e-4, 4000);
    let mut scale = get(&mut s, "energy.kinetic");
    let (mut worst_rate, mut worst_power, mut peak_power) = (0.0_f64, 0.0_f64, 0.0_f64);
    let mut largest_contact_force = 0.0_f64;
    for k in 1..=steps {
        let t = k as f64 * h;
        s.step_to(t).unwrap();
        // the crank turns at the prescribed rate, exactly
        let rate = get(&mut s, "crank_pivot.qd");
        let angle = get(&mut s, "crank_pivot.q");
        worst_rate = worst_rate.max((rate - omega).abs()).max((angle - omega * t).abs());
        scale = scale.max(get(&mut s, "energy.kinetic"));
        largest_contact_force = largest_contact_force.max(get(&mut s, "impact.force"));
        if k % 400 == 200 {
            // the drive's power against the rate of change of total + dissipated energy
            // (central differences over ±1 µs from a saved state)
            let snap = s.snapshot(Vec::new());
            let power = get(&mut s, "motor.force") * omega;
            let eps = 1e-6;
            let at = |dt: f64| {
                let mut probe = driven_crank();
                probe.restore(&snap).unwrap();
                probe.step_to(t + dt).unwrap();
                get(&mut probe, "energy.total") + get(&mut probe, "energy.dissipated")
            };
            let e_now = get(&mut s, "energy.total") + get(&mut s, "energy.dissipated");
            // second-order one-sided difference
            let rate_of_energy = (-3.0 * e_now + 4.0 * at(eps) - at(2.0 * eps)) / (2.0 * eps);
            peak_power = peak_power.max(power.abs());
            worst_power = worst_power.max((rate_of_energy - power).abs());
        }
    }
    let drift = (balance(&mut s) - e0).abs() / scale;
    println!(
        "driven crank: rate off by {worst_rate:.2e}, power balance off by {worst_power:.3e} W (peak {peak_power:.3} W), \
         energy balance {drift:.2e} of {scale:.3} J, largest contact force {largest_contact_force:.1} N, input work {:.4} J",
        get(&mut s, "energy.input_work")
    );
    assert!(
        worst_rate < 1e-10,
        "the crank left its prescribed motion by {worst_rate:e}"
    );
    assert!(drift < 1e-6, "energy balance drifted by {drift:e}");
    assert!(
        worst_power < 1e-3 * peak_power,
        "drive power against dE/dt: {worst_power:e} W"
    );
    // the block still hits the slider and is resolved
    assert!(largest_contact_force > 100.0, "no impact: {largest_contact_force} N");
}

/// The ball on the vibrating table: the scene, and its parameters.
const BALL_R: f64 = 0.01;
const BALL_M: f64 = 0.05;
const TABLE_A: f64 = 0.002;
const TABLE_W: f64 = 2.0 * std::f64::consts::PI * 15.0;
const E: f64 = 0.8;
const Z0: f64 = 0.025;

fn vibrating_table() -> Simulation {
    let slide = |name, child| JointSpec::new(name, JointType::Prismatic, GROUND, child).axis([0.0, 0.0, 1.0]);
    let ball = Sphere::new("ball", [0.0, 0.0, Z0], BALL_R);
    let scene = SceneBuilder::new("vibrating_table")
        .gravity([0.0, 0.0, -G])
        .experiment(1.0, 1e-3)
        .tolerances(1e-11, 1e-13)
        .body(BodySpec::new("table", 10.0, [0.1, 0.1, 0.1], [0.0; 3]))
        .body(BodySpec::new("ball", BALL_M, [2e-6, 2e-6, 2e-6], [0.0, 0.0, Z0]))
        .joints([slide("table_slide", "table"), slide("ball_slide", "ball")])
        .contact(
            ContactSpec::sphere_plane(
                "hit",
                Law::Impulse,
                ball,
                "table",
                Plane::horizontal([0.0; 3], [1.0, 1.0]),
            )
            .restitution(E),
        )
        .input(InputSpec::joint_motion("shake", "table_slide"));
    common::start(scene)
}

/// The host's drive at communication point `t`: the table's `A sin ωt`, its rate and
/// acceleration (between the points the table follows their quadratic).
fn drive_at(t: f64) -> [f64; 3] {
    let (s, c) = (TABLE_W * t).sin_cos();
    [TABLE_A * s, TABLE_A * TABLE_W * c, -TABLE_A * TABLE_W * TABLE_W * s]
}

/// Gives the input `shake` the table's drive at communication point `t`.
fn set_drive(s: &mut Simulation, t: f64) {
    let [q, qd, qdd] = drive_at(t);
    for (name, value) in [("shake.q", q), ("shake.qd", qd), ("shake.qdd", qdd)] {
        s.set_by_name(name, value).unwrap();
    }
}

/// The closed form: the ball in free flight between impacts on the piecewise quadratic table;
/// each impact `v⁺ = v_t − e (v⁻ − v_t)`. Returns the ball's height at every communication point
/// (k h, k = 0..=n) and the impacts (time, normal impulse).
fn closed_form(h: f64, n: usize) -> (Vec<f64>, Vec<(f64, f64)>) {
    let (mut z, mut v) = (Z0, 0.0);
    let mut heights = vec![z];
    let mut impacts = Vec::new();
    for k in 0..n {
        let t0 = k as f64 * h;
        let [q, qd, qdd] = drive_at(t0);
        let mut tau = 0.0; // where the ball's state (z, v) is, within the interval
        loop {
            // gap(s) = a + b s + c s², s from tau: the ball's bottom over the table
            let (tq, tqd) = (q + qd * tau + 0.5 * qdd * tau * tau, qd + qdd * tau);
            let (a, b, c) = (z - BALL_R - tq, v - tqd, 0.5 * (-G - qdd));
            // the smallest root in (0, h − tau] where the gap closes
            let disc = b * b - 4.0 * a * c;
            let mut hit = None;
            if disc >= 0.0 {
                let r = disc.sqrt();
                let mut roots = [(-b - r) / (2.0 * c), (-b + r) / (2.0 * c)];
                roots.sort_by(f64::total_cmp);
                hit = roots.into_iter().find(|&s| s > 1e-12 && s <= h - tau);
            }
            match hit {
                Some(s) => {
                    z += v * s - 0.5 * G * s * s;
                    v -= G * s;
                    tau += s;
                    let vt = qd + qdd * tau;
                    let after = vt - E * (v - vt);
                    impacts.push((t0 + tau, BALL_M * (after - v)));
                    v = after;
                }
                None => {
                    let s = h - tau;
                    z += v * s - 0.5 * G * s * s;
                    v -= G * s;
                    break;
                }
            }
        }
        heights.push(z);
    }
    (heights, impacts)
}

#[test]
fn a_ball_bounces_on_a_driven_table_at_the_closed_form_impacts() {
    let (h, n) = (1e-3, 1000);
    let (heights, impacts) = closed_form(h, n);
    assert!(impacts.len() >= 5, "{} impacts in the closed form", impacts.len());
    let mut s = vibrating_table();
    let mut worst_height = 0.0_f64;
    for k in 0..n {
        set_drive(&mut s, k as f64 * h);
        s.step_to((k + 1) as f64 * h).unwrap();
        worst_height = worst_height.max((get(&mut s, "ball.r[3]") - heights[k + 1]).abs());
    }
    let located: Vec<(f64, f64)> = s
        .contact_events()
        .iter()
        .filter(|e| e.kind == ContactEventKind::Impact)
        .map(|e| (e.time, e.force))
        .collect();
    println!("closed form: {impacts:?}\nlocated:     {located:?}\nheight off by {worst_height:.2e} m");
    let first = 5;
    assert!(located.len() >= first, "{} impacts located", located.len());
    for (k, ((t, p), (t_exact, p_exact))) in located.iter().zip(&impacts).take(first).enumerate() {
        assert!((t - t_exact).abs() < 1e-9, "impact {k}: t = {t}, closed form {t_exact}");
        assert!(
            (p - p_exact).abs() < 1e-7 * p_exact.abs(),
            "impact {k}: impulse {p}, closed form {p_exact}"
        );
    }
    // over the first bounces, the flight at every communication point
    let until = ((impacts[first - 1].0 / h) as usize).min(n);
    let mut worst = 0.0_f64;
    let mut s = vibrating_table();
    for k in 0..until {
        set_drive(&mut s, k as f64 * h);
        s.step_to((k + 1) as f64 * h).unwrap();
        worst = worst.max((get(&mut s, "ball.r[3]") - heights[k + 1]).abs());
        // the table follows the host's quadratic exactly
        let [q1, qd1, qdd1] = drive_at(k as f64 * h);
        let table = q1 + qd1 * h + 0.5 * qdd1 * h * h;
        assert!(
            (get(&mut s, "table.r[3]") - table).abs() < 1e-13,
            "table off its motion at {k}"
        );
    }
    assert!(worst < 1e-9, "ball height off the closed form by {worst:e} m");
}

#[test]
fn the_energy_balance_counts_the_work_of_every_kind_of_input() {
    // the bundled rail vehicle with traction (a force) and braking (joint forces on every axle)
    let mut s = Simulation::from_file(&common::bundled("rail_vehicle")).unwrap();
    s.initialize(0.0).unwrap();
    let e0 = balance(&mut s);
    let mut scale = get(&mut s, "energy.kinetic");
    for k in 1..=200 {
        let t = k as f64 * 1e-2;
        s.set_by_name("traction", 20_000.0 * (3.0 * t).sin()).unwrap();
        s.set_by_name("axle_torque", -1500.0 * (1.0 + (5.0 * t).cos())).unwrap();
        s.step_to(t).unwrap();
        scale = scale.max(get(&mut s, "energy.kinetic"));
    }
    let work = get(&mut s, "energy.input_work");
    let drift = (balance(&mut s) - e0).abs() / scale;
    println!("rail vehicle, traction and brakes: input work {work:.1} J, balance {drift:.2e} of {scale:.0} J");
    assert!(work.abs() > 1e3, "the inputs did work: {work}");
    assert!(drift < 1e-6, "rail vehicle: {drift:e}");

    // a torque on a free body spinning it up, and a drive: the vibrating table
    let wheel = BodySpec::new("wheel", 2.0, [0.01, 0.02, 0.03], [0.0, 0.0, 1.0]).angular_velocity([0.0, 0.0, 1.0]);
    let scene = SceneBuilder::new("spun")
        .gravity([0.0, 0.0, -G])
        .experiment(1.0, 1e-2)
        .body(wheel)
        .input(InputSpec::torque("spin", "wheel", [0.0, 0.0, 1.0]))
        .build();
    let mut s = common::start(scene);
    let e0 = balance(&mut s);
    s.set_by_name("spin", 0.5).unwrap();
    s.step_to(1.0).unwrap();
    // the torque's work: ½ I (ω₁² − ω₀²) with ω₁ = ω₀ + τ t / I
    let omega1 = 1.0 + 0.5 / 0.03;
    let exact = 0.5 * 0.03 * (omega1 * omega1 - 1.0);
    let work = get(&mut s, "energy.input_work");
    assert!((work - exact).abs() < 1e-8 * exact, "torque work {work}, exact {exact}");
    assert!((balance(&mut s) - e0).abs() < 1e-9 * exact);

    let mut s = vibrating_table();
    let e0 = balance(&mut s);
    for k in 0..400 {
        set_drive(&mut s, k as f64 * 1e-3);
        s.step_to((k + 1) as f64 * 1e-3).unwrap();
    }
    let scale = BALL_M * G * Z0;
    let drift = (balance(&mut s) - e0).abs() / scale;
    println!(
        "vibrating table: input work {:.3e} J, balance {drift:.2e}",
        get(&mut s, "energy.input_work")
    );
    assert!(drift < 1e-6, "vibrating table: {drift:e}");
}

#[test]
fn an_inaccurate_run_still_warns_of_energy_drift() {
    let text = std::fs::read_to_string(common::bundled("bouncing_ball")).unwrap();
    let mut s = Simulation::from_scene_str(&text, "ball.toml").unwrap();
    s.set_by_name("solver.method", contact_fmu::scene::Method::Rk4 as i64 as f64)
        .unwrap();
    s.set_by_name("solver.max_step", 1e-4).unwrap();
    s.initialize(0.0).unwrap();
    // (it warns at its first impact; later it is stopped as a blow-up, its energy grown
    // beyond ten times its scale: tests/python/test_blow_up.py)
    let mut warned = Vec::new();
    for k in 1..=100 {
        let stepped = s.step_to(k as f64 * 1e-2);
        warned.extend(s.take_warnings());
        if stepped.is_err() {
            break;
        }
    }
    assert!(
        warned
            .iter()
            .any(|w| w.contains("energy.input_work") && w.contains("drifted")),
        "{warned:?}"
    );
}

#[test]
fn static_friction_follows_friction_when_only_friction_is_set() {
    // a sliding solid sphere starts rolling at t = 2 v0 / (7 μ g)
    let (m, r, v0, mu) = (1.0, 0.05, 1.0, 0.3);
    let k = 1e13;
    let delta0 = (m * G / k).powf(2.0 / 3.0);
    let ball = BodySpec::sphere("ball", m, r, [0.0, 0.0, r - delta0]).velocity([v0, 0.0, 0.0]);
    let floor = ContactSpec::sphere_plane(
        "floor",
        Law::Hertz,
        Sphere::of(&ball, r),
        GROUND,
        Plane::horizontal([0.0; 3], [100.0, 100.0]),
    )
    .stiffness(k)
    .stiction_velocity(1e-7);
    let mut scene = SceneBuilder::new("slide")
        .gravity([0.0, 0.0, -G])
        .experiment(1.0, 1e-2)
        .solver(Method::Dopri5, 1e-11, 1e-15, 1e-2)
        .body(ball)
        .contact(floor)
        .build();
    scene.solver.max_steps = 10_000_000;
    let mut s = common::open(scene.clone());
    // the host sets friction only; static friction follows it (a flat Stribeck curve)
    s.set_by_name("floor.friction", mu).unwrap();
    assert_eq!(get(&mut s, "floor.static_friction"), mu);
    s.initialize(0.0).unwrap();
    let t_roll = 2.0 * v0 / (7.0 * mu * G);
    s.step_to(1.05 * t_roll).unwrap();
    let stick = s
        .contact_events()
        .iter()
        .find(|e| e.kind == ContactEventKind::Stick)
        .map(|e| e.time)
        .expect("a Stick event");
    let off = (stick - t_roll).abs() / t_roll;
    println!("rolling onset {stick:.6} s, closed form {t_roll:.6} s ({off:.2e})");
    assert!(off <= 5e-3, "onset off by {off:e}");
    // the host may still set it apart
    let mut s = common::open(scene);
    s.set_by_name("floor.friction", mu).unwrap();
    s.set_by_name("floor.static_friction", 0.5).unwrap();
    assert_eq!(get(&mut s, "floor.static_friction"), 0.5);
}

#[test]
fn bad_motion_inputs_are_refused_with_a_message() {
    let base = std::fs::read_to_string(common::bundled("slider_crank")).unwrap();
    let with = |input: &str| format!("{base}\n{input}\n");
    let motion = |joint: &str| format!("[[input]]\nname = \"m\"\ntype = \"joint_motion\"\njoint = \"{joint}\"\n");
    let spherical = base.replacen(
        "name = \"crank_pin\"\ntype = \"revolute\"",
        "name = \"crank_pin\"\ntype = \"spherical\"",
        1,
    );
    for (text, fragments) in [
        (
            with(&motion("nowhere")),
            vec!["input \"m\"", "joint", "unknown joint \"nowhere\""],
        ),
        (
            format!("{spherical}\n{}", motion("crank_pin")),
            vec!["input \"m\"", "not a 1-DOF joint"],
        ),
        (with(&motion("slider_pin")), vec!["input \"m\"", "closes a loop"]),
        (
            with(&format!(
                "{}\n[[input]]\nname = \"m2\"\ntype = \"joint_motion\"\njoint = \"crank_pivot\"\n",
                motion("crank_pivot")
            )),
            vec!["input \"m2\"", "already driven by input \"m\""],
        ),
    ] {
        let err = match Simulation::from_scene_str(&text, "bad.toml") {
            Err(e) => e.to_string(),
            Ok(mut s) => s
                .initialize(0.0)
                .map(|_| String::new())
                .unwrap_or_else(|e| e.to_string()),
        };
        for f in &fragments {
            assert!(err.contains(f), "{err:?} lacks {f:?}");
        }
    }
    // non-finite values from a host: refused, naming the input; nothing changes
    let mut s = driven_crank();
    s.step_to(1e-3).unwrap();
    let before = s.snapshot(Vec::new());
    for name in ["motor.q", "motor.qd", "motor.qdd"] {
        for x in [f64::NAN, f64::INFINITY] {
            let err = s.set_by_name(name, x).unwrap_err().to_string();
            assert!(err.contains(name), "{err}");
        }
    }
    assert_eq!(s.snapshot(Vec::new()), before, "a refused value changed the simulation");
    s.step_to(2e-3).unwrap();
}
