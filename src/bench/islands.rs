//! Independent islands at scale: N spheres in a box ([`super::scenes::sphere_box_groups`],
//! contact groups, no gravity) with the default method (auto, rtol 1e-6, atol 1e-9, no
//! largest step) running as islands, against the former way to simulate the same spheres
//! ([`super::scenes::sphere_box`]: the explicit pair list of lattice neighbours, dopri5 with a
//! 1 ms largest step, the whole scene with one integrator) and against the groups scene with
//! one integrator (`solver.islands = false`). Reports the run time per simulated second
//! (setup excluded; wall clock, median of the repeats), the deterministic counters, the
//! islands (how many at the end, the largest, rounds, candidate-list rebuilds, islands
//! formed and the models cut for them) and the fitted exponent of the run time against N.

use super::scaling::loglog_slope;
use super::{f, scenes, setup, step_through, time_runs, Csv, RunSpec};
use crate::scene::{Method, Scene};
use std::path::Path;
use std::time::Instant;

/// Settings of a run (the options of `contact-fmu bench islands`).
#[derive(Debug, clap::Args)]
pub struct Settings {
    /// Simulated time per run (s).
    #[arg(long, default_value_t = 0.05)]
    pub time: f64,
    /// Timed runs per point.
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// The former way and one integrator are timed up to this N.
    #[arg(long, default_value_t = 1000)]
    pub compare_max: usize,
    /// Their simulated time (s).
    #[arg(long, default_value_t = 0.05)]
    pub compare_time: f64,
    /// Broad-phase margin (m).
    #[arg(long, default_value_t = 0.0015)]
    pub margin: f64,
    /// Threads that advance the islands side by side (`[solver] threads`; 0: as many as
    /// the machine has); the former way and one integrator run on one.
    #[arg(long, default_value_t = 1)]
    pub threads: usize,
}

/// The groups scene of `n` spheres with the default method (`islands`: as islands).
pub fn grouped(n: usize, time: f64, margin: f64, islands: bool) -> Scene {
    let mut s = scenes::sphere_box_groups(n, time);
    s.solver.method = Method::Auto;
    s.solver.max_step = 0.0;
    s.solver.islands = islands;
    s.broad_phase.margin = Some(margin);
    s
}

/// Wall seconds per simulated second of one run of `scene` (setup excluded), or the failure.
fn one_run(scene: Scene, origin: &str, time: f64) -> Result<(f64, u64, u64), String> {
    let spec = RunSpec::new(scene, origin, time, time / 10.0);
    let (wall, _cpu, c, failure) = time_runs(&spec, 1)?;
    match failure {
        Some(e) => Err(e),
        None => Ok((wall / time, c.steps, c.rhs_evals)),
    }
}

/// Runs the benchmark and writes the CSV.
pub fn run(ns: &[usize], s: &Settings, csv_path: &Path) -> Result<(), String> {
    let mut csv = Csv::new(&[
        "n",
        "seconds_per_simulated_second",
        "steps",
        "rhs_evals",
        "events",
        "islands_at_end",
        "largest_island",
        "rounds",
        "rebuilds",
        "islands_compiled",
        "models_cut",
        "former_seconds_per_simulated_second",
        "one_integrator_seconds_per_simulated_second",
        "speedup_over_former",
        "speedup_over_one_integrator",
        "threads",
    ]);
    if s.threads != 1 {
        println!("(the islands on {} threads; 0: as many as the machine has)", s.threads);
    }
    println!(
        "{:>6} {:>12} {:>8} {:>9} {:>7} {:>8} {:>8} {:>7} {:>8} {:>9} {:>6} {:>12} {:>12} {:>11} {:>9}",
        "N",
        "s per sim s",
        "steps",
        "rhs",
        "events",
        "islands",
        "largest",
        "rounds",
        "rebuilds",
        "compiled",
        "cut",
        "former",
        "one integr.",
        "over former",
        "over one"
    );
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    for &n in ns {
        let origin = format!("sphere_box_groups_{n}");
        let mut scene = grouped(n, s.time, s.margin, true);
        scene.solver.threads = s.threads;
        let spec = RunSpec::new(scene.clone(), &origin, s.time, s.time / 10.0);
        let (wall, _cpu, c, failure) = time_runs(&spec, s.repeats)?;
        if let Some(e) = failure {
            return Err(format!("N = {n}: {e}"));
        }
        let per_sim = wall / s.time;
        // one more run for the islands' diagnostics
        let mut sim = setup(&spec)?;
        if let Some(e) = step_through(&mut sim, &spec, |_| {}) {
            return Err(format!("N = {n}: {e}"));
        }
        let islands = sim.islands();
        let largest = islands.iter().map(|i| i.bodies.len()).max().unwrap_or(0);
        let (rounds, compiled, cut) = sim.island_diagnostics();
        let rebuilds = sim.candidate_refreshes();
        let (former, one) = if n <= s.compare_max {
            let t0 = Instant::now();
            let timed = |scene: Scene, what: &str| match one_run(scene, &origin, s.compare_time) {
                Ok(r) => Some(r.0),
                Err(e) => {
                    eprintln!("  N = {n}, {what}: {e}");
                    None
                }
            };
            let former = timed(scenes::sphere_box(n, s.compare_time), "former");
            let one = timed(grouped(n, s.compare_time, s.margin, false), "one integrator");
            eprintln!("  (N = {n}: comparisons took {:.1} s)", t0.elapsed().as_secs_f64());
            (former, one)
        } else {
            (None, None)
        };
        let speedup = former.map(|x| x / per_sim);
        let over_one = one.map(|x| x / per_sim);
        let opt = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.3}"));
        println!(
            "{:>6} {:>12.3} {:>8} {:>9} {:>7} {:>8} {:>8} {:>7} {:>8} {:>9} {:>6} {:>12} {:>12} {:>11} {:>9}",
            n,
            per_sim,
            c.steps,
            c.rhs_evals,
            c.events,
            islands.len(),
            largest,
            rounds,
            rebuilds,
            compiled,
            cut,
            opt(former),
            opt(one),
            speedup.map_or("-".to_string(), |v| format!("{v:.1}x")),
            over_one.map_or("-".to_string(), |v| format!("{v:.1}x"))
        );
        let optf = |x: Option<f64>| x.map_or(String::new(), f);
        csv.push(vec![
            n.to_string(),
            f(per_sim),
            c.steps.to_string(),
            c.rhs_evals.to_string(),
            c.events.to_string(),
            islands.len().to_string(),
            largest.to_string(),
            rounds.to_string(),
            rebuilds.to_string(),
            compiled.to_string(),
            cut.to_string(),
            optf(former),
            optf(one),
            optf(speedup),
            optf(over_one),
            s.threads.to_string(),
        ]);
        if n >= 100 {
            xs.push(n as f64);
            ys.push(per_sim);
        }
    }
    csv.write(csv_path)?;
    if xs.len() >= 2 {
        println!(
            "fitted exponent (N ≥ 100): run time per simulated second as islands ∝ N^{:.2}",
            loglog_slope(&xs, &ys)
        );
    }
    Ok(())
}
