//! Work-precision comparison of the integrators: error at the final time against right-hand-side
//! evaluations and run time (median of several runs), on
//!
//! - `hertz_ode`: a ball dropped on a plane with a Hertz contact (K = 1e9 N/m^1.5, Hunt-Crossley
//!   damping), integrated as a plain ODE straight through the contact switches (no events);
//! - `hertz_engine`: the same drop through the engine (contact events located on the dense
//!   output, Lankarani-Nikravesh damping), advanced in 1 ms communication steps as an FMU is;
//! - `settle_ode`, `settle_engine`: the same ball dropped from 1 mm with e = 0.5, so that it
//!   soon rests on the plane: a stiff resting contact for most of the 0.5 s;
//! - `stiff_spring`: a critically damped spring of ω = 1e4 rad/s on a slowly moving support
//!   (1 s): genuinely stiff, as a strongly damped resting contact is;
//! - `double_pendulum`: a smooth multibody problem (two rods on revolute joints, the project's
//!   joint-space dynamics as right-hand side).
//!
//! Methods: our `dopri5`, `sdirk` (SDIRK4), `radau5` (Radau IIA 5) and `rk4` (fixed steps), and, when built with
//! `--features diffsol`, diffsol's `tsit45`, `esdirk34`, `tr_bdf2` and `bdf` on the ODE problems.
//!
//! ```text
//! cargo run --release --example integrator_compare [--features diffsol] [-- --runs 5]
//! ```
//!
//! Prints a markdown table and writes `docs/integrator_compare.csv`. Heap allocations per step
//! are counted with a counting global allocator.

use contact_fmu::compile::compile;
use contact_fmu::forward::Rhs;
use contact_fmu::integrator::{dopri5::Dopri5, radau::Radau5, rk4::Rk4, sdirk::Sdirk, Integrator, OdeSystem};
use contact_fmu::model::{Data, Model};
use contact_fmu::scene::{BodySpec, JointSpec, Method, Scene, GROUND};
use contact_fmu::scene_builder::SceneBuilder;
use contact_fmu::simulation::Simulation;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// The system allocator, counting allocations.
struct Counting;
static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        System.alloc(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        System.realloc(ptr, layout, new_size)
    }
}
#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations() -> u64 {
    ALLOCATIONS.load(Ordering::Relaxed)
}

// ---------------------------------------------------------------------------------------------
// Problems

/// Ball of mass m on a plane: height `x` of the sphere's lowest point, velocity `v`;
/// Hunt-Crossley force `K δ^1.5 (1 + 3(1−e)/2 · δ̇/v_in)` for penetration `δ = −x > 0`.
struct HertzBall {
    /// Drop height [m] and restitution coefficient.
    drop: f64,
    restitution: f64,
    evals: u64,
}
const BALL_MASS: f64 = 0.0329;
const BALL_K: f64 = 1e9;
/// A few bounces: from 0.1 m, e = 0.8, 0.6 s.
const BOUNCE: (f64, f64, f64) = (0.1, 0.8, 0.6);
/// Settling to rest: from 1 mm, e = 0.5, 0.5 s (mostly resting contact).
const SETTLE: (f64, f64, f64) = (1e-3, 0.5, 0.5);
impl OdeSystem for HertzBall {
    fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        self.evals += 1;
        let (x, v) = (y[0], y[1]);
        let v_in = (2.0 * 9.81 * self.drop).sqrt();
        let delta = -x;
        let force = if delta > 0.0 {
            (BALL_K * delta.powf(1.5) * (1.0 + 1.5 * (1.0 - self.restitution) * (-v) / v_in)).max(0.0)
        } else {
            0.0
        };
        dy[0] = v;
        dy[1] = -9.81 + force / BALL_MASS;
    }
}

/// A unit mass on a stiff, critically damped spring (a resting contact with strong damping)
/// whose support moves slowly, `s(t) = 1 mm · sin(2π·5 Hz·t)`, under gravity:
/// `x'' = −ω²(x − s) − 2ω(x' − s') − g`, ω = 1e4 rad/s, from x = 0, x' = −1 m/s. After a
/// 1 ms transient the mass follows the support: a smooth solution with a stiff mode.
struct StiffSpring {
    evals: u64,
}
const SPRING_OMEGA: f64 = 1e4;
const SPRING_T_END: f64 = 1.0;
impl OdeSystem for StiffSpring {
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        self.evals += 1;
        let w = 2.0 * std::f64::consts::PI * 5.0;
        let (s, sd) = (1e-3 * (w * t).sin(), 1e-3 * w * (w * t).cos());
        dy[0] = y[1];
        dy[1] = -SPRING_OMEGA * SPRING_OMEGA * (y[0] - s) - 2.0 * SPRING_OMEGA * (y[1] - sd) - 9.81;
    }
}

