//! Benchmarks: programs that print tables and write CSV (never timed tests).
//!
//! `contact-fmu bench <what>`:
//! - `work-precision`: every bundled scene × every integrator × a sweep of tolerances (step
//!   sizes for rk4); error against a closed form or a tight reference; median run time of
//!   several runs and the deterministic work counters ([`work_precision`]).
//! - `defaults`: `auto` against the best fixed method at error 1e-6 on every bundled scene,
//!   the rail vehicle with no `[solver]` against the former defaults, its 5 ms goal
//!   ([`defaults`]).
//! - `stress`: stiffness, restitution, impact speed, communication step, long resting
//!   contact, Newton's cradle, slow touches of `hertz_ln` ([`stress`]).
//! - `scaling`: N free spheres in a box, time per simulated second against N ([`scaling`]).
//! - `targets`: the rail vehicle's speed and accuracy targets, RHS cost, allocations
//!   ([`targets`]).
//! - `lu`: dense and sparse LU of the implicit methods' iteration matrices ([`lu`]); with
//!   `--scenes`, N spheres in a box with sdirk and radau5 on the dense and the sparse path.
//! - `rhs`: the cost of one right-hand-side evaluation of each bundled scene ([`rhs`]).
//! - `pile`: the pile's phase by windows, with the touching spheres and islands ([`pile`]).
//! - `run`: one scene, repeated, with its median time, counters and a trajectory CSV (used by
//!   the Python peer comparison in `scripts/`).
//!
//! Machines are noisy: times are medians of `--repeats` runs (default 5), both wall clock
//! and the thread's CPU time; the counters (steps, RHS and Jacobian evaluations, events)
//! are exact and repeat bit for bit.

pub mod defaults;
pub mod groups;
pub mod islands;
pub mod lu;
pub mod pile;
pub mod rhs;
pub mod scaling;
pub mod scenes;
pub mod stress;
pub mod targets;
pub mod work_precision;

use crate::model::Counters;
use crate::outputs::Energies;
use crate::scene::{Method, Scene};
use crate::simulation::{RunError, SimError, Simulation};
use crate::variables::VarRef;
use clap::Subcommand;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What a tolerance sweep over the bundled scenes takes (`work-precision`, `defaults`).
#[derive(Debug, clap::Args)]
pub struct SweepArgs {
    /// Folder of bundled scenes (`<dir>/<name>/scene.toml`).
    #[arg(long, default_value = "fmu")]
    pub scenes: PathBuf,
    /// Only the scene of this name, or (when none has it) the scenes whose name contains it.
    #[arg(long)]
    pub only: Option<String>,
    /// Timed runs per point (the median is reported).
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
    /// Stop refining a method once one run takes longer than this (s).
    #[arg(long, default_value_t = 4.0)]
    pub budget: f64,
}

impl SweepArgs {
    /// The bundled scenes to sweep (`--only` applied): name and scene file.
    pub fn selected_scenes(&self) -> Result<Vec<(String, PathBuf)>, String> {
        Ok(select_scenes(bundled_scenes(&self.scenes)?, self.only.as_deref()))
    }
}

/// The scenes `--only` selects: the one named exactly so when there is one (`rail_vehicle`
/// is not also `rail_vehicle_track`), else every scene whose name contains it; all without it.
pub fn select_scenes(scenes: Vec<(String, PathBuf)>, only: Option<&str>) -> Vec<(String, PathBuf)> {
    let Some(o) = only else { return scenes };
    if scenes.iter().any(|(name, _)| name == o) {
        return scenes.into_iter().filter(|(name, _)| name == o).collect();
    }
    scenes.into_iter().filter(|(name, _)| name.contains(o)).collect()
}

/// The run of `method` at tolerance `tol` (rk4: step `tol`) of a sweep from `base`, with
/// `atol = tol · atol_ratio`.
pub fn sweep_point(base: &RunSpec, method: Method, tol: f64, atol_ratio: f64) -> RunSpec {
    let s = base.clone().method(method);
    match method {
        Method::Rk4 => s.with("solver.max_step", tol),
        _ => s.with("solver.rtol", tol).with("solver.atol", tol * atol_ratio),
    }
}

