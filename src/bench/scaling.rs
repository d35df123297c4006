//! Scaling: N free spheres in a box (see [`super::scenes::sphere_box`]), N = 10 … 10,000.
//! Reports the run time per simulated second against N and the fitted exponent, the cost of
//! one right-hand-side evaluation and of one evaluation of the event functions, and checks
//! the structure that makes a scene of free bodies cheap: one 6×6 mass block per free body
//! and no loop-constraint rows.

use super::{f, median, scenes, thread_cpu_seconds, time_runs, Csv, RunSpec};
use crate::compile::compile;
use crate::contact;
use crate::forward::Rhs;
use crate::integrator::OdeSystem;
use crate::kinematics::kinematics;
use crate::model::{Data, Model};
use crate::scene::Scene;
use std::path::Path;
use std::time::Instant;

/// Median CPU time of one call of `body` \[s\] (the thread's CPU clock, which other load on
/// the machine does not inflate), from `repeats` batches of `iters` calls.
pub fn time_per_call(repeats: usize, iters: usize, mut body: impl FnMut()) -> f64 {
    let mut v = Vec::new();
    for _ in 0..repeats.max(1) {
        let t = thread_cpu_seconds();
        for _ in 0..iters {
            body();
        }
        v.push((thread_cpu_seconds() - t) / iters as f64);
    }
    median(&v)
}

/// Median cost of one RHS evaluation and of one evaluation of all event functions at the
/// initial state of a compiled model \[s\].
pub fn rhs_and_event_cost(m: &Model, d: &mut Data, repeats: usize) -> (f64, f64) {
    let state = d.state.clone();
    let mut dy = vec![0.0; state.len()];
    // Every contact active, so that the force laws are part of the cost.
    for mem in d.contact_memory.iter_mut() {
        mem.active = true;
        mem.impact_velocity = 1.0;
    }
    let t0 = Instant::now();
    Rhs { model: m, data: d }.rhs(0.0, &state, &mut dy);
    let once = t0.elapsed().as_secs_f64().max(1e-9);
    let iters = ((0.05 / once) as usize).clamp(1, 200_000);
    let rhs = time_per_call(repeats, iters, || {
        Rhs { model: m, data: d }.rhs(0.0, &state, &mut dy);
        std::hint::black_box(&dy);
    });
    let mut g = vec![0.0; d.contacts.len()];
    d.eval_state.copy_from_slice(&state);
    let ev = time_per_call(repeats, iters, || {
        kinematics(m, d);
        for (i, o) in g.iter_mut().enumerate() {
            *o = contact::event_function(&d.contacts[i], &contact::gap(d, i));
        }
        std::hint::black_box(&g);
    });
    (rhs, ev)
}

/// Least-squares slope of log(y) against log(x).
pub fn loglog_slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    let mx = lx.iter().sum::<f64>() / n;
    let my = ly.iter().sum::<f64>() / n;
    let sxy: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = lx.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// Runs the benchmark and writes the CSV.
pub fn run(ns: &[usize], time: f64, repeats: usize, csv_path: &Path) -> Result<(), String> {
    let mut csv = Csv::new(&[
        "n",
        "contacts",
        "nv",
        "mass_blocks",
        "largest_block",
        "loop_rows",
        "compile_seconds",
        "seconds_per_simulated_second",
        "steps",
        "rhs_evals",
        "events",
        "rhs_seconds",
        "event_seconds",
        "status",
    ]);
    println!(
        "{:>6} {:>8} {:>7} {:>7} {:>5} {:>5} {:>9} {:>12} {:>8} {:>9} {:>7} {:>10} {:>10}",
        "N",
        "contacts",
        "nv",
        "blocks",
        "max",
        "loops",
        "compile",
        "s per sim s",
        "steps",
        "rhs",
        "events",
        "rhs [µs]",
        "event [µs]"
    );
    let (mut xs, mut ys, mut ys_rhs) = (Vec::new(), Vec::new(), Vec::new());
    for &n in ns {
        // Compiled from its text, as a scene file is: the compile time includes parsing.
        let text = scenes::sphere_box(n, time).to_toml();
        let origin = format!("sphere_box_{n}");
        let t0 = Instant::now();
        let scene = Scene::from_str(&text, &origin).map_err(|e| e.to_string())?;
        let (m, mut d) = compile(&scene, &origin).map_err(|e| e.to_string())?;
        let compile = t0.elapsed().as_secs_f64();
        let blocks = m.trees.len();
        let largest = m.trees.iter().map(|t| t.1).max().unwrap_or(0);
        if blocks != n || largest != 6 || d.nc != 0 || d.mass_blocks.len() != 36 * n {
            return Err(format!(
                "N = {n}: expected {n} mass blocks of 6 and no loop rows, got {blocks} blocks (largest {largest}), {} loop rows, {} stored mass entries",
                d.nc,
                d.mass_blocks.len()
            ));
        }
        let (rhs, ev) = rhs_and_event_cost(&m, &mut d, repeats);
        let reps = if n >= 3000 { repeats.clamp(1, 3) } else { repeats };
        let spec = RunSpec::new(scene, &origin, time, time / 10.0);
        let (wall, _cpu, c, failure) = time_runs(&spec, reps)?;
        let per_sim = wall / time;
        println!(
            "{:>6} {:>8} {:>7} {:>7} {:>5} {:>5} {:>8.3}s {:>12.4e} {:>8} {:>9} {:>7} {:>10.2} {:>10.2} {}",
            n,
            d.contacts.len(),
            m.nv,
            blocks,
            largest,
            d.nc,
            compile,
            per_sim,
            c.steps,
            c.rhs_evals,
            c.events,
            rhs * 1e6,
            ev * 1e6,
            failure.as_deref().unwrap_or("")
        );
        csv.push(vec![
            n.to_string(),
            d.contacts.len().to_string(),
            m.nv.to_string(),
            blocks.to_string(),
            largest.to_string(),
            d.nc.to_string(),
            f(compile),
            f(per_sim),
            c.steps.to_string(),
            c.rhs_evals.to_string(),
            c.events.to_string(),
            f(rhs),
            f(ev),
            failure.unwrap_or_else(|| "ok".into()),
        ]);
        if n >= 100 {
            xs.push(n as f64);
            ys.push(per_sim);
            ys_rhs.push(rhs);
        }
    }
    csv.write(csv_path)?;
    if xs.len() >= 2 {
        println!(
            "fitted exponent (N ≥ 100): run time per simulated second ∝ N^{:.2}; one RHS evaluation ∝ N^{:.2}",
            loglog_slope(&xs, &ys),
            loglog_slope(&xs, &ys_rhs)
        );
    }
    Ok(())
}
