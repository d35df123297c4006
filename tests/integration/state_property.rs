//! The saved state is the whole future: for random scenes, methods, contact laws and save
//! points, with the integrator restarting at communication points or continuing across them,
//! get → serialise → deserialise → set into a fresh simulation and continue equals the
//! uninterrupted run bit for bit. A corrupted or truncated serialised state is refused
//! with a message, and the simulation it was meant for stays as it was (no NaN reaches an
//! output).

use crate::common;
use contact_fmu::checkpoint::Snapshot;
use contact_fmu::scene::{BodySpec, ContactSpec, Law, Method, Scene, GROUND};
use contact_fmu::scene_builder::{Plane, SceneBuilder, Sphere};
use contact_fmu::simulation::Simulation;
use proptest::prelude::*;

/// A ball dropped on a floor with a given stiffness and damping, so that every law
/// (Kelvin-Voigt included) can be selected by the `floor.law` parameter.
fn ball() -> Scene {
    let ball = BodySpec::new("ball", 0.5, [2e-4; 3], [0.0, 0.0, 0.12]).velocity([0.3, 0.0, 0.0]);
    let floor = Plane::horizontal([0.0; 3], [2.0, 2.0]);
    SceneBuilder::new("ball")
        .gravity([0.0, 0.0, -9.81])
        .experiment(0.6, 0.01)
        .tolerances(1e-8, 1e-10)
        .max_step(1e-3)
        .contact(
            ContactSpec::sphere_plane("floor", Law::HertzLn, Sphere::of(&ball, 0.02), GROUND, floor)
                .restitution(0.7)
                .stiffness(2e7)
                .damping(40.0),
        )
        .body(ball)
        .build()
}

fn bundled(name: &str) -> Scene {
    Scene::from_file(&common::bundled(name)).unwrap()
}

/// The scene, the contact whose law is varied, and the time span to run.
fn scene(k: usize) -> (Scene, &'static str, f64) {
    match k {
        0 => (ball(), "floor", 0.6),
        1 => (bundled("bouncing_ball"), "ball_floor", 0.8),
        2 => (bundled("two_spheres"), "impact", 0.02),
        3 => (bundled("slider_crank"), "impact", 0.12),
        _ => (bundled("rail_vehicle"), "", 0.5),
    }
}

fn outputs(sim: &mut Simulation) -> Vec<u64> {
    sim.output_indices()
        .iter()
        .map(|&i| sim.get(i).unwrap().to_bits())
        .collect()
}

/// A simulation of `scene` with `method` and `law`; `continuation`: the integrator continues
/// across communication points (its state then includes a step reaching past the save point).
fn configured(mut scene: Scene, method: Method, contact: &str, law: Law, continuation: bool) -> Simulation {
    scene.solver.continuation = continuation;
    let mut s = common::open(scene);
    s.set_by_name("solver.method", method as i64 as f64).unwrap();
    if !contact.is_empty() {
        s.set_by_name(&format!("{contact}.law"), law as i64 as f64).unwrap();
    }
    s
}

/// Runs scene `k` with `method` and `law` over `n` communication points, saves after
/// `split` of them, restores the serialised state into a fresh simulation (configured with
/// another method, so the state's parameter values must rule) and checks that both continue
/// bit for bit; then that damaged bytes are refused without harm. Returns the number of
/// points compared.
fn check(
    k: usize,
    method: Method,
    law: Law,
    continuation: bool,
    split_fraction: f64,
    damage: usize,
) -> Result<usize, TestCaseError> {
    let (scene, contact, span) = scene(k);
    let n = 24;
    let h = span / n as f64;
    let mut a = configured(scene.clone(), method, contact, law, continuation);
    a.initialize(0.0).unwrap();
    let split = ((split_fraction * n as f64) as usize).clamp(1, n - 1);
    for i in 1..=split {
        if a.step_to(i as f64 * h).is_err() {
            // the method cannot run this case (e.g. fixed-step rk4 on a stiff contact)
            return Ok(0);
        }
    }
    let bytes = a.snapshot(Vec::new()).to_bytes(17);
    let other = if method == Method::Dopri5 {
        Method::Rk4
    } else {
        Method::Dopri5
    };
    let mut b = configured(scene, other, "", law, continuation);
    b.initialize(0.0).unwrap();
    // Damaged bytes first: refused with a message, and `b` stays usable with finite outputs.
    let mut flipped = bytes.clone();
    flipped[damage % bytes.len()] ^= 0x5a;
    let truncated = &bytes[..damage % bytes.len()];
    for bad in [&flipped[..], truncated] {
        let err = Snapshot::from_bytes(bad, 17).err();
        prop_assert!(err.as_deref().is_some_and(|m| !m.is_empty()), "damaged state accepted");
    }
    let before = outputs(&mut b);
    prop_assert!(before.iter().all(|&x| f64::from_bits(x).is_finite()));
    // A well-formed state of the wrong length is refused too, and changes nothing.
    let mut short = Snapshot::from_bytes(&bytes, 17).unwrap();
    short.state.pop();
    prop_assert!(b.restore(&short).is_err());
    prop_assert_eq!(outputs(&mut b), before.clone());
    b.restore(&Snapshot::from_bytes(&bytes, 17).unwrap()).unwrap();
    prop_assert_eq!(outputs(&mut a), outputs(&mut b), "outputs differ right after restore");
    for i in split + 1..=n {
        let t = i as f64 * h;
        // the same result, a failure included (then both stop at the same time and state)
        let (ra, rb) = (a.step_to(t), b.step_to(t));
        prop_assert_eq!(&ra, &rb, "restored run's step to {} ended otherwise", t);
        prop_assert_eq!(outputs(&mut a), outputs(&mut b), "restored run differs at t = {}", t);
        if ra.is_err() {
            return Ok(i - split);
        }
    }
    Ok(n - split)
}

