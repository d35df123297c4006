//! Tunable parameters (the contact-law constants) set between communication points after
//! initialisation, and the energy-balance warning.
//!
//! A change takes effect from the next step on: the model is compiled again with the new
//! value and the data (state, contact memory, counters, time) is kept. So the rest of the run
//! equals a run restored from the state saved at that point with the new value; with the
//! `impulse` law each bounce follows Newton's restitution with the coefficient in force at
//! its impact; a saved state carries the values in force when it was saved.

use crate::common;

use common::{bundled, get};
use contact_fmu::checkpoint::Snapshot;
use contact_fmu::model::ContactEventKind;
use contact_fmu::scene::Scene;
use contact_fmu::simulation::Simulation;

const G: f64 = 9.81;

/// The bundled bouncing ball (R = 10 mm, dropped 0.1 m onto a steel plate, hertz_ln, e = 0.8).
fn ball_text() -> String {
    std::fs::read_to_string(bundled("bouncing_ball")).unwrap()
}

/// The bouncing ball with a given, soft stiffness K = 1e5 N/m^1.5: its first contact lasts
/// about 8 ms from t = 0.1428 s, so communication points (1 ms apart) fall inside it.
fn soft_ball() -> Scene {
    let text = ball_text().replacen("law = \"hertz_ln\"", "law = \"hertz_ln\"\nstiffness = 1.0e5", 1);
    Scene::from_str(&text, "soft_ball.toml").unwrap_or_else(|e| panic!("{e}"))
}

fn ball() -> Scene {
    Scene::from_str(&ball_text(), "bouncing_ball.toml").unwrap()
}

