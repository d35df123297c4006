//! Stability stress cases: each one finishes, or fails with a clear error; for each the
//! energy-balance error and the largest penetration against `max_penetration` are reported,
//! with a case-specific check (effective restitution, drift, chatter, momentum, the rolling
//! speed reached by a sliding ball with friction).

use super::scenes::{self, steel_ball_plane_stiffness, BALL_MASS};
use super::{f, record, Csv, Outcome, RunSpec};
use crate::scene::{Law, Method, Scene};
use std::path::Path;
/// Largest penetration of an undamped Hertz impact `(5 m v² / (4 K))^(2/5)` \[m\].
pub fn hertz_max_penetration(m: f64, v: f64, k: f64) -> f64 {
    (5.0 * m * v * v / (4.0 * k)).powf(0.4)
}

/// Hertz contact duration `2.94328 δ_max / v` \[s\].
pub fn hertz_duration(m: f64, v: f64, k: f64) -> f64 {
    2.94328 * hertz_max_penetration(m, v, k) / v
}

/// One row of the stress table.
pub struct Row {
    /// Group of cases.
    pub group: &'static str,
    /// The case.
    pub case: String,
    /// Integrator.
    pub method: Method,
    /// The run.
    pub out: Outcome,
    /// Name of the case-specific check.
    pub check: &'static str,
    /// Its value.
    pub value: f64,
    /// What it should be.
    pub expected: f64,
}

fn spec(scene: &Scene, origin: &str, method: Method, stop: f64, interval: f64) -> RunSpec {
    RunSpec::new(scene.clone(), origin, stop, interval).method(method)
}

fn last(out: &Outcome, name: &str) -> f64 {
    out.last(name).unwrap_or(f64::NAN)
}

/// Records the ball's height only; returns the run and the final height \[m\].
fn height_run(spec: &RunSpec) -> Result<(Outcome, f64), String> {
    let out = record(spec, &["ball.r[3]"])?;
    let z = last(&out, "ball.r[3]");
    Ok((out, z))
}

/// Effective restitution of a ball that hit the plane at `v0` without gravity.
fn rebound(out: &Outcome, v0: f64) -> f64 {
    last(out, "ball.v[3]") / v0
}

fn print_row(r: &Row) {
    let status = r.out.failure.as_deref().unwrap_or("ok");
    println!(
        "{:<10} {:<34} {:<6} {:>9.3} {:>9} {:>10} {:>6} {:>10.2e} {:>10.2e} {:>8.2e}  {}={:.4e} (expect {:.4e})  {}",
        r.group,
        r.case,
        r.method.name(),
        r.out.seconds,
        r.out.counters.steps,
        r.out.counters.rhs_evals,
        r.out.counters.events,
        r.out.energy_error,
        r.out.max_penetration,
        r.out.penetration_ratio,
        r.check,
        r.value,
        r.expected,
        if status.len() > 160 { &status[..160] } else { status }
    );
}