/// The `bench` subcommands.
#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Work-precision diagrams: error vs run time for every bundled scene and integrator.
    WorkPrecision {
        #[command(flatten)]
        sweep: SweepArgs,
        /// Tolerances (rk4: step sizes) run per point, spread evenly on a log scale over
        /// ±25 % around it, four times as many where their evaluations spread by more than
        /// 2×; the point reports their medians (1: its own tolerance alone).
        #[arg(long, default_value_t = work_precision::SAMPLES)]
        samples: usize,
        /// Output CSV.
        #[arg(long, default_value = "docs/work_precision.csv")]
        csv: PathBuf,
    },
    /// The defaults: `auto` against the best fixed method at error 1e-6 on every bundled
    /// scene; the rail vehicle with no `[solver]` against the former defaults; its 5 ms goal.
    Defaults {
        #[command(flatten)]
        sweep: SweepArgs,
        /// Output CSV.
        #[arg(long, default_value = "docs/defaults.csv")]
        csv: PathBuf,
    },
    /// Stability stress cases: each finishes or fails with a clear error.
    Stress {
        /// Simulated duration of the long resting-contact cases (s).
        #[arg(long, default_value_t = 1000.0)]
        resting_time: f64,
        /// Output CSV.
        #[arg(long, default_value = "docs/stress.csv")]
        csv: PathBuf,
        /// Write the generated scenes (ball, bar with loop, cradle) to this folder and exit.
        #[arg(long)]
        write_scenes: Option<PathBuf>,
    },
    /// N free spheres in a box: time per simulated second vs N.
    Scaling {
        /// Sphere counts.
        #[arg(long, value_delimiter = ',', default_value = "10,30,100,300,1000,3000,10000")]
        n: Vec<usize>,
        /// Simulated time per run (s).
        #[arg(long, default_value_t = 0.05)]
        time: f64,
        /// Timed runs per point.
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// Output CSV.
        #[arg(long, default_value = "docs/scaling.csv")]
        csv: PathBuf,
        /// Write the generated scene for this N to a file and exit (for profiling).
        #[arg(long)]
        write_scene: Option<PathBuf>,
    },
    /// Independent islands at scale (spheres in a box with contact groups, the default
    /// method) against the former pair list with one integrator: run time per simulated
    /// second, counters, islands, fitted exponent.
    Islands {
        /// Sphere counts.
        #[arg(long, value_delimiter = ',', default_value = "100,300,1000,3000")]
        n: Vec<usize>,
        #[command(flatten)]
        settings: islands::Settings,
        /// Output CSV.
        #[arg(long, default_value = "docs/islands.csv")]
        csv: PathBuf,
        /// Write the groups scene for the first N (the default method, as islands) to this file
        /// and exit (for `scripts/bench_mujoco.py` and profiling).
        #[arg(long)]
        write_scene: Option<PathBuf>,
    },
    /// The pile's phase by windows (by default `pile_of_balls`, 0.5-1.5 s): CPU time against
    /// real time, steps, events, and the touching spheres and islands that set them.
    Pile(pile::Settings),
    /// Contact groups against the explicit pair list (spheres in a box): compile time, one
    /// RHS, broad phase by sweep and prune and by grid.
    Groups {
        /// Sphere counts.
        #[arg(long, value_delimiter = ',', default_value = "100,1000,3000")]
        n: Vec<usize>,
        /// Timed batches per point.
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// Also run each scene for this simulated time (s; N ≤ 1,000; 0: no run).
        #[arg(long, default_value_t = 0.0)]
        run_time: f64,
        /// Output CSV.
        #[arg(long, default_value = "docs/groups.csv")]
        csv: PathBuf,
    },
    /// Speed and accuracy targets (rail vehicle), RHS cost per scene, allocations per step.
    Targets {
        /// Folder of bundled scenes.
        #[arg(long, default_value = "fmu")]
        scenes: PathBuf,
        /// Timed runs per point.
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// Output CSV.
        #[arg(long, default_value = "docs/targets.csv")]
        csv: PathBuf,
    },
    /// The cost of one RHS evaluation of each bundled scene (free flight, every contact
    /// active).
    Rhs {
        /// Folder of bundled scenes.
        #[arg(long, default_value = "fmu")]
        scenes: PathBuf,
        /// Only the scene of this name, or (when none has it) the scenes whose name contains it.
        #[arg(long)]
        only: Option<String>,
        /// Timed batches (the median is reported).
        #[arg(long, default_value_t = 9)]
        repeats: usize,
        /// Calls per batch (default: about 50 ms worth); fixed for instruction counts.
        #[arg(long)]
        calls: Option<usize>,
        /// Only one contact mode: `free` (as the scene starts) or `contact` (every contact
        /// active).
        #[arg(long)]
        mode: Option<String>,
        /// Output CSV.
        #[arg(long, default_value = "docs/rhs.csv")]
        csv: PathBuf,
    },
    /// Dense (own, faer) and sparse (faer) LU of iteration matrices shaped like a multibody
    /// Jacobian: factorisation and solve times.
    Lu {
        /// System sizes n.
        #[arg(long, value_delimiter = ',', default_value = "18,100,1000,5000,20000")]
        n: Vec<usize>,
        /// Largest matrix factored densely.
        #[arg(long, default_value_t = 1500)]
        dense_max: usize,
        /// Timed batches per point.
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// Output CSV.
        #[arg(long, default_value = "docs/lu_compare.csv")]
        csv: PathBuf,
        /// Instead: N spheres in a box (these N) with sdirk and radau5, dense against sparse.
        #[arg(long, value_delimiter = ',')]
        scenes: Vec<usize>,
        /// Simulated time of the scene runs (s).
        #[arg(long, default_value_t = 0.01)]
        time: f64,
        /// Skip a dense scene run whose estimated factorisation time exceeds this (s).
        #[arg(long, default_value_t = 30.0)]
        dense_budget: f64,
    },
    /// One scene, repeated: median time, counters, and the outputs at every communication
    /// point written to a CSV.
    Run {
        /// Scene file (TOML).
        scene: PathBuf,
        #[command(flatten)]
        experiment: crate::run::Experiment,
        /// Timed runs.
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// Trajectory CSV (time and every output).
        #[arg(long)]
        csv: Option<PathBuf>,
        /// Outputs to read at every communication point in the timed runs (as a host that
        /// records the trajectory does): comma-separated names, or `all`.
        #[arg(long, value_delimiter = ',')]
        read: Vec<String>,
        /// Also print the error as the work-precision benchmark measures it (closed form, or
        /// a dopri5 reference at rtol 1e-13 with the same settings otherwise).
        #[arg(long)]
        error: bool,
    },
}

