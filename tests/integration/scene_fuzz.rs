//! Mutated bundled scenes: 1,000 scenes, each a bundled scene with a few random mutations
//! (items removed, among them shapes, contact groups, bodies and joints; values negated,
//! zeroed, made huge or non-finite; names swapped; keys removed), are parsed, validated,
//! initialised and stepped a little through the facade every host uses. Each is either refused
//! with a message or runs; none panics. Those that run continue bit for bit when their state is
//! saved and restored, taken back, run in one call, by early returns or on one thread, and
//! when a host sets tunable parameters and inputs between communication points.
//!
//! `cargo test --release --test integration scene_fuzz:: -- --nocapture` prints the tally.
//! `SCENE_FUZZ_COUNT` and `SCENE_FUZZ_SEED` (environment) ask for more scenes and other
//! mutations than CI's 1,000 from its fixed seed, for a deeper search by hand.

use crate::common;
use common::Rng;

use contact_fmu::checkpoint::Snapshot;
use contact_fmu::scene::Scene;
use contact_fmu::simulation::{SimError, Simulation};
use std::cell::Cell;
use std::panic::{catch_unwind, AssertUnwindSafe};
use toml::Value;

/// Scenes mutated in CI, from this seed of the random numbers.
const SCENES: usize = 1000;
const SEED: u64 = 0x9e37_79b9_7f4a_7c15;

/// `name` from the environment (a decimal or `0x` hexadecimal number), or `default`.
fn from_env(name: &str, default: u64) -> u64 {
    let Ok(text) = std::env::var(name) else {
        return default;
    };
    let parsed = match text.strip_prefix("0x") {
        Some(hex) => u64::from_str_radix(&hex.replace('_', ""), 16),
        None => text.replace('_', "").parse(),
    };
    parsed.unwrap_or_else(|e| panic!("{name}={text:?}: {e}"))
}

/// The arrays of tables of a scene (`[[body]]`, `[[shape]]`, ...), by key.
fn table_arrays(v: &Value) -> Vec<String> {
    v.as_table()
        .map(|t| {
            t.iter()
                .filter(|(_, x)| x.as_array().is_some_and(|a| a.iter().all(Value::is_table)))
                .map(|(k, _)| k.clone())
                .collect()
        })
        .unwrap_or_default()
}

/// Every name in the scene (a value of a `name` key), to swap references among them.
fn names(v: &Value, out: &mut Vec<String>) {
    match v {
        Value::Table(t) => {
            for (k, x) in t {
                if k == "name" {
                    if let Some(s) = x.as_str() {
                        out.push(s.to_string());
                    }
                }
                names(x, out);
            }
        }
        Value::Array(a) => a.iter().for_each(|x| names(x, out)),
        _ => {}
    }
}

/// A random leaf (number, string, boolean, or array of numbers) of `v`, mutated.
fn mutate_leaf(v: &mut Value, rng: &mut Rng, all_names: &[String]) {
    match v {
        Value::Table(t) => {
            if t.is_empty() {
                return;
            }
            let keys: Vec<String> = t.keys().cloned().collect();
            let k = &keys[rng.below(keys.len())];
            if rng.chance(0.15) {
                t.remove(k);
            } else if let Some(x) = t.get_mut(k) {
                mutate_leaf(x, rng, all_names);
            }
        }
        Value::Array(a) => {
            if a.is_empty() {
                return;
            }
            let i = rng.below(a.len());
            if rng.chance(0.1) {
                a.remove(i);
            } else {
                mutate_leaf(&mut a[i], rng, all_names);
            }
        }
        Value::Float(x) => {
            *x = [-*x, 0.0, *x * 1e12, *x * 1e-12, f64::NAN, f64::INFINITY, -1.0, 1e300][rng.below(8)];
        }
        Value::Integer(i) => *i = [-*i, 0, 1, i64::MAX, -1, 7][rng.below(6)],
        Value::String(s) => {
            *s = match rng.below(3) {
                0 if !all_names.is_empty() => all_names[rng.below(all_names.len())].clone(),
                1 => String::new(),
                _ => format!("{s}_x"),
            }
        }
        Value::Boolean(b) => *b = !*b,
        Value::Datetime(_) => {}
    }
}