/// A compiled multibody model as an ODE.
struct Multibody {
    model: Model,
    data: Data,
    evals: u64,
}
impl OdeSystem for Multibody {
    fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        self.evals += 1;
        Rhs {
            model: &self.model,
            data: &mut self.data,
        }
        .rhs(0.0, y, dy);
    }
}

/// Two rods (1 kg, 1 m, along x) on revolute joints about y, released horizontally; the
/// scene's default solver and experiment.
fn pendulum_scene() -> Scene {
    let rod = |name: &str, x: f64| BodySpec::new(name, 1.0, [1e-3, 1.0 / 12.0, 1.0 / 12.0], [x, 0.0, 0.0]);
    let y = [0.0, 1.0, 0.0];
    SceneBuilder::new("double_pendulum")
        .gravity([0.0, 0.0, -9.81])
        .body(rod("upper", 0.5))
        .body(rod("lower", 1.5))
        .joint(JointSpec::revolute("shoulder", GROUND, "upper", [0.0; 3], y))
        .joint(JointSpec::revolute("elbow", "upper", "lower", [1.0, 0.0, 0.0], y))
        .build()
}
const PENDULUM_T_END: f64 = 2.0;

fn pendulum() -> (Multibody, Vec<f64>) {
    let scene = pendulum_scene();
    scene.validate("double_pendulum").expect("scene");
    let (model, data) = compile(&scene, "double_pendulum").expect("compile");
    let y0 = data.state.clone();
    (Multibody { model, data, evals: 0 }, y0)
}

fn ball_scene(method: Method, rtol: f64, atol: f64, max_step: f64, drop: f64, restitution: f64) -> Scene {
    let text = std::fs::read_to_string("fmu/bouncing_ball/scene.toml").expect("fmu/bouncing_ball/scene.toml");
    let mut scene = Scene::from_str(&text, "bouncing_ball").expect("scene");
    // E = 13.6 GPa for both: K = 4/3 E* sqrt(R) = 1.0e9 N/m^1.5
    for m in scene.material.iter_mut() {
        m.youngs_modulus = 13.6e9;
    }
    // sphere of R = 10 mm, its lowest point `drop` above the plane
    scene.body[0].position[2] = 0.01 + drop;
    scene.contact[0].center[2] = 0.01 + drop;
    scene.contact[0].restitution = restitution;
    scene.solver.method = method;
    scene.solver.rtol = rtol;
    scene.solver.atol = atol;
    scene.solver.max_step = max_step;
    scene
}

// ---------------------------------------------------------------------------------------------
// Runs

/// One measured run.
#[derive(Clone, Debug)]
struct Outcome {
    y: Vec<f64>,
    rhs_evals: u64,
    steps: u64,
    rejected: u64,
    jac_evals: u64,
    seconds: f64,
    allocs_per_step: f64,
}

fn run_ours(m: &mut dyn Integrator, sys: &mut dyn OdeSystem, y0: &[f64], t_end: f64) -> Result<Outcome, String> {
    let start = Instant::now();
    m.reset(sys, 0.0, y0, 0.0);
    let a0 = allocations();
    while m.t() < t_end {
        m.step(sys, t_end).map_err(|e| e.to_string())?;
    }
    let allocs = allocations() - a0;
    let seconds = start.elapsed().as_secs_f64();
    let s = m.stats();
    Ok(Outcome {
        y: m.y().to_vec(),
        rhs_evals: s.rhs_evals,
        steps: s.steps,
        rejected: s.rejected,
        jac_evals: s.jac_evals,
        seconds,
        allocs_per_step: allocs as f64 / s.steps.max(1) as f64,
    })
}

fn make_ours(method: &str, n: usize, tol: f64) -> Box<dyn Integrator> {
    match method {
        "dopri5" => Box::new(Dopri5::new(n, tol, tol, f64::INFINITY)),
        "sdirk" => Box::new(Sdirk::new(n, tol, tol, f64::INFINITY)),
        "radau5" => Box::new(Radau5::new(n, tol, tol, f64::INFINITY)),
        "rk4" => Box::new(Rk4::new(n, tol)), // `tol` is the step here
        _ => unreachable!(),
    }
}

