//! A saved state restored into a fresh simulation continues bit for bit like the original,
//! for every bundled scene (the property `fmi2SetFMUstate` and serialisation rely on), with
//! the scene's own method and with the implicit methods, whose Jacobian and controller memory
//! survive the restart at each communication point and so must travel with the state.

use crate::common;

use contact_fmu::checkpoint::Snapshot;
use contact_fmu::scene::Method;
use contact_fmu::simulation::Simulation;
use std::path::{Path, PathBuf};

/// Every output, as bits.
fn outputs(sim: &mut Simulation) -> Vec<u64> {
    sim.output_indices()
        .into_iter()
        .map(|i| sim.get(i).unwrap().to_bits())
        .collect()
}

/// Opens `path`, with `method` instead of the scene's own when given.
fn open(path: &Path, method: Option<Method>) -> Simulation {
    let mut s = Simulation::from_file(path).unwrap();
    if let Some(m) = method {
        s.set_by_name("solver.method", m as i64 as f64).unwrap();
    }
    s
}

/// Runs a third of the scene, saves, restores into a fresh simulation (`fresh_method`: the
/// method set there before the restore, which the snapshot's parameters must override) and
/// compares both runs to the end; then rewinds the original (which has run on, with other
/// integrator memory) to the saved state and compares again. Returns the saved state's
/// length and the size of the ODE system.
fn check_scene(path: &Path, method: Option<Method>, fresh_method: Option<Method>) -> (usize, usize) {
    let what = format!("{} ({method:?})", path.display());
    let mut a = open(path, method);
    let stop = a.scene().model.stop_time.min(0.6);
    let h = a.scene().model.interval.max(stop / 400.0);
    a.initialize(0.0).unwrap();
    let n = (stop / h).round() as usize;
    let split = n / 3;
    for k in 1..=split {
        a.step_to(k as f64 * h).unwrap();
    }
    let snap = a.snapshot(Vec::new());
    let bytes = snap.to_bytes(0);
    let mut b = open(path, fresh_method);
    b.restore(&Snapshot::from_bytes(&bytes, 0).unwrap()).unwrap();
    assert_eq!(
        outputs(&mut a),
        outputs(&mut b),
        "{what}: outputs differ right after restore"
    );
    let mut trace = Vec::new();
    for k in split + 1..=n {
        let t = k as f64 * h;
        a.step_to(t).unwrap();
        b.step_to(t).unwrap();
        let out = outputs(&mut a);
        assert_eq!(
            out,
            outputs(&mut b),
            "{what}: restored run differs from the original at t = {t}"
        );
        trace.push(out);
    }
    a.restore(&Snapshot::from_bytes(&bytes, 0).unwrap()).unwrap();
    for (k, out) in (split + 1..=n).zip(&trace) {
        let t = k as f64 * h;
        a.step_to(t).unwrap();
        assert_eq!(&outputs(&mut a), out, "{what}: rewound run differs at t = {t}");
    }
    let n_ode = a.model().unwrap().nstate();
    (snap.state.len(), n_ode)
}

fn scenes() -> Vec<PathBuf> {
    let v: Vec<PathBuf> = common::bundled_scenes().into_iter().map(|(_, p)| p).collect();
    assert!(v.len() >= 4, "expected the bundled scenes, found {}", v.len());
    v
}

#[test]
fn restored_state_continues_bit_identically_for_every_bundled_scene() {
    for p in scenes() {
        check_scene(&p, None, None);
    }
}

#[test]
fn implicit_methods_carry_their_jacobian_in_the_state_and_continue_bit_identically() {
    for method in [Method::Sdirk, Method::Radau5] {
        let mut carried = 0;
        for p in scenes() {
            if p.parent().is_some_and(|d| d.ends_with("pile_of_balls")) {
                // it runs as islands, whose integrators are saved in the state's islands part
                // (tests/integration/islands.rs restores them bit for bit); the state's size below is the
                // scene's alone; and the implicit methods on its stiff steel contacts take minutes
                continue;
            }
            let (plain, _) = check_scene(&p, Some(Method::Dopri5), Some(Method::Dopri5));
            // the fresh simulation starts with another method: the snapshot's parameters rule
            let (warm, n) = check_scene(&p, Some(method), Some(Method::Dopri5));
            // the integrator's own state: dopri5 9 + 7n numbers, sdirk and radau5 16 + 6n,
            // plus the n² Jacobian while they hold one
            if warm + 7 * n + 9 >= plain + 6 * n + 16 + n * n {
                carried += 1;
            }
        }
        // the rail vehicle is in contact from the start: its Jacobian is in the state
        assert!(carried >= 1, "{method:?}: no scene's state carried a Jacobian");
    }
}

