//! Contact groups against the explicit pair list on the spheres in a box
//! ([`super::scenes::sphere_box_groups`] and [`super::scenes::sphere_box`]): the time to
//! parse and compile each, the contacts the model holds, one right-hand-side evaluation as
//! the scene starts and with every contact active, and the time of one broad-phase pass by
//! sweep and prune and by the uniform grid. Optionally a short run of each.

use super::{f, median, scenes, time_runs, Csv, RunSpec};
use crate::compile::compile;
use crate::contact::groups::pose;
use crate::forward::Rhs;
use crate::integrator::OdeSystem;
use crate::model::{Data, Model};
use crate::scene::{BroadPhaseMethod, Scene};
use std::path::Path;
use std::time::Instant;

/// Median time of one call of `body` \[s\] over `repeats` batches of about 50 ms.
fn timed(repeats: usize, mut body: impl FnMut()) -> f64 {
    let t0 = Instant::now();
    body();
    let once = t0.elapsed().as_secs_f64().max(1e-9);
    let iters = ((0.05 / once) as usize).clamp(1, 100_000);
    let mut v = Vec::new();
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        for _ in 0..iters {
            body();
        }
        v.push(t.elapsed().as_secs_f64() / iters as f64);
    }
    median(&v)
}

/// One RHS at the initial state with the contacts as they start and with every contact
/// active \[s\].
fn rhs_costs(m: &Model, d: &mut Data, repeats: usize) -> (f64, f64) {
    let state = d.state.clone();
    let mut dy = vec![0.0; state.len()];
    let mut cost = [0.0; 2];
    for (k, active) in [false, true].into_iter().enumerate() {
        for mem in d.contact_memory.iter_mut() {
            mem.active = active;
            mem.impact_velocity = 1.0;
        }
        cost[k] = timed(repeats, || {
            Rhs { model: m, data: d }.rhs(0.0, &state, &mut dy);
            std::hint::black_box(&dy);
        });
    }
    (cost[0], cost[1])
}

/// Parses and compiles `scene` from its text \[s\].
fn compiled(scene: &Scene, origin: &str) -> Result<(Model, Data, f64), String> {
    let text = scene.to_toml();
    let t0 = Instant::now();
    let scene = Scene::from_str(&text, origin).map_err(|e| e.to_string())?;
    let (m, d) = compile(&scene, origin).map_err(|e| e.to_string())?;
    Ok((m, d, t0.elapsed().as_secs_f64()))
}

/// Runs the benchmark and writes the CSV; `run_time` > 0 also runs each scene for that
/// long (N ≤ 1,000).
pub fn run(ns: &[usize], repeats: usize, run_time: f64, csv_path: &Path) -> Result<(), String> {
    let mut csv = Csv::new(&[
        "n",
        "scene",
        "contacts",
        "compile_seconds",
        "rhs_start_seconds",
        "rhs_all_active_seconds",
        "sweep_seconds",
        "grid_seconds",
        "run_seconds_per_simulated_second",
        "steps",
        "events",
    ]);
    println!(
        "{:>6} {:<9} {:>9} {:>12} {:>14} {:>16} {:>12} {:>12} {:>12} {:>7} {:>7}",
        "N",
        "scene",
        "contacts",
        "compile [s]",
        "RHS start [µs]",
        "RHS active [µs]",
        "sweep [µs]",
        "grid [µs]",
        "s per sim s",
        "steps",
        "events"
    );
    for &n in ns {
        for (kind, scene) in [
            ("explicit", scenes::sphere_box(n, 0.05)),
            ("groups", scenes::sphere_box_groups(n, 0.05)),
        ] {
            let origin = format!("sphere_box_{kind}_{n}");
            let (m, mut d, compile_s) = compiled(&scene, &origin)?;
            let (rhs0, rhs1) = rhs_costs(&m, &mut d, repeats);
            let (mut sweep, mut grid) = (f64::NAN, f64::NAN);
            if m.groups.is_active() {
                let mut g = m.groups.clone();
                let mut counts = [0; 2];
                for (k, method) in [BroadPhaseMethod::Sweep, BroadPhaseMethod::Grid]
                    .into_iter()
                    .enumerate()
                {
                    g.method = method;
                    let t = timed(repeats, || {
                        counts[k] = std::hint::black_box(g.find(&|b| pose(&d, b))).len();
                    });
                    if k == 0 {
                        sweep = t;
                    } else {
                        grid = t;
                    }
                }
                if counts[0] != counts[1] || counts[0] != d.candidates.len() {
                    return Err(format!("N = {n}: sweep and grid disagree: {counts:?}"));
                }
            }
            let (mut per_sim, mut steps, mut events) = (f64::NAN, 0, 0);
            if run_time > 0.0 && n <= 1000 {
                let spec = RunSpec::new(scene, &origin, run_time, run_time / 10.0);
                let (wall, _cpu, c, failure) = time_runs(&spec, repeats.min(3))?;
                if let Some(e) = failure {
                    return Err(format!("{origin}: {e}"));
                }
                per_sim = wall / run_time;
                steps = c.steps;
                events = c.events;
            }
            println!(
                "{:>6} {:<9} {:>9} {:>12.4} {:>14.1} {:>16.1} {:>12.1} {:>12.1} {:>12.3} {:>7} {:>7}",
                n,
                kind,
                d.contacts.len(),
                compile_s,
                rhs0 * 1e6,
                rhs1 * 1e6,
                sweep * 1e6,
                grid * 1e6,
                per_sim,
                steps,
                events
            );
            csv.push(vec![
                n.to_string(),
                kind.into(),
                d.contacts.len().to_string(),
                f(compile_s),
                f(rhs0),
                f(rhs1),
                f(sweep),
                f(grid),
                f(per_sim),
                steps.to_string(),
                events.to_string(),
            ]);
        }
    }
    csv.write(csv_path)
}
