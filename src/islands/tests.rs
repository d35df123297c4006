//! Tests of the rounds: islands taken back to a round's start.

use super::Islands;
use crate::bench::islands::grouped;
use crate::compile::{compile, Parameters};
use crate::model::{state, Counters, Data, Model};
use crate::scene::Scene;

/// Every island's bodies and whole state, the scene's state (bits) and counters, after
/// gathering the islands into the scene's data `d`.
type Snapshot = (Vec<(Vec<usize>, Vec<u64>)>, Vec<u64>, Counters);

pub(super) fn snapshot(is: &mut Islands, m: &Model, d: &mut Data) -> Snapshot {
    is.gather(m, d);
    let islands = is
        .parts
        .iter()
        .enumerate()
        .map(|(k, island)| {
            let mut v = Vec::new();
            state::get(&island.model, &island.data, state::FULL, &mut v);
            (d.partition.bodies(k).to_vec(), v.iter().map(|x| x.to_bits()).collect())
        })
        .collect();
    (islands, d.state.iter().map(|x| x.to_bits()).collect(), d.counters)
}

/// `f` of 64 grouped spheres that collide within 0.02 s (broad-phase margin 1.5 mm, file name
/// `origin`): their model, data and islands at the start.
pub(super) fn on_64_spheres<R>(origin: &str, f: impl FnOnce(&Model, &mut Data, &mut Islands) -> R) -> R {
    on_scene(&grouped(64, 0.02, 0.0015, true), origin, f)
}

/// `f` of `scene` (file name `origin`): its model, data and islands at the start.
fn on_scene<R>(scene: &Scene, origin: &str, f: impl FnOnce(&Model, &mut Data, &mut Islands) -> R) -> R {
    let (m, mut d) = compile(scene, origin).unwrap();
    let mut is = Islands::new(Parameters::of_scene(scene), &m, &mut d).unwrap();
    f(&m, &mut d, &mut is)
}

/// 64 grouped spheres that collide within 0.02 s, spinning (a free body's lean kinematics,
/// which the steps use, and the whole kinematics, which a restore evaluates, round its
/// velocity differently then).
fn spinning_spheres() -> Scene {
    let mut scene = grouped(64, 0.02, 0.0015, true);
    for (k, b) in scene.body.iter_mut().enumerate() {
        let k = k as f64;
        b.angular_velocity = [30.0 * (0.7 * k).sin(), 30.0 * (1.3 * k).cos(), 20.0 - 0.5 * k];
    }
    scene
}

/// Islands taken back to a round's start from their time and coordinates alone (those that
/// only interpolated in the round) go on as those taken back from their whole state: 64
/// grouped spheres advanced from contact event to contact event (at each, the islands that
/// went further are taken back), then on without stops. Every island's whole state, the
/// scene's state and the counters are the same bit for bit at every stop and at the end.
#[test]
fn light_takebacks_go_on_as_whole_state_takebacks() {
    let run = |light: bool| {
        on_64_spheres("take-back test", |m, d, is| {
            is.light_saves = light;
            let mut snapshots = Vec::new();
            let mut stops = 0;
            while is.advance(m, d, 0.01, true).unwrap() {
                stops += 1;
                assert!(stops < 100_000, "no end of the stops at events");
                snapshots.push(snapshot(is, m, d));
            }
            is.advance(m, d, 0.02, false).unwrap();
            snapshots.push(snapshot(is, m, d));
            (snapshots, stops, is.light_takebacks)
        })
    };
    let (light, whole) = (run(true), run(false));
    assert!(light.1 > 10, "stops at events: {}", light.1);
    assert!(
        light.2 > 0,
        "islands taken back from their time and coordinates alone: {}",
        light.2
    );
    assert_eq!(whole.2, 0);
    assert_eq!(light.1, whole.1, "the stops at events");
    for (k, (a, b)) in light.0.iter().zip(&whole.0).enumerate() {
        assert_eq!(a, b, "after stop {k}");
    }
    assert_eq!(light.0.len(), whole.0.len());
}