/// A state without the integrator's own state (its length 0) still restores and restarts
/// cold, deterministically; a damaged length of that state is refused.
#[test]
fn state_without_integrator_memory_restores_cold_and_bad_memory_is_refused() {
    let path = &common::bundled("rail_vehicle");
    let mut a = open(path, Some(Method::Sdirk));
    a.initialize(0.0).unwrap();
    for k in 1..=10 {
        a.step_to(k as f64 * 0.01).unwrap();
    }
    let ncontacts = a.contacts().unwrap().len();
    let m = a.model().unwrap();
    let (n, head) = (m.nstate(), 1 + m.nstate() + m.inputs.len() + 3 * ncontacts + 5);
    let snap = a.snapshot(Vec::new());
    let len = snap.state.len();
    // integrator part: started, next step, pending event, length, then sdirk's own state
    // (tag, 7 + 3n of the step, 3n dense output, 10 Newton numbers, the n² Jacobian)
    let memory = 1 + 7 + 3 * n + 3 * n + 10 + n * n;
    // (then the energy watch's five numbers, and the islands' part: one number, 0, for a
    // scene that runs as one integrator)
    let end = len - 1;
    let watch = end - 5;
    assert_eq!(snap.state[end], 0.0, "no islands");
    assert_eq!(snap.state[watch], 1.0, "the energy watch started");
    assert_eq!(
        head + 4 + memory,
        watch,
        "the integrator part ends the scene's physical parts"
    );
    assert_eq!(
        snap.state[watch - memory - 1],
        memory as f64,
        "length prefix, then the method's state with J"
    );
    let mut old = snap.clone();
    old.state.truncate(watch - memory);
    old.state[watch - memory - 1] = 0.0;
    old.state[head] = 0.0; // not continuing a step
    old.state.extend_from_slice(&snap.state[watch..]);
    let mut runs = Vec::new();
    for _ in 0..2 {
        let mut b = open(path, None);
        b.restore(&old).unwrap();
        for k in 11..=30 {
            b.step_to(k as f64 * 0.01).unwrap();
        }
        runs.push(outputs(&mut b));
    }
    assert_eq!(runs[0], runs[1]);
    let mut bad = snap.clone();
    bad.state[watch - memory - 1] += 1.0;
    assert!(open(path, None).restore(&bad).is_err());
    let mut bad = snap;
    bad.state.pop();
    assert!(open(path, None).restore(&bad).is_err());
}

/// Where the numbers of a one-integrator scene's saved state are: the integrator part's
/// start (started, next step, pending event, length, then the method's own state) and the
/// counters' start.
fn solver_part(sim: &mut Simulation) -> (usize, usize) {
    let ncontacts = sim.contacts().unwrap().len();
    let m = sim.model().unwrap();
    let counters = 1 + m.nstate() + m.input_values() + 3 * ncontacts;
    (counters + 5, counters)
}