/// A run on an ODE problem; `evals` counted by the system itself.
fn ode_run(problem: &str, method: &str, tol: f64) -> Result<Outcome, String> {
    if let Some(name) = method.strip_prefix("diffsol_") {
        return diffsol_run::run(problem, name, tol);
    }
    match problem {
        "hertz_ode" | "settle_ode" => {
            let (drop, restitution, t_end) = if problem == "hertz_ode" { BOUNCE } else { SETTLE };
            let mut sys = HertzBall {
                drop,
                restitution,
                evals: 0,
            };
            let mut m = make_ours(method, 2, tol);
            let mut o = run_ours(m.as_mut(), &mut sys, &[drop, 0.0], t_end)?;
            o.rhs_evals = sys.evals;
            Ok(o)
        }
        "stiff_spring" => {
            let mut sys = StiffSpring { evals: 0 };
            let mut m = make_ours(method, 2, tol);
            let mut o = run_ours(m.as_mut(), &mut sys, &[0.0, -1.0], SPRING_T_END)?;
            o.rhs_evals = sys.evals;
            Ok(o)
        }
        "double_pendulum" => {
            let (mut sys, y0) = pendulum();
            let mut m = make_ours(method, y0.len(), tol);
            let mut o = run_ours(m.as_mut(), &mut sys, &y0, PENDULUM_T_END)?;
            o.rhs_evals = sys.evals;
            Ok(o)
        }
        _ => unreachable!(),
    }
}

/// The bouncing ball through the engine, advanced in 1 ms communication steps.
fn engine_run(problem: &str, method: &str, tol: f64) -> Result<Outcome, String> {
    let (drop, restitution, t_end) = if problem == "hertz_engine" { BOUNCE } else { SETTLE };
    let (m, rtol, atol, max_step) = match method {
        "dopri5" => (Method::Dopri5, tol, tol, 1.0),
        "sdirk" => (Method::Sdirk, tol, tol, 1.0),
        "radau5" => (Method::Radau5, tol, tol, 1.0),
        "rk4" => (Method::Rk4, 1e-8, 1e-10, tol),
        _ => return Err("not available through the engine".into()),
    };
    let scene = ball_scene(m, rtol, atol, max_step, drop, restitution);
    let start = Instant::now();
    let mut e = Simulation::new(scene, "bouncing_ball");
    e.initialize(0.0).map_err(|e| e.to_string())?;
    let a0 = allocations();
    let interval = 1e-3;
    let n = (t_end / interval).round() as usize;
    for k in 1..=n {
        e.step_to(k as f64 * interval).map_err(|e| e.to_string())?;
    }
    let allocs = allocations() - a0;
    let seconds = start.elapsed().as_secs_f64();
    let c = e.counters();
    let d = e.data().ok_or("no data")?;
    let y = d.state[..d.state.len() - 1].to_vec();
    Ok(Outcome {
        y,
        rhs_evals: c.rhs_evals,
        steps: c.steps,
        rejected: c.rejected,
        jac_evals: c.jac_evals,
        seconds,
        allocs_per_step: allocs as f64 / c.steps.max(1) as f64,
    })
}

fn one(problem: &str, method: &str, tol: f64) -> Result<Outcome, String> {
    if problem.ends_with("_engine") {
        engine_run(problem, method, tol)
    } else {
        ode_run(problem, method, tol)
    }
}

#[cfg(feature = "diffsol")]
mod diffsol_run {
    //! diffsol behind closures over our `OdeSystem`; the Jacobian-vector product is a forward
    //! difference (diffsol assembles the dense Jacobian from it column by column).
    use super::*;
    use diffsol::{NalgebraLU, NalgebraMat, OdeBuilder, OdeSolverMethod, OdeSolverStopReason, Vector};
    use std::cell::RefCell;

    type M = NalgebraMat<f64>;
    type LS = NalgebraLU<f64>;