const METHODS: [Method; 5] = Method::ALL;

#[test]
fn every_method_and_law_continues_bit_for_bit_after_a_serialised_restore() {
    for continuation in [false, true] {
        let mut compared = 0;
        for (mi, method) in METHODS.into_iter().enumerate() {
            for (li, law) in Law::ALL.into_iter().enumerate() {
                let split = 0.2 + 0.1 * ((mi * 6 + li) % 7) as f64;
                compared += check(0, method, law, continuation, split, 13 * (mi * 6 + li) + 5).unwrap();
            }
        }
        assert!(compared > 24 * 5);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn random_scene_method_law_and_save_point_continue_bit_for_bit(
        k in 0usize..5,
        method in prop::sample::select(METHODS.to_vec()),
        law in prop::sample::select(Law::ALL.to_vec()),
        continuation in any::<bool>(),
        split in 0.05f64..0.95,
        damage in 0usize..100_000,
    ) {
        // Kelvin-Voigt needs a given stiffness: only the ball scene has one.
        let law = if k > 0 && law == Law::KelvinVoigt { Law::Hertz } else { law };
        check(k, method, law, continuation, split, damage)?;
    }
}

/// `scene` run to `save`, its serialised state restored into a fresh simulation, and both run
/// over `points` after it: their outputs equal at every point and their counters at the last,
/// bit for bit. `check_saved` looks at the first at `save` first. Returns the points compared.
fn restored_run_continues(
    scene: &Scene,
    save: f64,
    points: &[f64],
    what: &str,
    check_saved: impl Fn(&mut Simulation),
) -> usize {
    let mut a = common::open(scene.clone());
    a.initialize(0.0).unwrap();
    a.step_to(save).unwrap();
    check_saved(&mut a);
    let bytes = a.snapshot(Vec::new()).to_bytes(17);
    let mut b = common::open(scene.clone());
    b.initialize(0.0).unwrap();
    b.restore(&Snapshot::from_bytes(&bytes, 17).unwrap()).unwrap();
    for &t in points {
        a.step_to(t).unwrap();
        b.step_to(t).unwrap();
        assert_eq!(outputs(&mut a), outputs(&mut b), "{what}: differs at t = {t}");
    }
    assert_eq!(a.counters(), b.counters(), "{what}");
    points.len()
}

/// A state saved where the method's last step ended exactly at the save point (its step was
/// accepted there, not continued past it) continues bit for bit. Two spheres whose paths run
/// through each other deeper than the contact's largest penetration (the large sphere's
/// contact sphere moved to the origin), without gravity: the contact never acts, and the
/// steps are bounded by the time in which the small sphere could reach it (its radius at
/// 1 m/s, 10 ms) until its centre passes the other's at 10.5 ms, so a step ends at 20 ms.
/// The restore once put the event values of the step's start where those of its end belong:
/// the resumed run saw the contact still closing, took steps of 10 ms instead of 100 ms, and
/// its positions differed in the last bits.
#[test]
fn a_state_saved_at_the_end_of_a_step_continues_bit_for_bit() {
    let points: Vec<f64> = (1..=30).map(|k| 0.02 + k as f64 * 1e-3).collect();
    for islands in [false, true] {
        let mut scene = bundled("two_spheres");
        scene.contact[0].other_center = Some([0.0; 3]);
        scene.solver.islands = islands;
        let what = format!("islands = {islands}");
        restored_run_continues(&scene, 0.02, &points, &what, |a| {
            let d = a.data().unwrap();
            let m = d.solver.method().unwrap();
            assert!(
                m.t() == 0.02 && m.t_prev() < m.t(),
                "{what}: the last step should end at the save point: [{}, {}]",
                m.t_prev(),
                m.t()
            );
        });
    }
}

/// A scene with a loop and a free body continues bit for bit after a restore, also when the
/// free body's inertia is near singular: the slider-crank with its block let free (its guide
/// removed) and the block's second moment of inertia 1e-12 of the others. The block's block of
/// the mass matrix, expressed about the world origin by a full evaluation (the restore's), has
/// then a negative pivot from rounding, and that evaluation fails; the right-hand side's lean
/// path once solved over every block with the failed factor and the NaN it left, so the
/// restored run's first steps came out NaN and were rejected.
#[test]
fn a_loop_beside_a_near_singular_free_body_continues_bit_for_bit_after_a_restore() {
    let mut scene = bundled("slider_crank");
    scene
        .joint
        .retain(|j| j.name != "block_guide" && j.name != "crank_pivot");
    let block = scene.body.iter_mut().find(|b| b.name == "block").unwrap();
    block.inertia = [1.2e-5, 1.2e-17, 1.2e-5];
    let mut compared = 0;
    for save in [0.005, 0.01, 0.015] {
        // (points 5 ms apart: the restored run takes steps before an output read evaluates
        // the whole model again, which would overwrite what the restore's evaluation left)
        let points: Vec<f64> = (1..=10).map(|k| save + k as f64 * 5e-3).collect();
        compared += restored_run_continues(&scene, save, &points, &format!("saved at {save}"), |_| {});
    }
    assert_eq!(compared, 30);
}

/// `simulate --save-state` then `simulate --resume` gives the rows of one uninterrupted run,
/// digit for digit, and a summary of its own part: the time it simulated, and the steps and
/// evaluations of the uninterrupted run less those before the checkpoint; a damaged checkpoint
/// is refused with a message naming the file.
#[test]
fn command_line_checkpoint_resumes_bit_for_bit() {
    let exe = env!("CARGO_BIN_EXE_contact-fmu");
    let dir = std::env::temp_dir().join(format!("contact_fmu_checkpoint_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = format!("{}/fmu/bouncing_ball/scene.toml", env!("CARGO_MANIFEST_DIR"));
    let run = |args: &[&str]| {
        let out = std::process::Command::new(exe).args(args).output().unwrap();
        (out.status.success(), String::from_utf8_lossy(&out.stderr).to_string())
    };
    // the summary's simulated time, steps and evaluations
    let summary = |stop: &str, extra: &[&str]| -> (String, u64, u64) {
        let mut args = vec!["simulate", &scene, "--stop-time", stop];
        args.extend_from_slice(extra);
        let out = std::process::Command::new(exe).args(&args).output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let text = String::from_utf8_lossy(&out.stdout).to_string();
        let row: Vec<&str> = text
            .lines()
            .find(|l| l.starts_with("bouncing_ball "))
            .unwrap_or_else(|| panic!("no summary in {text}"))
            .split_whitespace()
            .collect();
        (row[1].to_string(), row[2].parse().unwrap(), row[3].parse().unwrap())
    };
    let (full, state, rest) = (dir.join("full.csv"), dir.join("ball.state"), dir.join("rest.csv"));
    let p = |x: &std::path::Path| x.to_str().unwrap().to_string();
    let simulate = |stop: &str, extra: &[&str]| {
        let mut args = vec!["simulate", &scene, "--quiet", "--stop-time", stop];
        args.extend_from_slice(extra);
        run(&args)
    };
    assert!(simulate("0.6", &["--csv", &p(&full)]).0);
    assert!(simulate("0.25", &["--save-state", &p(&state)]).0);
    let (ok, err) = simulate("0.6", &["--resume", &p(&state), "--csv", &p(&rest)]);
    assert!(ok, "{err}");
    let full = std::fs::read_to_string(&full).unwrap();
    let rest = std::fs::read_to_string(&rest).unwrap();
    let tail: Vec<&str> = full.lines().skip_while(|l| !l.starts_with("0.25,")).collect();
    assert!(tail.len() > 300, "{} rows after the checkpoint", tail.len());
    assert_eq!(rest.lines().skip(1).collect::<Vec<_>>(), tail);
    let whole = summary("0.6", &[]);
    let before = summary("0.25", &[]);
    let resumed = summary("0.6", &["--resume", &p(&state)]);
    assert_eq!(
        (whole.0.as_str(), before.0.as_str(), resumed.0.as_str()),
        ("0.600s", "0.250s", "0.350s")
    );
    assert!(before.1 > 10 && before.1 < whole.1, "{before:?} of {whole:?}");
    assert_eq!((resumed.1, resumed.2), (whole.1 - before.1, whole.2 - before.2));
    let mut bytes = std::fs::read(&state).unwrap();
    bytes[40] ^= 1;
    std::fs::write(&state, bytes).unwrap();
    let (ok, err) = simulate("0.6", &["--resume", &p(&state)]);
    assert!(!ok && err.contains("ball.state") && err.contains("checksum"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The slider-crank with the bundled bouncing ball beside it, 5 m away: two islands, one of
/// them the mechanism's three bodies joined by joints and a loop, and the block that strikes
/// it.
fn slider_crank_and_ball() -> Scene {
    let mut scene = bundled("slider_crank");
    let ball = bundled("bouncing_ball");
    let away = |p: &mut [f64; 3]| p[0] += 5.0;
    scene.material.extend(ball.material);
    for mut b in ball.body {
        away(&mut b.position);
        scene.body.push(b);
    }
    for mut c in ball.contact {
        away(&mut c.center);
        if let Some(o) = c.origin.as_mut() {
            away(o);
        }
        scene.contact.push(c);
    }
    scene
}

/// Every bundled scene's whole state, saved after a tenth of its experiment (the pile at
/// 0.05 s, with its islands), and the slider-crank's with a ball (as islands, one of them
/// jointed), once per scene.
fn saved_states() -> &'static Vec<(Scene, Snapshot, f64)> {
    static SAVED: std::sync::OnceLock<Vec<(Scene, Snapshot, f64)>> = std::sync::OnceLock::new();
    SAVED.get_or_init(|| {
        let mut scenes: Vec<(String, Scene)> = common::bundled_scenes()
            .into_iter()
            .map(|(name, path)| (name, Scene::from_file(&path).unwrap()))
            .collect();
        scenes.push(("slider_crank_and_ball".into(), slider_crank_and_ball()));
        scenes
            .into_iter()
            .map(|(name, scene)| {
                let h = scene.model.interval;
                let stop = if name == "pile_of_balls" {
                    0.05
                } else {
                    0.1 * scene.model.stop_time
                };
                let mut s = Simulation::new(scene.clone(), &name);
                s.initialize(0.0).unwrap();
                let n = (stop / h).ceil() as usize;
                for k in 1..=n {
                    s.step_to(k as f64 * h).unwrap();
                }
                if name == "slider_crank_and_ball" {
                    assert_eq!(s.islands().len(), 2, "the mechanism and the ball");
                }
                (scene, s.snapshot(Vec::new()), h)
            })
            .collect()
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 600, ..ProptestConfig::default() })]

    /// A bundled scene's saved state, or the slider-crank's with a ball (islands, one jointed),
    /// with one number damaged anywhere (not a number, infinite,
    /// negative, fractional, huge, one more, zero), its bytes whole (as a host's own state
    /// object, or bytes whose checksum was made to agree): refused with a message, or restored
    /// and run on one communication step to a result (an error included). Nothing panics.
    #[test]
    fn damaged_state_numbers_are_refused_or_run_without_panic(
        scene in 0usize..64,
        at in 0usize..1_000_000,
        kind in 0usize..7,
    ) {
        let saved = saved_states();
        let (scene, snap, h) = &saved[scene % saved.len()];
        let mut damaged = snap.clone();
        let k = at % damaged.state.len();
        let x = damaged.state[k];
        damaged.state[k] = [f64::NAN, f64::INFINITY, -1.0, x + 0.5, 1e300, x + 1.0, 0.0][kind];
        let mut b = Simulation::new(scene.clone(), "damaged");
        b.initialize(0.0).unwrap();
        match b.restore(&damaged) {
            Err(e) => prop_assert!(!e.to_string().is_empty()),
            Ok(()) => {
                let t = b.time();
                let _ = b.step_to(t + h);
            }
        }
    }
}
