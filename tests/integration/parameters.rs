//! Spring-damper constants, initial body velocities, masses and inertias, contact radii and
//! sizes are FMU parameters: set before initialisation, they change the model as the same
//! scene keys would (closed forms; bit for bit the scene edited by hand), and a value the
//! scene would refuse is refused with a message naming the variable.

use crate::common;

use contact_fmu::contact::laws::hertz_stiffness;
use contact_fmu::scene::{BodySpec, ContactSpec, ContactType, JointSpec, Law, Scene, Side, SpringDamperSpec, GROUND};
use contact_fmu::scene_builder::{Cylinder, SceneBuilder, Sphere};
use contact_fmu::simulation::Simulation;

/// A 2 kg mass on a slide along x, tied to the ground by a spring (200 N/m, no damping, free
/// length the initial distance of 1 m), without gravity.
fn oscillator() -> Scene {
    SceneBuilder::new("oscillator")
        .gravity([0.0, 0.0, 0.0])
        .tolerances(1e-10, 1e-12)
        .body(BodySpec::new("mass", 2.0, [0.01; 3], [0.0; 3]))
        .joint(JointSpec::prismatic("slide", GROUND, "mass", [0.0; 3], [1.0, 0.0, 0.0]))
        .spring_damper(SpringDamperSpec::new(
            "spring",
            GROUND,
            [-1.0, 0.0, 0.0],
            "mass",
            [0.0; 3],
            200.0,
        ))
        .build()
}

fn get(s: &mut Simulation, name: &str) -> f64 {
    let vr = s.table().index_of(name).unwrap_or_else(|| panic!("no variable {name}"));
    s.get(vr).unwrap()
}

/// Position of the mass at `t` after initialisation with the parameters `set`.
fn position_at(set: &[(&str, f64)], t: f64) -> (Simulation, f64) {
    let mut s = Simulation::new(oscillator(), "oscillator");
    for (name, value) in set {
        s.set_by_name(name, *value).unwrap();
    }
    s.initialize(0.0).unwrap();
    s.step_to(t).unwrap();
    let x = get(&mut s, "mass.r[1]");
    (s, x)
}

#[test]
fn spring_parameters_change_the_oscillation_as_the_closed_form_says() {
    let (m, t) = (2.0, 0.37);
    // defaults: free length = initial distance, so the mass rests
    assert_eq!(position_at(&[], t).1, 0.0);
    for k in [200.0, 800.0] {
        // a free length 1 cm longer pushes the mass to x = 0.01: x(t) = 0.01 (1 − cos ω t),
        // ω = sqrt(k/m)
        let (_, x) = position_at(&[("spring.stiffness", k), ("spring.free_length", 1.01)], t);
        let exact = 0.01 * (1.0 - ((k / m).sqrt() * t).cos());
        assert!((x - exact).abs() < 1e-9, "k = {k}: x = {x}, closed form {exact}");
    }
    // damping dissipates: total + dissipated stays, dissipated grows
    let (mut s, _) = position_at(&[("spring.free_length", 1.01), ("spring.damping", 3.0)], t);
    let dissipated = get(&mut s, "energy.dissipated");
    let total = get(&mut s, "energy.total");
    assert!(dissipated > 1e-4, "dissipated {dissipated} J of 0.01 J");
    assert!((total + dissipated - 0.5 * 200.0 * 1e-4).abs() < 1e-9);
}

#[test]
fn initial_velocity_parameters_are_projected_onto_the_joints() {
    // the slide allows only x: v = (0.5, 0.3, 0) gives q̇ = 0.5 (least squares), with a warning
    let (mut s, x) = position_at(&[("spring.stiffness", 0.0), ("mass.velocity[1]", 0.5)], 2.0);
    assert!((x - 1.0).abs() < 1e-9, "x = {x}");
    assert!((get(&mut s, "mass.v[1]") - 0.5).abs() < 1e-12);
    let mut s = Simulation::new(oscillator(), "oscillator");
    s.set_by_name("mass.velocity[2]", 0.3).unwrap();
    s.set_by_name("mass.angular_velocity[3]", 1.0).unwrap();
    assert!(
        s.warnings().unwrap().iter().any(|w| w.contains("inconsistent")),
        "{:?}",
        s.warnings()
    );
    assert!(s.set_by_name("mass.velocity[1]", f64::NAN).is_ok());
    assert!(
        s.initialize(0.0).is_err(),
        "a NaN initial velocity is refused at initialisation"
    );
}