fn start(scene: &Scene, set: &[(&str, f64)]) -> Simulation {
    let mut s = Simulation::new(scene.clone(), "scene");
    for (name, value) in set {
        s.set_by_name(name, *value).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    s.initialize(0.0).unwrap_or_else(|e| panic!("{e}"));
    s
}

const DT: f64 = 1e-3;

/// Steps to the communication points k·DT for k in `from..=to`, returning every output (as
/// bits) at each.
fn record(s: &mut Simulation, from: usize, to: usize) -> Vec<Vec<u64>> {
    let outputs = s.output_indices();
    (from..=to)
        .map(|k| {
            s.step_to(k as f64 * DT).unwrap_or_else(|e| panic!("{e}"));
            outputs.iter().map(|&i| s.get(i).unwrap().to_bits()).collect()
        })
        .collect()
}

#[test]
fn a_change_mid_run_equals_a_run_restored_from_that_point_with_the_new_value() {
    for continuation in [false, true] {
        let mut scene = soft_ball();
        scene.solver.continuation = continuation;
        change_mid_run_equals_restored_run(&scene);
    }
}

/// With `solver.continuation` off, the state saved at t1 with the new value written into it
/// equals the change; with it on (the default) the saved state holds the method's pending
/// step, taken with the old value, so the new value is set after the restore, as a host does.
fn change_mid_run_equals_restored_run(scene: &Scene) {
    let (k1, k2) = (146, 400); // t1 = 0.146 s lies inside the first contact
    for (name, value) in [
        ("ball_floor.restitution", 0.3),
        ("ball_floor.stiffness", 3e5),
        ("ball_floor.exponent", 1.3),
    ] {
        let mut a = start(scene, &[]);
        record(&mut a, 1, k1);
        assert_eq!(get(&mut a, "ball_floor.active"), 1.0, "t1 must lie inside the contact");
        let saved = a.snapshot(Vec::new());
        a.set_by_name(name, value).unwrap();
        assert_eq!(get(&mut a, name), value);
        let changed = record(&mut a, k1 + 1, k2);

        // the state saved at t1, with the new value in place of the old one, restored into a
        // fresh simulation: a new model compiled with the value, the saved data set into it
        let mut b = Simulation::new(scene.clone(), "scene");
        if scene.solver.continuation {
            b.restore(&saved).unwrap();
            b.set_by_name(name, value).unwrap();
        } else {
            let vr = a.table().index_of(name).unwrap();
            let mut with_value = saved.clone();
            with_value.values[vr] = value;
            b.restore(&with_value).unwrap();
        }
        let restored = record(&mut b, k1 + 1, k2);
        assert!(
            changed == restored,
            "{name}: the change mid-run differs from the restored run"
        );

        let mut c = Simulation::new(scene.clone(), "scene");
        c.restore(&saved).unwrap();
        assert!(
            record(&mut c, k1 + 1, k2) != changed,
            "{name}: the change made no difference"
        );
        // counters and time went on: they were not reset by the change
        assert_eq!(a.time(), k2 as f64 * DT);
        assert!(a.counters().steps > b.counters().steps / 2 && a.counters() == b.counters());
    }
}

/// The speed the ball would have at the plate, from its state in flight:
/// √(v² + 2 g (z − R)) (constant between impacts; the rebound speed of the last impact).
fn flight_speed(s: &mut Simulation) -> f64 {
    let (z, v) = (get(s, "ball.r[3]"), get(s, "ball.v[3]"));
    (v * v + 2.0 * G * (z - 0.01)).sqrt()
}

#[test]
fn each_bounce_rebounds_with_the_restitution_in_force_at_its_impact() {
    // impulse law: Newton's restitution, exactly. Dropped from 0.1 m: v0 = √(2 g h).
    let mut s = start(&ball(), &[("ball_floor.law", 6.0)]);
    let v0 = (2.0 * G * 0.1).sqrt();
    // (time of the change, in flight before the next impact; coefficient from then on)
    let changes = [(0.2, 0.5), (0.4, 0.3), (0.5, 0.9)];
    let coefficients = [0.8, 0.5, 0.3, 0.9];
    let mut expected = vec![v0];
    for e in coefficients {
        expected.push(expected.last().unwrap() * e);
    }
    let mut k = 0;
    for (t, e) in changes.iter().copied().chain([(0.545, f64::NAN)]) {
        while (k as f64) * DT < t - 1e-12 {
            k += 1;
            s.step_to(k as f64 * DT).unwrap();
        }
        // in flight after as many impacts as changes so far: the rebound speed of the last
        let impacts = get(&mut s, "ball_floor.impacts") as usize;
        let speed = flight_speed(&mut s);
        assert!(
            (speed - expected[impacts]).abs() < 1e-9 * v0,
            "t = {t}: after {impacts} impacts the ball flies at {speed}, closed form {}",
            expected[impacts]
        );
        if !e.is_nan() {
            s.set_by_name("ball_floor.restitution", e).unwrap();
        }
    }
    assert_eq!(get(&mut s, "ball_floor.impacts"), 4.0);
    // the approach speed of each impact is the rebound speed of the one before
    let approach: Vec<f64> = s
        .contact_events()
        .iter()
        .filter(|e| e.kind == ContactEventKind::Impact)
        .map(|e| e.delta_dot.abs())
        .collect();
    assert_eq!(approach.len(), 4);
    for (i, v) in approach.iter().enumerate() {
        assert!(
            (v - expected[i]).abs() < 1e-9 * v0,
            "impact {i}: {v} vs {}",
            expected[i]
        );
    }
}

#[test]
fn a_saved_state_restores_the_tunable_values_it_was_saved_with() {
    let scene = soft_ball();
    let mut a = start(&scene, &[]);
    record(&mut a, 1, 146);
    let bytes = a.snapshot(Vec::new()).to_bytes(7);
    let untouched = {
        let mut c = Simulation::new(scene.clone(), "scene");
        c.restore(&Snapshot::from_bytes(&bytes, 7).unwrap()).unwrap();
        record(&mut c, 147, 300)
    };
    a.set_by_name("ball_floor.restitution", 0.2).unwrap();
    a.set_by_name("ball_floor.stiffness", 2e5).unwrap();
    let after_change = a.snapshot(Vec::new()).to_bytes(7);
    let changed = record(&mut a, 147, 300);
    assert!(changed != untouched);
    // back to the state saved before the change: the old values, the old future
    a.restore(&Snapshot::from_bytes(&bytes, 7).unwrap()).unwrap();
    assert_eq!(get(&mut a, "ball_floor.restitution"), 0.8);
    assert_eq!(get(&mut a, "ball_floor.stiffness"), 1e5);
    assert!(record(&mut a, 147, 300) == untouched);
    // the state saved after the change carries the new values, into a fresh simulation too
    let mut b = Simulation::new(scene, "scene");
    b.restore(&Snapshot::from_bytes(&after_change, 7).unwrap()).unwrap();
    assert_eq!(get(&mut b, "ball_floor.restitution"), 0.2);
    assert_eq!(get(&mut b, "ball_floor.stiffness"), 2e5);
    assert!(record(&mut b, 147, 300) == changed);
}

#[test]
fn fixed_parameters_stay_refused_and_a_refused_value_changes_nothing() {
    let scene = soft_ball();
    let mut s = start(&scene, &[]);
    let mut untouched = start(&scene, &[]);
    record(&mut s, 1, 100);
    record(&mut untouched, 1, 100);
    for name in [
        "ball.mass",
        "ball.inertia[1]",
        "ball_floor.radius",
        "ball_floor.size[1]",
        "ball_floor.law",
        "ball_floor.max_penetration",
        "ball_floor.min_impact_velocity",
        "steel.youngs_modulus",
        "solver.rtol",
        "solver.method",
    ] {
        let vr = s.table().index_of(name).unwrap();
        let old = s.get(vr).unwrap();
        let e = s.set(vr, old * 0.5 + 1.0).expect_err(name).to_string();
        assert!(e.contains(name) && e.contains("fixed parameter"), "{e}");
        assert_eq!(s.get(vr).unwrap(), old);
    }
    for (name, value) in [
        ("ball_floor.restitution", 1.5),
        ("ball_floor.restitution", f64::NAN),
        ("ball_floor.stiffness", 0.0),
        ("ball_floor.exponent", 0.5),
        ("ball_floor.damping", -1.0),
    ] {
        let vr = s.table().index_of(name).unwrap();
        let old = s.get(vr).unwrap();
        let e = s.set(vr, value).expect_err(name).to_string();
        assert!(
            e.contains(&format!("parameter {name} = ")) && e.contains("allowed range"),
            "{e}"
        );
        assert_eq!(s.get(vr).unwrap(), old);
    }
    assert!(record(&mut s, 101, 300) == record(&mut untouched, 101, 300));

    // a value the law cannot take together with the others: flores needs e > 0
    let mut f = start(&scene, &[("ball_floor.law", 5.0)]);
    let e = f.set_by_name("ball_floor.restitution", 0.0).unwrap_err().to_string();
    assert!(
        e.contains("\"ball_floor.restitution\" = 0") && e.contains("e > 0"),
        "{e}"
    );
    assert_eq!(get(&mut f, "ball_floor.restitution"), 0.8);
    f.step_to(0.01).unwrap();
}

/// Runs to `stop` at the scene's interval; returns the warnings.
fn warnings_of_run(s: &mut Simulation, stop: f64) -> Vec<String> {
    let (warnings, ended) = warnings_and_end(s, stop);
    ended.unwrap_or_else(|e| panic!("{e}"));
    warnings
}

#[test]
fn a_coarse_fixed_step_on_a_stiff_contact_warns_once_of_the_energy_drift() {
    // rk4 at 0.1 ms through a steel-on-steel contact of ~40 µs: the ball gains energy
    // the ball gains energy at every impact; once the balance has drifted beyond ten times its
    // scale the run is stopped as a blow-up (simulation::ENERGY_BLOW_UP)
    let mut s = start(&ball(), &[("solver.method", 3.0), ("solver.max_step", 1e-4)]);
    let e0 = common::energy_balance(&mut s);
    let interval = s.scene().model.interval;
    let stopped = s.run(1.0, interval, |_| Ok(()));
    let warnings = s.take_warnings();
    let drift = (common::energy_balance(&mut s) - e0).abs() / e0;
    assert!(drift > 0.1, "the coarse run drifts by {drift}");
    let stopped = stopped.expect_err("stopped as a blow-up").to_string();
    assert!(stopped.contains("blew up") && stopped.contains("rk4"), "{stopped}");
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("energy balance") && warnings[0].contains("more than 1 %"),
        "{}",
        warnings[0]
    );
    // the first impact (t = 0.1428 s) is where it goes wrong
    let t = warning_time(&warnings[0]);
    assert!((0.1428..0.25).contains(&t), "warned at t = {t}");
    // once per run
    let _ = s.run(1.5, interval, |_| Ok(()));
    assert!(s.take_warnings().is_empty());
}