/// One mutated scene text from `base`.
fn mutated(base: &Value, rng: &mut Rng) -> String {
    let mut v = base.clone();
    let mut all_names = Vec::new();
    names(&v, &mut all_names);
    for _ in 0..1 + rng.below(3) {
        let arrays = table_arrays(&v);
        if !arrays.is_empty() && rng.chance(0.5) {
            // remove one item of an array of tables (a shape, a group pair, a body, ...)
            let key = &arrays[rng.below(arrays.len())];
            if let Some(a) = v.get_mut(key).and_then(Value::as_array_mut) {
                if !a.is_empty() {
                    let i = rng.below(a.len());
                    a.remove(i);
                }
            }
        } else {
            mutate_leaf(&mut v, rng, &all_names);
        }
    }
    toml::to_string(&v).unwrap_or_default()
}

/// The bundled scenes as TOML values, by name.
fn bundled_bases() -> Vec<(String, Value)> {
    common::bundled_scenes()
        .into_iter()
        .map(|(name, path)| {
            let text = std::fs::read_to_string(&path).unwrap();
            (name, text.parse::<Value>().unwrap())
        })
        .collect()
}

/// The seed of the mutations: `SCENE_FUZZ_SEED`, or CI's.
fn seed() -> u64 {
    let seed = from_env("SCENE_FUZZ_SEED", SEED);
    // (the generator, xorshift, stays at 0 from 0)
    assert!(seed != 0, "SCENE_FUZZ_SEED must not be 0");
    seed
}

/// What became of one scene.
#[derive(Debug, PartialEq)]
enum Outcome {
    Refused,
    Ran,
    FailedToStep,
}

/// Parses, initialises and steps `text` for a short time with a small step budget.
fn exercise(text: &str) -> Outcome {
    let Ok(mut sim) = Simulation::from_scene_str(text, "mutated.toml") else {
        return Outcome::Refused;
    };
    if let Some(vr) = sim.table().index_of("solver.max_steps") {
        if sim.set(vr, 200.0).is_err() {
            return Outcome::Refused;
        }
    }
    if sim.initialize(0.0).is_err() {
        return Outcome::Refused;
    }
    let outputs = sim.output_indices();
    for k in 1..=3 {
        if sim.step_to(k as f64 * 1e-4).is_err() {
            return Outcome::FailedToStep;
        }
        let mut values = vec![0.0; outputs.len()];
        if sim.get_many(&outputs, &mut values).is_err() {
            return Outcome::FailedToStep;
        }
    }
    let _ = sim.snapshot(Vec::new());
    Outcome::Ran
}

/// `f()`, or the message of its panic.
fn caught<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    catch_unwind(AssertUnwindSafe(f)).map_err(|payload| {
        payload
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default()
    })
}

/// Writes the text of failing scene `k` (made from bundled scene `base`) to the temporary
/// directory as `<kind>_<k>.toml`; the words that name it in a failure.
fn kept(kind: &str, k: usize, base: &str, text: &str) -> String {
    let file = std::env::temp_dir().join(format!("{kind}_{k}.toml"));
    let _ = std::fs::write(&file, text);
    format!("scene {k} (from {base}, written to {})", file.display())
}

#[test]
fn mutated_bundled_scenes_are_refused_or_run_never_panic() {
    let bases = bundled_bases();
    let scenes = from_env("SCENE_FUZZ_COUNT", SCENES as u64) as usize;
    let mut rng = Rng(seed());
    let mut tally = [0usize; 3];
    let mut panics = Vec::new();
    for k in 0..scenes {
        let (name, base) = &bases[k % bases.len()];
        let text = mutated(base, &mut rng);
        match caught(|| exercise(&text)) {
            Ok(o) => tally[o as usize] += 1,
            Err(why) => {
                panics.push(format!("{}: {why}", kept("scene_fuzz", k, name, &text)));
            }
        }
    }
    println!(
        "{scenes} mutated scenes: {} refused with a message, {} ran, {} stopped with a step error, {} panicked",
        tally[0],
        tally[1],
        tally[2],
        panics.len()
    );
    assert!(panics.is_empty(), "{}", panics.join("\n"));
    // the mutations reach every stage: some are refused, some run
    assert!(tally[0] > 50 && tally[1] > 50, "{tally:?}");
}