    pub fn run(problem: &str, method: &str, tol: f64) -> Result<Outcome, String> {
        match problem {
            "hertz_ode" | "settle_ode" => {
                let (drop, restitution, t_end) = if problem == "hertz_ode" { BOUNCE } else { SETTLE };
                let sys = HertzBall {
                    drop,
                    restitution,
                    evals: 0,
                };
                solve(sys, vec![drop, 0.0], t_end, method, tol, |s| s.evals)
            }
            "stiff_spring" => solve(
                StiffSpring { evals: 0 },
                vec![0.0, -1.0],
                SPRING_T_END,
                method,
                tol,
                |s| s.evals,
            ),
            "double_pendulum" => {
                let (sys, y0) = pendulum();
                solve(sys, y0, PENDULUM_T_END, method, tol, |s| s.evals)
            }
            _ => unreachable!(),
        }
    }

    fn solve<S: OdeSystem>(
        sys: S,
        y0: Vec<f64>,
        t_end: f64,
        method: &str,
        tol: f64,
        evals: impl Fn(&S) -> u64,
    ) -> Result<Outcome, String> {
        let n = y0.len();
        let start = Instant::now();
        let sys = RefCell::new(sys);
        let work = RefCell::new((vec![0.0; n], vec![0.0; n], vec![0.0; n]));
        let problem = OdeBuilder::<M>::new()
            .rtol(tol)
            .atol(vec![tol; n])
            .rhs_implicit(
                |x: &[f64], _p: &[f64], t: f64, y: &mut [f64]| sys.borrow_mut().rhs(t, x, y),
                |x: &[f64], _p: &[f64], t: f64, v: &[f64], y: &mut [f64]| {
                    let vmax = v.iter().fold(0.0_f64, |a, b| a.max(b.abs()));
                    if vmax == 0.0 {
                        y.iter_mut().for_each(|e| *e = 0.0);
                        return;
                    }
                    let xmax = x.iter().fold(0.0_f64, |a, b| a.max(b.abs()));
                    let eps = f64::EPSILON.sqrt() * xmax.max(1e-5) / vmax;
                    let mut w = work.borrow_mut();
                    let (xp, f0, f1) = &mut *w;
                    for i in 0..n {
                        xp[i] = x[i] + eps * v[i];
                    }
                    let mut s = sys.borrow_mut();
                    s.rhs(t, x, f0);
                    s.rhs(t, xp, f1);
                    for i in 0..n {
                        y[i] = (f1[i] - f0[i]) / eps;
                    }
                },
            )
            .init(|_p: &[f64], _t: f64, y: &mut [f64]| y.copy_from_slice(&y0), n)
            .build()
            .map_err(|e| e.to_string())?;
        let (y, stats, allocs) = match method {
            "tsit45" => drive(problem.tsit45().map_err(|e| e.to_string())?, t_end)?,
            "esdirk34" => drive(problem.esdirk34::<LS>().map_err(|e| e.to_string())?, t_end)?,
            "tr_bdf2" => drive(problem.tr_bdf2::<LS>().map_err(|e| e.to_string())?, t_end)?,
            "bdf" => drive(problem.bdf::<LS>().map_err(|e| e.to_string())?, t_end)?,
            _ => unreachable!(),
        };
        let seconds = start.elapsed().as_secs_f64();
        drop(problem);
        let rhs_evals = evals(&sys.borrow());
        Ok(Outcome {
            y,
            rhs_evals,
            steps: stats.0,
            rejected: stats.1,
            jac_evals: stats.2,
            seconds,
            allocs_per_step: allocs as f64 / stats.0.max(1) as f64,
        })
    }

    type Driven = (Vec<f64>, (u64, u64, u64), u64);

    fn drive<'a, Eqn, S>(mut solver: S, t_end: f64) -> Result<Driven, String>
    where
        Eqn: diffsol::OdeEquations<T = f64> + 'a,
        S: OdeSolverMethod<'a, Eqn>,
    {
        solver.set_stop_time(t_end).map_err(|e| e.to_string())?;
        let a0 = allocations();
        loop {
            match solver.step().map_err(|e| e.to_string())? {
                OdeSolverStopReason::TstopReached => break,
                _ => continue,
            }
        }
        let allocs = allocations() - a0;
        let st = solver.state();
        let y: Vec<f64> = (0..st.y.len()).map(|i| st.y.get_index(i)).collect();
        let s = solver.get_statistics();
        Ok((
            y,
            (
                s.number_of_steps as u64,
                s.number_of_error_test_failures as u64,
                s.number_of_linear_solver_setups as u64,
            ),
            allocs,
        ))
    }
}

