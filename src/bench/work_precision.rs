//! Work-precision: for every bundled scene and every integrator, a sweep of tolerances
//! (fixed step sizes for rk4); the error against a closed form where one exists, otherwise
//! against a dopri5 run at rtol 1e-13, 100× tighter than the tightest of the sweep (that
//! reference is confirmed by the other methods converging to it); the median run time and
//! the work counters.

use super::{f, record, sweep_point, time_runs, Csv, RunSpec, SweepArgs, Trajectory};
use crate::scene::{Method, Scene};
use std::path::Path;

/// Relative tolerances of the adaptive sweep.
pub(crate) const RTOLS: [f64; 9] = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11];
/// `auto` may cost this much more than the best fixed method at the error of any point.
pub const AUTO_MARGIN: f64 = 1.3;
/// Fixed steps of the rk4 sweep \[s\].
const STEPS: [f64; 9] = [1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7, 1e-7];
/// Tolerance of the reference run (100× tighter than the tightest of the sweep).
const RTOL_REF: f64 = 1e-13;
/// Tolerances run per point by default (see [`sample_factors`]).
pub const SAMPLES: usize = 5;
/// The samples of a point span its tolerance divided and multiplied by this.
const SAMPLE_SPAN: f64 = 1.25;
/// A point whose samples' evaluations spread by more than this factor is run at four times
/// as many tolerances (the first ones among them: 17 for 5).
const SPREAD_LIMIT: f64 = 2.0;

/// The factors on a point's tolerance of its `k` samples: evenly spaced on a log scale from
/// 1/`SAMPLE_SPAN` to `SAMPLE_SPAN`, 1 among them when `k` is odd (`[1]` for k ≤ 1).
///
/// Why more than one: where a scene's motion is not resolved at a loose tolerance (the rail
/// vehicle at rtol 1e-3, whose error weight on the car's 22 m/s, 2.2 cm/s, exceeds the
/// friction law's stiction band of 2 cm/s), the work and the error of every adaptive method
/// change by 10-30× between neighbouring tolerances (radau5: 560 to 6,737 evaluations over 16
/// tolerances from 0.7e-3 to 1.5e-3), so one tolerance is one draw of that spread; the median
/// of a few is a measurement.
pub fn sample_factors(k: usize) -> Vec<f64> {
    if k <= 1 {
        return vec![1.0];
    }
    (0..k)
        .map(|j| SAMPLE_SPAN.powf(2.0 * j as f64 / (k - 1) as f64 - 1.0))
        .collect()
}

/// How the error of a run is measured.
pub(crate) enum Truth {
    /// Closed-form final velocities of a central elastic impact of two free spheres:
    /// (output names, exact values, speed scale).
    FinalVelocities(Vec<String>, Vec<f64>, f64),
    /// A reference trajectory of the body positions.
    Reference(Trajectory),
}

/// The closed form where the scene is a central impact of two free spheres under the pure
/// Hertz law without gravity (elastic: the exact post-impact velocities are known).
pub(crate) fn closed_form(scene: &Scene) -> Option<Truth> {
    use crate::scene::{ContactType, Law};
    if scene.body.len() != 2
        || !scene.joint.is_empty()
        || scene.contact.len() != 1
        || scene.model.gravity != [0.0; 3]
        || !scene.spring_damper.is_empty()
    {
        return None;
    }
    let c = &scene.contact[0];
    if c.kind != ContactType::SphereSphere || c.law != Law::Hertz {
        return None;
    }
    let (a, b) = (&scene.body[0], &scene.body[1]);
    let (m1, m2) = (a.mass, b.mass);
    let (v1, v2) = (a.velocity, b.velocity);
    let dir = {
        let d = [
            b.position[0] - a.position[0],
            b.position[1] - a.position[1],
            b.position[2] - a.position[2],
        ];
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        [d[0] / n, d[1] / n, d[2] / n]
    };
    let dot = |v: [f64; 3]| v[0] * dir[0] + v[1] * dir[1] + v[2] * dir[2];
    let (u1, u2) = (dot(v1), dot(v2));
    // Elastic central impact: normal components exchange as (14)-(15) with e = 1.
    let w1 = ((m1 - m2) * u1 + 2.0 * m2 * u2) / (m1 + m2);
    let w2 = ((m2 - m1) * u2 + 2.0 * m1 * u1) / (m1 + m2);
    let mut names = Vec::new();
    let mut vals = Vec::new();
    for (body, v, u, w) in [(a, v1, u1, w1), (b, v2, u2, w2)] {
        for k in 0..3 {
            names.push(format!("{}.v[{}]", body.name, k + 1));
            vals.push(v[k] + (w - u) * dir[k]);
        }
    }
    let scale = (u1 - u2).abs().max(1e-300);
    Some(Truth::FinalVelocities(names, vals, scale))
}

