//! Spring-damper constants and initial body velocities are FMU parameters: set before
//! initialisation, they change the model as the same scene keys would (closed forms).

use contact_fmu::simulation::Simulation;

const OSCILLATOR: &str = r#"
[model]
name = "oscillator"
gravity = [0.0, 0.0, 0.0]

[solver]
rtol = 1e-10
atol = 1e-12

[[body]]
name = "mass"
mass = 2.0
inertia = [0.01, 0.01, 0.01]
position = [0.0, 0.0, 0.0]

[[joint]]
name = "slide"
type = "prismatic"
parent = "ground"
child = "mass"
anchor = [0.0, 0.0, 0.0]
axis = [1.0, 0.0, 0.0]

[[spring_damper]]
name = "spring"
body_a = "ground"
point_a = [-1.0, 0.0, 0.0]
body_b = "mass"
point_b = [0.0, 0.0, 0.0]
stiffness = 200.0
damping = 0.0
"#;

fn get(s: &mut Simulation, name: &str) -> f64 {
    let vr = s.table().index_of(name).unwrap_or_else(|| panic!("no variable {name}"));
    s.get(vr).unwrap()
}

/// Position of the mass at `t` after initialisation with the parameters `set`.
fn position_at(set: &[(&str, f64)], t: f64) -> (Simulation, f64) {
    let mut s = Simulation::from_scene_str(OSCILLATOR, "oscillator.toml").unwrap();
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
    let mut s = Simulation::from_scene_str(OSCILLATOR, "oscillator.toml").unwrap();
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