/// The warning's time (its text begins "at t = ...:").
fn warning_time(warning: &str) -> f64 {
    warning["at t = ".len()..].split(':').next().unwrap().parse().unwrap()
}

/// Runs to `stop` at the scene's interval from where `s` is: the warnings, and how it ended.
fn warnings_and_end(s: &mut Simulation, stop: f64) -> (Vec<String>, Result<(), String>) {
    let interval = s.scene().model.interval;
    let ended = s.run(stop, interval, |_| Ok(())).map_err(|e| e.to_string());
    (s.take_warnings(), ended)
}

#[test]
fn a_restored_run_warns_and_stops_where_the_uninterrupted_one_does() {
    // the coarse rk4 runs above: the energy watch (its reference, scale, last check and
    // warning) is saved with the state, so that a run restored from a state saved before the
    // drift warns with the same words and stops at the same step, and one restored from a
    // state saved after the warning does not warn again
    let interval = ball().model.interval;
    for (step, blows_up) in [(3e-5, false), (1e-4, true)] {
        let settings = [("solver.method", 3.0), ("solver.max_step", step)];
        let mut straight = start(&ball(), &settings);
        let (warnings, ended) = warnings_and_end(&mut straight, 1.0);
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert_eq!(ended.is_err(), blows_up, "{ended:?}");
        let warned_at = warning_time(&warnings[0]);
        let mut saves = vec![(0.1, false)];
        if !blows_up {
            saves.push((warned_at + 3.0 * interval, true));
        }
        for (save, warned) in saves {
            let mut first = start(&ball(), &settings);
            first.run(save, interval, |_| Ok(())).unwrap();
            let _ = first.take_warnings();
            let bytes = first.snapshot(Vec::new()).to_bytes(7);
            let mut restored = Simulation::new(ball(), "scene");
            restored.restore(&Snapshot::from_bytes(&bytes, 7).unwrap()).unwrap();
            assert_eq!(restored.energy_drifted(), warned, "step {step}, saved at {save}");
            let (again, ended_again) = warnings_and_end(&mut restored, 1.0);
            let expected = if warned { Vec::new() } else { warnings.clone() };
            assert_eq!(again, expected, "step {step}, saved at {save}");
            assert_eq!(ended_again, ended, "step {step}, saved at {save}");
        }
    }
}

