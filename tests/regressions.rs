//! Regression tests named after the bug they pin.

use contact_fmu::simulation::Simulation;

/// A Y-shaped tree: a free hub with two pendulum arms on revolute joints (sibling branches).
const BRANCHED: &str = r#"
[model]
name = "branched"
gravity = [0.0, 0.0, -9.81]
[solver]
rtol = 1e-11
atol = 1e-13
max_step = 1e-2
[[body]]
name = "hub"
mass = 3.0
inertia = [0.02, 0.03, 0.04]
position = [0.0, 0.0, 0.0]
velocity = [0.3, 0.0, 1.0]
angular_velocity = [0.2, 0.5, -0.1]
[[body]]
name = "left"
mass = 1.0
inertia = [0.001, 0.05, 0.05]
position = [-0.5, 0.0, 0.0]
[[body]]
name = "right"
mass = 1.5
inertia = [0.001, 0.08, 0.08]
position = [0.5, 0.0, 0.2]
[[joint]]
name = "hinge_left"
type = "revolute"
parent = "hub"
child = "left"
anchor = [-0.1, 0.0, 0.0]
axis = [0.0, 1.0, 0.0]
[[joint]]
name = "hinge_right"
type = "revolute"
parent = "hub"
child = "right"
anchor = [0.1, 0.0, 0.0]
axis = [0.0, 0.0, 1.0]
"#;

/// The in-place Cholesky left fill-in between sibling branches, and the next assembly did not
/// overwrite it: every evaluation after the first used a wrong mass matrix for branched trees
/// (found because a restored FMU state, assembled into fresh buffers, diverged).
#[test]
fn mass_matrix_of_sibling_branches_is_rebuilt_each_evaluation() {
    let mut sim = Simulation::from_scene_str(BRANCHED, "branched.toml").unwrap();
    sim.initialize(0.0).unwrap();
    let e0 = sim.energies().unwrap();
    let total0 = e0.kinetic + e0.potential;
    let mut worst = 0.0_f64;
    for k in 1..=200 {
        sim.step_to(k as f64 * 0.01).unwrap();
        let e = sim.energies().unwrap();
        worst = worst.max(((e.kinetic + e.potential) - total0).abs() / e0.kinetic);
    }
    assert!(worst < 1e-8, "relative energy drift {worst:e} over 2 s");
}