/// Islands that stop at every contact event before the end of an advance (the islands that
/// went further taken back to it, from either kind of save) go on as islands that do not stop:
/// [`spinning_spheres`] advanced to 0.01 s from event to event and on to 0.02 s, against the same without stops. Every
/// island's whole state, the scene's state and the counters are the same bit for bit at the end.
#[test]
fn stops_at_events_leave_the_islands_trajectories_as_they_are() {
    let scene = spinning_spheres();
    let run = |stops: bool, light: bool| {
        on_scene(&scene, "stop test", |m, d, is| {
            is.light_saves = light;
            let mut n = 0;
            while is.advance(m, d, 0.01, stops).unwrap() {
                n += 1;
                assert!(n < 100_000, "no end of the stops at events");
            }
            is.advance(m, d, 0.02, false).unwrap();
            (snapshot(is, m, d), n, is.light_takebacks)
        })
    };
    let through = run(false, true);
    assert_eq!(through.1, 0);
    for light in [true, false] {
        let stopped = run(true, light);
        assert!(stopped.1 > 10, "stops at events: {}", stopped.1);
        assert_eq!(light, stopped.2 > 0, "light take-backs: {}", stopped.2);
        assert_eq!(stopped.0, through.0, "light saves {light}");
    }
}

/// Islands advanced side by side on three threads go as when advanced one after the other:
/// 64 grouped spinning spheres to 0.02 s, straight through and stopping at every contact
/// event. Every island's whole state, the scene's state and the counters are the same bit for
/// bit.
#[test]
fn islands_side_by_side_go_as_one_after_the_other() {
    let run = |threads: usize, stops: bool| {
        let mut scene = spinning_spheres();
        scene.solver.threads = threads;
        on_scene(&scene, "threads test", |m, d, is| {
            let mut n = 0;
            while is.advance(m, d, 0.01, stops).unwrap() {
                n += 1;
                assert!(n < 100_000, "no end of the stops at events");
            }
            is.advance(m, d, 0.02, false).unwrap();
            (snapshot(is, m, d), n)
        })
    };
    for stops in [false, true] {
        let (one, side) = (run(1, stops), run(3, stops));
        assert_eq!(one.1, side.1, "stops at events");
        assert!(!stops || one.1 > 10, "stops at events: {}", one.1);
        assert_eq!(one.0, side.0, "stopping at events: {stops}");
    }
}

/// Near the step budget too, islands side by side go as one after the other: 64 spinning
/// spheres with `max_steps` = 30 stop at the budget within one advance (several rounds, each
/// island limited to the steps left at the round's start) with the same message and time, and
/// the islands are taken back to the same states, on three threads and on one.
#[test]
fn islands_side_by_side_stop_at_the_step_budget_as_one_after_the_other() {
    let run = |threads: usize| {
        let mut scene = spinning_spheres();
        scene.solver.threads = threads;
        scene.solver.max_steps = 30;
        on_scene(&scene, "budget test", |m, d, is| {
            let e = is.advance(m, d, 0.02, false).unwrap_err();
            assert!(e.step_limit, "{}", e.message);
            assert!(is.rounds > 1, "rounds: {}", is.rounds);
            (e.message, e.time.to_bits(), snapshot(is, m, d))
        })
    };
    let (one, side) = (run(1), run(3));
    eprintln!("{}", one.0);
    assert_eq!(one.0, side.0);
    assert_eq!(one.1, side.1);
    assert_eq!(one.2, side.2);
}

/// The former index of each pair of a new candidate list is its index in the former list (its
/// last, should a list hold a pair twice), or none: by the walk through two sorted lists and
/// by the map of an unsorted one, against a search of each pair, over 300 random lists.
#[test]
fn former_indices_are_the_pairs_places_in_the_former_list() {
    use crate::contact::elements::{former_indices, NOT_LISTED};
    use crate::model::groups::Candidate;
    // (a small linear congruential generator: the lists are the same every run)
    let mut seed = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = |n: u64| {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((seed >> 33) % n) as usize
    };
    let mut out = Vec::new();
    for round in 0..300 {
        let mut pick = |len: usize| -> Vec<Candidate> {
            (0..len)
                .map(|_| Candidate {
                    pair: next(2),
                    sphere: next(6),
                    other: next(6),
                })
                .collect()
        };
        let (mut old, mut new) = (pick(17 + round % 23), pick(31 - round % 29));
        if round % 3 != 0 {
            // sorted without repeats, as the broad phase lists them
            for l in [&mut old, &mut new] {
                l.sort_unstable();
                l.dedup();
            }
        }
        former_indices(&old, &new, &mut out);
        let wanted: Vec<usize> = new
            .iter()
            .map(|c| old.iter().rposition(|o| o == c).unwrap_or(NOT_LISTED))
            .collect();
        assert_eq!(out, wanted, "round {round}: old {old:?}, new {new:?}");
    }
}