/// Writes a benchmark's scene to `path` as TOML (`--write-scene`).
fn save_scene(path: &std::path::Path, scene: &crate::scene::Scene) -> Result<(), String> {
    std::fs::write(path, scene.to_toml()).map_err(|e| format!("{}: {e}", path.display()))
}

/// Runs a `bench` subcommand.
pub fn bench_command(cmd: BenchCommand) -> Result<(), String> {
    match cmd {
        BenchCommand::WorkPrecision { sweep, samples, csv } => work_precision::run(&sweep, samples, &csv),
        BenchCommand::Defaults { sweep, csv } => defaults::run(&sweep, &csv),
        BenchCommand::Stress {
            resting_time,
            csv,
            write_scenes,
        } => match write_scenes {
            Some(dir) => stress::write_scenes(&dir, resting_time),
            None => stress::run(resting_time, &csv),
        },
        BenchCommand::Scaling {
            n,
            time,
            repeats,
            csv,
            write_scene,
        } => match write_scene {
            Some(p) => save_scene(&p, &scenes::sphere_box(n.first().copied().unwrap_or(100), time)),
            None => scaling::run(&n, time, repeats, &csv),
        },
        BenchCommand::Islands {
            write_scene: Some(p),
            n,
            settings: s,
            ..
        } => save_scene(
            &p,
            &islands::grouped(n.first().copied().unwrap_or(100), s.time, s.margin, true),
        ),
        BenchCommand::Islands {
            n,
            settings,
            csv,
            write_scene: None,
        } => islands::run(&n, &settings, &csv),
        BenchCommand::Pile(settings) => pile::run(&settings),
        BenchCommand::Groups {
            n,
            repeats,
            run_time,
            csv,
        } => groups::run(&n, repeats, run_time, &csv),
        BenchCommand::Lu {
            n,
            dense_max,
            repeats,
            csv,
            scenes,
            time,
            dense_budget,
        } => {
            if scenes.is_empty() {
                lu::run(&n, dense_max, repeats, &csv)
            } else {
                lu::run_scenes(&scenes, time, repeats, dense_budget, &csv)
            }
        }
        BenchCommand::Targets { scenes, repeats, csv } => targets::run(&scenes, repeats, &csv),
        BenchCommand::Rhs {
            scenes,
            only,
            repeats,
            calls,
            mode,
            csv,
        } => rhs::run(&scenes, only.as_deref(), repeats, calls, mode.as_deref(), &csv),
        BenchCommand::Run {
            scene,
            experiment,
            repeats,
            csv,
            read,
            error,
        } => run_command(&scene, &experiment, repeats, csv.as_deref(), read, error),
    }
}

