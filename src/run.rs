//! Native runs for the command line: `simulate` and the main job (export and run every
//! bundled scene, print one summary table).

use crate::checkpoint::Snapshot;
use crate::simulation::{RunError, SimError, Simulation};
use crate::variables::VarType;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The experiment of a native run: its stop time, communication interval and settings
/// (the command-line arguments shared by `simulate` and `bench run`).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct Experiment {
    /// Stop time [s] (default: the scene's stop_time).
    #[arg(long)]
    pub stop_time: Option<f64>,
    /// Communication interval [s] (default: the scene's interval).
    #[arg(long)]
    pub interval: Option<f64>,
    /// Set a parameter or input: NAME=VALUE (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
}

/// Options of `contact-fmu simulate`.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct RunOptions {
    /// Stop time, interval, settings.
    #[command(flatten)]
    pub experiment: Experiment,
    /// Write the outputs at every communication point to this CSV file.
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Print nothing but errors.
    #[arg(long)]
    pub quiet: bool,
    /// Write the state at the stop time to this file (a checkpoint to resume from).
    #[arg(long, value_name = "FILE")]
    pub save_state: Option<PathBuf>,
    /// Start from a state saved with --save-state (of the same scene) instead of the
    /// initial configuration; the stop time must lie after its time.
    #[arg(long, value_name = "FILE")]
    pub resume: Option<PathBuf>,
}

/// Summary of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    /// Scene name.
    pub name: String,
    /// Simulated time [s].
    pub simulated: f64,
    /// Accepted steps.
    pub steps: u64,
    /// Right-hand-side evaluations.
    pub rhs_evals: u64,
    /// Wall-clock run time [s].
    pub seconds: f64,
    /// Relative energy-balance error at the end: |ΔE_total + E_dissipated| / E_scale, with
    /// E_scale the larger of |E_total(0)| and the largest kinetic energy seen.
    pub energy_error: f64,
}

/// Applies `NAME=VALUE` settings.
pub fn apply_settings(sim: &mut Simulation, set: &[String]) -> Result<(), String> {
    for s in set {
        let (name, value) = s
            .split_once('=')
            .ok_or_else(|| format!("--set {s:?}: expected NAME=VALUE"))?;
        let name = name.trim();
        let value = value.trim();
        let vr = sim
            .table()
            .index_of(name)
            .ok_or_else(|| format!("--set {s:?}: unknown variable {name:?}"))?;
        let var = &sim.variables()[vr];
        let x = match var.vtype {
            VarType::Enumeration(e) => match e.items().iter().find(|(n, _)| *n == value) {
                Some((_, i)) => *i as f64,
                None => value.parse::<f64>().map_err(|_| {
                    let names: Vec<&str> = e.items().iter().map(|(n, _)| *n).collect();
                    format!("--set {s:?}: {value:?} is not one of {}", names.join(", "))
                })?,
            },
            VarType::Boolean => match value {
                "true" | "1" => 1.0,
                "false" | "0" => 0.0,
                _ => return Err(format!("--set {s:?}: expected true or false")),
            },
            _ => value
                .parse::<f64>()
                .map_err(|_| format!("--set {s:?}: {value:?} is not a number"))?,
        };
        sim.set(vr, x).map_err(|e| format!("--set {s:?}: {e}"))?;
    }
    Ok(())
}

/// Runs a simulation on communication points `interval` apart to `stop_time`, calling
/// `each(sim)` at every point (the start included). Returns the summary.
pub fn run_simulation(
    sim: &mut Simulation,
    stop_time: f64,
    interval: f64,
    mut each: impl FnMut(&mut Simulation) -> Result<(), String>,
    mut progress: impl FnMut(f64),
) -> Result<RunSummary, String> {
    if !(stop_time > 0.0 && stop_time.is_finite()) {
        return Err(format!("stop time must be > 0 (got {stop_time})"));
    }
    if !sim.is_initialized() {
        sim.initialize(0.0).map_err(|e| e.to_string())?;
    }
    let e0 = sim.energies().map_err(|e| e.to_string())?;
    let mut scale = e0.total().abs().max(e0.kinetic);
    each(sim)?;
    let start = Instant::now();
    let result = sim.run(stop_time, interval, |sim| {
        each(sim)?;
        let e = sim.energies().map_err(|e| e.to_string())?;
        scale = scale.max(e.kinetic);
        progress(sim.time());
        Ok(())
    });
    for w in sim.take_warnings() {
        eprintln!("warning: {w}");
    }
    result.map_err(|e| match e {
        RunError::Step(SimError::Step { time, message }) => format!("simulation failed at t = {time}: {message}"),
        other => other.to_string(),
    })?;
    let seconds = start.elapsed().as_secs_f64();
    let e1 = sim.energies().map_err(|e| e.to_string())?;
    let c = sim.counters();
    let err = ((e1.total() + e1.dissipated) - (e0.total() + e0.dissipated)).abs() / scale.max(f64::MIN_POSITIVE);
    Ok(RunSummary {
        name: sim.scene().model.name.clone(),
        simulated: stop_time,
        steps: c.steps,
        rhs_evals: c.rhs_evals,
        seconds,
        energy_error: err,
    })
}

