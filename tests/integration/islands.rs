//! Independent islands: a scene of two far-apart islands gives each island the trajectory it
//! has alone, and an impact in one does not change the steps of the other; the energy balance
//! holds per island and the located events keep their closed-form times; islands against the
//! whole scene with one integrator (`solver.islands = false`); contact groups whose islands
//! merge and split as the spheres collide; a saved state continues bit for bit.
//!
//! `cargo test --release --test integration islands:: -- --nocapture` prints the measurements.

use crate::common;

use common::{energy_balance, get, start};
use contact_fmu::bench::scenes::sphere_box_groups;
use contact_fmu::scene::{BodySpec, ContactSpec, Law, Scene, GROUND};
use contact_fmu::scene_builder::{Plane, SceneBuilder, Sphere};
use contact_fmu::simulation::Simulation;

const G: f64 = 9.81;
const R: f64 = 0.01;

/// A steel ball of radius 10 mm at (x, 0, height) over a floor patch around x, with a Hertz
/// contact (`hertz_ln`, e = 0.8): its body and contact.
fn ball(name: &str, x: f64, height: f64, vx: f64) -> (BodySpec, ContactSpec) {
    let body = BodySpec::new(name, 0.0329, [1.316e-6; 3], [x, 0.0, height]).velocity([vx, 0.0, 0.0]);
    let floor = Plane::horizontal([x, 0.0, 0.0], [2.0, 2.0]);
    let contact = ContactSpec::sphere_plane(
        &format!("{name}_floor"),
        Law::HertzLn,
        Sphere::of(&body, R),
        GROUND,
        floor,
    )
    .materials("steel", "steel")
    .restitution(0.8);
    (body, contact)
}

fn scene(balls: &[(BodySpec, ContactSpec)], islands: bool) -> Scene {
    let mut scene = SceneBuilder::new("islands")
        .gravity([0.0, 0.0, -G])
        .experiment(0.6, 0.01)
        .tolerances(1e-9, 1e-12)
        .steel()
        .bodies(balls.iter().map(|(body, _)| body.clone()))
        .contacts(balls.iter().map(|(_, contact)| contact.clone()))
        .build();
    scene.solver.islands = islands;
    scene
}

/// Runs `scene` to `t_end` and returns the paths of `bodies` (side by side per point) and
/// the simulation.
fn run(scene: Scene, bodies: &[&str], t_end: f64, dt: f64) -> (Vec<Vec<f64>>, Simulation) {
    let mut s = start(scene);
    let mut paths = vec![Vec::new(); bodies.len()];
    for k in 1..=(t_end / dt).round() as usize {
        s.step_to(k as f64 * dt).unwrap_or_else(|e| panic!("{e}"));
        for (p, b) in paths.iter_mut().zip(bodies) {
            for key in ["r[1]", "r[3]", "v[1]", "v[3]"] {
                p.push(get(&mut s, &format!("{b}.{key}")));
            }
        }
    }
    (paths, s)
}

fn largest_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