/// Median of a list (NaN for an empty one).
pub fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

pub use crate::run::thread_cpu_seconds;

/// What one scene is run with.
#[derive(Debug, Clone)]
pub struct RunSpec {
    /// The scene (validated by [`setup`]).
    pub scene: Scene,
    /// Name for messages.
    pub origin: String,
    /// `NAME=VALUE` parameter settings.
    pub set: Vec<(String, f64)>,
    /// Stop time \[s\].
    pub stop_time: f64,
    /// Communication interval \[s\].
    pub interval: f64,
    /// Outputs read at every communication point in the timed runs too (as a host that
    /// records the trajectory does): their names, or `all`; none when empty.
    pub read_outputs: Vec<String>,
}

impl RunSpec {
    /// A run of `scene` with its own parameters to `stop_time`, `interval` apart.
    pub fn new(scene: Scene, origin: &str, stop_time: f64, interval: f64) -> RunSpec {
        RunSpec {
            scene,
            origin: origin.to_string(),
            set: Vec::new(),
            stop_time,
            interval,
            read_outputs: Vec::new(),
        }
    }

    /// Adds the parameter setting `name = value`.
    pub fn with(mut self, name: &str, value: f64) -> RunSpec {
        self.set.push((name.to_string(), value));
        self
    }

    /// Sets `solver.method`.
    pub fn method(self, method: Method) -> RunSpec {
        self.with("solver.method", method as i64 as f64)
    }
}

/// Outputs recorded at every communication point.
#[derive(Debug, Clone, Default)]
pub struct Trajectory {
    /// Output names (the first is `time`).
    pub names: Vec<String>,
    /// One row per communication point.
    pub rows: Vec<Vec<f64>>,
}

impl Trajectory {
    /// Column index of an output.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }
    /// Writes the trajectory as CSV.
    pub fn write_csv(&self, path: &Path) -> Result<(), String> {
        let mut w = create_csv(path)?;
        writeln!(w, "{}", self.names.join(",")).map_err(|e| e.to_string())?;
        for r in &self.rows {
            let line: Vec<String> = r.iter().map(|x| format!("{x:?}")).collect();
            writeln!(w, "{}", line.join(",")).map_err(|e| e.to_string())?;
        }
        w.flush().map_err(|e| e.to_string())
    }
}