/// Names of the body-position outputs of a scene.
pub(crate) fn position_outputs(scene: &Scene) -> Vec<String> {
    scene
        .body
        .iter()
        .flat_map(|b| (1..=3).map(move |k| format!("{}.r[{k}]", b.name)))
        .collect()
}

/// Largest position error over all communication points, each coordinate relative to its
/// own range of motion in the reference (floored at 1e-3 of the largest range, so that a
/// coordinate that hardly moves does not divide by zero). NaN when the run stopped early.
pub fn trajectory_error(run: &Trajectory, reference: &Trajectory) -> f64 {
    if run.rows.len() != reference.rows.len() {
        return f64::NAN;
    }
    let ncol = reference.names.len();
    let ranges: Vec<f64> = (0..ncol)
        .map(|c| {
            let (lo, hi) = reference
                .rows
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
                    (lo.min(r[c]), hi.max(r[c]))
                });
            hi - lo
        })
        .collect();
    let largest = ranges[1..].iter().copied().fold(0.0_f64, f64::max).max(1e-300);
    let mut err = 0.0_f64;
    for (a, b) in run.rows.iter().zip(&reference.rows) {
        for c in 1..ncol {
            let e = (a[c] - b[c]).abs() / ranges[c].max(1e-3 * largest);
            if e.is_nan() {
                return f64::NAN;
            }
            err = err.max(e);
        }
    }
    err
}

/// The truth the runs of `scene` are measured against: the closed form where there is one
/// ([`closed_form`]), otherwise a reference run of `base` with dopri5 at [`RTOL_REF`] (atol
/// in the scene's ratio to rtol); with the kind of error it gives.
pub(crate) fn truth_of(scene: &Scene, base: &RunSpec) -> Result<(Truth, &'static str), String> {
    if let Some(t) = closed_form(scene) {
        return Ok((t, "closed_form_final_velocity"));
    }
    let positions = position_outputs(scene);
    let outputs: Vec<&str> = positions.iter().map(|s| s.as_str()).collect();
    let ratio = scene.solver.atol / scene.solver.rtol;
    let r = record(&sweep_point(base, Method::Dopri5, RTOL_REF, ratio), &outputs)?;
    match r.failure {
        Some(fail) => Err(format!("reference run (dopri5, rtol {RTOL_REF:e}) failed: {fail}")),
        None => Ok((Truth::Reference(r.traj), "reference_position")),
    }
}

