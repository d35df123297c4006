//! Regression tests named after the bug they pin.

use crate::common;

use contact_fmu::scene::{BodySpec, JointSpec, Scene};
use contact_fmu::scene_builder::SceneBuilder;

/// A Y-shaped tree: a free hub with two pendulum arms on revolute joints (sibling branches).
fn branched() -> Scene {
    let hub = BodySpec::new("hub", 3.0, [0.02, 0.03, 0.04], [0.0, 0.0, 0.0])
        .velocity([0.3, 0.0, 1.0])
        .angular_velocity([0.2, 0.5, -0.1]);
    // an arm hinged to the hub
    let hinge =
        |name: &str, arm: &str, anchor: [f64; 3], axis: [f64; 3]| JointSpec::revolute(name, "hub", arm, anchor, axis);
    SceneBuilder::new("branched")
        .gravity([0.0, 0.0, -9.81])
        .tolerances(1e-11, 1e-13)
        .max_step(1e-2)
        .body(hub)
        .body(BodySpec::new("left", 1.0, [0.001, 0.05, 0.05], [-0.5, 0.0, 0.0]))
        .body(BodySpec::new("right", 1.5, [0.001, 0.08, 0.08], [0.5, 0.0, 0.2]))
        .joint(hinge("hinge_left", "left", [-0.1, 0.0, 0.0], [0.0, 1.0, 0.0]))
        .joint(hinge("hinge_right", "right", [0.1, 0.0, 0.0], [0.0, 0.0, 1.0]))
        .build()
}

/// The in-place Cholesky left fill-in between sibling branches, and the next assembly did not
/// overwrite it: every evaluation after the first used a wrong mass matrix for branched trees
/// (found because a restored FMU state, assembled into fresh buffers, diverged).
#[test]
fn mass_matrix_of_sibling_branches_is_rebuilt_each_evaluation() {
    let mut sim = common::start(branched());
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

/// A scene with contact groups and a body without any `[[shape]]`: its island holds no shape
/// of the group pairs' groups. Compiling that island looked the groups up by its own shapes
/// and panicked ("no entry found for key"); now it runs, with islands and without, and the
/// shapeless body falls freely.
#[test]
fn a_body_without_shapes_beside_contact_groups_runs() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/pile_of_balls/scene.toml");
    let text = std::fs::read_to_string(path).unwrap().replacen(
        "\n[[shape]]\n",
        "\n[[body]]\nname = \"loose\"\nmass = 1.0\ninertia = [0.01, 0.01, 0.01]\nposition = [1.0, 1.0, 0.5]\n\n[[shape]]\n",
        1,
    );
    for islands in [true, false] {
        let text = text.replacen(
            "\n[broad_phase]",
            &format!("\n[solver]\nislands = {islands}\n\n[broad_phase]"),
            1,
        );
        let mut sim = contact_fmu::simulation::Simulation::from_scene_str(&text, "loose.toml").unwrap();
        sim.initialize(0.0).unwrap();
        sim.step_to(0.05).unwrap_or_else(|e| panic!("islands = {islands}: {e}"));
        let z = common::get(&mut sim, "loose.r[3]");
        let exact = 0.5 - 0.5 * 9.81 * 0.05 * 0.05;
        assert!(
            (z - exact).abs() < 1e-9,
            "islands = {islands}: z = {z}, free fall {exact}"
        );
    }
}