/// Result of one (untimed, recorded) run.
#[derive(Debug, Clone, Default)]
pub struct Outcome {
    /// Trajectory at the communication points reached.
    pub traj: Trajectory,
    /// Counters at the end (or at the failure).
    pub counters: Counters,
    /// The error message when the run failed.
    pub failure: Option<String>,
    /// Largest |E_total + E_dissipated − E_0| seen, relative to max(|E_0|, max kinetic).
    pub energy_error: f64,
    /// Largest ratio penetration / max_penetration over all contacts and points.
    pub penetration_ratio: f64,
    /// Largest penetration seen \[m\].
    pub max_penetration: f64,
    /// Largest loop-constraint residual |Φ| seen.
    pub constraint_residual: f64,
    /// Wall time of the run \[s\].
    pub seconds: f64,
}

impl Outcome {
    /// The value of output `name` at the last communication point recorded.
    pub fn last(&self, name: &str) -> Option<f64> {
        Some(self.traj.rows.last()?[self.traj.column(name)?])
    }
}

/// Validates the scene, builds and initialises a simulation.
pub fn setup(spec: &RunSpec) -> Result<Simulation, String> {
    spec.scene.validate(&spec.origin).map_err(|e| e.to_string())?;
    let mut sim = Simulation::new(spec.scene.clone(), &spec.origin);
    for (name, value) in &spec.set {
        sim.set_by_name(name, *value).map_err(|e| e.to_string())?;
    }
    sim.initialize(0.0).map_err(|e| e.to_string())?;
    Ok(sim)
}

fn step_error(e: SimError) -> String {
    match e {
        SimError::Step { time, message } => format!("failed at t = {time}: {message}"),
        other => other.to_string(),
    }
}

/// Steps `sim` through the communication points of `spec` (the last one at its stop time),
/// calling `each` after every point reached. Returns the failure, if a step failed.
pub fn step_through(sim: &mut Simulation, spec: &RunSpec, mut each: impl FnMut(&mut Simulation)) -> Option<String> {
    let result = sim.run(spec.stop_time, spec.interval, |s| {
        each(s);
        Ok(())
    });
    match result {
        Ok(()) => None,
        Err(RunError::Step(e)) => Some(step_error(e)),
        Err(RunError::Setup(e)) => Some(e),
    }
}

/// Times `repeats` runs (setup excluded). Returns (median wall \[s\], median thread CPU \[s\],
/// counters of the last run, failure of the last run).
pub fn time_runs(spec: &RunSpec, repeats: usize) -> Result<(f64, f64, Counters, Option<String>), String> {
    let mut wall = Vec::new();
    let mut cpu = Vec::new();
    let mut counters = Counters::default();
    let mut failure = None;
    for _ in 0..repeats.max(1) {
        let mut sim = setup(spec)?;
        let c0 = thread_cpu_seconds();
        let t0 = Instant::now();
        let outputs = read_indices(&sim, &spec.read_outputs)?;
        let mut values = vec![0.0; outputs.len()];
        let mut sink = 0.0;
        failure = step_through(&mut sim, spec, |s| {
            // one call for the list, as a host's fmi2GetReal
            if s.get_many(&outputs, &mut values).is_ok() {
                sink += values.iter().sum::<f64>();
            }
        });
        std::hint::black_box(sink);
        wall.push(t0.elapsed().as_secs_f64());
        cpu.push(thread_cpu_seconds() - c0);
        counters = sim.counters();
    }
    Ok((median(&wall), median(&cpu), counters, failure))
}

/// The variable indices of `names` (`all`: every output).
fn read_indices(sim: &Simulation, names: &[String]) -> Result<Vec<usize>, String> {
    if names.iter().any(|n| n == "all") {
        return Ok(sim.output_indices());
    }
    names
        .iter()
        .map(|n| {
            sim.table()
                .index_of(n)
                .ok_or_else(|| format!("--read: no variable {n:?}"))
        })
        .collect()
}