#[test]
fn default_settings_and_a_retuned_loaded_contact_do_not_warn() {
    for (name, path) in common::bundled_scenes() {
        let mut s = Simulation::from_file(&path).unwrap();
        s.initialize(0.0).unwrap();
        let stop = s.scene().model.stop_time;
        assert_eq!(warnings_of_run(&mut s, stop), Vec::<String>::new(), "{name}");
    }
    // tripling the stiffness of a loaded contact triples its stored energy: a jump of the
    // balance made by the host, not a drift of the integration
    let mut s = start(&soft_ball(), &[]);
    record(&mut s, 1, 146);
    let before = common::energy_balance(&mut s);
    s.set_by_name("ball_floor.stiffness", 3e5).unwrap();
    let jump = common::energy_balance(&mut s) - before;
    assert!(jump > 0.05 * before, "jump {jump} J of {before} J");
    record(&mut s, 147, 1000);
    assert_eq!(s.take_warnings(), Vec::<String>::new());
}

/// A tunable parameter of a declared contact can be changed after the broad phase made the
/// contact groups' list anew (the new constants are compiled for the data's list, not the
/// list the run started with): the pile of balls with a declared probe contact out of reach.
#[test]
fn a_tunable_value_changes_after_the_candidate_list_changed() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/pile_of_balls/scene.toml");
    let mut text = std::fs::read_to_string(path).unwrap();
    text.push_str(
        "\n[[contact]]\nname = \"probe\"\ntype = \"sphere_plane\"\nlaw = \"hertz_ln\"\nrestitution = 0.8\n\
         stiffness = 1.0e9\nsphere_body = \"ball1\"\ncenter = [0.0, 0.0, 0.0]\nradius = 0.001\nbody = \"ground\"\n\
         origin = [0.0, 0.0, -10.0]\nnormal = [0.0, 0.0, 1.0]\nu_axis = [1.0, 0.0, 0.0]\nsize = [1.0, 1.0]\n",
    );
    let scene = Scene::from_str(&text, "probe.toml").unwrap();
    let mut s = Simulation::new(scene, "probe.toml");
    s.initialize(0.0).unwrap();
    let n0 = s.contacts().unwrap().len();
    let mut t = 0.0;
    while s.contacts().unwrap().len() == n0 {
        t += 1e-3;
        assert!(t < 0.4, "the candidate list never changed");
        s.step_to(t).unwrap();
    }
    s.set_by_name("probe.restitution", 0.7).unwrap();
    let probe = &s.contacts().unwrap()[0];
    assert_eq!((probe.name.as_str(), probe.restitution), ("probe", 0.7));
    s.step_to(t + 0.01).unwrap();
}

