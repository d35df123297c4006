//! Native runs for the command line: `simulate` and the main job (export and run every
//! bundled scene, print one summary table).

use crate::checkpoint::Snapshot;
use crate::export::{export_command, fmu_folder};
use crate::fmi::lifecycle::Version;
use crate::scene::{short, Num, MAX_COMMUNICATION_POINTS};
use crate::simulation::{RunError, SimError, Simulation};
use crate::variables::VarType;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The experiment of a native run: its stop time, communication interval and settings
/// (the command-line arguments shared by `simulate` and `bench run`).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct Experiment {
    /// Stop time (s; default: the scene's stop_time).
    #[arg(long)]
    pub stop_time: Option<f64>,
    /// Communication interval (s; default: the scene's interval).
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
    /// Exit with status 0 also when the energy balance drifted by more than 1 % (the run
    /// is inaccurate: by default that is an error, after the CSV is written).
    #[arg(long)]
    pub allow_energy_drift: bool,
}

/// Options of `contact-fmu variables`.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct VariablesOptions {
    /// Only variables of these causalities (comma-separated: parameter, calculatedParameter,
    /// input, output).
    #[arg(long, value_name = "LIST")]
    pub causality: Option<String>,
}

/// Summary of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    /// Scene name.
    pub name: String,
    /// Time simulated by the run \[s\] (from the resumed state's time when it resumed).
    pub simulated: f64,
    /// Accepted steps of the run (not those before a resumed state).
    pub steps: u64,
    /// Right-hand-side evaluations of the run.
    pub rhs_evals: u64,
    /// True when the energy balance drifted by more than 1 % during the run (a warning was
    /// given: the run is inaccurate).
    pub energy_drifted: bool,
    /// Wall-clock run time \[s\].
    pub seconds: f64,
    /// CPU time of the run \[s\] (the calling thread's; the wall-clock time where the platform
    /// has no thread CPU clock).
    pub cpu_seconds: f64,
    /// Relative energy-balance error at the end: |Δ(E_total + E_dissipated − W_inputs)| / E_scale, with
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
        return Err(format!("stop time must be > 0 (got {})", short(stop_time)));
    }
    if !(interval > 0.0 && interval.is_finite()) {
        return Err(format!(
            "the communication interval must be > 0 (got {})",
            short(interval)
        ));
    }
    if !sim.is_initialized() {
        sim.initialize(0.0).map_err(|e| e.to_string())?;
    }
    // (the scene's own experiment is checked with the scene; overrides are checked here)
    let points = (stop_time - sim.time()) / interval;
    if points > MAX_COMMUNICATION_POINTS {
        return Err(format!(
            "interval {} gives {points:.3e} communication points from t = {} s to the stop time {} s; at most {MAX_COMMUNICATION_POINTS:e}",
            short(interval),
            short(sim.time()),
            short(stop_time)
        ));
    }
    let e0 = sim.energies().map_err(|e| e.to_string())?;
    let mut scale = e0.total().abs().max(e0.kinetic);
    // (a resumed run starts at its state's time, with its counters and its energy watch: a
    // drift warned of before it was saved is not this run's)
    let (t0, c0, drifted_before) = (sim.time(), sim.counters(), sim.energy_drifted());
    each(sim)?;
    let start = Instant::now();
    let cpu_start = thread_cpu_seconds();
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
        RunError::Step(SimError::Step { time, message }) => {
            format!("simulation failed at t = {}: {message}", Num(time))
        }
        other => other.to_string(),
    })?;
    let seconds = start.elapsed().as_secs_f64();
    let cpu_seconds = thread_cpu_seconds() - cpu_start;
    let e1 = sim.energies().map_err(|e| e.to_string())?;
    let c = sim.counters();
    let err = (e1.balance() - e0.balance()).abs() / scale.max(f64::MIN_POSITIVE);
    Ok(RunSummary {
        name: sim.scene().model.name.clone(),
        simulated: stop_time - t0,
        steps: c.steps - c0.steps,
        rhs_evals: c.rhs_evals - c0.rhs_evals,
        energy_drifted: sim.energy_drifted() && !drifted_before,
        seconds,
        cpu_seconds,
        energy_error: err,
    })
}

/// `contact-fmu simulate`.
pub fn simulate_command(scene: &Path, o: &RunOptions) -> Result<RunSummary, String> {
    simulate(scene, o, !o.quiet)
}