/// Runs all cases and writes the CSV.
pub fn run(resting_time: f64, csv_path: &Path) -> Result<(), String> {
    println!(
        "{:<10} {:<34} {:<6} {:>9} {:>9} {:>10} {:>6} {:>10} {:>10} {:>8}  check",
        "group", "case", "method", "seconds", "steps", "rhs_evals", "events", "energy_err", "max_pen", "pen/max"
    );
    let mut rows: Vec<Row> = Vec::new();
    let mut push = |r: Row| {
        print_row(&r);
        rows.push(r);
    };
    let methods = [Method::Dopri5, Method::Sdirk, Method::Rk4];

    // 1. Stiffness 1e4 .. 1e13 N/m^1.5, hertz_ln e = 0.8, 1 m/s, no gravity.
    for k in [1e4, 1e6, 1e8, 1e10, 1e11, 1e12, 1e13] {
        let v0 = 1.0;
        let tc = hertz_duration(BALL_MASS, v0, k);
        let gap = 1e-3;
        let stop = gap / v0 + 2.0 * tc;
        let mut scene = scenes::ball_plane("stiff", Law::HertzLn, 0.8, v0, gap, false, stop, stop / 200.0);
        scene.contact[0].stiffness = Some(k);
        for m in methods {
            // rk4 with a step of t_c/100 (its step is max_step).
            let run = spec(&scene, "stiffness", m, stop, stop / 200.0).with("solver.max_step", (tc / 100.0).min(1e-3));
            let out = record(&run, &[])?;
            let e = rebound(&out, v0);
            push(Row {
                group: "stiffness",
                case: format!("K={k:.0e}"),
                method: m,
                out,
                check: "e_eff",
                value: e,
                expected: f64::NAN,
            });
        }
    }

    // 2. Restitution 0.01 .. 1 for the three dissipative Hertz laws, steel, 1 m/s.
    let ks = steel_ball_plane_stiffness();
    for law in [Law::HertzLn, Law::Flores, Law::HuntCrossley] {
        for e in [0.01, 0.1, 0.3, 0.5, 0.8, 0.95, 1.0] {
            let v0 = 1.0;
            let tc = hertz_duration(BALL_MASS, v0, ks);
            let stop = 1e-3 + 3.0 * tc;
            let scene = scenes::ball_plane("restitution", law, e, v0, 1e-3, false, stop, stop / 100.0);
            let out = record(&spec(&scene, "restitution", Method::Dopri5, stop, stop / 100.0), &[])?;
            let eff = rebound(&out, v0);
            push(Row {
                group: "restitution",
                case: format!("{} e={e}", law.name()),
                method: Method::Dopri5,
                out,
                check: "e_eff",
                value: eff,
                expected: e,
            });
        }
    }

    // 3. Impact speed 1e-4 .. 50 m/s, hertz_ln e = 0.8, steel, no gravity.
    for v0 in [1e-4, 1e-3, 1e-2, 0.1, 1.0, 10.0, 50.0] {
        let tc = hertz_duration(BALL_MASS, v0, ks);
        let gap = v0 * 1e-3;
        let stop = 1e-3 + 3.0 * tc;
        let scene = scenes::ball_plane("speed", Law::HertzLn, 0.8, v0, gap, false, stop, stop / 100.0);
        for m in [Method::Dopri5, Method::Sdirk] {
            let out = record(&spec(&scene, "speed", m, stop, stop / 100.0), &[])?;
            let eff = rebound(&out, v0);
            let dmax = hertz_max_penetration(BALL_MASS, v0, ks);
            push(Row {
                group: "speed",
                case: format!("v0={v0:.0e} (undamped δmax {dmax:.2e})"),
                method: m,
                out,
                check: "e_eff",
                value: eff,
                expected: 0.8,
            });
        }
    }

    // 4. Communication step 1e-6 .. 1 s: the bouncing ball for 1 s (hertz_ln e = 0.8); the
    // final height must not depend on the communication step (events are located inside).
    let bb = scenes::ball_plane("comm", Law::HertzLn, 0.8, 0.0, 0.1, true, 1.0, 1e-3);
    let (_, z_ref) = height_run(&spec(&bb, "comm", Method::Dopri5, 1.0, 1e-3))?;
    for h in [1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0] {
        for m in [Method::Dopri5, Method::Sdirk] {
            let (out, z) = height_run(&spec(&bb, "comm", m, 1.0, h))?;
            push(Row {
                group: "comm_step",
                case: format!("h_comm={h:.0e}"),
                method: m,
                out,
                check: "z(1s)-z_ref",
                value: z - z_ref,
                expected: 0.0,
            });
        }
    }

    // 5. Long resting contact: a ball, and a bar whose loop is closed by a redundant joint.
    let static_delta = (BALL_MASS * 9.81 / ks).powf(2.0 / 3.0);
    let rest_interval = 0.1;
    for m in [Method::Dopri5, Method::Sdirk] {
        let scene = scenes::ball_plane(
            "resting",
            Law::HertzLn,
            0.8,
            0.0,
            1e-4,
            true,
            resting_time,
            rest_interval,
        );
        let out = record(
            &spec(&scene, "resting", m, resting_time, rest_interval),
            &["ball.r[3]", "ball.v[3]", "floor.active"],
        )?;
        let z = last(&out, "ball.r[3]");
        let toggles = chatter(&out, "floor.active");
        let drift = z - (0.01 - static_delta);
        push(Row {
            group: "resting",
            case: format!("ball {resting_time} s: z drift [m]"),
            method: m,
            out: out.clone(),
            check: "z-z_static",
            value: drift,
            expected: 0.0,
        });
        push(Row {
            group: "resting",
            case: format!("ball {resting_time} s: chatter"),
            method: m,
            out,
            check: "toggles_2nd_half",
            value: toggles,
            expected: 0.0,
        });
        let scene = scenes::resting_bar(Law::HertzLn, 0.8, resting_time, rest_interval);
        let out = record(
            &spec(&scene, "resting_bar", m, resting_time, rest_interval),
            &["bar.r[3]", "pivot.q", "tip.active"],
        )?;
        let toggles = chatter(&out, "tip.active");
        let res = out.constraint_residual;
        push(Row {
            group: "resting",
            case: format!("bar+loop {resting_time} s: |Φ|max"),
            method: m,
            out: out.clone(),
            check: "loop_residual",
            value: res,
            expected: 0.0,
        });
        push(Row {
            group: "resting",
            case: format!("bar+loop {resting_time} s: chatter"),
            method: m,
            out,
            check: "toggles_2nd_half",
            value: toggles,
            expected: 0.0,
        });
    }

    // 6. Newton's cradle: 5 balls, pure Hertz, 0.1 m/s; the last ball leaves with nearly v0,
    // momentum and energy are conserved.
    for (law, e) in [(Law::Hertz, 1.0), (Law::HertzLn, 0.9), (Law::Impulse, 1.0)] {
        let n = 5;
        let scene = scenes::newtons_cradle(n, 0.1, 1e-5, law, e, 3e-3);
        for m in [Method::Dopri5, Method::Sdirk] {
            let out = record(&spec(&scene, "cradle", m, 3e-3, 1e-5), &[])?;
            let v_last = last(&out, &format!("b{}.v[1]", n - 1));
            let p: f64 = (0..n).map(|i| BALL_MASS * last(&out, &format!("b{i}.v[1]"))).sum();
            push(Row {
                group: "cradle",
                case: format!(
                    "{} e={e}: v_last/v0 (momentum err {:.1e})",
                    law.name(),
                    (p / (BALL_MASS * 0.1) - 1.0).abs()
                ),
                method: m,
                out,
                check: "v_last/v0",
                value: v_last / 0.1,
                expected: f64::NAN,
            });
        }
    }

    // 7. hertz_ln with δ̇⁻ → 0: a ball touching the floor at ever slower speed, with and
    // without the floor on δ̇⁻ (min_impact_velocity), then resting under gravity.
    for v in [1e-2, 1e-4, 1e-6, 1e-8] {
        for floor in [0.0, 1e-3] {
            let scene = scenes::slow_touch(v, floor);
            for m in [Method::Dopri5, Method::Sdirk] {
                let (out, z) = height_run(&spec(&scene, "slow", m, 0.1, 1e-3))?;
                push(Row {
                    group: "slow_touch",
                    case: format!("v={v:.0e} floor={floor:.0e}"),
                    method: m,
                    out,
                    check: "z-z_static",
                    value: z - (0.01 - static_delta),
                    expected: 0.0,
                });
            }
        }
    }

    // 8. Friction: the ball launched sliding at 1 mm/s … 10 m/s with μ = 0.05 … 1.5 (stiction
    // velocity 1e-4 m/s): sliding, the stick transition (rolling), rolling. Whatever the
    // regularisation does around the transition, the angular momentum about the contact point
    // is kept, so the final speed is 5/7 v0 (to the lever arm R − δ of the contact point).
    for v0 in [1e-3, 1e-2, 1e-1, 1.0, 10.0] {
        for mu in [0.05, 0.3, 1.5] {
            let t_roll = 2.0 * v0 / (7.0 * mu * 9.81);
            let stop = 1.5 * t_roll;
            let scene = scenes::sliding_ball(v0, mu, 1e-4, stop, stop / 100.0);
            for m in [Method::Dopri5, Method::Sdirk] {
                let out = record(&spec(&scene, "friction", m, stop, stop / 100.0), &["ball.v[1]"])?;
                let v = last(&out, "ball.v[1]");
                push(Row {
                    group: "friction",
                    case: format!("v0={v0:.0e} mu={mu}: v/(5/7 v0)"),
                    method: m,
                    out,
                    check: "v_roll/v0",
                    value: v / (5.0 / 7.0 * v0),
                    expected: 1.0,
                });
            }
        }
    }

    let mut csv = Csv::new(&[
        "group",
        "case",
        "method",
        "status",
        "seconds",
        "steps",
        "rhs_evals",
        "events",
        "energy_error",
        "max_penetration",
        "penetration_ratio",
        "constraint_residual",
        "check",
        "value",
        "expected",
    ]);
    for r in &rows {
        csv.push(vec![
            r.group.into(),
            r.case.clone(),
            r.method.name().into(),
            r.out.failure.clone().unwrap_or_else(|| "ok".into()),
            f(r.out.seconds),
            r.out.counters.steps.to_string(),
            r.out.counters.rhs_evals.to_string(),
            r.out.counters.events.to_string(),
            f(r.out.energy_error),
            f(r.out.max_penetration),
            f(r.out.penetration_ratio),
            f(r.out.constraint_residual),
            r.check.into(),
            f(r.value),
            f(r.expected),
        ]);
    }
    csv.write(csv_path)
}