/// A steel ball (R = 10 mm) thrown into a horizontal steel trough (inside of a cylinder,
/// ρ = 0.1 m, 0.5 m long): the sphere_cylinder element.
fn trough() -> Scene {
    let ball = BodySpec::sphere("ball", 0.0329, 0.01, [0.0, 0.02, -0.05]).velocity([0.1, 0.3, 0.0]);
    let cylinder = Cylinder::new([0.0; 3], [1.0, 0.0, 0.0], 0.1, 0.5);
    SceneBuilder::new("trough")
        .experiment(0.3, 1e-3)
        .tolerances(1e-9, 1e-12)
        .steel()
        .contact(
            ContactSpec::sphere_cylinder("ball_trough", Law::HertzLn, Sphere::of(&ball, 0.01), GROUND, cylinder)
                .restitution(0.7)
                .materials("steel", "steel")
                .side(Side::Inside),
        )
        .body(ball)
        .build()
}

/// The bundled scenes and the trough: (name, scene, stop time).
fn scenes() -> Vec<(String, Scene, f64)> {
    let mut all: Vec<(String, Scene, f64)> = common::bundled_scenes()
        .into_iter()
        .map(|(name, path)| {
            let scene = Scene::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
            let stop = scene.model.stop_time.min(0.5);
            (name, scene, stop)
        })
        .collect();
    all.push(("trough".into(), common::checked(trough()), 0.3));
    all
}

/// Every new geometry and inertia parameter of `scene` changed a little: the settings by
/// FMU name, and the same change made to the scene by hand. Radii change by 1e-5 relative
/// (the rail vehicle's wheels rest pre-loaded by 26 µm on their rails), the rest by more.
fn edited(scene: &Scene) -> (Vec<(String, f64)>, Scene) {
    let mut set = Vec::new();
    let mut by_hand = scene.clone();
    for b in &mut by_hand.body {
        b.mass *= 1.5;
        set.push((format!("{}.mass", b.name), b.mass));
        for k in 0..3 {
            b.inertia[k] *= 1.25;
            set.push((format!("{}.inertia[{}]", b.name, k + 1), b.inertia[k]));
        }
    }
    let grow = 1.0 + 1e-5;
    for c in &mut by_hand.contact {
        c.radius *= grow;
        set.push((format!("{}.radius", c.name), c.radius));
        match c.kind {
            ContactType::SphereSphere => {
                let r = c.other_radius.unwrap() * grow;
                c.other_radius = Some(r);
                set.push((format!("{}.other_radius", c.name), r));
            }
            ContactType::SpherePlane => {
                let [lu, lv] = c.size.unwrap();
                c.size = Some([lu * 1.1, lv * 0.9]);
                set.push((format!("{}.size[1]", c.name), lu * 1.1));
                set.push((format!("{}.size[2]", c.name), lv * 0.9));
            }
            ContactType::SphereCylinder => {
                let (rho, len) = (c.cylinder_radius.unwrap() * 1.05, c.length.unwrap() * 0.8);
                c.cylinder_radius = Some(rho);
                c.length = Some(len);
                set.push((format!("{}.cylinder_radius", c.name), rho));
                set.push((format!("{}.length", c.name), len));
            }
        }
    }
    by_hand.validate("edited").unwrap_or_else(|e| panic!("{e}"));
    (set, by_hand)
}

/// Every output, as bits, at every communication point of a run to `stop` (the last entry:
/// the error that ended it early, if any).
fn trajectory(mut s: Simulation, stop: f64) -> Vec<Vec<u64>> {
    s.initialize(0.0).unwrap_or_else(|e| panic!("{e}"));
    let outputs = s.output_indices();
    let interval = s.scene().model.interval;
    let mut rows = Vec::new();
    let result = s.run(stop, interval, |s| {
        rows.push(outputs.iter().map(|&i| s.get(i).unwrap().to_bits()).collect());
        Ok(())
    });
    if let Err(e) = result {
        rows.push(e.to_string().bytes().map(u64::from).collect());
    }
    rows
}

#[test]
fn mass_inertia_radius_and_size_parameters_equal_the_scene_edited_by_hand() {
    for (name, scene, stop) in scenes() {
        let (set, by_hand) = edited(&scene);
        let mut s = Simulation::new(scene.clone(), "scene");
        for (var, value) in &set {
            s.set_by_name(var, *value)
                .unwrap_or_else(|e| panic!("{name}: {var}: {e}"));
        }
        let changed = trajectory(s, stop);
        let expected = trajectory(Simulation::new(by_hand, "scene"), stop);
        assert_eq!(changed.len(), expected.len(), "{name}");
        assert!(
            changed == expected,
            "{name}: the parameters differ from the scene edited by hand"
        );
        let unchanged = trajectory(Simulation::new(scene, "scene"), stop);
        assert!(changed != unchanged, "{name}: the parameters changed nothing");
    }
}