/// `contact-fmu simulate`.
pub fn simulate_command(scene: &Path, o: &RunOptions) -> Result<RunSummary, String> {
    let mut sim = Simulation::from_file(scene).map_err(|e| e.to_string())?;
    for w in warnings_of(&mut sim) {
        eprintln!("warning: {w}");
    }
    let model_hash = || -> Result<u64, String> {
        let text = std::fs::read_to_string(scene).map_err(|e| format!("{}: {e}", scene.display()))?;
        Ok(crate::guid::model_hash(&text))
    };
    if let Some(path) = &o.resume {
        let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let snapshot = Snapshot::from_bytes(&bytes, model_hash()?).map_err(|e| format!("{}: {e}", path.display()))?;
        sim.restore(&snapshot).map_err(|e| format!("{}: {e}", path.display()))?;
        if !sim.is_initialized() {
            sim.initialize(0.0).map_err(|e| e.to_string())?;
        }
    }
    apply_settings(&mut sim, &o.experiment.set)?;
    let stop = o.experiment.stop_time.unwrap_or(sim.scene().model.stop_time);
    let interval = o.experiment.interval.unwrap_or(sim.scene().model.interval);
    let outputs = sim.output_indices();
    let mut writer = match &o.csv {
        Some(p) => {
            if let Some(dir) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            }
            let f = std::fs::File::create(p).map_err(|e| format!("{}: {e}", p.display()))?;
            let mut w = std::io::BufWriter::new(f);
            let header: Vec<&str> = outputs.iter().map(|&i| sim.variables()[i].name.as_str()).collect();
            writeln!(w, "time,{}", header.join(",")).map_err(|e| e.to_string())?;
            Some(w)
        }
        None => None,
    };
    let mut last_report = Instant::now();
    let quiet = o.quiet;
    // one row at a time, in one buffer: shortest round-trip digits (ryu), no allocation
    let (mut line, mut numbers) = (String::new(), ryu::Buffer::new());
    let summary = run_simulation(
        &mut sim,
        stop,
        interval,
        |s| {
            if let Some(w) = writer.as_mut() {
                line.clear();
                line.push_str(numbers.format(s.time()));
                for &i in &outputs {
                    line.push(',');
                    line.push_str(numbers.format(s.get(i).map_err(|e| e.to_string())?));
                }
                line.push('\n');
                w.write_all(line.as_bytes()).map_err(|e| e.to_string())?;
            }
            Ok(())
        },
        |t| {
            if !quiet && last_report.elapsed().as_secs_f64() > 2.0 {
                eprintln!("  t = {t:.6} s of {stop} s ({:.0} %)", 100.0 * t / stop);
                last_report = Instant::now();
            }
        },
    )?;
    if let Some(mut w) = writer {
        w.flush().map_err(|e| e.to_string())?;
    }
    if let Some(path) = &o.save_state {
        let bytes = sim.snapshot(Vec::new()).to_bytes(model_hash()?);
        std::fs::write(path, bytes).map_err(|e| format!("{}: {e}", path.display()))?;
        if !o.quiet {
            println!("saved the state at t = {} to {}", sim.time(), path.display());
        }
    }
    if !o.quiet {
        print_table(std::slice::from_ref(&summary));
        if let Some(p) = &o.csv {
            println!("wrote {}", p.display());
        }
    }
    Ok(summary)
}

fn warnings_of(sim: &mut Simulation) -> Vec<String> {
    sim.warnings().unwrap_or_default()
}

/// Prints the summary table.
pub fn print_table(rows: &[RunSummary]) {
    println!(
        "{:<16} {:>10} {:>9} {:>10} {:>10} {:>10} {:>12}",
        "scene", "sim time", "steps", "rhs evals", "run time", "RT factor", "energy err"
    );
    for r in rows {
        println!(
            "{:<16} {:>9.3}s {:>9} {:>10} {:>9.3}s {:>10.1} {:>12.3e}",
            r.name,
            r.simulated,
            r.steps,
            r.rhs_evals,
            r.seconds,
            r.simulated / r.seconds.max(1e-9),
            r.energy_error
        );
    }
}

/// The main job: export every `fmu/<name>/scene.toml` to `out_dir/<name>.fmu`, run each
/// default experiment natively and print one table.
pub fn main_job(fmu_dir: &Path, out_dir: &Path) -> Result<(), String> {
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(fmu_dir)
        .map_err(|e| format!("{}: {e} (run from the repository root)", fmu_dir.display()))?
        .filter_map(|e| e.ok())
        .map(|e| e.path().join("scene.toml"))
        .filter(|p| p.is_file())
        .collect();
    scenes.sort();
    let mut rows = Vec::new();
    for scene in &scenes {
        let sim = Simulation::from_file(scene).map_err(|e| e.to_string())?;
        let name = sim.scene().model.name.clone();
        let folder = scene
            .parent()
            .and_then(|p| p.file_name())
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default();
        if folder != name {
            return Err(format!(
                "{}: model.name {name:?} must equal the folder name {folder:?}",
                scene.display()
            ));
        }
        let out = out_dir.join(format!("{name}.fmu"));
        let exported = crate::export::export_command(scene, Some(&out), &[]).map_err(|e| e.to_string())?;
        eprintln!("exported {}", exported.path.display());
        let opts = RunOptions {
            quiet: true,
            ..Default::default()
        };
        rows.push(simulate_command(scene, &opts)?);
    }
    print_table(&rows);
    Ok(())
}