/// The outputs a run must record to be measured against `truth`: the positions, and the
/// final velocities of a closed form.
pub(crate) fn truth_outputs<'a>(truth: &'a Truth, positions: &[&'a str]) -> Vec<&'a str> {
    let mut outputs = positions.to_vec();
    if let Truth::FinalVelocities(names, _, _) = truth {
        outputs.extend(names.iter().map(|s| s.as_str()));
    }
    outputs
}

/// The error of a run against the truth (see [`Truth`]).
pub(crate) fn error_of(truth: &Truth, traj: &Trajectory) -> f64 {
    match truth {
        Truth::Reference(r) => trajectory_error(traj, r),
        Truth::FinalVelocities(names, vals, scale) => {
            let Some(last) = traj.rows.last() else { return f64::NAN };
            let mut e = 0.0_f64;
            for (n, v) in names.iter().zip(vals) {
                match traj.column(n) {
                    Some(c) => e = e.max((last[c] - v).abs()),
                    None => return f64::NAN,
                }
            }
            e / scale
        }
    }
}

/// One point of a sweep: the medians over its samples (see [`sample_factors`]).
struct Point {
    method: Method,
    tolerance: f64,
    /// Median error of the samples.
    error: f64,
    /// Median wall-clock and CPU time of the samples (each the median of its timed runs).
    seconds: f64,
    cpu: f64,
    /// Timed runs per sample.
    repeats: usize,
    /// The counters of the sample with the median evaluations.
    counters: crate::model::Counters,
    /// Samples run, the least and the most evaluations and error among them.
    samples: usize,
    rhs_range: (u64, u64),
    error_range: (f64, f64),
    status: String,
}

/// One sample of a point: its error, timing and counters.
struct Sample {
    error: f64,
    seconds: f64,
    cpu: f64,
    counters: crate::model::Counters,
}

impl Point {
    /// The point of `method` at `tolerance` from its samples (at least one).
    fn of(method: Method, tolerance: f64, repeats: usize, samples: &[Sample], status: String) -> Point {
        let med = |f: &dyn Fn(&Sample) -> f64| super::median(&samples.iter().map(f).collect::<Vec<_>>());
        let mut by_rhs: Vec<&Sample> = samples.iter().collect();
        by_rhs.sort_by_key(|s| s.counters.rhs_evals);
        let errors = samples.iter().map(|s| s.error);
        Point {
            method,
            tolerance,
            error: med(&|s| s.error),
            seconds: med(&|s| s.seconds),
            cpu: med(&|s| s.cpu),
            repeats,
            counters: by_rhs[by_rhs.len() / 2].counters,
            samples: samples.len(),
            rhs_range: (
                by_rhs[0].counters.rhs_evals,
                by_rhs[by_rhs.len() - 1].counters.rhs_evals,
            ),
            error_range: (
                errors.clone().fold(f64::INFINITY, f64::min),
                errors.fold(f64::NEG_INFINITY, f64::max),
            ),
            status,
        }
    }
}

/// Runs the benchmark and writes the CSV.
pub fn run(args: &SweepArgs, samples: usize, csv_path: &Path) -> Result<(), String> {
    let factors = sample_factors(samples);
    let (repeats, budget) = (args.repeats, args.budget);
    let mut csv = Csv::new(&[
        "scene",
        "method",
        "tolerance",
        "error",
        "error_kind",
        "seconds",
        "cpu_seconds",
        "repeats",
        "steps",
        "rejected",
        "rhs_evals",
        "jac_evals",
        "events",
        "samples",
        "rhs_min",
        "rhs_max",
        "error_min",
        "error_max",
        "status",
    ]);
    let mut summary: Vec<String> = Vec::new();
    let mut auto_summary: Vec<String> = Vec::new();
    for (name, path) in args.selected_scenes()? {
        let origin = path.display().to_string();
        let scene = match Scene::from_file(&path) {
            Ok(s) => s,
            Err(e) => {
                println!("{name}: skipped, the scene does not load: {e}");
                continue;
            }
        };
        let ratio = scene.solver.atol / scene.solver.rtol;
        let base = RunSpec::new(scene.clone(), &origin, scene.model.stop_time, scene.model.interval);
        let with = |method: Method, tol: f64| sweep_point(&base, method, tol, ratio);
        let positions = position_outputs(&scene);
        let pos_refs: Vec<&str> = positions.iter().map(|s| s.as_str()).collect();
        let (truth, kind) = match truth_of(&scene, &base) {
            Ok(t) => t,
            Err(fail) => {
                println!("{name}: {fail}; skipped");
                continue;
            }
        };
        let outputs = truth_outputs(&truth, &pos_refs);
        println!(
            "\n{name} ({kind}; medians of {} samples): {:<7} {:>9} {:>10} {:>10} {:>9} {:>10} {:>6} {:>7} {:>17}",
            factors.len(),
            "method",
            "tol/step",
            "error",
            "seconds",
            "steps",
            "rhs_evals",
            "jac",
            "events",
            "rhs_evals min-max"
        );
        let mut points: Vec<Point> = Vec::new();
        for method in Method::ALL {
            let tols: Vec<f64> = match method {
                Method::Rk4 => STEPS
                    .iter()
                    .copied()
                    .filter(|h| *h <= scene.model.interval * 1.0001)
                    .collect(),
                _ => RTOLS.to_vec(),
            };
            let mut consecutive_failures = 0;
            for tol in tols {
                // the samples of the point; the first failure or overlong run ends them; a
                // spread beyond SPREAD_LIMIT adds the samples between them
                let (mut runs, mut failure, mut slowest, mut reps) = (Vec::new(), None, 0.0_f64, repeats);
                let mut run_factors = |list: &[f64], runs: &mut Vec<(f64, Sample)>| -> Result<bool, String> {
                    for factor in list {
                        if runs.iter().any(|(f, _)| (f / factor - 1.0).abs() < 1e-9) {
                            continue;
                        }
                        let spec = with(method, tol * factor);
                        let rec = record(&spec, &outputs)?;
                        slowest = slowest.max(rec.seconds);
                        let error = error_of(&truth, &rec.traj);
                        let (seconds, cpu) = if rec.seconds > budget || rec.failure.is_some() {
                            reps = 1;
                            (rec.seconds, f64::NAN)
                        } else {
                            let (w, c, _, _) = time_runs(&spec, repeats)?;
                            (w, c)
                        };
                        runs.push((
                            *factor,
                            Sample {
                                error,
                                seconds,
                                cpu,
                                counters: rec.counters,
                            },
                        ));
                        if rec.failure.is_some() || rec.seconds > budget {
                            failure = rec.failure;
                            return Ok(false);
                        }
                    }
                    Ok(true)
                };
                if run_factors(&factors, &mut runs)? && factors.len() > 1 {
                    let rhs = runs.iter().map(|(_, r)| r.counters.rhs_evals as f64);
                    let (lo, hi) = rhs.fold((f64::INFINITY, 0.0_f64), |(lo, hi), x| (lo.min(x), hi.max(x)));
                    if hi > SPREAD_LIMIT * lo {
                        run_factors(&sample_factors(4 * (factors.len() - 1) + 1), &mut runs)?;
                    }
                }
                let runs: Vec<Sample> = runs.into_iter().map(|(_, r)| r).collect();
                let status = failure.unwrap_or_else(|| "ok".into());
                let point = Point::of(method, tol, reps, &runs, status.clone());
                let (error, seconds, c) = (point.error, point.seconds, point.counters);
                println!(
                    "{name:>12}  {:<7} {:>9.1e} {:>10.3e} {:>10.3e} {:>9} {:>10} {:>6} {:>7} {:>17} {}",
                    method.name(),
                    tol,
                    error,
                    seconds,
                    c.steps,
                    c.rhs_evals,
                    c.jac_evals,
                    c.events,
                    format!("{}-{}", point.rhs_range.0, point.rhs_range.1),
                    if status == "ok" { "" } else { &status }
                );
                points.push(point);
                if status != "ok" {
                    consecutive_failures += 1;
                    if consecutive_failures >= 2 {
                        break;
                    }
                } else {
                    consecutive_failures = 0;
                }
                if slowest > budget {
                    println!(
                        "{name:>12}  {} stops refining: one run took {slowest:.1} s",
                        method.name()
                    );
                    break;
                }
            }
        }
        auto_summary.extend(auto_against_best(&name, &points));
        for p in &points {
            csv.push(vec![
                name.clone(),
                p.method.name().into(),
                format!("{:e}", p.tolerance),
                f(p.error),
                kind.into(),
                f(p.seconds),
                f(p.cpu),
                p.repeats.to_string(),
                p.counters.steps.to_string(),
                p.counters.rejected.to_string(),
                p.counters.rhs_evals.to_string(),
                p.counters.jac_evals.to_string(),
                p.counters.events.to_string(),
                p.samples.to_string(),
                p.rhs_range.0.to_string(),
                p.rhs_range.1.to_string(),
                f(p.error_range.0),
                f(p.error_range.1),
                p.status.clone(),
            ]);
        }
        // Summary: the fastest method reaching each error level.
        for target in [1e-2, 1e-4, 1e-6, 1e-8] {
            let mut best: Option<&Point> = None;
            // CPU time of the thread where measured (other load does not inflate it).
            let t = |p: &Point| if p.cpu.is_finite() { p.cpu } else { p.seconds };
            for p in points.iter().filter(|p| p.status == "ok" && p.error <= target) {
                if best.is_none_or(|b| t(p) < t(b)) {
                    best = Some(p);
                }
            }
            let alt: Vec<String> = Method::ALL
                .iter()
                .map(|m| {
                    points
                        .iter()
                        .filter(|p| p.method == *m && p.status == "ok" && p.error <= target)
                        .map(t)
                        .fold(f64::INFINITY, f64::min)
                })
                .map(|s| {
                    if s.is_finite() {
                        format!("{s:.2e}")
                    } else {
                        "—".into()
                    }
                })
                .collect();
            summary.push(match best {
                Some(b) => format!(
                    "| {name} | {target:.0e} | **{}** ({} {:.0e}) | {} |",
                    b.method.name(),
                    if b.method == Method::Rk4 { "h" } else { "rtol" },
                    b.tolerance,
                    alt.join(" | ")
                ),
                None => format!("| {name} | {target:.0e} | none reached it | {} |", alt.join(" | ")),
            });
        }
    }
    csv.write(csv_path)?;
    let names: Vec<String> = Method::ALL.iter().map(|m| format!("{} [s]", m.name())).collect();
    println!("\n| scene | error ≤ | fastest | {} |", names.join(" | "));
    println!("| --- | --- | --- |{}", " --- |".repeat(names.len()));
    for s in summary {
        println!("{s}");
    }
    println!("\nauto against the best fixed method at the error of every point of the sweep (cost interpolated log-log; worst CPU and RHS ratios; Jacobians of auto's points):");
    println!("| scene | error levels | worst CPU ratio (at error) | worst RHS ratio (at error) | within {AUTO_MARGIN}× (CPU) | auto's Jacobians per point |");
    println!("| --- | --- | --- | --- | --- | --- |");
    for s in auto_summary {
        println!("{s}");
    }
    Ok(())
}

/// What a sweep point cost at its error: CPU time and RHS evaluations.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Cost {
    pub(crate) error: f64,
    pub(crate) cpu: f64,
    pub(crate) rhs: f64,
}