#[test]
fn far_apart_islands_keep_their_own_trajectories_and_steps() {
    let (t_end, dt) = (0.6, 0.01);
    // island A: dropped from 0.11 m (first impact at 0.143 s); island B, 5 m away: from
    // 0.21 m, rolling sideways (first impact at 0.202 s)
    let a = ball("a", 0.0, 0.11, 0.0);
    let b = ball("b", 5.0, 0.21, 0.3);
    let (both, mut s) = run(scene(&[a.clone(), b.clone()], true), &["a", "b"], t_end, dt);
    let islands = s.islands();
    assert_eq!(islands.len(), 2, "two islands expected");
    assert_eq!(islands[0].bodies, ["a"]);
    assert_eq!(islands[1].bodies, ["b"]);
    // each island as when simulated alone
    let (alone_a, _) = run(scene(std::slice::from_ref(&a), true), &["a"], t_end, dt);
    let (alone_b, sb) = run(scene(std::slice::from_ref(&b), true), &["b"], t_end, dt);
    let (da, db) = (
        largest_difference(&both[0], &alone_a[0]),
        largest_difference(&both[1], &alone_b[0]),
    );
    println!("island against alone: largest difference a {da:e}, b {db:e} (m, m/s)");
    assert!(da <= 1e-12 && db <= 1e-12, "a {da}, b {db}");
    // B's steps do not depend on A's impacts: A dropped from elsewhere (other impact times),
    // or A at rest high above the floor (no impact at all)
    let steps_b = islands[1].counters;
    assert_eq!(steps_b.steps, sb.counters().steps, "B's steps alone");
    for a_height in [0.16, 0.31, 5.0] {
        let other_a = ball("a", 0.0, a_height, 0.0);
        let (paths, mut s2) = run(scene(&[other_a, b.clone()], true), &["a", "b"], t_end, dt);
        let isl = s2.islands();
        println!(
            "A from {a_height} m: A {} steps, {} events; B {} steps, {} events, {} RHS",
            isl[0].counters.steps,
            isl[0].counters.events,
            isl[1].counters.steps,
            isl[1].counters.events,
            isl[1].counters.rhs_evals
        );
        assert_eq!(isl[1].counters, steps_b, "B's counters changed with A's impacts");
        assert_eq!(paths[1], both[1], "B's trajectory changed with A's impacts");
    }
    // the counters of the scene are the sum of its islands'
    let c = s.counters();
    assert_eq!(c.steps, islands[0].counters.steps + islands[1].counters.steps);
    assert_eq!(c.events, islands[0].counters.events + islands[1].counters.events);
}

#[test]
fn islands_agree_with_one_integrator_and_do_less_work() {
    let (t_end, dt) = (0.6, 0.01);
    let balls = [
        ball("a", 0.0, 0.11, 0.0),
        ball("b", 5.0, 0.21, 0.3),
        ball("c", -5.0, 0.06, 0.0),
    ];
    let names = ["a", "b", "c"];
    let (split, mut si) = run(scene(&balls, true), &names, t_end, dt);
    let (whole, mut sw) = run(scene(&balls, false), &names, t_end, dt);
    let diff = (0..3)
        .map(|k| largest_difference(&split[k], &whole[k]))
        .fold(0.0, f64::max);
    let (ci, cw) = (si.counters(), sw.counters());
    // the work: RHS evaluations times the bodies each evaluates
    let work_split: u64 = si
        .islands()
        .iter()
        .map(|i| i.counters.rhs_evals * i.bodies.len() as u64)
        .sum();
    let work_whole = cw.rhs_evals * 3;
    println!(
        "three balls: islands {} steps, {} RHS ({work_split} body evaluations), {} events; one integrator {} steps, \
         {} RHS ({work_whole} body evaluations), {} events; largest difference {diff:e}",
        ci.steps, ci.rhs_evals, ci.events, cw.steps, cw.rhs_evals, cw.events
    );
    assert_eq!(ci.events, cw.events, "the same impacts");
    // the output counts them too, the islands' summed into the scene's
    assert_eq!(get(&mut si, "solver.events"), ci.events as f64);
    assert_eq!(get(&mut sw, "solver.events"), cw.events as f64);
    assert!(diff < 1e-6, "difference {diff}");
    assert!(
        2 * work_split < work_whole,
        "islands should need less than half the body evaluations ({work_split} against {work_whole})"
    );
}

#[test]
fn energy_balance_and_located_events_hold_per_island() {
    let balls = [ball("a", 0.0, 0.11, 0.0), ball("b", 5.0, 0.21, 0.3)];
    let mut s = start(scene(&balls, true));
    let e0 = energy_balance(&mut s);
    let mut islands0 = Vec::new();
    for k in 1..=60 {
        s.step_to(k as f64 * 0.01).unwrap_or_else(|e| panic!("{e}"));
        let isl = s.islands();
        if k == 1 {
            islands0 = isl.iter().map(|i| i.energies.total() + i.energies.dissipated).collect();
        }
        for (i, e) in isl.iter().zip(&islands0) {
            let balance = i.energies.total() + i.energies.dissipated;
            let drift = (balance - e).abs() / e.abs();
            assert!(
                drift < 1e-6,
                "island {:?}: balance drifted by {drift:e} at t = {}",
                i.bodies,
                i.time
            );
        }
    }
    let drift = (energy_balance(&mut s) - e0).abs() / e0.abs();
    let dissipated: f64 = s.islands().iter().map(|i| i.energies.dissipated).sum();
    println!("scene balance drift {drift:e}; dissipated by the islands {dissipated:e} J");
    assert!(drift < 1e-6);
    assert!(dissipated > 1e-4, "the impacts dissipate energy");
    assert!((s.energies().unwrap().dissipated - dissipated).abs() < 1e-12);
    // each island's first touch at the closed-form time of free fall, in the scene's log
    let events = s.contact_events().to_vec();
    for (contact, height) in [(0, 0.11), (1, 0.21)] {
        let first = events
            .iter()
            .find(|e| e.contact == contact)
            .unwrap_or_else(|| panic!("no event of contact {contact}"));
        let exact = (2.0 * (height - R) / G).sqrt();
        println!(
            "contact {contact}: first touch at {} s, closed form {exact} s",
            first.time
        );
        assert!(
            (first.time - exact).abs() < 1e-9,
            "touch at {} against {exact}",
            first.time
        );
    }
    assert!(events.windows(2).all(|w| w[0].time <= w[1].time), "log in time order");
}