/// Runs once, recording the named outputs (all outputs when `outputs` is empty) at every
/// communication point, with the energy balance, penetrations and loop residuals.
pub fn record(spec: &RunSpec, outputs: &[&str]) -> Result<Outcome, String> {
    let mut sim = setup(spec)?;
    let vars: Vec<(usize, String)> = sim
        .output_indices()
        .into_iter()
        .map(|i| (i, sim.variables()[i].name.clone()))
        .filter(|(_, name)| outputs.is_empty() || outputs.contains(&name.as_str()))
        .collect();
    let mut traj = Trajectory {
        names: std::iter::once("time".to_string())
            .chain(vars.iter().map(|(_, n)| n.clone()))
            .collect(),
        rows: Vec::new(),
    };
    let mut out = Outcome::default();
    let e0 = energies(&mut sim);
    let mut scale = e0.total().abs().max(e0.kinetic);
    let mut sample = |sim: &mut Simulation, out: &mut Outcome, traj: &mut Trajectory| {
        let mut row = vec![sim.time()];
        for (i, _) in &vars {
            row.push(sim.get(*i).unwrap_or(f64::NAN));
        }
        traj.rows.push(row);
        let e = energies(sim);
        scale = scale.max(e.kinetic);
        let balance = e.balance() - e0.balance();
        out.energy_error = out.energy_error.max(balance.abs() / scale.max(f64::MIN_POSITIVE));
        if let Ok(r) = sim.constraint_residual() {
            out.constraint_residual = out.constraint_residual.max(r);
        }
        let max_penetration: Vec<f64> = sim
            .model()
            .map(|m| {
                m.initial_contacts[..m.groups.n_explicit]
                    .iter()
                    .map(|c| c.max_penetration)
                    .collect()
            })
            .unwrap_or_default();
        for (i, dm) in max_penetration.into_iter().enumerate() {
            let d = sim.output(VarRef::ContactDelta(i)).ok().flatten().unwrap_or(f64::NAN);
            out.max_penetration = out.max_penetration.max(d);
            out.penetration_ratio = out.penetration_ratio.max(d / dm);
        }
    };
    sample(&mut sim, &mut out, &mut traj);
    let t0 = Instant::now();
    out.failure = step_through(&mut sim, spec, |sim| sample(sim, &mut out, &mut traj));
    out.seconds = t0.elapsed().as_secs_f64();
    out.counters = sim.counters();
    out.traj = traj;
    Ok(out)
}

/// The energies at the current state (NaN when the model does not compile).
pub fn energies(sim: &mut Simulation) -> Energies {
    sim.energies().unwrap_or(Energies {
        kinetic: f64::NAN,
        potential: f64::NAN,
        contact: f64::NAN,
        dissipated: f64::NAN,
        input_work: f64::NAN,
    })
}

/// Creates a CSV file (and its folder).
pub fn create_csv(path: &Path) -> Result<std::io::BufWriter<std::fs::File>, String> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let f = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(std::io::BufWriter::new(f))
}