/// `(cpu, rhs)` at `target` error, interpolated log-log between the loosest point that
/// reaches it and the point before it (the loosest point itself when it already does);
/// None when no point reaches it.
pub(crate) fn at_error(points: &[Cost], target: f64) -> Option<(f64, f64)> {
    let i = points.iter().position(|p| p.error <= target)?;
    if i == 0 {
        return Some((points[0].cpu, points[0].rhs));
    }
    let (a, b) = (points[i - 1], points[i]);
    let s = if b.error > 0.0 && a.error > b.error {
        (target.ln() - a.error.ln()) / (b.error.ln() - a.error.ln())
    } else {
        1.0
    };
    let lerp = |x: f64, y: f64| (x.ln() + s * (y.ln() - x.ln())).exp();
    Some((lerp(a.cpu, b.cpu), lerp(a.rhs, b.rhs)))
}

/// The table row of `auto` against the best fixed method of a scene: at the error of every
/// successful point of every method (within the range auto's sweep reaches), auto's CPU time
/// and RHS evaluations interpolated log-log at that error against the least of the fixed
/// methods' (each interpolated likewise); the worst ratios.
fn auto_against_best(name: &str, points: &[Point]) -> Option<String> {
    let curve = |m: Method| -> Vec<Cost> {
        points
            .iter()
            .filter(|p| p.method == m && p.status == "ok" && p.error.is_finite() && p.cpu.is_finite())
            .map(|p| Cost {
                error: p.error,
                cpu: p.cpu,
                rhs: p.counters.rhs_evals as f64,
            })
            .collect()
    };
    let auto = curve(Method::Auto);
    let fixed: Vec<Vec<Cost>> = Method::ALL
        .iter()
        .filter(|m| **m != Method::Auto)
        .map(|m| curve(*m))
        .collect();
    let mut levels: Vec<f64> = points.iter().filter(|p| p.status == "ok").map(|p| p.error).collect();
    levels.retain(|e| e.is_finite() && *e > 0.0);
    let (mut worst_cpu, mut worst_rhs, mut n) = ((0.0_f64, f64::NAN), (0.0_f64, f64::NAN), 0);
    for e in levels {
        let Some(a) = at_error(&auto, e) else { continue };
        let best_cpu = fixed
            .iter()
            .filter_map(|c| at_error(c, e))
            .map(|x| x.0)
            .fold(f64::INFINITY, f64::min);
        let best_rhs = fixed
            .iter()
            .filter_map(|c| at_error(c, e))
            .map(|x| x.1)
            .fold(f64::INFINITY, f64::min);
        if !best_cpu.is_finite() {
            continue;
        }
        n += 1;
        if a.0 / best_cpu > worst_cpu.0 {
            worst_cpu = (a.0 / best_cpu, e);
        }
        if a.1 / best_rhs > worst_rhs.0 {
            worst_rhs = (a.1 / best_rhs, e);
        }
    }
    let jacobians: Vec<String> = points
        .iter()
        .filter(|p| p.method == Method::Auto)
        .map(|p| p.counters.jac_evals.to_string())
        .collect();
    (n > 0).then(|| {
        format!(
            "| {name} | {n} | {:.2}× ({:.1e}) | {:.2}× ({:.1e}) | {} | {} |",
            worst_cpu.0,
            worst_cpu.1,
            worst_rhs.0,
            worst_rhs.1,
            if worst_cpu.0 <= AUTO_MARGIN { "yes" } else { "no" },
            jacobians.join(", ")
        )
    })
}
