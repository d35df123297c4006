//! Tests of the facade's saved states with islands.

use super::Simulation;
use crate::model::island_state::{self, IslandsState};
use crate::model::state::{self, StatePart};
use crate::scene::Scene;

/// The bundled pile, initialised and run to `t` (its balls still apart at 0.1 s: several
/// islands; at 0, not yet stepped: no islands yet).
fn pile_at(t: f64) -> Simulation {
    pile_with(t, None)
}

/// [`pile_at`], with the balls' coefficient of restitution set to `restitution` before the
/// initialisation (a tunable parameter: its value is part of a saved state).
fn pile_with(t: f64, restitution: Option<f64>) -> Simulation {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/pile_of_balls/scene.toml");
    let mut s = Simulation::new(Scene::from_file(&path).unwrap(), "pile_of_balls");
    if let Some(e) = restitution {
        s.set_by_name("ball_ball.restitution", e).unwrap();
    }
    s.initialize(0.0).unwrap();
    // (in communication steps of 10 ms: the step budget is per communication step)
    let n = (t / 0.01).ceil() as usize;
    for k in 1..=n {
        s.step_to(if k == n { t } else { k as f64 * 0.01 }).unwrap();
    }
    s
}

/// The bits of a saved state's values and state.
fn bits(s: &crate::checkpoint::Snapshot) -> (Vec<u64>, Vec<u64>) {
    let b = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect();
    (b(&s.values), b(&s.state))
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
/// state left from the refused one would show), one at 0.12 s with another restitution of the
/// balls (the saved state's values differ: the model is compiled for them before the state is
/// read, and the running one is put back). The state itself, restored, continues as the
/// simulation that saved it.
#[test]
fn refused_islands_leave_the_simulation_as_it_was() {
    let (snap, start) = pile_state();
    let mut a = pile_at(0.1);
    let c = a.compiled.as_mut().unwrap();
    let (mut saved, len): (IslandsState, usize) =
        island_state::read(&c.model, c.data.time, &snap.state[*start..]).unwrap();
    assert_eq!(start + len, snap.state.len());
    assert!(saved.count() > 1, "{} islands", saved.count());
    saved.records.last_mut().unwrap().pop();
    let mut damaged = snap.clone();
    damaged.state.truncate(*start);
    island_state::get(&saved, &mut damaged.state);

    for (t, restitution) in [(0.12, None), (0.0, None), (0.12, Some(0.6))] {
        let mut b = pile_with(t, restitution);
        let e = b.restore(&damaged).expect_err("islands that do not fit").to_string();
        assert!(e.contains("saved islands: island"), "{e}");
        let mut untouched = pile_with(t, restitution);
        for s in [&mut b, &mut untouched] {
            s.step_to(t + 0.05).unwrap();
        }
        assert_eq!(
            bits(&b.snapshot(Vec::new())),
            bits(&untouched.snapshot(Vec::new())),
            "the refused state changed the simulation at {t} s (restitution {restitution:?})"
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
    let damaged = |k: usize, x: f64| {
        let mut bad = snap.clone();
        bad.state[k] = x;
        bad
    };
    let mut twice = snap.clone();
    assert!(n > 1, "two pairs to list one twice");
    twice.state.copy_within(at + 1..at + 4, at + 4);
    for (bad, why) in [
        (damaged(sphere, shapes as f64), "a shape past the model's"),
        (damaged(sphere, wall as f64), "a wall as a ball"),
        (
            damaged(pair, m.groups.pair_names.len() as f64),
            "a pair past the model's",
        ),
        (twice, "a pair listed twice"),
    ] {
        let e = pile_at(0.0).restore(&bad).expect_err(why).to_string();
        assert!(e.contains("candidate pairs"), "{why}: {e}");
    }
}

/// A saved state whose islands are not those the bodies' joints, springs, inputs and candidate
/// pairs make (the pile's last island merged into its first, the first two islands' numbers
/// swapped, an island without bodies, a candidate pair added that joins two islands; the
/// records made to agree in number) is refused by that check, before an island is cut (a body cut from the bodies it is
/// joined to would be cut into a model that names a parent it does not hold), and so is an
/// islands' part in the state of a scene that runs as one integrator.
#[test]
fn islands_other_than_their_partition_are_refused() {
    let (snap, start) = pile_state();
    let mut a = pile_at(0.0);
    let m = a.model().unwrap().clone();
    let (saved, _) = island_state::read(&m, snap.state[0], &snap.state[*start..]).unwrap();
    assert!(saved.count() > 2, "{} islands", saved.count());
    let with = |change: &dyn Fn(&mut IslandsState)| {
        let mut islands = saved.clone();
        change(&mut islands);
        let mut bad = snap.clone();
        bad.state.truncate(*start);
        island_state::get(&islands, &mut bad.state);
        bad
    };
    let merged = with(&|s| {
        let last = s.count() - 1;
        for k in s.island_of.iter_mut().filter(|k| **k == last) {
            *k = 0;
        }
        s.records.pop();
    });
    let out_of_order = with(&|s| {
        for k in s.island_of.iter_mut().filter(|k| **k < 2) {
            *k = 1 - *k;
        }
        s.records.swap(0, 1);
    });
    let without_bodies = with(&|s| {
        let first = s.records[0].clone();
        s.records.push(first);
    });
    // (a pair of the first two balls, in two islands at 0.1 s, added to the list)
    let joining = with(&|s| {
        let g = &m.groups;
        let ball_ball = g.pair_names.iter().position(|p| p == "ball_ball").unwrap();
        let (a, b) = g.pair_groups[ball_ball];
        let sphere = g.shapes.iter().position(|x| x.group == a).unwrap();
        let other = (sphere + 1..g.shapes.len()).find(|&o| g.shapes[o].group == b).unwrap();
        let pair = crate::model::groups::Candidate {
            pair: ball_ball,
            sphere,
            other,
        };
        let (ba, bb) = (g.shapes[sphere].body.unwrap(), g.shapes[other].body.unwrap());
        assert_ne!(s.island_of[ba], s.island_of[bb]);
        let at = s.candidates.partition_point(|c| *c < pair);
        s.candidates.insert(at, pair);
        s.memory.insert(g.n_explicit + at, Default::default());
    });
    for (bad, why) in [
        (merged, "two islands merged"),
        (out_of_order, "islands out of the order of their first bodies"),
        (without_bodies, "an island without bodies"),
        (joining, "a candidate pair of two islands"),
    ] {
        let e = a.restore(&bad).expect_err(why).to_string();
        assert!(e.contains("not those their joints"), "{why}: {e}");
    }

    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/two_spheres/scene.toml");
    let mut one = Simulation::new(Scene::from_file(&path).unwrap(), "two_spheres");
    one.initialize(0.0).unwrap();
    one.step_to(0.001).unwrap();
    let mut s = one.snapshot(Vec::new());
    assert_eq!(s.state.last(), Some(&0.0), "no islands");
    let m = one.model().unwrap();
    let islands = IslandsState {
        island_of: vec![0; m.bodies.len()],
        memory: vec![Default::default(); m.groups.n_explicit],
        records: vec![vec![0.0; 2]],
        head: island_state::IslandsHead {
            round_end: f64::INFINITY,
            ..Default::default()
        },
        ..Default::default()
    };
    s.state.pop();
    island_state::get(&islands, &mut s.state);
    let e = one
        .restore(&s)
        .expect_err("islands of a scene that runs as one")
        .to_string();
    assert!(e.contains("runs as one integrator"), "{e}");
}

/// A saved state does not depend on whether outputs were read before it was saved: the pile
/// run to 0.1 s in steps of 10 ms, once reading every output at every step (which makes the
/// scene's contact list the islands' candidate pairs) and once reading none, saves the same
/// state bit for bit, and both go on to the same state at 0.15 s.
#[test]
fn saved_states_do_not_depend_on_the_outputs_read() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/pile_of_balls/scene.toml");
    let run = |read: bool| {
        let mut s = Simulation::new(Scene::from_file(&path).unwrap(), "pile_of_balls");
        s.initialize(0.0).unwrap();
        let outputs: Vec<usize> = (0..s.variables().len())
            .filter(|&vr| s.variables()[vr].causality == crate::variables::Causality::Output)
            .collect();
        let mut values = vec![0.0; outputs.len()];
        for k in 1..=10 {
            s.step_to(k as f64 * 0.01).unwrap();
            if read {
                s.get_many(&outputs, &mut values).unwrap();
            }
        }
        assert!(outputs.len() > 100, "{} outputs", outputs.len());
        let at_01 = s.snapshot(Vec::new());
        s.step_to(0.15).unwrap();
        (bits(&at_01), bits(&s.snapshot(Vec::new())))
    };
    let (read, unread) = (run(true), run(false));
    assert_eq!(read.0, unread.0, "saved at 0.1 s");
    assert_eq!(read.1, unread.1, "saved at 0.15 s");
}

/// A saved state whose round ends a rounding error before its time (which a stop at a contact
/// event past a round's end within rounding of the communication point leaves, and which the
/// reader accepts for that) restores and runs on: the round ends at once, where an advance to
/// a later point integrated the islands backwards to the round's end and failed.
#[test]
fn a_round_that_ended_a_rounding_error_before_the_state_runs_on() {
    let (snap, start) = pile_state();
    let mut a = pile_at(0.0);
    let m = a.model().unwrap().clone();
    let time = snap.state[0];
    let (mut saved, _) = island_state::read(&m, time, &snap.state[*start..]).unwrap();
    for round_end in [time.next_down(), time - 16.0 * f64::EPSILON * time] {
        saved.head.round_end = round_end;
        let mut early = snap.clone();
        early.state.truncate(*start);
        island_state::get(&saved, &mut early.state);
        let mut b = pile_at(0.0);
        b.restore(&early).unwrap();
        b.step_to(time + 0.01)
            .unwrap_or_else(|e| panic!("round end {round_end}: {e}"));
        assert_eq!(b.time(), time + 0.01);
    }
}
