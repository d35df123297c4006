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
    // (in communication steps of 10 ms: the step budget is per communication step)
    let n = (t / 0.01).ceil() as usize;
    for k in 1..=n {
        s.step_to(if k == n { t } else { k as f64 * 0.01 }).unwrap();
    }
    s
}

/// The pile's state at 0.1 s and where its islands' part starts.
fn pile_state() -> &'static (crate::checkpoint::Snapshot, usize) {
    static STATE: std::sync::OnceLock<(crate::checkpoint::Snapshot, usize)> = std::sync::OnceLock::new();
    STATE.get_or_init(|| {
        let mut a = pile_at(0.1);
        let snap = a.snapshot(Vec::new());
        let c = a.compiled.as_mut().unwrap();
        let mut scene_parts = Vec::new();
        state::get(
            &c.model,
            &c.data,
            state::FULL & !(StatePart::Islands as u32),
            &mut scene_parts,
        );
        // (the islands' part follows the scene's other parts)
        assert_eq!(snap.state[..scene_parts.len()], scene_parts[..]);
        (snap, scene_parts.len())
    })
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
    let (snap, start) = pile_state();
    let mut a = pile_at(0.1);
    let c = a.compiled.as_mut().unwrap();
    let (mut saved, len): (IslandsState, usize) =
        island_state::read(&c.model, c.data.time, &snap.state[*start..]).unwrap();
    assert_eq!(start + len, snap.state.len());
    assert!(saved.count > 1, "{} islands", saved.count);
    saved.records.pop();
    *saved.record_at.last_mut().unwrap() -= 1;
    let mut damaged = snap.clone();
    damaged.state.truncate(*start);
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
    r.restore(snap).unwrap();
    for s in [&mut a, &mut r] {
        s.step_to(0.15).unwrap();
    }
    assert_eq!(
        r.snapshot(Vec::new()),
        a.snapshot(Vec::new()),
        "the restored state does not continue"
    );
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 1000, ..Default::default() })]

    /// A saved state whose islands' part holds a damaged number anywhere (not a number, infinite,
    /// negative, fractional, huge, one more, zero) is refused with a message, or restores and
    /// runs on 0.01 s (to a result, an error included): nothing panics, into a simulation that
    /// had not stepped yet.
    #[test]
    fn damaged_islands_parts_are_refused_or_run_without_panic(at in 0usize..1_000_000, kind in 0usize..7) {
        let (snap, start) = pile_state();
        let mut damaged = snap.clone();
        let k = start + at % (snap.state.len() - start);
        let x = damaged.state[k];
        damaged.state[k] = [f64::NAN, f64::INFINITY, -1.0, x + 0.5, 1e300, x + 1.0, 0.0][kind];
        let mut b = pile_at(0.0);
        match b.restore(&damaged) {
            Err(e) => proptest::prop_assert!(!e.to_string().is_empty()),
            Ok(()) => {
                let t = b.time();
                let _ = b.step_to(t + 0.01);
            }
        }
    }
}

/// A saved state whose scene's candidate pairs name a shape the model does not have, or a
/// pair of shapes that are not of the pair's groups, is refused with a message (the contact
/// list made for it would index past the shapes' sides).
#[test]
fn saved_candidate_pairs_the_groups_cannot_list_are_refused() {
    let mut a = pile_at(0.3);
    // (the scene's contact list takes the islands' candidate pairs when something reads it)
    a.contacts().unwrap();
    let snap = a.snapshot(Vec::new());
    let m = a.model().unwrap();
    let at = 1 + m.nstate() + m.input_values();
    let (shapes, n) = (m.groups.shapes.len(), snap.state[at] as usize);
    assert!(n > 0, "the pile lists candidate pairs at 0.3 s");
    // (the first pair: its pair, sphere and other shape)
    let (pair, sphere) = (at + 1, at + 2);
    let wall = m.groups.shapes.iter().position(|s| s.body.is_none()).unwrap();
    for (k, x, why) in [
        (sphere, shapes as f64, "a shape past the model's"),
        (sphere, wall as f64, "a wall as a ball"),
        (pair, m.groups.pair_names.len() as f64, "a pair past the model's"),
    ] {
        let mut bad = snap.clone();
        bad.state[k] = x;
        let e = pile_at(0.0).restore(&bad).expect_err(why).to_string();
        assert!(e.contains("candidate pairs"), "{why}: {e}");
    }
}
