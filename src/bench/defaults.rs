//! The defaults a user gets: `solver.method = "auto"` against every fixed method, and the
//! rail vehicle as bundled against the former defaults.
//!
//! 1. **Auto against the best fixed method**, per bundled scene: a tolerance sweep of every
//!    method (fixed steps for rk4), the error measured as in the work-precision benchmark
//!    (closed form or a reference run), and the CPU time and RHS evaluations at an error of
//!    exactly [`TARGET_ERROR`], interpolated log-log between the two sweep points around it.
//!    Auto passes when its CPU time is within [`AUTO_MARGIN`] of the best fixed method's.
//! 2. **The rail vehicle as bundled** (auto at the scene's tolerances) against the former
//!    defaults (dopri5, rtol 1e-8, atol 1e-10, `max_step` 1 ms, a restart at every communication point), timed
//!    alternately in one run, with the error of each against a reference; and auto at
//!    tighter tolerances until it is as accurate as the former defaults.
//! 3. **The rail vehicle's 5 s within 1e-6 in 5 ms**: auto's sweep there, with the RHS count
//!    times the cost of one RHS against the run time (what bounds it).

use super::scaling::rhs_and_event_cost;
use super::work_precision::{
    at_error, error_of, position_outputs, truth_of, truth_outputs, Cost, Truth, AUTO_MARGIN, RTOLS,
};
use super::{f, median, record, sweep_point, time_runs, Counters, Csv, RunSpec, SweepArgs};
use crate::compile::compile;
use crate::scene::{Method, Scene};
use std::path::Path;

/// Error at which the methods are compared (relative to the range of motion).
pub const TARGET_ERROR: f64 = 1e-6;
/// The rail vehicle's CPU goal for 5 s within [`TARGET_ERROR`] \[s\].
pub const RAIL_GOAL: f64 = 5e-3;
/// Fixed steps of the rk4 sweep \[s\].
const STEPS: [f64; 8] = [1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7];

/// A CSV row: part, scene, setting, tolerance (empty: none), error, CPU and wall time,
/// counters, note.
#[allow(clippy::too_many_arguments)]
fn row(
    part: &str,
    scene: &str,
    setting: &str,
    tol: Option<f64>,
    error: f64,
    cpu: f64,
    wall: f64,
    c: &Counters,
    note: String,
) -> Vec<String> {
    vec![
        part.into(),
        scene.into(),
        setting.into(),
        tol.map(|t| format!("{t:e}")).unwrap_or_default(),
        f(error),
        f(cpu),
        f(wall),
        c.steps.to_string(),
        c.rhs_evals.to_string(),
        c.jac_evals.to_string(),
        note,
    ]
}