#[test]
fn saved_islands_continue_bit_for_bit() {
    for groups in [false, true] {
        let scene = if groups {
            let mut s = sphere_box_groups(27, 0.2);
            s.broad_phase.margin = Some(0.0015);
            s
        } else {
            scene(&[ball("a", 0.0, 0.11, 0.0), ball("b", 5.0, 0.21, 0.3)], true)
        };
        let names: Vec<String> = scene.body.iter().map(|b| b.name.clone()).collect();
        let mut s = start(scene.clone());
        let read = |s: &mut Simulation| -> Vec<f64> {
            names
                .iter()
                .flat_map(|b| ["r[1]", "r[2]", "r[3]", "v[1]"].map(|k| format!("{b}.{k}")))
                .map(|n| get(s, &n))
                .collect()
        };
        for k in 1..=7 {
            s.step_to(k as f64 * 0.013).unwrap();
        }
        let snap = s.snapshot(Vec::new());
        let saved = s.islands().len();
        let mut uninterrupted = Vec::new();
        for k in 8..=15 {
            s.step_to(k as f64 * 0.013).unwrap();
            uninterrupted.push(read(&mut s));
        }
        let mut r = start(scene);
        r.restore(&snap).unwrap();
        // (the islands come from the state, not formed anew at the first step)
        assert_eq!(r.islands().len(), saved, "the islands are saved and restored");
        let mut restored = Vec::new();
        for k in 8..=15 {
            r.step_to(k as f64 * 0.013).unwrap();
            restored.push(read(&mut r));
        }
        assert_eq!(uninterrupted, restored, "groups {groups}: not bit for bit");
        assert_eq!(s.counters(), r.counters());
        assert!(s.islands().len() > 1);
        println!(
            "groups {groups}: {} islands, {} candidate-list rebuilds, restored bit for bit",
            s.islands().len(),
            s.candidate_refreshes()
        );
    }
}

#[test]
fn sphere_box_islands_agree_with_one_integrator() {
    // 27 spheres in a box, no gravity, a margin smaller than the gaps between them: the
    // islands form, merge and split as the spheres collide. (Collisions of many spheres
    // amplify differences of the steps: at rtol 1e-6 the two differ by 2e-3, at 1e-8 by 1e-5.)
    let mut scene = sphere_box_groups(27, 0.1);
    scene.broad_phase.margin = Some(0.0015);
    scene.solver.rtol = 1e-10;
    scene.solver.atol = 1e-13;
    let mut whole_scene = scene.clone();
    whole_scene.solver.islands = false;
    let names: Vec<String> = scene.body.iter().map(|b| b.name.clone()).collect();
    let refs: Vec<&str> = names.iter().map(|n| n.as_str()).collect();
    let (split, mut si) = run(scene.clone(), &refs, 0.1, 0.01);
    let (whole, sw) = run(whole_scene, &refs, 0.1, 0.01);
    let diff = (0..names.len())
        .map(|k| largest_difference(&split[k], &whole[k]))
        .fold(0.0, f64::max);
    let (ci, cw) = (si.counters(), sw.counters());
    let sizes: Vec<usize> = si.islands().iter().map(|i| i.bodies.len()).collect();
    println!(
        "27 spheres: islands {} steps, {} RHS, {} events, {} rebuilds (island sizes at the end {sizes:?}); \
         one integrator {} steps, {} RHS, {} events; largest difference {diff:e}",
        ci.steps,
        ci.rhs_evals,
        ci.events,
        si.candidate_refreshes(),
        cw.steps,
        cw.rhs_evals,
        cw.events
    );
    assert_eq!(ci.events, cw.events, "the same impacts");
    assert!(sizes.len() > 1);
    assert!(si.candidate_refreshes() > 5);
    assert!(diff < 1e-5, "difference {diff}");
}