/// Saved states that no run can have written, though each number passes the checks of its
/// own part, are refused, and the simulation they were given to goes on as if they had not
/// been. Before, each was accepted: the method's time infinite froze the ball for 70 ms, a
/// NaN in its dense output gave rows of NaN outputs, a scene time before the method's step
/// had the ball 3 cm inside the floor without a contact, an event time in the past cost a 36 %
/// energy drift, an energy watch that had checked at more evaluations than the run had made
/// never checked again, and a joint quaternion far from unit length gave NaN orientations.
#[test]
fn states_no_run_saves_are_refused_and_change_nothing() {
    let path = &common::bundled("bouncing_ball");
    let start = |sim: &mut Simulation| {
        sim.initialize(0.0).unwrap();
        sim.step_to(0.3).unwrap();
    };
    let mut a = open(path, Some(Method::Dopri5));
    start(&mut a);
    let (solver, counters) = solver_part(&mut a);
    let n = a.model().unwrap().nstate();
    let snap = a.snapshot(Vec::new());
    // dopri5's own state: tag, t, t_prev, h, four counters, y, y_prev, f (n each), the last
    // error norm, the dense output (4n)
    let own = solver + 4;
    let (t, t_prev) = (own + 1, own + 2);
    assert_eq!(
        snap.state[solver + 3],
        (8 + 3 * n + 1 + 4 * n) as f64,
        "the method's state's length"
    );
    assert_eq!(snap.state[solver], 1.0, "the method continues its step");
    let time = snap.state[0];
    assert!(
        snap.state[t_prev] <= time && time < snap.state[t],
        "the point lies inside the method's step"
    );
    let watch = own + 8 + 3 * n + 1 + 4 * n;
    assert_eq!(snap.state[watch], 1.0, "the energy watch started");
    let rhs_evals = snap.state[counters + 2];
    // (the coordinates follow the time)
    let quaternion = 1 + a.model().unwrap().quaternions[0];
    let damaged: Vec<(&str, usize, f64)> = vec![
        ("a finite number (the time)", t, f64::INFINITY),
        ("a finite number (the time)", t, f64::NAN),
        ("or at its end is not finite", watch - 1, f64::NAN),
        ("or at its end is not finite", own + 8, f64::NEG_INFINITY),
        ("is not a step size", own + 3, f64::INFINITY),
        ("before it begins", t_prev, snap.state[t] + 0.01),
        ("does not hold the state's time", 0, snap.state[t_prev] - 0.1),
        ("does not hold the state's time", 0, snap.state[t] + 0.01),
        ("comes before the state's time", solver + 2, time - 1.0),
        ("the energy watch last checked", watch + 3, rhs_evals + 1.0),
        ("is no orientation", quaternion, 10.0),
    ];
    let mut reference = open(path, None);
    start(&mut reference);
    let mut k = 0.3;
    for (what, at, x) in damaged {
        let mut bad = snap.clone();
        bad.state[at] = x;
        let e = a.restore(&bad).unwrap_err().to_string();
        assert!(e.contains(what), "{what} ({at} = {x}): {e}");
        // (refused into a fresh simulation as well)
        assert!(open(path, None).restore(&bad).is_err());
        k += 0.05;
        a.step_to(k).unwrap();
        reference.step_to(k).unwrap();
        assert_eq!(outputs(&mut a), outputs(&mut reference), "after the refused {what}");
    }
    // what the run did save is restored
    let mut b = open(path, None);
    b.restore(&snap).unwrap();
}

/// An input's value in a saved state's values is the host's: one that is not finite, or
/// differs from the input in the model's state, is refused (before, `fmi2GetReal` read back
/// a NaN the engine did not apply), and the simulation goes on as it was.
#[test]
fn a_state_whose_input_values_disagree_is_refused() {
    let (mut a, vr) = rail_vehicle_with_traction(0.05, 1500.0);
    a.step_to(0.1).unwrap();
    let snap = a.snapshot(Vec::new());
    assert_eq!(snap.values[vr], 1500.0);
    let (mut reference, _) = rail_vehicle_with_traction(0.05, 1500.0);
    reference.step_to(0.1).unwrap();
    for (x, what) in [(f64::NAN, "not a finite number"), (1600.0, "among its values")] {
        let mut bad = snap.clone();
        bad.values[vr] = x;
        let e = a.restore(&bad).unwrap_err().to_string();
        assert!(e.contains(what), "{x}: {e}");
        assert_eq!(a.get(vr).unwrap(), 1500.0);
    }
    a.step_to(0.15).unwrap();
    reference.step_to(0.15).unwrap();
    assert_eq!(outputs(&mut a), outputs(&mut reference));
}

/// A state saved after a failed step is restored, though its method holds what it failed on
/// (here an infinite derivative: the traction input at 1e308 N overflows the accelerations):
/// a method that does not continue its step restarts from the model's state, and the restored
/// run fails at the same step again. (A first form of the checks above refused it.)
#[test]
fn a_state_saved_after_a_failed_step_restores_and_fails_alike() {
    let (mut a, _) = rail_vehicle_with_traction(0.01, 1e308);
    let failed = a.step_to(0.02).unwrap_err().to_string();
    let snap = a.snapshot(Vec::new());
    let mut b = open(&common::bundled("rail_vehicle"), None);
    b.restore(&snap).unwrap();
    assert_eq!(b.step_to(0.02).unwrap_err().to_string(), failed);
}

/// The bundled rail vehicle run to `t`, its traction input then set to `traction` \[N\], and
/// that input's value reference.
fn rail_vehicle_with_traction(t: f64, traction: f64) -> (Simulation, usize) {
    let mut sim = open(&common::bundled("rail_vehicle"), None);
    sim.initialize(0.0).unwrap();
    sim.step_to(t).unwrap();
    let vr = sim
        .table()
        .index_of("traction")
        .expect("the rail vehicle's traction input");
    sim.set(vr, traction).unwrap();
    (sim, vr)
}