/// Runs the benchmark and writes the CSV.
pub fn run(args: &SweepArgs, csv_path: &Path) -> Result<(), String> {
    let (repeats, budget) = (args.repeats, args.budget);
    let mut csv = Csv::new(&[
        "part",
        "scene",
        "setting",
        "tolerance",
        "error",
        "cpu_seconds",
        "wall_seconds",
        "steps",
        "rhs_evals",
        "jac_evals",
        "note",
    ]);
    let mut summary = Vec::new();
    for (name, path) in args.selected_scenes()? {
        let origin = path.display().to_string();
        let scene = Scene::from_file(&path).map_err(|e| e.to_string())?;
        let ratio = scene.solver.atol / scene.solver.rtol;
        let base = RunSpec::new(scene.clone(), &origin, scene.model.stop_time, scene.model.interval);
        let with = |method: Method, tol: f64| sweep_point(&base, method, tol, ratio);
        let positions = position_outputs(&scene);
        let positions: Vec<&str> = positions.iter().map(|s| s.as_str()).collect();
        let (truth, _) = truth_of(&scene, &base).map_err(|e| format!("{name}: {e}"))?;
        let outputs = truth_outputs(&truth, &positions);
        println!(
            "\n{name}: {:<7} {:>9} {:>10} {:>10} {:>9} {:>10} {:>5}",
            "method", "tol/step", "error", "cpu [s]", "steps", "rhs", "jac"
        );
        let mut at_target: Vec<(Method, Option<(f64, f64)>)> = Vec::new();
        for method in Method::ALL {
            let tols: Vec<f64> = match method {
                Method::Rk4 => STEPS.to_vec(),
                _ => RTOLS.to_vec(),
            };
            let mut points = Vec::new();
            for tol in tols {
                let spec = with(method, tol);
                let rec = record(&spec, &outputs)?;
                let error = if rec.failure.is_some() {
                    f64::NAN
                } else {
                    error_of(&truth, &rec.traj)
                };
                let (wall, cpu, c, _) = if rec.seconds > budget {
                    (rec.seconds, rec.seconds, rec.counters, None)
                } else {
                    time_runs(&spec, repeats)?
                };
                println!(
                    "{name:>14} {:<7} {:>9.1e} {:>10.3e} {:>10.3e} {:>9} {:>10} {:>5} {}",
                    method.name(),
                    tol,
                    error,
                    cpu,
                    c.steps,
                    c.rhs_evals,
                    c.jac_evals,
                    rec.failure.as_deref().unwrap_or("")
                );
                let note = rec.failure.clone().unwrap_or_default();
                csv.push(row(
                    "sweep",
                    &name,
                    method.name(),
                    Some(tol),
                    error,
                    cpu,
                    wall,
                    &c,
                    note,
                ));
                if error.is_finite() {
                    points.push(Cost {
                        error,
                        cpu,
                        rhs: c.rhs_evals as f64,
                    });
                }
                let tight_enough = error.is_finite() && error < 0.01 * TARGET_ERROR;
                if rec.seconds > budget || tight_enough {
                    break;
                }
            }
            at_target.push((method, at_error(&points, TARGET_ERROR)));
        }
        let auto = at_target.iter().find(|(m, _)| *m == Method::Auto).and_then(|(_, x)| *x);
        let best = at_target
            .iter()
            .filter(|(m, _)| *m != Method::Auto)
            .filter_map(|(m, x)| x.map(|x| (*m, x)))
            .min_by(|a, b| a.1 .0.total_cmp(&b.1 .0));
        let cells: Vec<String> = at_target
            .iter()
            .map(|(m, x)| match x {
                Some((cpu, rhs)) => format!("{}: {:.3} ms, {:.0} RHS", m.name(), cpu * 1e3, rhs),
                None => format!("{}: not reached", m.name()),
            })
            .collect();
        println!("{name}: at error {TARGET_ERROR:e}: {}", cells.join("; "));
        let verdict = match (auto, best) {
            (Some(a), Some((bm, b))) => {
                let r = a.0 / b.0;
                csv.push(vec![
                    "auto_vs_best".into(),
                    name.clone(),
                    format!("auto / {}", bm.name()),
                    format!("{TARGET_ERROR:e}"),
                    f(TARGET_ERROR),
                    f(a.0),
                    f(b.0),
                    format!("{:.0}", a.1),
                    format!("{:.0}", b.1),
                    String::new(),
                    format!("cpu ratio {r:.3}, rhs ratio {:.3}", a.1 / b.1),
                ]);
                format!(
                    "| {name} | {} | {:.3} | {:.3} | {r:.2}× | {:.2}× | {} |",
                    bm.name(),
                    b.0 * 1e3,
                    a.0 * 1e3,
                    a.1 / b.1,
                    if r <= AUTO_MARGIN { "met" } else { "missed" }
                )
            }
            _ => format!("| {name} | — | — | — | — | — | not reached |"),
        };
        summary.push(verdict);
        if name == "rail_vehicle" {
            rail_defaults(&scene, &origin, &truth, &outputs, repeats, &mut csv)?;
        }
    }
    println!("\nAuto against the best fixed method at error {TARGET_ERROR:e} (CPU interpolated between sweep points):");
    println!("| scene | best fixed | its CPU [ms] | auto CPU [ms] | CPU ratio | RHS ratio | within {AUTO_MARGIN}× |");
    println!("| --- | --- | --- | --- | --- | --- | --- |");
    for s in &summary {
        println!("{s}");
    }
    csv.write(csv_path)
}