/// The contacts' memory the islands take from the scene's data: a declared contact's by its
/// index, a candidate pair's by its place in the scene's list, and none for a pair the scene
/// does not list (with a declared contact before the pairs, whose memory a pair not listed
/// must not take).
#[test]
fn a_pair_the_scene_does_not_list_carries_no_memory() {
    use crate::model::contact::ContactMemory;
    use crate::model::groups::Candidate;
    use crate::scene::{ContactSpec, ContactType, Law, GROUND};
    let mut scene = grouped(8, 0.02, 0.0015, true);
    let ball = scene.body[0].name.clone();
    let mut floor = ContactSpec::new(
        "floor",
        ContactType::SpherePlane,
        Law::Hertz,
        &ball,
        [0.0; 3],
        0.01,
        GROUND,
    );
    floor.origin = Some([0.0, 0.0, -1.0]);
    floor.normal = Some([0.0, 0.0, 1.0]);
    floor.size = Some([10.0, 10.0]);
    floor.stiffness = Some(1e7);
    scene.contact.push(floor);
    on_scene(&scene, "memory test", |m, d, _| {
        assert_eq!(m.groups.n_explicit, 1);
        let declared = ContactMemory {
            active: true,
            impact_velocity: -0.25,
            impacts: 3,
        };
        let listed = ContactMemory {
            active: true,
            impact_velocity: -0.5,
            impacts: 7,
        };
        // the scene's data lists one pair; the islands' list holds it and one more
        let pair = Candidate {
            pair: 0,
            sphere: 0,
            other: 1,
        };
        let unlisted = Candidate { other: 2, ..pair };
        d.candidates = vec![pair];
        d.contact_memory = vec![declared, listed];
        let memory = super::carry::memory_of_scene(m, d, &[pair, unlisted]);
        assert_eq!(memory.explicit, vec![declared]);
        assert_eq!(memory.candidates, vec![listed, ContactMemory::default()]);
    });
}

