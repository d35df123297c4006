//! No allocation inside a step: a counting global allocator records the allocations made by
//! this thread while `Engine::advance` runs, after a warm-up (the first advances may size
//! buffers lazily). Asserts a count, not a time.

use contact_fmu::model::ContactEventKind;
use contact_fmu::scene::{Law, Method};
use contact_fmu::simulation::Simulation;

use crate::alloc_counter;
use crate::common;
use alloc_counter::count;

/// The bundled scene `scene` with `method`, not initialised. rk4 on the bouncing ball takes a
/// step that resolves its 40 µs contact (at the scene's 1 ms it steps over the contact, gains
/// energy without bound and is stopped as a blow-up).
fn load(scene: &str, method: Method) -> Simulation {
    let mut sim = Simulation::from_file(&common::bundled(scene)).expect("scene loads");
    sim.set_by_name("solver.method", method as i64 as f64).expect("method");
    if method == Method::Rk4 && scene == "bouncing_ball" {
        sim.set_by_name("solver.max_step", 5e-6).expect("max_step");
    }
    sim
}

fn start(scene: &str, method: Method) -> Simulation {
    let mut sim = load(scene, method);
    sim.initialize(0.0).expect("initialises");
    sim
}

/// Steps over `n` communication intervals of the scene from t = 0; returns the interval and
/// the time reached.
fn warm_up(sim: &mut Simulation, n: usize) -> (f64, f64) {
    let h = sim.scene().model.interval;
    let mut t = 0.0;
    for _ in 0..n {
        t += h;
        sim.step_to(t).expect("warm-up advances");
    }
    (h, t)
}

/// Allocations during `advance` over `steps` communication intervals after `warmup` ones,
/// and the number of integrator steps and events meanwhile.
fn allocations(scene: &str, method: Method, warmup: usize, steps: usize) -> (u64, u64, u64) {
    let mut sim = start(scene, method);
    let (h, mut t) = warm_up(&mut sim, warmup);
    let (s0, e0) = (sim.counters().steps, sim.counters().events);
    let n = count(|| {
        for _ in 0..steps {
            t += h;
            sim.step_to(t).expect("advances");
        }
    });
    (n, sim.counters().steps - s0, sim.counters().events - e0)
}

/// Allocations of one `advance` over `span` seconds starting at `t0` (after a warm-up
/// advance to `t0`), and the steps it took.
fn one_advance(scene: &str, method: Method, t0: f64, span: f64, max_step: f64) -> (u64, u64, u64) {
    let mut sim = load(scene, method);
    // free flight needs no largest step: one is set so that the window holds many steps
    sim.set_by_name("solver.max_step", max_step).expect("max_step");
    sim.initialize(0.0).expect("initialises");
    sim.step_to(t0).expect("warm-up advance");
    let (s0, e0) = (sim.counters().steps, sim.counters().events);
    let n = count(|| sim.step_to(t0 + span).expect("advances"));
    (n, sim.counters().steps - s0, sim.counters().events - e0)
}

/// Inside one `advance` without events, the allocation count does not grow with the number
/// of integrator steps: the step itself allocates nothing.
fn check_steps(scene: &str, method: Method, t0: f64, span: f64) -> Result<(), String> {
    let (a, sa, ea) = one_advance(scene, method, t0, span, span / 8.0);
    let (b, sb, eb) = one_advance(scene, method, t0, 4.0 * span, span / 8.0);
    println!(
        "{scene} {}: {a} allocations in one advance of {sa} steps, {b} in one of {sb} steps",
        method.name()
    );
    if (ea, eb) != (0, 0) {
        return Err(format!("{scene}: the window must be free of events"));
    }
    if !(sb > sa && sa > 0) {
        return Err(format!("{scene}: the longer advance must take more steps ({sa}, {sb})"));
    }
    if a != b {
        return Err(format!(
            "{scene} {}: allocations grow with the steps ({a} in {sa} steps, {b} in {sb})",
            method.name()
        ));
    }
    Ok(())
}