#[test]
fn a_command_line_run_resumed_after_the_drift_warning_notes_it_and_is_not_refused_for_it() {
    // the watch is saved with the checkpoint and warns once per run: the resumed part gives no
    // warning of its own, and says the state had drifted before
    let scene = common::bundled("bouncing_ball");
    let dir = std::env::temp_dir().join(format!("contact_fmu_drift_resume_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let state = dir.join("drifted.state");
    let (scene, state) = (scene.to_str().unwrap(), state.to_str().unwrap());
    let rk4 = ["--set", "solver.method=rk4", "--set", "solver.max_step=3e-5", "--quiet"];
    let simulate = |extra: &[&str]| {
        let mut args = vec!["simulate", scene];
        args.extend_from_slice(&rk4);
        args.extend_from_slice(extra);
        common::run_command(&args)
    };
    // the first impact (0.143 s) drifts: refused without --allow-energy-drift
    let (ok, err) = simulate(&["--stop-time", "0.2"]);
    assert!(!ok && err.contains("the warning above"), "{err}");
    let (ok, err) = simulate(&["--stop-time", "0.2", "--allow-energy-drift", "--save-state", state]);
    assert!(ok, "{err}");
    // (the method and its step come with the state)
    let (ok, err) = common::run_command(&["simulate", scene, "--quiet", "--stop-time", "0.3", "--resume", state]);
    assert!(ok, "{err}");
    assert!(
        err.contains("note:") && err.contains("had drifted") && !err.contains("warning"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every output's bits at the end of a run of bundled scene `path` to `stop` over its
/// communication points: at the first point a host sets `changed`, and at every later point it
/// sets each of `settable` to the value it has then (or not, with an empty list).
fn run_setting_present_values(
    path: &std::path::Path,
    stop: f64,
    changed: &[(usize, f64)],
    settable: &[usize],
) -> Vec<u64> {
    let mut s = Simulation::from_file(path).unwrap();
    s.initialize(0.0).unwrap();
    let interval = s.scene().model.interval;
    let mut first = true;
    s.run(stop, interval, |s| {
        if std::mem::take(&mut first) {
            for &(vr, value) in changed {
                s.set(vr, value).map_err(|e| e.to_string())?;
            }
            return Ok(());
        }
        for &vr in settable {
            let value = s.get(vr).map_err(|e| e.to_string())?;
            s.set(vr, value).map_err(|e| e.to_string())?;
        }
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let outputs = s.output_indices();
    outputs.iter().map(|&vr| s.get(vr).unwrap().to_bits()).collect()
}

#[test]
fn a_host_that_sets_the_present_values_again_changes_nothing() {
    // co-simulation masters set every input (and may set the tunable parameters) at every
    // communication point, unchanged or not: a value set to what it is changes no bit, also
    // a parameter that follows another (`static_friction` follows `friction`, here changed at
    // the first point). Not a driven joint's coordinate or rate (`<drive>.q`, `.qd`): setting
    // one moves the joint to it, and the joint's coordinate, integrated with the rest of the
    // state, differs from the value set by rounding (about 1e-15 m on the track scene's rails
    // held at 0), so setting the value again is a move and the method restarts.
    use contact_fmu::variables::VarRef;
    let mut with_values = 0;
    for (name, path) in common::bundled_scenes() {
        let mut sim = Simulation::from_file(&path).unwrap();
        sim.initialize(0.0).unwrap();
        let drives: Vec<usize> = sim
            .model()
            .unwrap()
            .drives
            .iter()
            .flat_map(|d| [d.value, d.value + 1])
            .collect();
        let vars = sim.variables();
        let settable: Vec<usize> = common::settable(&sim)
            .into_iter()
            .filter(|&vr| !matches!(vars[vr].target, VarRef::Input(i) if drives.contains(&i)))
            .collect();
        if settable.is_empty() {
            continue;
        }
        with_values += 1;
        let changed: Vec<(usize, f64)> = settable
            .iter()
            .filter(|&&vr| vars[vr].name.ends_with(".friction"))
            .map(|&vr| (vr, 0.8 * vars[vr].start.unwrap()))
            .collect();
        let stop = sim.scene().model.stop_time.min(0.4);
        assert!(
            run_setting_present_values(&path, stop, &changed, &settable)
                == run_setting_present_values(&path, stop, &changed, &[]),
            "{name}: setting {} values to what they are changed the run",
            settable.len()
        );
    }
    assert!(with_values >= 4, "{with_values} scenes with values to set");
}