/// Islands of alike bodies that share one model take the steps of islands that have models of
/// their own: 64 spinning spheres (0.02 s) and the bundled pile (0.15 s), formed with the
/// bodies' likeness and without it. Every island's whole state, the scene's state and the
/// counters are the same bit for bit, and sharing cut fewer models.
#[test]
fn shared_models_give_the_trajectories_of_own_models() {
    let pile = Scene::from_file(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/pile_of_balls/scene.toml"))
        .unwrap();
    for (scene, t) in [(spinning_spheres(), 0.02), (pile, 0.15)] {
        let run = |share: bool| {
            let origin = "share test";
            let (m, mut d) = compile(&scene, origin).unwrap();
            let mut is = Islands::bare(Parameters::of_scene(&scene), &m, &d);
            let plain = is.cutter.alike.iter().filter(|a| a.is_some()).count();
            if !share {
                is.cutter.alike.fill(None);
            }
            is.form_from_scene(&m, &mut d).unwrap();
            is.advance(&m, &mut d, t, false).unwrap();
            let cuts = is.compiled - is.pooled;
            (snapshot(&mut is, &m, &mut d), cuts, plain, is.compiled)
        };
        let (with, without) = (run(true), run(false));
        assert_eq!(with.2, scene.body.len(), "every sphere is plain");
        assert!(with.3 > 2 * scene.body.len() as u64, "{} islands formed", with.3);
        assert!(
            with.1 < without.1,
            "{} models cut with the likeness, {} without",
            with.1,
            without.1
        );
        assert_eq!(with.0 .0, without.0 .0, "the islands' whole states");
        assert_eq!(with.0 .1, without.0 .1, "the scene's state");
        assert_eq!(with.0 .2, without.0 .2, "the counters");
    }
}

/// Bodies that differ only in the sign of a zero are not alike: the numbers a cut takes of a
/// body are compared bit for bit (`==` would take −0 for +0). The bundled pile's balls are all
/// alike to the first; with one ball's sphere centre at x = −0 instead of +0 it is a kind of
/// its own, and the others stay alike.
#[test]
fn bodies_that_differ_in_the_sign_of_a_zero_are_not_alike() {
    let scene =
        Scene::from_file(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/pile_of_balls/scene.toml"))
            .unwrap();
    let (mut m, _) = compile(&scene, "sign test").unwrap();
    let alike = super::cut_model::ModelCutter::new(&m).alike;
    assert!(alike.iter().all(|a| *a == Some(0)), "{alike:?}");
    let s = (0..m.groups.shapes.len())
        .find(|&s| m.groups.shapes[s].body == Some(1))
        .unwrap();
    let center = &mut m.groups.sphere_sides[s].center;
    assert_eq!(center.x.to_bits(), 0.0f64.to_bits());
    center.x = -0.0;
    let alike = super::cut_model::ModelCutter::new(&m).alike;
    assert_eq!(alike[1], Some(1));
    assert!(
        alike.iter().enumerate().all(|(b, a)| b == 1 || *a == Some(0)),
        "{alike:?}"
    );
}

/// The partition in the scene's data is the one the islands are cut for, after every forming:
/// island k's model has its bodies, and its contact list is its candidate pairs', in the
/// partition's order, each at its place in the islands' list; per body, its island; and it is
/// the partition of the islands' candidate pairs. 64 grouped spheres advanced to 0.02 s in steps
/// of 1 ms, checked after each (rebuilds and merges behind them).
#[test]
fn the_datas_partition_is_the_islands() {
    on_64_spheres("partition test", |m, d, is| {
        let rebuilds = is.rebuilds;
        for t in 1..=20 {
            is.advance(m, d, t as f64 * 1e-3, false).unwrap();
            let p = &d.partition;
            assert_eq!(p.len(), is.parts.len());
            for (k, island) in is.parts.iter().enumerate() {
                assert_eq!(island.model.bodies.len(), p.bodies(k).len());
                assert!(p.bodies(k).iter().all(|&b| p.island_of[b] == k));
                let shapes = &island.numbering.shapes;
                assert!(shapes
                    .iter()
                    .all(|&s| m.groups.shapes[s].body.is_none_or(|b| p.island_of[b] == k)));
                assert_eq!(
                    island.data.candidates,
                    super::cut::local_candidates(shapes, p.candidates(k))
                );
                assert!(p.candidates(k).iter().zip(p.listed(k)).all(|(c, &l)| p.list()[l] == *c));
            }
            assert_eq!(*p, super::partition(m, p.list()));
        }
        assert!(is.rebuilds > rebuilds + 3, "{} rebuilds", is.rebuilds - rebuilds);
    });
}

/// Islands built from their part of a saved state (gathered into the scene's data, written and
/// read through the state spec with the scene's whole state, and set into a data compiled
/// anew) hold every island's whole state as the islands that saved it, bit for bit, and go on
/// as they do: 64 spinning spheres saved at 0.02 s and the bundled pile at 0.15 s (islands
/// with candidate pairs, contact memory and events behind them), both advanced 0.02 s further.
#[test]
fn islands_restored_from_their_saved_part_hold_their_whole_states() {
    let pile = Scene::from_file(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/pile_of_balls/scene.toml"))
        .unwrap();
    for (scene, t) in [(spinning_spheres(), 0.02), (pile, 0.15)] {
        on_scene(&scene, "restore test", |m, d, is| {
            is.advance(m, d, t, false).unwrap();
            is.gather(m, d);
            is.record(m, d);
            let mut saved = Vec::new();
            state::get(m, d, state::FULL, &mut saved);
            d.islands.clear();
            let (m2, mut d2) = compile(&scene, "restore test").unwrap();
            if let Some(found) = state::group_candidates(&m2, &saved) {
                crate::contact::elements::set_candidates(&m2, &mut d2, &found).unwrap();
            }
            state::set(&m2, &mut d2, state::FULL, &saved).unwrap();
            crate::engine::resync(&m2, &mut d2);
            let mut restored = Islands::load(Parameters::of_scene(&scene), &m2, &mut d2).unwrap();
            assert!(restored.parts.len() > 1, "{} islands", restored.parts.len());
            assert_eq!(d2.partition, d.partition);
            assert_eq!(snapshot(is, m, d), snapshot(&mut restored, &m2, &mut d2), "at {t} s");
            is.advance(m, d, t + 0.02, false).unwrap();
            restored.advance(&m2, &mut d2, t + 0.02, false).unwrap();
            assert_eq!(
                snapshot(is, m, d),
                snapshot(&mut restored, &m2, &mut d2),
                "at {} s",
                t + 0.02
            );
        });
    }
}

/// A candidate pair new to the list at a rebuild that the broad phase finds already touching
/// (a body moved more than half the margin within a step, which only a body accelerated far
/// beyond gravity does), or whose contact element cannot be made, is refused before anything
/// changes: the islands, their partition and candidate pairs, the reference poses and the
/// counters stay as they were (before, the touch was found while the new islands were formed,
/// and a refusal there dropped the islands with the counters and energies of those not yet
/// formed), and they go on from there. Here one of 64 grouped spheres is put, in the scene's
/// data, onto a sphere it is not listed with (1 µm deep), or within the margin of it with the
/// contact groups' laws and materials taken away from the model the rebuild is given.
#[test]
fn a_new_pair_that_touches_or_cannot_be_made_is_refused_and_the_islands_stay_as_they_were() {
    let scene = grouped(64, 0.02, 0.0015, true);
    for (depth, unmade) in [(1e-6, false), (-0.5 * 0.0015, true)] {
        on_scene(&scene, "rebuild test", |m, d, is| {
            is.advance(m, d, 0.004, false).unwrap();
            let before = snapshot(is, m, d);
            let (partition, rebuilds, references) = (d.partition.clone(), is.rebuilds, d.broad_reference.clone());
            // two spheres on bodies a and b that are not a candidate pair
            let shapes = &m.groups.shapes;
            let listed = |s: usize, o: usize| {
                partition
                    .list()
                    .iter()
                    .any(|c| (c.sphere, c.other) == (s.min(o), s.max(o)))
            };
            let spheres: Vec<usize> = (0..shapes.len()).filter(|&s| shapes[s].body.is_some()).collect();
            let (sa, sb) = spheres
                .iter()
                .flat_map(|&s| spheres.iter().map(move |&o| (s, o)))
                .find(|&(s, o)| s != o && !listed(s, o))
                .unwrap();
            let (a, b) = (shapes[sa].body.unwrap(), shapes[sb].body.unwrap());
            let r = |s: usize| scene.shape[s].radius.unwrap();
            crate::kinematics::poses_and_velocities_at_state(m, d);
            let (pa, pb) = (d.body_pos[a], d.body_pos[b]);
            let target = pb + (pa - pb).normalize() * (r(sa) + r(sb) - depth);
            let qpos = m.joints.iter().find(|j| j.child == a).unwrap().qpos;
            for k in 0..3 {
                d.state[qpos + k] += target[k] - pa[k];
            }
            crate::kinematics::poses_and_velocities_at_state(m, d);
            assert!(
                (d.body_pos[a] - target).norm() < 1e-12,
                "{} against {target}",
                d.body_pos[a]
            );
            let mut unmade_model = m.clone();
            if unmade {
                let g = &mut unmade_model.groups;
                g.laws.iter_mut().for_each(|l| l.stiffness = None);
                g.sphere_sides.iter_mut().for_each(|s| s.material = None);
            }

            let e = is.rebuild(&unmade_model, d).unwrap_err();
            let expected = if unmade {
                "give stiffness"
            } else {
                "touched before the broad phase listed it"
            };
            assert!(e.message.contains(expected), "{}", e.message);
            assert_eq!(e.time, 0.004);
            assert_eq!(d.partition, partition);
            assert_eq!(is.rebuilds, rebuilds);
            assert_eq!(d.broad_reference, references);
            // (gathering writes the islands' coordinates back into the scene's data)
            assert_eq!(snapshot(is, m, d), before);
            is.advance(m, d, 0.008, false).unwrap();
            assert_eq!(is.parts.iter().map(|i| i.data.time).fold(0.0, f64::max), 0.008);
        });
    }
}

/// A forming that fails ends every island, the kept ones too, with their steps counted, and
/// says so (`formed` false: the caller drops the islands and forms them anew). The rebuild's
/// check refuses what would make forming fail before anything changes (above), so forming is
/// called here directly: one island's candidate pairs less one, under laws that cannot make
/// an element.
#[test]
fn a_forming_that_fails_ends_every_island_and_says_so() {
    let scene = grouped(64, 0.02, 0.0015, true);
    on_scene(&scene, "forming test", |m, d, is| {
        is.advance(m, d, 0.012, false).unwrap();
        assert!(is.formed);
        let (steps, n) = (is.total_steps(), is.parts.len());
        let k = (0..n)
            .find(|&k| d.partition.candidates(k).len() >= 2)
            .expect("an island of two pairs");
        let dropped = d.partition.candidates(k)[0];
        let found: Vec<_> = d.partition.list().iter().copied().filter(|&c| c != dropped).collect();
        let mut former = Vec::new();
        crate::contact::elements::former_indices(d.partition.list(), &found, &mut former);
        let memory = is.memory_of_islands(m, &d.partition);
        let mut unmade = m.clone();
        unmade.groups.laws.iter_mut().for_each(|l| l.stiffness = None);
        unmade.groups.sphere_sides.iter_mut().for_each(|s| s.material = None);
        // (the pool's models were cut from the scene's: cut them anew from these laws)
        is.pool = super::Pool::default();
        let old = std::mem::take(&mut is.parts);
        let e = is.form(&unmade, d, &found, &former, &memory, old).unwrap_err();
        assert!(e.message.contains("give stiffness"), "{}", e.message);
        assert!(!is.formed);
        assert!(is.parts.is_empty(), "{} islands left", is.parts.len());
        assert_eq!(is.total_steps(), steps, "the ended islands' steps");
    });
}