#[test]
fn derived_hertz_stiffness_and_default_max_penetration_follow_the_radius() {
    let path = common::bundled("bouncing_ball");
    let mut s = Simulation::from_file(&path).unwrap();
    let k0 = common::get(&mut s, "ball_floor.stiffness");
    // steel on steel, R = 10 mm: K = 4/3 E/(2(1 − ν²)) √R
    let closed = |r: f64| 4.0 / 3.0 * 210e9 / (2.0 * (1.0 - 0.09)) * f64::sqrt(r);
    assert!(
        (k0 - closed(0.01)).abs() < 1e-12 * k0,
        "K = {k0}, closed form {}",
        closed(0.01)
    );
    assert_eq!(common::get(&mut s, "ball_floor.max_penetration"), 0.01);
    s.set_by_name("ball_floor.radius", 0.04).unwrap();
    let k = common::get(&mut s, "ball_floor.stiffness");
    assert!(
        (k - closed(0.04)).abs() < 1e-12 * k,
        "K = {k}, closed form {}",
        closed(0.04)
    );
    assert_eq!(k, hertz_stiffness(210e9, 0.3, 210e9, 0.3, 0.04));
    // the scene gives no max_penetration: its default, the radius, follows...
    assert_eq!(common::get(&mut s, "ball_floor.max_penetration"), 0.04);
    assert_eq!(s.contacts().unwrap()[0].max_penetration, 0.04);
    // ...until the host sets it
    s.set_by_name("ball_floor.max_penetration", 0.002).unwrap();
    s.set_by_name("ball_floor.radius", 0.03).unwrap();
    assert_eq!(common::get(&mut s, "ball_floor.max_penetration"), 0.002);
    assert_eq!(s.contacts().unwrap()[0].max_penetration, 0.002);
}

/// Initialises `scene` with `set`; returns the error message.
fn refused(scene: &Scene, set: &[(&str, f64)]) -> String {
    let mut s = Simulation::new(scene.clone(), "scene");
    for (name, value) in set {
        s.set_by_name(name, *value).unwrap();
    }
    let e = s.initialize(0.0).expect_err("refused").to_string();
    assert!(!s.is_initialized());
    // the instance is usable: with the scene's values again it initialises and runs
    for (name, _) in set {
        let vr = s.table().index_of(name).unwrap();
        let start = s.variables()[vr].start.unwrap();
        s.set(vr, start).unwrap();
    }
    s.initialize(0.0).unwrap_or_else(|e| panic!("{e}"));
    s.step_to(0.01).unwrap();
    e
}

#[test]
fn invalid_inertia_radius_and_size_are_refused_naming_the_variable() {
    let ball = Scene::from_file(&common::bundled("bouncing_ball")).unwrap();
    for (name, value) in [
        ("ball.mass", 0.0),
        ("ball.inertia[2]", -1e-6),
        ("ball.inertia[3]", 0.0),
        ("ball.inertia[1]", f64::NAN),
        ("ball_floor.radius", 0.0),
        ("ball_floor.radius", -0.01),
        ("ball_floor.radius", 2e12),
        ("ball_floor.size[1]", -1.0),
        ("ball_floor.size[2]", f64::INFINITY),
    ] {
        let e = refused(&ball, &[(name, value)]);
        assert!(e.contains(&format!("parameter {name} = ")), "{name} = {value}: {e}");
        assert!(e.contains("out of its allowed range"), "{e}");
    }
    // each moment is positive, but together they are no body's: I3 > I1 + I2
    let e = refused(
        &ball,
        &[
            ("ball.inertia[1]", 1e-6),
            ("ball.inertia[2]", 1e-6),
            ("ball.inertia[3]", 3e-6),
        ],
    );
    assert!(
        e.contains("\"ball.inertia[1]\", \"ball.inertia[2]\", \"ball.inertia[3]\"")
            && e.contains("triangle inequality"),
        "{e}"
    );
    let trough = common::checked(trough());
    // an inside cylinder must be larger than its sphere
    for set in [
        vec![("ball_trough.cylinder_radius", 0.01)],
        vec![("ball_trough.radius", 0.2)],
    ] {
        let e = refused(&trough, &set);
        assert!(
            e.contains("\"ball_trough.cylinder_radius\"")
                && e.contains("\"ball_trough.radius\"")
                && e.contains("must exceed the sphere radius"),
            "{e}"
        );
    }
    for (name, value) in [("ball_trough.length", 0.0), ("ball_trough.cylinder_radius", -0.1)] {
        let e = refused(&trough, &[(name, value)]);
        assert!(e.contains(&format!("parameter {name} = ")), "{e}");
    }
}

/// A range with an infinite end is written open there: `inf` is refused as out of `[0, inf)`;
/// the message said `[0, inf]`, a range that holds it (found by a review).
#[test]
fn an_infinite_end_of_a_range_is_written_open() {
    let ball = Scene::from_file(&common::bundled("bouncing_ball")).unwrap();
    let e = refused(&ball, &[("ball_floor.viscous_friction", f64::INFINITY)]);
    assert!(
        e.contains("parameter ball_floor.viscous_friction = inf is out of its allowed range [0, inf)"),
        "{e}"
    );
}