/// Number of changes of a Boolean output in the second half of the run (chatter).
pub fn chatter(out: &Outcome, name: &str) -> f64 {
    let Some(c) = out.traj.column(name) else {
        return f64::NAN;
    };
    let n = out.traj.rows.len();
    let half = &out.traj.rows[n / 2..];
    half.windows(2).filter(|w| w[0][c] != w[1][c]).count() as f64
}

/// Writes the generated stress scenes to `dir` (to reproduce a case with `simulate`).
pub fn write_scenes(dir: &Path, resting_time: f64) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let files = [
        (
            "ball_plane.toml",
            scenes::ball_plane("ball_plane", Law::HertzLn, 0.8, 1.0, 1e-3, false, 0.01, 1e-5),
        ),
        (
            "resting_ball.toml",
            scenes::ball_plane("resting", Law::HertzLn, 0.8, 0.0, 1e-4, true, resting_time, 0.1),
        ),
        (
            "resting_bar.toml",
            scenes::resting_bar(Law::HertzLn, 0.8, resting_time, 0.1),
        ),
        (
            "newtons_cradle.toml",
            scenes::newtons_cradle(5, 0.1, 1e-5, Law::Hertz, 1.0, 3e-3),
        ),
        ("sliding_ball.toml", scenes::sliding_ball(1.0, 0.3, 1e-4, 0.15, 1e-3)),
    ];
    for (name, scene) in files {
        let p = dir.join(name);
        std::fs::write(&p, scene.to_toml()).map_err(|e| format!("{}: {e}", p.display()))?;
        println!("wrote {}", p.display());
    }
    Ok(())
}