#[cfg(not(feature = "diffsol"))]
mod diffsol_run {
    use super::Outcome;
    pub fn run(_: &str, _: &str, _: f64) -> Result<Outcome, String> {
        Err("built without --features diffsol".into())
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let runs: usize = args
        .iter()
        .position(|a| a == "--runs")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let only: Option<Vec<String>> = args
        .iter()
        .position(|a| a == "--methods")
        .and_then(|i| args.get(i + 1))
        .map(|s| s.split(',').map(String::from).collect());
    let tols = [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10];
    let diffsol_methods = ["diffsol_tsit45", "diffsol_esdirk34", "diffsol_tr_bdf2", "diffsol_bdf"];
    let mut csv = String::from(
        "problem,method,tol_or_step,error,rhs_evals,steps,rejected,jac_evals,seconds_median,allocs_per_step\n",
    );
    println!("| problem | method | tol / step | error | RHS evals | steps | rejected | Jacobians | time [ms] | allocs/step |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let problems: Vec<String> = args
        .iter()
        .position(|a| a == "--problems")
        .and_then(|i| args.get(i + 1))
        .map(|s| s.split(',').map(String::from).collect())
        .unwrap_or_else(|| {
            [
                "hertz_ode",
                "hertz_engine",
                "settle_ode",
                "settle_engine",
                "stiff_spring",
                "double_pendulum",
            ]
            .map(String::from)
            .to_vec()
        });
    for problem in problems.iter().map(String::as_str) {
        // reference: dopri5 at a tight tolerance, checked against SDIRK4 at a tight tolerance
        let reference = one(problem, "dopri5", 1e-13).expect("reference run");
        let check = one(problem, "sdirk", 1e-12).expect("reference check");
        let floor = max_abs_diff(&reference.y, &check.y);
        eprintln!("{problem}: reference dopri5(1e-13) vs sdirk(1e-12) differ by {floor:.2e}");
        let rk4_steps: &[f64] = match problem {
            "double_pendulum" => &[2e-2, 1e-2, 5e-3, 2.5e-3, 1.25e-3],
            // stable only below h = 2.785/ω·(…) ≈ 1.4e-4
            "stiff_spring" => &[1e-4, 5e-5, 2.5e-5],
            _ => &[1e-4, 5e-5, 2.5e-5, 1.25e-5, 6.25e-6],
        };
        let mut methods: Vec<(&str, Vec<f64>)> = vec![
            ("dopri5", tols.to_vec()),
            ("sdirk", tols.to_vec()),
            ("radau5", tols.to_vec()),
            ("rk4", rk4_steps.to_vec()),
        ];
        if !problem.ends_with("_engine") && cfg!(feature = "diffsol") {
            for m in diffsol_methods {
                methods.push((m, tols.to_vec()));
            }
        }
        for (method, params) in methods {
            if only.as_ref().is_some_and(|o| !o.iter().any(|m| m == method)) {
                continue;
            }
            for &p in &params {
                let mut times = Vec::new();
                let mut last = None;
                for _ in 0..runs {
                    match one(problem, method, p) {
                        Ok(o) => {
                            times.push(o.seconds);
                            last = Some(o);
                        }
                        Err(e) => {
                            eprintln!("{problem} {method} {p:e}: {e}");
                            break;
                        }
                    }
                }
                let Some(o) = last else { continue };
                let err = max_abs_diff(&o.y, &reference.y);
                let t = median(&mut times);
                println!(
                    "| {problem} | {method} | {p:.0e} | {err:.2e} | {} | {} | {} | {} | {:.3} | {:.1} |",
                    o.rhs_evals,
                    o.steps,
                    o.rejected,
                    o.jac_evals,
                    t * 1e3,
                    o.allocs_per_step
                );
                csv.push_str(&format!(
                    "{problem},{method},{p:e},{err:e},{},{},{},{},{t:e},{}\n",
                    o.rhs_evals, o.steps, o.rejected, o.jac_evals, o.allocs_per_step
                ));
            }
        }
        csv.push_str(&format!("{problem},reference_floor,,{floor:e},,,,,,\n"));
    }
    std::fs::create_dir_all("docs").ok();
    std::fs::write("docs/integrator_compare.csv", csv).expect("write docs/integrator_compare.csv");
    eprintln!("wrote docs/integrator_compare.csv");
}
