//! The cost of one right-hand-side evaluation of each bundled scene, at its initial state,
//! in two contact modes: as the scene starts (contacts not yet touching, the cost of free
//! flight) and with every contact active (the force laws included). Medians of `repeats`
//! batches; with `--calls N` every batch has exactly N calls, so that an instruction count
//! (`scripts/rhs_instructions.sh`) divides into a count per evaluation; `--mode` restricts the
//! run to one of the two contact modes.

use super::{bundled_scenes, f, median, thread_cpu_seconds, Csv};
use crate::compile::compile;
use crate::forward::Rhs;
use crate::integrator::OdeSystem;
use crate::scene::Scene;
use std::path::Path;
use std::time::Instant;

/// Runs the benchmark and writes the CSV.
pub fn run(
    dir: &Path,
    only: Option<&str>,
    repeats: usize,
    calls: Option<usize>,
    mode: Option<&str>,
    csv_path: &Path,
) -> Result<(), String> {
    let modes: &[bool] = match mode {
        None => &[false, true],
        Some("free") => &[false],
        Some("contact") => &[true],
        Some(other) => return Err(format!("--mode {other:?}: expected free or contact")),
    };
    let mut csv = Csv::new(&[
        "scene",
        "contacts_active",
        "nv",
        "contacts",
        "calls",
        "rhs_cpu_seconds",
        "rhs_wall_seconds",
    ]);
    println!(
        "{:<16} {:>5} {:>6} {:>9} {:>16} {:>16} {:>16} {:>16}",
        "scene", "nv", "ncont", "calls", "free cpu [ns]", "contact cpu [ns]", "free wall [ns]", "contact wall [ns]"
    );
    for (name, path) in super::select_scenes(bundled_scenes(dir)?, only) {
        let scene = Scene::from_file(&path).map_err(|e| e.to_string())?;
        let (m, mut d) = compile(&scene, &path.display().to_string()).map_err(|e| e.to_string())?;
        let state = d.state.clone();
        let mut dy = vec![0.0; state.len()];
        let mut cost = [0.0; 2];
        let mut wall = [0.0; 2];
        let mut n_calls = 0;
        for &active in modes {
            let k = active as usize;
            for mem in d.contact_memory.iter_mut() {
                mem.active = active;
                mem.impact_velocity = 1.0;
            }
            let t0 = Instant::now();
            Rhs {
                model: &m,
                data: &mut d,
            }
            .rhs(0.0, &state, &mut dy);
            let once = t0.elapsed().as_secs_f64().max(1e-9);
            n_calls = calls.unwrap_or(((0.05 / once) as usize).clamp(1, 1_000_000));
            let (mut cpu_runs, mut wall_runs) = (Vec::new(), Vec::new());
            for _ in 0..repeats.max(1) {
                let (c0, t0) = (thread_cpu_seconds(), Instant::now());
                for _ in 0..n_calls {
                    Rhs {
                        model: &m,
                        data: &mut d,
                    }
                    .rhs(0.0, &state, &mut dy);
                    std::hint::black_box(&dy);
                }
                wall_runs.push(t0.elapsed().as_secs_f64() / n_calls as f64);
                cpu_runs.push((thread_cpu_seconds() - c0) / n_calls as f64);
            }
            (cost[k], wall[k]) = (median(&cpu_runs), median(&wall_runs));
            csv.push(vec![
                name.clone(),
                active.to_string(),
                m.nv.to_string(),
                d.contacts.len().to_string(),
                n_calls.to_string(),
                f(cost[k]),
                f(wall[k]),
            ]);
        }
        println!(
            "{:<16} {:>5} {:>6} {:>9} {:>16.1} {:>16.1} {:>16.1} {:>16.1}",
            name,
            m.nv,
            d.contacts.len(),
            n_calls,
            cost[0] * 1e9,
            cost[1] * 1e9,
            wall[0] * 1e9,
            wall[1] * 1e9
        );
    }
    csv.write(csv_path)
}
