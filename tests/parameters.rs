//! Spring-damper constants and initial body velocities are FMU parameters: set before
//! initialisation, they change the model as the same scene keys would (closed forms).

use contact_fmu::scene::{BodySpec, JointSpec, Scene, SpringDamperSpec, GROUND};
use contact_fmu::scene_builder::SceneBuilder;
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