/// 10,000 free bodies without contacts, each its own island: `solver.max_steps` bounds the
/// steps of each island per communication step, so the run goes on (when it bounded the steps
/// of all islands together, it stopped at t = 0), and every body flies straight on.
#[test]
fn ten_thousand_free_bodies_run_as_islands() {
    use contact_fmu::bench::scenes::sphere_box;
    use contact_fmu::scene::Method;
    let mut scene = sphere_box(10_000, 0.1);
    scene.contact.clear();
    scene.solver.method = Method::Auto;
    scene.solver.max_step = 0.0;
    let start_positions: Vec<([f64; 3], [f64; 3])> = scene.body.iter().map(|b| (b.position, b.velocity)).collect();
    let t0 = std::time::Instant::now();
    let mut sim = start(scene);
    for k in 1..=10 {
        sim.step_to(0.01 * k as f64).unwrap_or_else(|e| panic!("{e}"));
    }
    println!(
        "10,000 free bodies, 0.1 s: {} islands, {} steps, {:.2} s",
        sim.islands().len(),
        sim.counters().steps,
        t0.elapsed().as_secs_f64()
    );
    assert_eq!(sim.islands().len(), 10_000);
    let mut worst = 0.0_f64;
    for (k, (r0, v)) in start_positions.iter().enumerate().step_by(97) {
        for i in 0..3 {
            let r = get(&mut sim, &format!("s{k}.r[{}]", i + 1));
            worst = worst.max((r - (r0[i] + v[i] * 0.1)).abs());
        }
    }
    assert!(worst < 1e-12, "free flight off the straight line by {worst:e} m");
}

/// A contact's error inside an island names the contact as the scene does (not by the
/// island's own numbering of its shapes): a sphere thrown at 30 m/s into a soft wall, as an
/// island and with one integrator, fails at the same contact.
#[test]
fn an_islands_errors_name_contacts_as_the_scene_does() {
    let mut names = Vec::new();
    for islands in [true, false] {
        let mut scene = sphere_box_groups(3, 0.05);
        scene.broad_phase.margin = Some(0.0015);
        scene.body[2].velocity = [-30.0, 0.0, 0.0];
        let wall = scene.contact_group.iter_mut().find(|g| g.name == "ball_wall").unwrap();
        wall.stiffness = Some(1000.0);
        scene.solver.islands = islands;
        let mut s = start(scene);
        let e = (1..=50)
            .find_map(|k| s.step_to(k as f64 * 1e-3).err())
            .expect("the wall gives way")
            .to_string();
        assert!(e.contains("max_penetration"), "{e}");
        let name = e.split('"').find(|p| p.starts_with("ball_wall[")).map(str::to_string);
        names.push(name.unwrap_or_else(|| panic!("no contact named: {e}")));
    }
    assert_eq!(names[0], names[1], "islands against one integrator");
}

#[test]
fn a_budget_spent_on_rounds_too_short_for_the_margin_says_to_raise_the_margin() {
    // margin 1e-12 m: every round ends after a body moved a third of a picometre, the budget
    // of rounds runs out at once; the message gave only "shorter communication steps"
    let text = std::fs::read_to_string(common::bundled("pile_of_balls"))
        .unwrap()
        .replace("margin = 0.002", "margin = 1e-12");
    assert!(text.contains("margin = 1e-12"));
    let mut sim = Simulation::from_scene_str(&text, "tiny_margin.toml").unwrap();
    sim.initialize(0.0).unwrap();
    let err = sim.step_to(1e-3).unwrap_err().to_string();
    assert!(
        err.contains("rounds of the islands") && err.contains("raise the margin") && err.contains("margin = 1e-12 m"),
        "{err}"
    );
}
