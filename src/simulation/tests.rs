//! Tests of the facade's saved states with islands.

use super::Simulation;
use crate::model::island_state::{self, IslandsState};
use crate::model::state::{self, StatePart};
use crate::scene::Scene;

/// The bundled pile, initialised and run to `t` (its balls still apart at 0.1 s: several
/// islands; at 0, not yet stepped: no islands yet).
fn pile_at(t: f64) -> Simulation {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/pile_of_balls/scene.toml");
    let mut s = Simulation::new(Scene::from_file(&path).unwrap(), "pile_of_balls");
    s.initialize(0.0).unwrap();
    if t > 0.0 {
        s.step_to(t).unwrap();
    }
    s
}

/// A saved state whose islands do not fit their models (the last island's integrator part cut
/// short by a number, the lengths made to agree: only building that island finds it) is refused,
/// and the simulations given it go on as ones that never were: the same saved state, bit for
/// bit, after they ran on 0.05 s. One was at 0.12 s with its islands, one initialised and not
/// yet stepped (its islands are formed from the scene's data at its first step, so a scene's
/// state left from the refused one would show). The state itself, restored, continues as the
/// simulation that saved it.
#[test]
fn refused_islands_leave_the_simulation_as_it_was() {
    let mut a = pile_at(0.1);
    let snap = a.snapshot(Vec::new());
    // the islands' part follows the scene's other parts
    let c = a.compiled.as_mut().unwrap();
    let mut scene_parts = Vec::new();
    state::get(
        &c.model,
        &c.data,
        state::FULL & !(StatePart::Islands as u32),
        &mut scene_parts,
    );
    assert_eq!(snap.state[..scene_parts.len()], scene_parts[..]);
    let (mut saved, len): (IslandsState, usize) =
        island_state::read(&c.model, c.data.time, &snap.state[scene_parts.len()..]).unwrap();
    assert_eq!(scene_parts.len() + len, snap.state.len());
    assert!(saved.count > 1, "{} islands", saved.count);
    saved.records.pop();
    *saved.record_at.last_mut().unwrap() -= 1;
    let mut damaged = snap.clone();
    damaged.state.truncate(scene_parts.len());
    island_state::get(&saved, &mut damaged.state);

    for t in [0.12, 0.0] {
        let mut b = pile_at(t);
        let e = b.restore(&damaged).expect_err("islands that do not fit").to_string();
        assert!(e.contains("saved islands: island"), "{e}");
        let mut untouched = pile_at(t);
        for s in [&mut b, &mut untouched] {
            s.step_to(t + 0.05).unwrap();
        }
        assert_eq!(
            b.snapshot(Vec::new()),
            untouched.snapshot(Vec::new()),
            "the refused state changed the simulation at {t} s"
        );
    }
    let mut r = pile_at(0.12);
    r.restore(&snap).unwrap();
    for s in [&mut a, &mut r] {
        s.step_to(0.15).unwrap();
    }
    assert_eq!(
        r.snapshot(Vec::new()),
        a.snapshot(Vec::new()),
        "the restored state does not continue"
    );
}