/// Span over which a mutated scene's continuation is checked in CI \[ms\] (`SCENE_FUZZ_SPAN_MS`
/// asks for another), and the step budget of each call.
const CONTINUED_SPAN_MS: u64 = 20;
const CONTINUED_MAX_STEPS: f64 = 20_000.0;

/// The outputs of `sim`, as bits, and last whether the energy watch warned (its state is
/// saved with the rest).
fn output_bits(sim: &mut Simulation) -> Result<Vec<u64>, String> {
    let outputs = sim.output_indices();
    let mut values = vec![0.0; outputs.len()];
    sim.get_many(&outputs, &mut values).map_err(|e| e.to_string())?;
    let mut bits: Vec<u64> = values.iter().map(|v| v.to_bits()).collect();
    bits.push(u64::from(sim.energy_drifted()));
    Ok(bits)
}

/// `text` initialised with a step budget of [`CONTINUED_MAX_STEPS`] a call; `None` when it
/// is refused.
fn initialised(text: &str) -> Option<Simulation> {
    initialised_scene(Scene::from_str(text, "mutated.toml").ok()?)
}

/// [`initialised`] for a parsed scene.
fn initialised_scene(scene: Scene) -> Option<Simulation> {
    initialised_with_budget(scene, CONTINUED_MAX_STEPS)
}

/// [`initialised_scene`] with a step budget of `max_steps` a call (the budget only stops a
/// run: a run within it takes the same steps under any budget).
fn initialised_with_budget(scene: Scene, max_steps: f64) -> Option<Simulation> {
    let mut sim = Simulation::new(scene, "mutated.toml");
    if let Some(vr) = sim.table().index_of("solver.max_steps") {
        sim.set(vr, max_steps).ok()?;
    }
    sim.initialize(0.0).ok()?;
    Some(sim)
}

/// The first output whose bits differ between `a` and `b` ([`output_bits`]), named.
fn first_difference(sim: &Simulation, a: &[u64], b: &[u64]) -> Option<String> {
    let outputs = sim.output_indices();
    let k = a.iter().zip(b).position(|(x, y)| x != y)?;
    let Some(&vr) = outputs.get(k) else {
        return Some(format!("the energy watch warned: {} against {}", a[k], b[k]));
    };
    Some(format!(
        "{} {:e} against {:e}",
        sim.variables()[vr].name,
        f64::from_bits(a[k]),
        f64::from_bits(b[k])
    ))
}

/// What the first of `runs` (labelled) that differs from the outputs `end` of `sim`, or
/// failed, says; `None` when every one gave `end`.
fn first_differing(sim: &Simulation, end: &[u64], runs: Vec<(String, Result<Vec<u64>, String>)>) -> Option<String> {
    runs.into_iter().find_map(|(label, bits)| match bits {
        Ok(bits) => first_difference(sim, end, &bits).map(|d| format!("{label}: {d}")),
        Err(e) => Some(format!("{label}: {e}")),
    })
}