/// [`simulate_command`], with the progress lines (`t = ... s of ... s`, every 2 s on standard
/// error) on or off apart from `quiet`.
fn simulate(scene: &Path, o: &RunOptions, progress: bool) -> Result<RunSummary, String> {
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
        if sim.energy_drifted() {
            // (the watch is saved with the state and warns once: not again in this run)
            eprintln!(
                "note: {}: the energy balance had drifted by more than {} % before this state was saved",
                path.display(),
                100.0 * crate::simulation::ENERGY_DRIFT_WARNING
            );
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
            if progress && last_report.elapsed().as_secs_f64() > 2.0 {
                eprintln!(
                    "  {}: t = {t:.6} s of {stop} s ({:.0} %)",
                    scene.display(),
                    100.0 * t / stop
                );
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
    if summary.energy_drifted && !o.allow_energy_drift {
        return Err(format!(
            "{}: the energy balance drifted by more than {} % (the warning above): the results are inaccurate; \
             tighten solver.rtol and solver.atol (or, with rk4, shorten solver.max_step), or pass \
             --allow-energy-drift to accept them",
            scene.display(),
            100.0 * crate::simulation::ENERGY_DRIFT_WARNING
        ));
    }
    Ok(summary)
}

/// `contact-fmu variables`: the scene's FMU variables (as the exported FMU has them), one line
/// each: name, causality, variability, type, start value (enumerations by item name), unit and
/// description.
pub fn variables_command(scene: &Path, o: &VariablesOptions) -> Result<(), String> {
    let sim = Simulation::from_file(scene).map_err(|e| e.to_string())?;
    let wanted: Option<Vec<&str>> = o.causality.as_deref().map(|l| l.split(',').map(str::trim).collect());
    if let Some(w) = &wanted {
        let known = ["parameter", "calculatedParameter", "input", "output"];
        if let Some(bad) = w.iter().find(|c| !known.contains(c)) {
            return Err(format!(
                "--causality: unknown causality {bad:?} (known: {})",
                known.join(", ")
            ));
        }
    }
    let mut rows = vec![[
        "name".to_string(),
        "causality".into(),
        "variability".into(),
        "type".into(),
        "start".into(),
        "unit".into(),
        "description".into(),
    ]];
    for v in sim.variables() {
        if wanted.as_ref().is_some_and(|w| !w.contains(&v.causality.name())) {
            continue;
        }
        let (type_name, start) = match v.vtype {
            VarType::Real => ("Real".to_string(), v.start.map(crate::export::format_real)),
            VarType::Integer => ("Integer".into(), v.start.map(|x| format!("{x}"))),
            VarType::Boolean => ("Boolean".into(), v.start.map(|x| (x != 0.0).to_string())),
            VarType::Enumeration(e) => (
                e.type_name().to_string(),
                v.start.map(|x| {
                    e.items()
                        .iter()
                        .find(|(_, i)| *i as f64 == x)
                        .map_or(format!("{x}"), |(n, _)| n.to_string())
                }),
            ),
        };
        rows.push([
            v.name.clone(),
            v.causality.name().into(),
            v.variability.name().into(),
            type_name,
            start.unwrap_or_default(),
            v.unit.unwrap_or("").into(),
            crate::export::describe(v),
        ]);
    }
    let mut widths = [0usize; 6];
    for r in &rows {
        for (w, cell) in widths.iter_mut().zip(r.iter()) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let mut out = String::new();
    for r in &rows {
        for (w, cell) in widths.iter().zip(r.iter()) {
            out.push_str(&format!("{cell:<w$}  "));
        }
        out.push_str(&r[6]);
        out.push('\n');
    }
    print!("{out}");
    Ok(())
}

fn warnings_of(sim: &mut Simulation) -> Vec<String> {
    sim.warnings().unwrap_or_default()
}

/// Prints the summary table: per run the simulated time, accepted steps, RHS evaluations, CPU
/// time, the real-time factor (simulated over CPU time) and the energy-balance error.
pub fn print_table(rows: &[RunSummary]) {
    let w = rows.iter().map(|r| r.name.chars().count()).max().unwrap_or(0).max(16);
    println!(
        "{:<w$} {:>10} {:>9} {:>10} {:>12} {:>10} {:>12}",
        "scene", "sim time", "steps", "rhs evals", "cpu time", "RT factor", "energy err"
    );
    for r in rows {
        println!(
            "{:<w$} {:>9.3}s {:>9} {:>10} {:>12} {:>10} {:>12.3e}",
            r.name,
            r.simulated,
            r.steps,
            r.rhs_evals,
            cpu_text(r.cpu_seconds),
            significant(r.simulated / r.cpu_seconds.max(1e-9)),
            r.energy_error
        );
    }
    for r in rows.iter().filter(|r| r.energy_drifted) {
        println!(
            "{}: the energy balance drifted by more than {} % during the run: its results are inaccurate",
            r.name,
            100.0 * crate::simulation::ENERGY_DRIFT_WARNING
        );
    }
}

/// A CPU time with three significant digits in s or ms (`1.23 s`, `45.6 ms`, `0.789 ms`).
fn cpu_text(seconds: f64) -> String {
    if seconds >= 1.0 {
        format!("{} s", significant(seconds))
    } else {
        format!("{} ms", significant(seconds * 1e3))
    }
}

/// `x` with three significant digits (at least one decimal below 100).
fn significant(x: f64) -> String {
    let decimals = if x >= 100.0 {
        0
    } else if x >= 10.0 {
        1
    } else if x >= 1.0 {
        2
    } else {
        3
    };
    format!("{x:.decimals$}")
}

/// The main job: make sure the FMU libraries of every default platform (linux64, win64) are
/// built from these sources (else build them with `scripts/build_fmu_library.sh`), export every
/// `fmu/<name>/scene.toml` with them to `target/fmu/<name>.fmu` (FMI 2.0) and
/// `target/fmu3/<name>.fmu` (FMI 3.0) under `target`, run each default experiment natively and
/// print one table. Progress goes to standard error.
pub fn main_job(fmu_dir: &Path, target: &Path) -> Result<(), String> {
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(fmu_dir)
        .map_err(|e| format!("{}: {e} (run from the repository root)", fmu_dir.display()))?
        .filter_map(|e| e.ok())
        .map(|e| e.path().join("scene.toml"))
        .filter(|p| p.is_file())
        .collect();
    scenes.sort();
    let libraries = ensure_libraries()?;
    let binaries: Vec<String> = libraries
        .iter()
        .map(|(platform, path)| format!("{platform}={}", path.display()))
        .collect();
    let mut rows = Vec::new();
    for (k, scene) in scenes.iter().enumerate() {
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
        let mut written = Vec::new();
        for version in [Version::Fmi2, Version::Fmi3] {
            let out = target.join(fmu_folder(version)).join(format!("{name}.fmu"));
            let exported = export_command(scene, Some(&out), &binaries, None, version).map_err(|e| e.to_string())?;
            let size = std::fs::metadata(&exported.path).map_or(0, |m| m.len()) / 1000;
            written.push(format!("{} ({size} kB)", exported.path.display()));
        }
        eprintln!(
            "[{}/{}] exported {}; running its default experiment ({} s)",
            k + 1,
            scenes.len(),
            written.join(" and "),
            sim.scene().model.stop_time
        );
        // (a drift is marked in the table, not an error here)
        let opts = RunOptions {
            quiet: true,
            allow_energy_drift: true,
            ..Default::default()
        };
        rows.push(simulate(scene, &opts, true)?);
    }
    print_table(&rows);
    Ok(())
}

/// The `dist` library of every default platform built from these sources: found, or built by
/// `scripts/build_fmu_library.sh` (run from the current directory, the repository root), or
/// an error naming the step that failed.
fn ensure_libraries() -> Result<Vec<(String, PathBuf)>, String> {
    use crate::export::{dist_library, missing_message, platform, DEFAULT_PLATFORMS};
    let find = || -> Vec<(String, Result<PathBuf, crate::export::Missing>)> {
        DEFAULT_PLATFORMS
            .iter()
            .filter_map(|&p| platform(p))
            .map(|p| (p.name.to_string(), dist_library(p)))
            .collect()
    };
    let mut found = find();
    if found.iter().any(|(_, r)| r.is_err()) {
        let script = Path::new("scripts").join("build_fmu_library.sh");
        if !script.is_file() {
            let (platform, why) = found
                .iter()
                .find_map(|(p, r)| r.as_ref().err().map(|w| (p, w)))
                .unwrap();
            return Err(format!(
                "{} (and {} is not here: run from the repository root)",
                missing_message(platform, why),
                script.display()
            ));
        }
        let which: Vec<&str> = found
            .iter()
            .filter(|(_, r)| r.is_err())
            .map(|(p, _)| p.as_str())
            .collect();
        eprintln!(
            "== building the FMU libraries ({}) from these sources: {} (cargo profile dist; the first build takes a few minutes)",
            which.join(", "),
            script.display()
        );
        let status = std::process::Command::new("bash")
            .arg(&script)
            .args(&which)
            .status()
            .map_err(|e| format!("cannot run {}: {e}", script.display()))?;
        if !status.success() {
            return Err(format!(
                "building the FMU libraries failed ({} {}: {status}); its message above names the step",
                script.display(),
                which.join(" ")
            ));
        }
        found = find();
    }
    found
        .into_iter()
        .map(|(p, r)| r.map(|path| (p.clone(), path)).map_err(|why| missing_message(&p, &why)))
        .collect()
}

/// CPU time of the calling thread \[s\] (immune to other processes on a busy machine).
///
/// Only the command line and the benchmarks call it; the FMU functions read no clock, so the shared library an
/// FMU ships imports no clock function (`tests/python/test_distribution.py` checks its
/// symbol table). On Unix it is `clock_gettime(CLOCK_THREAD_CPUTIME_ID)`; elsewhere, where
/// that call does not exist, the wall-clock time since the first call stands in.
#[cfg(unix)]
pub fn thread_cpu_seconds() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes one timespec into the pointer we own.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    if rc != 0 {
        return f64::NAN;
    }
    ts.tv_sec as f64 + 1e-9 * ts.tv_nsec as f64
}

/// CPU time of the calling thread \[s\]: see the Unix version; here the wall-clock time since
/// the first call.
#[cfg(not(unix))]
pub fn thread_cpu_seconds() -> f64 {
    static START: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
    START.get_or_init(std::time::Instant::now).elapsed().as_secs_f64()
}