/// Part 2 and 3: the rail vehicle as bundled against the former defaults, and the 5 ms goal.
fn rail_defaults(
    scene: &Scene,
    origin: &str,
    truth: &Truth,
    outputs: &[&str],
    repeats: usize,
    csv: &mut Csv,
) -> Result<(), String> {
    let auto_row = |part, tol, error, cpu, wall, c: &Counters, note| {
        row(part, "rail_vehicle", "auto", Some(tol), error, cpu, wall, c, note)
    };
    let bundled = RunSpec::new(scene.clone(), origin, scene.model.stop_time, scene.model.interval);
    let mut former_scene = scene.clone();
    former_scene.solver.method = Method::Dopri5;
    former_scene.solver.rtol = 1e-8;
    former_scene.solver.atol = 1e-10;
    former_scene.solver.max_step = 1e-3;
    former_scene.solver.continuation = false;
    let former = RunSpec::new(former_scene, origin, scene.model.stop_time, scene.model.interval);
    let err = |spec: &RunSpec| -> Result<f64, String> {
        let r = record(spec, outputs)?;
        Ok(if r.failure.is_some() {
            f64::NAN
        } else {
            error_of(truth, &r.traj)
        })
    };
    let (e_new, e_old) = (err(&bundled)?, err(&former)?);
    // alternate the timed runs so that both see the same machine load
    let (mut cpu_new, mut cpu_old, mut wall_new, mut wall_old) = (vec![], vec![], vec![], vec![]);
    let (mut c_new, mut c_old) = Default::default();
    for _ in 0..repeats.max(1) {
        let (w, c, k, _) = time_runs(&bundled, 1)?;
        wall_new.push(w);
        cpu_new.push(c);
        c_new = k;
        let (w, c, k, _) = time_runs(&former, 1)?;
        wall_old.push(w);
        cpu_old.push(c);
        c_old = k;
    }
    let (cn, co) = (median(&cpu_new), median(&cpu_old));
    let label = format!(
        "as bundled ({}, rtol {:.0e})",
        scene.solver.method.name(),
        scene.solver.rtol
    );
    println!("\nrail_vehicle as bundled against the former defaults (dopri5, rtol 1e-8, max_step 1 ms, restart at every point), {repeats} alternated runs:");
    println!(
        "{:<34} {:>10} {:>10} {:>10} {:>8} {:>9} {:>5}",
        "setting", "error", "cpu [ms]", "wall [ms]", "steps", "rhs", "jac"
    );
    for (label, e, cpu, wall, c) in [
        (label.as_str(), e_new, cn, median(&wall_new), c_new),
        ("former defaults", e_old, co, median(&wall_old), c_old),
    ] {
        let c: Counters = c;
        println!(
            "{label:<34} {e:>10.3e} {:>10.2} {:>10.2} {:>8} {:>9} {:>5}",
            cpu * 1e3,
            wall * 1e3,
            c.steps,
            c.rhs_evals,
            c.jac_evals
        );
        csv.push(row(
            "rail_defaults",
            "rail_vehicle",
            label,
            None,
            e,
            cpu,
            wall,
            &c,
            String::new(),
        ));
    }
    println!(
        "ratios (former / auto): RHS {:.2}×, CPU {:.2}×; errors {e_new:.2e} (auto) and {e_old:.2e} (former)",
        c_old.rhs_evals as f64 / c_new.rhs_evals as f64,
        co / cn
    );
    // auto as bundled at another tolerance (atol = rtol/100) and largest step (0: none):
    // (error, wall, CPU, counters)
    let measure = |tol: f64, max_step: f64| -> Result<(f64, f64, f64, Counters), String> {
        let spec = bundled
            .clone()
            .with("solver.rtol", tol)
            .with("solver.atol", tol * 1e-2)
            .with("solver.max_step", max_step);
        let e = err(&spec)?;
        let (wall, cpu, c, _) = time_runs(&spec, repeats)?;
        Ok((e, wall, cpu, c))
    };
    // auto tightened until it is as accurate as the former defaults
    println!("\nauto at tighter tolerances (atol = rtol/100), until as accurate as the former defaults:");
    for tol in [1e-9, 1e-10, 1e-11] {
        let (e, wall, cpu, c) = measure(tol, 0.0)?;
        println!(
            "auto rtol {tol:.0e}: error {e:.3e}, cpu {:.2} ms ({:.2}× less than the former defaults), {} RHS ({:.2}× fewer)",
            cpu * 1e3,
            co / cpu,
            c.rhs_evals,
            c_old.rhs_evals as f64 / c.rhs_evals as f64
        );
        csv.push(auto_row("rail_tightened", tol, e, cpu, wall, &c, String::new()));
        if e <= e_old {
            break;
        }
    }
    // the 5 ms goal: the cheapest auto setting within the target error
    let (m, mut d) = compile(scene, origin).map_err(|e| e.to_string())?;
    let (rhs_cost, _) = rhs_and_event_cost(&m, &mut d, 9);
    println!(
        "\nrail vehicle, 5 s within {TARGET_ERROR:e} (goal {:.0} ms CPU); one RHS {:.2} µs:",
        RAIL_GOAL * 1e3,
        rhs_cost * 1e6
    );
    let mut best: Option<(f64, String)> = None;
    // (rtol, max_step): the defaults' continuation lets steps grow past many communication
    // points, where the outputs come from the dense output; a largest step trades that
    let settings = [
        (1e-3, 0.0),
        (1e-4, 0.0),
        (5e-5, 0.0),
        (2e-5, 0.0),
        (1e-5, 0.0),
        (1e-6, 0.0),
        (1e-7, 0.0),
        (1e-4, 0.05),
        (1e-4, 0.02),
        (1e-4, 0.01),
    ];
    for (tol, max_step) in settings {
        let (e, wall, cpu, c) = measure(tol, max_step)?;
        let rhs_time = c.rhs_evals as f64 * rhs_cost;
        let line = format!(
            "auto rtol {tol:.0e}, max_step {max_step}: error {e:.3e}, cpu {:.2} ms, {} steps, {} RHS × {:.2} µs = {:.2} ms ({:.0} % of the run), {} Jacobians",
            cpu * 1e3,
            c.steps,
            c.rhs_evals,
            rhs_cost * 1e6,
            rhs_time * 1e3,
            100.0 * rhs_time / cpu,
            c.jac_evals
        );
        println!("{line}");
        let note = format!("max_step {max_step}; rhs share {:.3}", rhs_time / cpu);
        csv.push(auto_row("rail_goal", tol, e, cpu, wall, &c, note));
        if e <= TARGET_ERROR && best.as_ref().is_none_or(|b| cpu < b.0) {
            best = Some((cpu, line));
        }
    }
    match best {
        Some((cpu, line)) => println!(
            "fastest within {TARGET_ERROR:e}: {line}: goal {}",
            if cpu <= RAIL_GOAL { "met" } else { "missed" }
        ),
        None => println!("no auto setting reached {TARGET_ERROR:e}"),
    }
    Ok(())
}