/// Runs `text` over `span` with communication points at `save` and halfway from there to the
/// end, reading its outputs at each and saving its state at `save` (through its bytes); then
/// compares its outputs at the end with those of
/// 1. the saved state restored into a fresh simulation of the same text and run over the same
///    points without reading anything;
/// 2. (with continuation) a simulation run to the end in one call, and, for a scene on
///    several threads, one on one thread;
/// 3. the first simulation taken back to the saved state (a host's rollback, its workspace
///    that of the end) and run again;
/// 4. (with continuation) a simulation run to the end by steps that return early at contact
///    events.
///
/// `None` when the scene is refused or the first run fails; otherwise what differs at the end
/// (nothing: `Some(None)`). The runs in one call have the budget of the first run's three
/// calls together; a run with a call that still ran out of its budget, which is per call, is
/// not compared (counted in `ONE_CALL_OVER_BUDGET`).
fn continuation_differs(text: &str, save: f64, span: f64) -> Option<Option<String>> {
    let (t_end, t_mid) = (span, 0.5 * (save + span));
    let mut run = initialised(text)?;
    run.step_to(save).ok()?;
    output_bits(&mut run).ok()?;
    // (through its bytes, as a host that serializes it)
    let saved = match Snapshot::from_bytes(&run.snapshot(Vec::new()).to_bytes(0), 0) {
        Ok(saved) => saved,
        Err(e) => return Some(Some(format!("its saved state's bytes: {e}"))),
    };
    run.step_to(t_mid).ok()?;
    output_bits(&mut run).ok()?;
    run.step_to(t_end).ok()?;
    let end = output_bits(&mut run).ok()?;
    let resume = |sim: &mut Simulation| {
        sim.restore(&saved)
            .and_then(|()| sim.step_to(t_mid))
            .and_then(|()| sim.step_to(t_end))
            .map_err(|e| e.to_string())
            .and_then(|()| output_bits(sim))
    };
    let mut runs = Vec::new();
    let mut restored = initialised(text)?;
    runs.push((format!("restored at {save}"), resume(&mut restored)));
    // (the first run's three calls' budgets in one)
    let one_call_budget = 3.0 * CONTINUED_MAX_STEPS;
    let straight = initialised_with_budget(Scene::from_str(text, "mutated.toml").ok()?, one_call_budget)?;
    // (without continuation the method restarts at every point: its steps depend on them)
    let continues = straight.scene().solver.continuation;
    if continues {
        // islands advanced side by side give the results of one thread
        let mut calls = Vec::new();
        if straight.scene().solver.threads != 1 {
            let mut one_thread = straight.scene().clone();
            one_thread.solver.threads = 1;
            let Some(single) = initialised_with_budget(one_thread, one_call_budget) else {
                return Some(Some("on one thread: refused".into()));
            };
            calls.push(("on one thread", single));
        }
        calls.push(("in one call", straight));
        for (label, mut sim) in calls {
            match sim.step_to(t_end) {
                Err(SimError::StepLimit { .. }) => ONE_CALL_OVER_BUDGET.with(|n| n.set(n.get() + 1)),
                other => runs.push((
                    label.into(),
                    other.map_err(|e| e.to_string()).and_then(|()| output_bits(&mut sim)),
                )),
            }
        }
        if let Some(bits) = with_early_returns(text, t_end) {
            runs.push(("with early returns at events".into(), bits));
        }
    }
    runs.push((format!("taken back to {save}"), resume(&mut run)));
    Some(first_differing(&run, &end, runs))
}

/// Most early returns a run of the continuation check may take.
const EARLY_RETURNS: usize = 2_000;

thread_local! {
    /// Early returns taken by the continuation check's runs on this thread (its tally: each
    /// test runs on a thread of its own).
    static EARLY_RETURNS_TAKEN: Cell<usize> = const { Cell::new(0) };
    /// Runs in one call of the continuation check on this thread that ran out of their budget
    /// (not compared).
    static ONE_CALL_OVER_BUDGET: Cell<usize> = const { Cell::new(0) };
    /// Runs of the host-values check on this thread in which a value set after the save was
    /// refused (its tally).
    static WITH_REFUSED_VALUES: Cell<usize> = const { Cell::new(0) };
}

/// `text` run to `t_end` by steps that return early at contact events (FMI 3.0's early
/// return: [`Simulation::step_to_event`]), each going on from where the last ended: its
/// outputs at the end, or an error. `None` when a call ran out of its budget or the run took
/// more than [`EARLY_RETURNS`] returns (not compared).
fn with_early_returns(text: &str, t_end: f64) -> Option<Result<Vec<u64>, String>> {
    let mut sim = initialised(text)?;
    for _ in 0..EARLY_RETURNS {
        let before = sim.time();
        match sim.step_to_event(t_end) {
            Err(SimError::StepLimit { .. }) => return None,
            Err(e) => return Some(Err(e.to_string())),
            Ok(false) => return Some(output_bits(&mut sim)),
            Ok(true) if !(before < sim.time() && sim.time() < t_end) => {
                return Some(Err(format!(
                    "an early return at t = {} outside ({before}, {t_end})",
                    sim.time()
                )))
            }
            Ok(true) => {
                EARLY_RETURNS_TAKEN.with(|n| n.set(n.get() + 1));
            }
        }
    }
    None
}