/// A CSV table built row by row and written at the end.
pub struct Csv {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Csv {
    /// A table with these columns.
    pub fn new(header: &[&str]) -> Csv {
        Csv {
            header: header.iter().map(|s| s.to_string()).collect(),
            rows: Vec::new(),
        }
    }
    /// Appends a row.
    pub fn push(&mut self, row: Vec<String>) {
        self.rows.push(row);
    }
    /// Writes the table.
    pub fn write(&self, path: &Path) -> Result<(), String> {
        let mut w = create_csv(path)?;
        writeln!(w, "{}", self.header.join(",")).map_err(|e| e.to_string())?;
        for r in &self.rows {
            let cells: Vec<String> = r
                .iter()
                .map(|c| {
                    if c.contains(',') {
                        format!("\"{}\"", c.replace('"', "'"))
                    } else {
                        c.clone()
                    }
                })
                .collect();
            writeln!(w, "{}", cells.join(",")).map_err(|e| e.to_string())?;
        }
        w.flush().map_err(|e| e.to_string())?;
        println!("wrote {}", path.display());
        Ok(())
    }
}

/// Bundled scenes: `(name, path)` for every `<dir>/<name>/scene.toml`, sorted.
pub fn bundled_scenes(dir: &Path) -> Result<Vec<(String, PathBuf)>, String> {
    let mut v: Vec<(String, PathBuf)> = std::fs::read_dir(dir)
        .map_err(|e| format!("{}: {e} (run from the repository root)", dir.display()))?
        .filter_map(|e| e.ok())
        .map(|e| (e.file_name().to_string_lossy().to_string(), e.path().join("scene.toml")))
        .filter(|(_, p)| p.is_file())
        .collect();
    v.sort();
    Ok(v)
}

/// Parses `NAME=VALUE` settings (enumerations by number or name are handled by
/// [`crate::run::apply_settings`]; here values must be numbers).
pub fn parse_settings(set: &[String]) -> Result<Vec<(String, f64)>, String> {
    set.iter()
        .map(|s| {
            let (n, v) = s
                .split_once('=')
                .ok_or_else(|| format!("--set {s:?}: expected NAME=VALUE"))?;
            let t = v.trim();
            let by_name = Method::ALL
                .iter()
                .find(|m| m.name() == t)
                .map(|m| *m as i64)
                .or_else(|| crate::scene::Law::ALL.iter().find(|l| l.name() == t).map(|l| *l as i64));
            let x = match by_name {
                Some(i) => i as f64,
                None => t
                    .parse::<f64>()
                    .map_err(|_| format!("--set {s:?}: {t:?} is neither a number nor a method or law name"))?,
            };
            Ok((n.trim().to_string(), x))
        })
        .collect()
}

fn run_command(
    scene: &Path,
    experiment: &crate::run::Experiment,
    repeats: usize,
    csv: Option<&Path>,
    read_outputs: Vec<String>,
    with_error: bool,
) -> Result<(), String> {
    let parsed = Scene::from_file(scene).map_err(|e| e.to_string())?;
    let spec = RunSpec {
        stop_time: experiment.stop_time.unwrap_or(parsed.model.stop_time),
        interval: experiment.interval.unwrap_or(parsed.model.interval),
        scene: parsed,
        origin: scene.display().to_string(),
        set: parse_settings(&experiment.set)?,
        read_outputs,
    };
    let (wall, cpu, c, failure) = time_runs(&spec, repeats)?;
    if let Some(p) = csv {
        let out = record(&spec, &[])?;
        out.traj.write_csv(p)?;
    }
    let error = if with_error {
        let (truth, _) = work_precision::truth_of(&spec.scene, &spec)?;
        let positions = work_precision::position_outputs(&spec.scene);
        let positions: Vec<&str> = positions.iter().map(|s| s.as_str()).collect();
        let run = record(&spec, &work_precision::truth_outputs(&truth, &positions))?;
        format!(" error={:.4e}", work_precision::error_of(&truth, &run.traj))
    } else {
        String::new()
    };
    println!(
        "seconds={wall:.6e} cpu_seconds={cpu:.6e} steps={} rejected={} rhs_evals={} jac_evals={} events={} status={}{error}",
        c.steps,
        c.rejected,
        c.rhs_evals,
        c.jac_evals,
        c.events,
        failure
            .as_deref()
            .map(|f| f.replace(' ', "_"))
            .unwrap_or_else(|| "ok".into())
    );
    Ok(())
}

/// Formats a float for a CSV cell.
pub fn f(x: f64) -> String {
    format!("{x:.6e}")
}

#[cfg(test)]
mod selection_tests {
    use super::select_scenes;
    use std::path::PathBuf;

    #[test]
    fn only_takes_the_exact_name_first_then_the_names_containing_it() {
        let scenes: Vec<(String, PathBuf)> = ["rail_vehicle", "rail_vehicle_track", "two_spheres"]
            .iter()
            .map(|n| (n.to_string(), PathBuf::from(n)))
            .collect();
        let names = |only| -> Vec<String> {
            select_scenes(scenes.clone(), only)
                .into_iter()
                .map(|(n, _)| n)
                .collect()
        };
        assert_eq!(names(Some("rail_vehicle")), ["rail_vehicle"]);
        assert_eq!(names(Some("rail")), ["rail_vehicle", "rail_vehicle_track"]);
        assert_eq!(names(Some("sphere")), ["two_spheres"]);
        assert!(names(Some("pile")).is_empty());
        assert_eq!(names(None).len(), 3);
    }
}