fn check(scene: &str, method: Method, warmup: usize, steps: usize) {
    let (n, taken, events) = allocations(scene, method, warmup, steps);
    println!(
        "{scene} {}: {n} allocations in {steps} advances, {taken} steps, {events} events",
        method.name()
    );
    assert!(taken > 0, "{scene}: no integrator step was taken");
    assert_eq!(
        n,
        0,
        "{scene} {}: {n} allocations in {steps} advances ({taken} steps, {events} events)",
        method.name()
    );
}

#[test]
fn counting_allocator_sees_allocations() {
    // The counter itself works: a vector allocates once.
    let n = count(|| {
        let v: Vec<u64> = Vec::with_capacity(16);
        std::hint::black_box(&v);
    });
    assert_eq!(n, 1);
}

#[test]
fn integrator_steps_do_not_allocate() {
    // Free flight of the ball (it touches at t ≈ 0.14 s), of the two spheres (touch at 1 ms),
    // the rail vehicle in rolling contact (no events), the slider-crank with its loop.
    let mut failures = Vec::new();
    for m in [Method::Dopri5, Method::Rk4, Method::Sdirk] {
        failures.extend(check_steps("bouncing_ball", m, 0.001, 0.02).err());
        failures.extend(check_steps("two_spheres", m, 1e-5, 1e-4).err());
    }
    // rk4 at the scene's 1 ms step locates contact events on the rail vehicle; the adaptive
    // methods roll without any.
    for m in [Method::Dopri5, Method::Sdirk] {
        failures.extend(check_steps("rail_vehicle", m, 0.01, 0.01).err());
    }
    failures.extend(check_steps("slider_crank", Method::Dopri5, 0.001, 0.005).err());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// Whole `advance` calls (restart, event handling) — the target is zero; see
// docs/benchmarks.md for the counts measured and where they come from.

#[test]
fn bouncing_ball_advance_does_not_allocate() {
    check("bouncing_ball", Method::Dopri5, 10, 300);
    check("bouncing_ball", Method::Rk4, 10, 300);
}

#[test]
fn rail_vehicle_and_slider_crank_advance_do_not_allocate() {
    check("rail_vehicle", Method::Dopri5, 5, 20);
    check("slider_crank", Method::Dopri5, 10, 200);
}

/// What an impulse-law run did while its allocations were counted.
struct ImpulseRun {
    allocations: u64,
    advances: usize,
    steps: u64,
    /// Impacts resolved in the counted window (the contact's counter).
    impacts: u64,
    /// Impact and Rest entries of the event log in the counted window.
    logged_impacts: usize,
    logged_rests: usize,
    /// Event log length after the window (at most its capacity, 4096).
    log_len: usize,
    /// The contact rests at the end.
    resting: bool,
    /// Energies at the end: kinetic, potential, contact, dissipated [J]; and the total at
    /// the start of the window.
    energies: contact_fmu::outputs::Energies,
    total_before: f64,
}

/// Runs `scene` with contact `contact` switched to the impulse law (a parameter set before
/// `initialize`, like an FMU host would), warms up over `warmup` communication intervals and
/// counts the allocations of the next `advances` ones. `friction`: the contact's Coulomb
/// coefficient.
fn impulse_run(
    scene: &str,
    contact: &str,
    friction: f64,
    method: Method,
    warmup: usize,
    advances: usize,
) -> ImpulseRun {
    let mut sim = load(scene, method);
    sim.set_by_name(&format!("{contact}.law"), Law::Impulse as i64 as f64)
        .expect("law");
    sim.set_by_name(&format!("{contact}.friction"), friction)
        .expect("friction");
    sim.initialize(0.0).expect("initialises");
    let (h, mut t) = warm_up(&mut sim, warmup);
    let ci = sim
        .contacts()
        .expect("model")
        .iter()
        .position(|c| c.name == contact)
        .expect("contact");
    assert_eq!(
        sim.contacts().expect("model")[ci].law,
        Law::Impulse,
        "the law parameter took effect"
    );
    let t_warm = sim.time();
    let s0 = sim.counters().steps;
    let impacts0 = sim.data().expect("data").contact_memory[ci].impacts;
    let e = sim.energies().expect("energies");
    let total_before = e.kinetic + e.potential + e.contact + e.dissipated;
    let allocations = count(|| {
        for _ in 0..advances {
            t += h;
            sim.step_to(t).expect("advances");
        }
    });
    let impacts = sim.data().expect("data").contact_memory[ci].impacts - impacts0;
    let resting = sim.data().expect("data").contact_memory[ci].active;
    let window = |k: ContactEventKind| {
        sim.contact_events()
            .iter()
            .filter(|ev| ev.time > t_warm && ev.contact == ci && ev.kind == k)
            .count()
    };
    ImpulseRun {
        allocations,
        advances,
        steps: sim.counters().steps - s0,
        impacts,
        logged_impacts: window(ContactEventKind::Impact),
        logged_rests: window(ContactEventKind::Rest),
        log_len: sim.contact_events().len(),
        resting,
        energies: sim.energies().expect("energies"),
        total_before,
    }
}

#[test]
fn impulse_law_impacts_and_resting_do_not_allocate() {
    // The ball dropped from 0.1 m with the impulse law: the first impact at t ≈ 0.14 s lies in
    // the counted window, then a geometric sequence of bounces (e = 0.8), plastic impacts
    // below min_impact_velocity, resting contact (constraint row on) until the end. Every
    // method steps at max_step (1 ms) in free flight, so the step counts coincide; each
    // locates the impacts on its own dense output.
    for method in [Method::Dopri5, Method::Rk4, Method::Sdirk, Method::Radau5] {
        let r = impulse_run("bouncing_ball", "ball_floor", 0.0, method, 10, 1500);
        println!(
            "bouncing_ball impulse {}: {} allocations in {} advances, {} steps, {} impacts, {} rests, log {}",
            method.name(),
            r.allocations,
            r.advances,
            r.steps,
            r.impacts,
            r.logged_rests,
            r.log_len
        );
        assert!(r.impacts >= 10, "{}: only {} impacts", method.name(), r.impacts);
        assert_eq!(r.logged_impacts as u64, r.impacts, "every impact is logged once");
        assert!(
            r.resting && r.logged_rests >= 1,
            "{}: the ball comes to rest",
            method.name()
        );
        // At rest the ball has no kinetic energy; the energy it had went to the impacts.
        let (ke, pe, ce, dissipated) = (
            r.energies.kinetic,
            r.energies.potential,
            r.energies.contact,
            r.energies.dissipated,
        );
        assert!(
            ke < 1e-12 * r.total_before,
            "{}: kinetic energy {ke:.3e} J at rest",
            method.name()
        );
        let total = ke + pe + ce + dissipated;
        assert!(
            (total - r.total_before).abs() <= 1e-9 * r.total_before,
            "{}: energy balance {total:.12e} J vs {:.12e} J",
            method.name(),
            r.total_before
        );
        assert!(r.log_len <= 4096);
        assert_eq!(r.allocations, 0, "bouncing_ball impulse {}: allocations", method.name());
    }
    // With friction: the resting contact's friction follows its multiplier (fixed-point
    // iteration on preallocated buffers).
    let r = impulse_run("bouncing_ball", "ball_floor", 0.3, Method::Dopri5, 10, 1500);
    println!(
        "bouncing_ball impulse dopri5, friction 0.3: {} allocations in {} advances, {} impacts, resting {}",
        r.allocations, r.advances, r.impacts, r.resting
    );
    assert!(r.resting, "the ball comes to rest");
    assert_eq!(r.allocations, 0, "bouncing_ball impulse with friction: allocations");
    // The slider-crank struck by the block, the impact resolved through the closed loop
    // (projection onto the loop rows, exact LCP), without and with friction (the tangential
    // impulses on the Coulomb disc).
    for friction in [0.0, 0.3] {
        let r = impulse_run("slider_crank", "impact", friction, Method::Dopri5, 10, 4000);
        println!(
            "slider_crank impulse dopri5, friction {friction}: {} allocations in {} advances, {} steps, {} impacts, \
             {} rests, log {}",
            r.allocations, r.advances, r.steps, r.impacts, r.logged_rests, r.log_len
        );
        assert!(r.impacts >= 1, "the block strikes the slider");
        assert_eq!(r.logged_impacts as u64, r.impacts, "every impact is logged once");
        assert_eq!(r.allocations, 0, "slider_crank impulse: allocations");
    }
}

#[test]
fn event_log_wraps_without_allocating() {
    // The log keeps the last 4096 contact events in its preallocated buffer: when full, the
    // older half is dropped in place. A steel ball bouncing elastically (pure Hertz, e = 1)
    // from 1 µm above the plate touches and leaves it about twice per millisecond: enough
    // events in 3,000 steps of 1 ms to wrap it.
    let scene = contact_fmu::bench::scenes::ball_plane("chatter", Law::Hertz, 1.0, 0.0, 1e-6, true, 4.0, 1e-3);
    let mut sim = common::start(scene);
    let h = 1e-3;
    let mut t = 0.0;
    for _ in 0..10 {
        t += h;
        sim.step_to(t).expect("warm-up advances");
    }
    let (mut allocations, mut wraps, mut longest) = (0, 0, 0);
    for _ in 0..3000 {
        let before = sim.contact_events().len();
        t += h;
        allocations += count(|| sim.step_to(t).expect("advances"));
        let after = sim.contact_events().len();
        wraps += usize::from(after < before);
        longest = longest.max(after);
    }
    println!(
        "elastic ball from 1 µm: {allocations} allocations in 3000 advances, {} events, log wrapped {wraps} times",
        sim.counters().events
    );
    assert!(wraps >= 1, "the log never filled ({longest} entries)");
    assert!(longest <= 4096, "the log grew to {longest} entries");
    assert_eq!(allocations, 0);
}

#[test]
fn contact_groups_allocate_only_when_the_candidate_list_is_made_again() {
    use contact_fmu::bench::scenes::sphere_box_groups;
    let run = |margin: f64| {
        let mut scene = sphere_box_groups(8, 0.2);
        scene.broad_phase.margin = Some(margin);
        let mut sim = common::start(scene);
        let h = 0.005;
        for k in 1..=4 {
            sim.step_to(k as f64 * h).expect("warm-up");
        }
        let (s0, e0, r0) = (sim.counters().steps, sim.counters().events, sim.candidate_refreshes());
        let n = count(|| {
            for k in 5..=30 {
                sim.step_to(k as f64 * h).expect("advances");
            }
        });
        (
            n,
            sim.counters().steps - s0,
            sim.counters().events - e0,
            sim.candidate_refreshes() - r0,
        )
    };
    // every pair a candidate: never made again, no allocation in steps and events
    let (n, steps, events, refreshes) = run(10.0);
    println!(
        "8 spheres, groups, margin 10 m: {n} allocations in {steps} steps, {events} events, {refreshes} refreshes"
    );
    assert!(steps > 0 && events > 0);
    assert_eq!((n, refreshes), (0, 0));
    // the default margin: the refreshes allocate (a new model), nothing else does
    let (n, steps, events, refreshes) = run(0.01);
    println!(
        "8 spheres, groups, margin 10 mm: {n} allocations in {steps} steps, {events} events, {refreshes} refreshes"
    );
    assert!(refreshes > 0 && n > 0);
}