/// Variant `which` of a bundled scene: as it is, with `[solver] islands = false` (one
/// integrator), with `continuation = false` (the method restarts at every communication
/// point), or with `threads = 2` (the islands of a round advance side by side), so that the
/// mutations reach those paths too.
fn variant(base: &Value, which: usize) -> Value {
    let mut v = base.clone();
    let (key, value) = match which {
        1 => ("islands", Value::Boolean(false)),
        2 => ("continuation", Value::Boolean(false)),
        3 => ("threads", Value::Integer(2)),
        _ => return v,
    };
    if let Some(t) = v.as_table_mut() {
        let solver = t.entry("solver").or_insert_with(|| Value::Table(Default::default()));
        if let Some(solver) = solver.as_table_mut() {
            solver.insert(key.into(), value);
        }
    }
    v
}

/// One scene of a continuation check.
struct Case<'a> {
    /// Its number.
    k: usize,
    /// The bundled scene it is made from.
    base: &'a str,
    /// Its text.
    text: String,
    /// Its save point: one of nine across the span.
    save: f64,
    /// The span it runs over (`SCENE_FUZZ_SPAN_MS`).
    span: f64,
}

/// Calls `each` with every scene of a check (`SCENE_FUZZ_COUNT` of them) and the generator:
/// scene k is `make` of bundled scene k's variant k, `make` drawing from the generator seeded
/// from [`seed`] rotated by `rotation`. Returns how many scenes there were.
fn each_case(rotation: u32, make: impl Fn(&Value, &mut Rng) -> String, mut each: impl FnMut(&Case, &mut Rng)) -> usize {
    let bases = bundled_bases();
    let scenes = from_env("SCENE_FUZZ_COUNT", SCENES as u64) as usize;
    let span = from_env("SCENE_FUZZ_SPAN_MS", CONTINUED_SPAN_MS) as f64 * 1e-3;
    let mut rng = Rng(seed().rotate_left(rotation));
    for k in 0..scenes {
        let (name, base) = &bases[k % bases.len()];
        let text = make(&variant(base, k / bases.len() % 4), &mut rng);
        let save = span * (1 + k % 9) as f64 / 10.0;
        let case = Case {
            k,
            base: name,
            text,
            save,
            span,
        };
        each(&case, &mut rng);
    }
    scenes
}

/// Mutated scenes that run continue bit for bit: saved at a communication point (one of nine
/// across the span) and restored into a fresh simulation or into the same one later (taken
/// back), run to the end in one call instead of over the points (the method's steps do not
/// depend on them, nor on whether the outputs were read there; with continuation), by steps
/// that return early at contact events, and on one thread instead of two, every output at the
/// end is the uninterrupted run's, counters included. A quarter of the scenes run as one
/// integrator, a quarter without continuation, a quarter on two threads.
#[test]
fn mutated_scenes_that_run_continue_bit_for_bit() {
    let (mut compared, mut differing) = (0, Vec::new());
    // (other mutations than the test above's)
    let scenes = each_case(17, mutated, |case, _| {
        let (k, name, text, save, span) = (case.k, case.base, case.text.as_str(), case.save, case.span);
        let Some(difference) = continuation_differs(text, save, span) else {
            return;
        };
        compared += 1;
        if let Some(d) = difference {
            differing.push(format!("{}: {d}", kept("scene_continued", k, name, text)));
        }
    });
    let early = EARLY_RETURNS_TAKEN.with(Cell::get);
    let over = ONE_CALL_OVER_BUDGET.with(Cell::get);
    println!(
        "{scenes} mutated scenes: {compared} ran and were compared ({early} early returns at events, \
         {over} runs in one call over their budget), {} differ",
        differing.len()
    );
    assert!(differing.is_empty(), "{}", differing.join("\n"));
    assert!(compared > 100, "only {compared} of {scenes} scenes ran");
    assert!(early > 10, "only {early} early returns");
}

/// A host's values at a communication point: up to three settable variables of `sim`, each
/// a multiple of its start value or a small number (some of them refused).
fn host_values(sim: &Simulation, rng: &mut Rng) -> Vec<(usize, f64)> {
    let vrs = common::settable(sim);
    if vrs.is_empty() {
        return Vec::new();
    }
    (0..1 + rng.below(3))
        .map(|_| {
            let vr = vrs[rng.below(vrs.len())];
            let start = sim.variables()[vr].start.unwrap_or(0.0);
            let value = match rng.below(4) {
                0 => start * [0.0, 0.5, 0.9, 1.1, 2.0, -1.0][rng.below(6)],
                1 => start + rng.range(-1.0, 1.0),
                2 => [0.0, 0.1, 1.0, 10.0][rng.below(4)],
                _ => start * rng.range(0.5, 1.5),
            };
            (vr, value)
        })
        .collect()
}

