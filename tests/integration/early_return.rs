//! Steps that end at contact events (`Simulation::step_to_event`, behind FMI 3.0's early
//! return): each ends at a located event that changed a contact's mode, the next goes on from
//! there, and the states at the communication points are those of the run without early
//! returns, bit for bit (the integrator's steps do not depend on where an advance ended). The
//! bundled scenes cover one integrator (the balls, the two spheres, the slider-crank), and
//! independent islands with contact groups (the pile of balls: the islands that went further
//! are taken back to the event of one).

use crate::common;

use common::bundled;
use contact_fmu::model::ContactEventKind;
use contact_fmu::simulation::{communication_points, Simulation};

/// Every output's bits at every communication point (`h` apart, to `stop`), and the times at
/// which a step returned early.
fn run(sim: &mut Simulation, stop: f64, h: f64, early: bool) -> (Vec<Vec<u64>>, Vec<f64>) {
    let outputs = sim.output_indices();
    let (mut grid, mut returns) = (Vec::new(), Vec::new());
    for t in communication_points(sim.time(), stop, h) {
        loop {
            let before = sim.time();
            let stopped = if early {
                sim.step_to_event(t).unwrap()
            } else {
                sim.step_to(t).unwrap();
                false
            };
            if !stopped {
                assert_eq!(sim.time(), t);
                break;
            }
            assert!(before < sim.time() && sim.time() < t, "{before} < {} < {t}", sim.time());
            returns.push(sim.time());
        }
        let mut row = vec![0; outputs.len()];
        sim.get_each(outputs.iter().copied(), |k, x| row[k] = x.to_bits())
            .unwrap();
        grid.push(row);
    }
    (grid, returns)
}

fn compare(name: &str, stop: f64, settings: &[(&str, f64)]) -> Vec<f64> {
    let mut runs = Vec::new();
    for early in [true, false] {
        let mut sim = Simulation::from_file(&bundled(name)).unwrap();
        for &(k, v) in settings {
            sim.set_by_name(k, v).unwrap();
        }
        sim.initialize(0.0).unwrap();
        let h = sim.scene().model.interval;
        runs.push(run(&mut sim, stop, h, early));
    }
    let (plain, none) = runs.pop().unwrap();
    let (grid, returns) = runs.pop().unwrap();
    assert!(none.is_empty());
    assert!(!returns.is_empty(), "{name}: no contact event before {stop} s");
    let first = grid.iter().zip(&plain).position(|(a, b)| a != b);
    assert_eq!(
        first, None,
        "{name}: the outputs differ from communication point {first:?} on"
    );
    returns
}

#[test]
fn the_bouncing_ball_returns_at_each_impact_and_its_trajectory_is_unchanged() {
    // the impulse law: one event per impact, at the closed-form time of free flight
    let e = 0.8;
    let returns = compare(
        "bouncing_ball",
        1.0,
        &[("ball_floor.law", 6.0), ("ball_floor.restitution", e)],
    );
    let g = 9.81;
    let mut v = (2.0 * g * 0.1f64).sqrt();
    let mut t = v / g;
    let mut exact = Vec::new();
    while t < 1.0 {
        exact.push(t);
        v *= e;
        t += 2.0 * v / g;
    }
    assert_eq!(returns.len(), exact.len());
    for (t, te) in returns.iter().zip(&exact) {
        assert!((t - te).abs() <= 2e-13 * te, "{t} against {te}");
    }
}

#[test]
fn continuous_laws_return_at_touch_and_separation() {
    // hertz_ln: a touch and a separation per bounce, nothing else ends a step
    let mut sim = Simulation::from_file(&bundled("bouncing_ball")).unwrap();
    sim.initialize(0.0).unwrap();
    let (_, returns) = run(&mut sim, 0.5, 1e-3, true);
    let modes: Vec<(f64, ContactEventKind)> = sim
        .contact_events()
        .iter()
        .filter(|e| e.kind.changes_mode())
        .map(|e| (e.time, e.kind))
        .collect();
    assert_eq!(returns, modes.iter().map(|m| m.0).collect::<Vec<_>>());
    assert!(modes.len() >= 4 && modes.len().is_multiple_of(2));
    for pair in modes.chunks(2) {
        assert_eq!(
            [pair[0].1, pair[1].1],
            [ContactEventKind::Touch, ContactEventKind::Separation]
        );
    }
    compare("bouncing_ball", 0.5, &[]);
}

#[test]
fn the_other_bundled_scenes_keep_their_trajectories() {
    compare("two_spheres", 0.01, &[]);
    compare("slider_crank", 0.4, &[]);
}

#[test]
fn independent_islands_keep_their_trajectories() {
    compare("pile_of_balls", 0.2, &[]);
}

/// A state saved at every early return and restored into a new simulation goes on as the run
/// that was never interrupted, bit for bit, with islands of every kind (balls, a spinning body,
/// a pendulum on a joint, a spring, a body with an input: `scenes/islands_mixed.toml`), and
/// with a spinning ball resting on the floor under the impulse law (`scenes/resting_spin.toml`):
/// the islands that did not stop at the event were taken back to it and continue a step begun
/// before it, whose event values at its end the restore evaluates as the step's check did (on
/// the plan's kinematics, or the whole ones while a contact rests).
#[test]
fn states_saved_at_early_returns_go_on_bit_for_bit_with_islands() {
    for (name, text, least) in [
        ("islands_mixed", include_str!("scenes/islands_mixed.toml"), 100),
        ("resting_spin", include_str!("scenes/resting_spin.toml"), 10),
    ] {
        let new = || {
            let mut sim = Simulation::from_scene_str(text, name).unwrap();
            sim.initialize(0.0).unwrap();
            sim
        };
        let (stop, h) = (0.2, 1e-3);
        let mut runs = Vec::new();
        for restore in [false, true] {
            let mut sim = new();
            let mut returns = 0;
            for t in communication_points(0.0, stop, h) {
                while sim.step_to_event(t).unwrap() {
                    returns += 1;
                    if restore {
                        let saved = sim.snapshot(Vec::new());
                        sim = Simulation::from_scene_str(text, name).unwrap();
                        sim.restore(&saved).unwrap();
                    }
                }
            }
            let state: Vec<u64> = sim.snapshot(Vec::new()).state.iter().map(|x| x.to_bits()).collect();
            runs.push((state, returns));
        }
        assert!(runs[0].1 >= least, "{name}: early returns: {}", runs[0].1);
        assert_eq!(runs[0].1, runs[1].1, "{name}: early returns");
        let differ = runs[0].0.iter().zip(&runs[1].0).filter(|(a, b)| a != b).count();
        assert_eq!(
            differ,
            0,
            "{name}: of {} numbers of the state at {stop} s",
            runs[0].0.len()
        );
    }
}
