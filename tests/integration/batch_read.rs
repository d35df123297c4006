//! Reading variables in a batch (`Simulation::get_many`, as `fmi2GetReal` receives them) gives
//! the same numbers, bit for bit, as reading them one by one and as the full evaluation of the
//! outputs; a batch of body kinematics evaluates only the kinematics, with the same values;
//! and reading changes nothing in the run.

use crate::common;

use common::bundled_scenes;
use contact_fmu::outputs::{needs, Needs};
use contact_fmu::simulation::Simulation;

fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits()
}

/// Runs `path` over its first `horizon` seconds at its own interval; at every communication
/// point calls `each`. Returns every output at the end.
fn run(path: &std::path::Path, mut each: impl FnMut(&mut Simulation)) -> Vec<f64> {
    let mut s = Simulation::from_file(path).unwrap_or_else(|e| panic!("{e}"));
    s.initialize(0.0).unwrap();
    let m = &s.scene().model;
    let (stop, interval) = (m.stop_time.min(0.5), m.interval);
    s.run(stop, interval, |s| {
        each(s);
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let all = s.output_indices();
    all.iter().map(|&i| s.get(i).unwrap()).collect()
}

#[test]
fn batch_reads_equal_single_reads_and_the_full_evaluation() {
    for (name, path) in bundled_scenes() {
        let mut points = 0;
        let with_reads = run(&path, |s| {
            let all: Vec<usize> = (0..s.variables().len()).collect();
            let kinematic: Vec<usize> = s
                .output_indices()
                .into_iter()
                .filter(|&i| needs(s.variables()[i].target) == Needs::Kinematics)
                .collect();
            // first at this point: only the kinematics are evaluated
            let mut fast = vec![0.0; kinematic.len()];
            s.get_many(&kinematic, &mut fast).unwrap();
            // the full evaluation of every output (what a single read did before batches)
            let full: Vec<f64> = kinematic
                .iter()
                .map(|&i| {
                    let target = s.variables()[i].target;
                    s.output(target).unwrap().unwrap()
                })
                .collect();
            for (k, &i) in kinematic.iter().enumerate() {
                assert!(
                    same(fast[k], full[k]),
                    "{name}: {} = {} from the kinematics alone, {} from the full evaluation",
                    s.variables()[i].name,
                    fast[k],
                    full[k]
                );
            }
            // every variable in one batch against one by one
            let mut batch = vec![0.0; all.len()];
            s.get_many(&all, &mut batch).unwrap();
            for &i in &all {
                let one = s.get(i).unwrap();
                assert!(
                    same(batch[i], one),
                    "{name}: {} = {} in a batch, {} alone",
                    s.variables()[i].name,
                    batch[i],
                    one
                );
            }
            points += 1;
        });
        assert!(points > 0, "{name}: no communication point");
        let without_reads = run(&path, |_| {});
        for (k, (a, b)) in with_reads.iter().zip(&without_reads).enumerate() {
            assert!(same(*a, *b), "{name}: output {k} is {a} with reads, {b} without");
        }
    }
}

#[test]
fn a_bad_value_reference_fails_the_batch() {
    let (_, path) = bundled_scenes().into_iter().next().unwrap();
    let mut s = Simulation::from_file(&path).unwrap();
    s.initialize(0.0).unwrap();
    let n = s.variables().len();
    let mut out = vec![0.0; 2];
    assert!(s.get_many(&[0, n], &mut out).is_err());
    assert!(s.get_many(&[0], &mut out).is_err(), "lengths differ");
}

/// A host reads the same free-body positions and velocities at every point: from the second
/// read on they are copied from the state by the slots of the first, so every batch (the same
/// list again, the list reversed, the list with a parameter in it) is compared bit for bit with
/// single reads, at every point of the two spheres' run and after a tunable parameter changed.
#[test]
fn repeated_batches_of_free_body_reads_equal_single_reads() {
    let mut s = Simulation::from_file(&common::bundled("two_spheres")).unwrap();
    s.initialize(0.0).unwrap();
    let vars = s.variables();
    let index = |name: &str| vars.iter().position(|v| v.name == name).unwrap();
    let mut list: Vec<usize> = ["small", "large"]
        .iter()
        .flat_map(|b| (1..=3).flat_map(move |k| [format!("{b}.r[{k}]"), format!("{b}.v[{k}]")]))
        .map(|n| index(&n))
        .collect();
    let parameter = index("solver.rtol");
    let check = |s: &mut Simulation, list: &[usize]| {
        let mut batch = vec![0.0; list.len()];
        s.get_many(list, &mut batch).unwrap();
        for (k, &vr) in list.iter().enumerate() {
            let one = s.get(vr).unwrap();
            assert!(
                same(batch[k], one),
                "{}: {} in a batch, {one} alone",
                s.variables()[vr].name,
                batch[k]
            );
        }
    };
    let mut points = 0;
    s.run(0.01, 1e-4, |s| {
        for _ in 0..2 {
            check(s, &list);
        }
        let mut reversed = list.clone();
        reversed.reverse();
        check(s, &reversed);
        let mut with_parameter = list.clone();
        with_parameter.push(parameter);
        check(s, &with_parameter);
        points += 1;
        Ok(())
    })
    .unwrap();
    assert_eq!(points, 100);
    // a tunable parameter recompiles the model: the slots are found again
    let contact = s.scene().contact[0].name.clone();
    s.set_by_name(&format!("{contact}.restitution"), 0.5).unwrap();
    s.step_to(0.0105).unwrap();
    list.swap(0, 1);
    check(&mut s, &list);
    check(&mut s, &list);
}

/// A communication point inside the method's step leaves the state to the dense output until
/// something reads it: the direct batch of free-body reads (from the dense output at its
/// slots) and the whole state (settled when read) equal, bit for bit, the state of the engine
/// advanced to every point without deferring. Two spheres and the bouncing ball (free bodies,
/// quaternions), on a grid finer than their steps, and a slider-crank (loops: not deferred).
#[test]
fn deferred_points_equal_the_engine_advanced_to_every_point() {
    use contact_fmu::{compile, engine};
    for name in ["two_spheres", "bouncing_ball", "slider_crank"] {
        let path = common::bundled(name);
        let mut s = Simulation::from_file(&path).unwrap();
        s.initialize(0.0).unwrap();
        let (m, mut d) = compile::compile(s.scene(), name).unwrap();
        engine::start(&m, &mut d).unwrap();
        engine::set_start_time(&mut d, 0.0);
        // the free bodies' positions and velocities, and their state slots
        let (free, slots): (Vec<usize>, Vec<usize>) = s
            .output_indices()
            .into_iter()
            .filter_map(|i| contact_fmu::outputs::state_slot(&m, s.variables()[i].target).map(|k| (i, k)))
            .unzip();
        let stop = s.scene().model.stop_time.min(0.5);
        let interval = s.scene().model.interval / 4.0;
        let mut points = 0;
        s.run(stop, interval, |s| {
            engine::advance(&m, &mut d, s.time()).unwrap();
            let mut batch = vec![0.0; free.len()];
            for _ in 0..2 {
                s.get_many(&free, &mut batch).unwrap();
                for (k, &slot) in slots.iter().enumerate() {
                    let var = &s.variables()[free[k]].name;
                    assert!(
                        same(batch[k], d.state[slot]),
                        "{name}: {var} = {} read, {} advanced",
                        batch[k],
                        d.state[slot]
                    );
                }
            }
            if points % 3 == 0 {
                let state = &s.data().unwrap().state;
                for (k, (a, b)) in state.iter().zip(&d.state).enumerate() {
                    assert!(same(*a, *b), "{name}: state[{k}] = {a} settled, {b} advanced");
                }
            }
            points += 1;
            Ok(())
        })
        .unwrap();
        assert!(points > 10, "{name}: {points} points");
        if name != "slider_crank" {
            assert!(!free.is_empty(), "{name}: no free body read");
        }
    }
}

/// A host that sets its inputs at every communication point (the same value mostly, a new one
/// now and then) leaves the points deferred: the run equals, bit for bit, one that reads the
/// whole state (settling it) before every setting. The rail vehicle with its axle torque.
#[test]
fn inputs_set_at_deferred_points_equal_inputs_set_at_settled_points() {
    let run = |settle_first: bool| {
        let mut s = Simulation::from_file(&common::bundled("rail_vehicle")).unwrap();
        s.initialize(0.0).unwrap();
        for k in 1..=100 {
            if settle_first {
                let _ = s.data();
            }
            s.set_by_name("axle_torque", if k < 40 { 500.0 } else { -800.0 })
                .unwrap();
            s.step_to(k as f64 * 0.005).unwrap();
        }
        (s.data().unwrap().state.clone(), s.counters())
    };
    let (deferred, c1) = run(false);
    let (settled, c2) = run(true);
    assert_eq!(c1, c2);
    for (k, (a, b)) in deferred.iter().zip(&settled).enumerate() {
        assert!(same(*a, *b), "state[{k}] = {a} deferred, {b} settled");
    }
}