/// Sets `values` in turn; what each call returned (a refused value is part of the run).
fn set_values(sim: &mut Simulation, values: &[(usize, f64)]) -> Vec<bool> {
    values.iter().map(|&(vr, v)| sim.set(vr, v).is_ok()).collect()
}

/// Runs `text` over `span`, a host setting `before` at a quarter of the way to `save` and
/// `after` just after the state is saved at `save`, outputs read at `save` and halfway to the
/// end; then the saved state restored into a fresh simulation and taken back in the first,
/// each given `after` and run on, and (when some of `after` were refused) restored into
/// another, given only the values of `after` that were accepted (a refused value changes
/// nothing). `None` when the scene is refused or the first run fails;
/// otherwise what differs at the end (the outputs, bit for bit, and which values were
/// refused; nothing: `Some(None)`).
fn continuation_with_host_values_differs(
    text: &str,
    save: f64,
    span: f64,
    before: &[(usize, f64)],
    after: &[(usize, f64)],
) -> Option<Option<String>> {
    let (t_end, t_mid) = (span, 0.5 * (save + span));
    let mut run = initialised(text)?;
    run.step_to(0.25 * save).ok()?;
    set_values(&mut run, before);
    run.step_to(save).ok()?;
    output_bits(&mut run).ok()?;
    let saved = run.snapshot(Vec::new());
    let accepted = set_values(&mut run, after);
    run.step_to(t_mid).ok()?;
    output_bits(&mut run).ok()?;
    run.step_to(t_end).ok()?;
    let end = output_bits(&mut run).ok()?;
    // (a refused value changes nothing: the same run given only the values accepted)
    let only_accepted: Vec<(usize, f64)> = after
        .iter()
        .zip(&accepted)
        .filter_map(|(&value, &ok)| ok.then_some(value))
        .collect();
    let resume = |sim: &mut Simulation, values: &[(usize, f64)], expected: &[bool]| -> Result<Vec<u64>, String> {
        sim.restore(&saved).map_err(|e| e.to_string())?;
        let again = set_values(sim, values);
        if again != expected {
            return Err(format!("values accepted {again:?} against {expected:?}"));
        }
        sim.step_to(t_mid)
            .and_then(|()| sim.step_to(t_end))
            .map_err(|e| e.to_string())?;
        output_bits(sim)
    };
    let mut restored = initialised(text)?;
    let mut runs = vec![
        (format!("restored at {save}"), resume(&mut restored, after, &accepted)),
        (format!("taken back to {save}"), resume(&mut run, after, &accepted)),
    ];
    if only_accepted.len() < after.len() {
        WITH_REFUSED_VALUES.with(|n| n.set(n.get() + 1));
        let mut fresh = initialised(text)?;
        let label = format!("restored at {save}, given only the values accepted");
        let all = vec![true; only_accepted.len()];
        runs.push((label, resume(&mut fresh, &only_accepted, &all)));
    }
    Some(first_differing(&run, &end, runs))
}

/// Mutated scenes whose tunable parameters and inputs a host sets between communication
/// points continue bit for bit: values set before the state is saved are restored with it,
/// and values set after it act alike in the uninterrupted run, in a fresh simulation restored
/// from the state and in the first taken back to it (the same values accepted and refused,
/// every output at the end the same). The variants as in the test above.
#[test]
fn mutated_scenes_given_host_values_continue_bit_for_bit() {
    let (mut compared, mut with_values, mut differing) = (0, 0, Vec::new());
    let scenes = each_case(29, mutated, |case, rng| {
        let (k, name, text, save, span) = (case.k, case.base, case.text.as_str(), case.save, case.span);
        let Some(sim) = initialised(text) else {
            return;
        };
        let before = host_values(&sim, rng);
        let after = host_values(&sim, rng);
        let Some(difference) = continuation_with_host_values_differs(text, save, span, &before, &after) else {
            return;
        };
        compared += 1;
        with_values += usize::from(!after.is_empty());
        if let Some(d) = difference {
            let names = |values: &[(usize, f64)]| {
                values
                    .iter()
                    .map(|&(vr, v)| format!("{} = {v:e}", sim.variables()[vr].name))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            differing.push(format!(
                "{} (before [{}], after [{}]): {d}",
                kept("scene_host_values", k, name, text),
                names(&before),
                names(&after)
            ));
        }
    });
    let refused = WITH_REFUSED_VALUES.with(Cell::get);
    println!(
        "{scenes} mutated scenes: {compared} ran and were compared ({with_values} given values after the save, \
         {refused} of them with a value refused), {} differ",
        differing.len()
    );
    assert!(differing.is_empty(), "{}", differing.join("\n"));
    assert!(
        with_values > 100,
        "only {with_values} of {scenes} scenes were given values"
    );
    assert!(refused > 10, "only {refused} runs with a value refused");
}

/// `base` with one to three items of its arrays of tables copied (a body, a shape, a contact,
/// a group pair, a joint, ...): each copy named anew (`<name>_copy<k>`) and its position,
/// centre, origin and anchor moved by up to a millimetre, a centimetre, a decimetre or a metre
/// in each direction, so that scenes reach what no bundled one has (more bodies and contacts,
/// a body with two shapes, a contact declared twice, two joints on one child, ...).
fn with_copies(base: &Value, rng: &mut Rng) -> Value {
    let mut v = base.clone();
    for k in 0..1 + rng.below(3) {
        let arrays = table_arrays(&v);
        if arrays.is_empty() {
            break;
        }
        let key = &arrays[rng.below(arrays.len())];
        let Some(items) = v.get_mut(key).and_then(Value::as_array_mut) else {
            continue;
        };
        if items.is_empty() {
            continue;
        }
        let mut copy = items[rng.below(items.len())].clone();
        let reach = [1e-3, 1e-2, 0.1, 1.0][rng.below(4)];
        if let Some(t) = copy.as_table_mut() {
            if let Some(Value::String(name)) = t.get_mut("name") {
                *name = format!("{name}_copy{k}");
            }
            for place in ["position", "center", "origin", "anchor"] {
                if let Some(Value::Array(xyz)) = t.get_mut(place) {
                    for x in xyz.iter_mut() {
                        if let Value::Float(x) = x {
                            *x += reach * rng.range(-1.0, 1.0);
                        }
                    }
                }
            }
        }
        items.push(copy);
    }
    v
}

/// Bundled scenes with copied items ([`with_copies`]), mutated further as above (or, one in
/// four, not), are refused with a message or run, never panic; and those that run continue
/// bit for bit ([`continuation_differs`], the variants as above).
#[test]
fn scenes_with_copied_items_never_panic_and_continue_bit_for_bit() {
    let (mut tally, mut compared, mut failures) = ([0usize; 3], 0, Vec::new());
    let copied_and_mutated = |base: &Value, rng: &mut Rng| {
        let copied = with_copies(base, rng);
        match rng.below(4) {
            0 => toml::to_string(&copied).unwrap_or_default(),
            _ => mutated(&copied, rng),
        }
    };
    let scenes = each_case(41, copied_and_mutated, |case, _| {
        let (k, name, text, save, span) = (case.k, case.base, case.text.as_str(), case.save, case.span);
        let checked = caught(|| {
            let outcome = exercise(text);
            let difference = match outcome {
                Outcome::Ran => continuation_differs(text, save, span),
                _ => None,
            };
            (outcome, difference)
        });
        let failure = match checked {
            Ok((outcome, difference)) => {
                tally[outcome as usize] += 1;
                compared += usize::from(difference.is_some());
                difference.flatten()
            }
            Err(why) => Some(format!("panicked: {why}")),
        };
        if let Some(why) = failure {
            failures.push(format!("{}: {why}", kept("scene_copied", k, name, text)));
        }
    });
    println!(
        "{scenes} scenes with copied items: {} refused with a message, {} ran, {} stopped with a step error; \
         {compared} compared; {} panicked or differ",
        tally[0],
        tally[1],
        tally[2],
        failures.len()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(tally[0] > 50 && compared > 100, "{tally:?}, {compared} compared");
}
