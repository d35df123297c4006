//! The pile's phase by windows: a scene of spheres (by default the bundled `pile_of_balls`)
//! run to `--from`, then timed window by window up to `--to` (each window from its saved
//! start, `--repeats` times, the thread's CPU time, median), with the work counters (steps,
//! RHS evaluations, contact events) and what sets them: sampled every `--sample` seconds in
//! one more run from the same start, the pairs of spheres that touch, the largest cluster of
//! touching spheres and the largest island; and the energies: the kinetic energy at each
//! window's end, the change of the potential energy over it (how far the pile still falls
//! together) and of the energy balance (the integration's error).
//!
//! An island advances all its bodies with one step; a cluster of touching spheres is what
//! the contact forces couple at that instant. Per window, `steps × largest island` is the
//! work of the islands now (body steps), and `steps × largest cluster` what a method whose
//! steps were local to the touching cluster would do if the largest cluster needed the
//! island's steps and nothing else needed any: an optimistic estimate of what such a
//! (multirate) method could gain.

use super::{f, Csv};
use crate::run::thread_cpu_seconds;
use crate::scene::{ShapeType, GROUND};
use crate::simulation::Simulation;
use crate::union_find::UnionFind;
use std::path::{Path, PathBuf};

/// Settings of a run (the options of `contact-fmu bench pile`).
#[derive(Debug, clap::Args)]
pub struct Settings {
    /// Scene file (TOML) of spheres.
    #[arg(long, default_value = "fmu/pile_of_balls/scene.toml")]
    pub scene: PathBuf,
    /// Start of the timed phase (s).
    #[arg(long, default_value_t = 0.5)]
    pub from: f64,
    /// End of the timed phase (s).
    #[arg(long, default_value_t = 1.5)]
    pub to: f64,
    /// Length of a window (s).
    #[arg(long, default_value_t = 0.125)]
    pub window: f64,
    /// Timed runs per window (the median is reported).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// Interval of the samples of touching spheres and islands (s; the contacts of steel
    /// balls at centimetres a second last about 0.1 ms).
    #[arg(long, default_value_t = 1e-5)]
    pub sample: f64,
    /// Output CSV.
    #[arg(long, default_value = "docs/pile.csv")]
    pub csv: PathBuf,
}

/// The spheres centred on their bodies' centres of mass (no `center` of their own): (the
/// variable indices of the body's `r[1..3]`, radius).
fn centred_spheres(sim: &Simulation) -> Vec<([usize; 3], f64)> {
    let mut out = Vec::new();
    for s in &sim.scene().shape {
        // (a sphere given a centre of its own may lie off its body's centre of mass)
        let (ShapeType::Sphere, None, Some(radius)) = (s.kind, s.center, s.radius) else {
            continue;
        };
        let r = |k: usize| sim.table().index_of(&format!("{}.r[{k}]", s.body));
        if let (false, Some(x), Some(y), Some(z)) = (s.body == GROUND, r(1), r(2), r(3)) {
            out.push(([x, y, z], radius));
        }
    }
    out
}

/// (touching pairs, size of the largest cluster of touching spheres) at the centres `p`.
fn touching(p: &[[f64; 3]], radii: &[f64]) -> (usize, usize) {
    let mut sets = UnionFind::new(p.len());
    let mut pairs = 0;
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            let d2: f64 = (0..3).map(|k| (p[i][k] - p[j][k]).powi(2)).sum();
            if d2 < (radii[i] + radii[j]).powi(2) {
                pairs += 1;
                sets.join(Some(i), Some(j));
            }
        }
    }
    let mut size = vec![0usize; p.len()];
    for i in 0..p.len() {
        size[sets.root(i)] += 1;
    }
    (pairs, size.into_iter().max().unwrap_or(0))
}

/// One window's figures.
struct Window {
    start: f64,
    end: f64,
    cpu: f64,
    steps: u64,
    rhs_evals: u64,
    events: u64,
    pairs: f64,
    cluster: f64,
    island: f64,
    /// Kinetic energy at the end \[J\].
    kinetic: f64,
    /// Change of the potential energy over the window \[J\].
    potential_change: f64,
    /// Change of the energy balance (total + dissipated − input work) over the window \[J\].
    balance_change: f64,
}

/// Runs `sim` to `t_end` over the communication points of `interval` ([`Simulation::run`];
/// nothing when it is there).
fn run_to(sim: &mut Simulation, t_end: f64, interval: f64) -> Result<(), String> {
    if t_end <= sim.time() {
        return Ok(());
    }
    sim.run(t_end, interval, |_| Ok(())).map_err(|e| e.to_string())
}

/// The means over the samples of a window (at its start, then every `dt` to `end`): touching
/// pairs, largest cluster, largest island (all the spheres when the scene does not run as
/// islands).
fn sample(sim: &mut Simulation, spheres: &[([usize; 3], f64)], end: f64, dt: f64) -> Result<[f64; 3], String> {
    let radii: Vec<f64> = spheres.iter().map(|s| s.1).collect();
    let vrs: Vec<usize> = spheres.iter().flat_map(|s| s.0).collect();
    let mut values = vec![0.0; vrs.len()];
    let (mut sums, mut n) = ([0.0; 3], 0.0);
    let mut add = |sim: &mut Simulation| -> Result<(), String> {
        sim.get_many(&vrs, &mut values).map_err(|e| e.to_string())?;
        let p: Vec<[f64; 3]> = values.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
        let (pairs, cluster) = touching(&p, &radii);
        let partition = &sim.data().ok_or("not initialised")?.partition;
        let island = (0..partition.len()).map(|k| partition.bodies(k).len()).max();
        for (s, x) in sums.iter_mut().zip([pairs, cluster, island.unwrap_or(spheres.len())]) {
            *s += x as f64;
        }
        n += 1.0;
        Ok(())
    };
    add(sim)?;
    sim.run(end, dt, &mut add).map_err(|e| e.to_string())?;
    Ok(sums.map(|s| s / n))
}

/// Runs the benchmark and writes the CSV.
pub fn run(s: &Settings) -> Result<(), String> {
    let origin = s.scene.display().to_string();
    let mut sim = Simulation::from_file(&s.scene).map_err(|e| e.to_string())?;
    sim.initialize(0.0).map_err(|e| e.to_string())?;
    let interval = sim.scene().model.interval;
    let spheres = centred_spheres(&sim);
    if !(s.to > s.from && s.from >= 0.0 && s.window > 0.0 && s.sample > 0.0) {
        return Err(format!(
            "--from {}, --to {}, --window {}, --sample {}: needs 0 <= from < to and window, sample > 0",
            s.from, s.to, s.window, s.sample
        ));
    }
    if spheres.len() < 2 {
        return Err(format!(
            "{origin}: {} [[shape]] sphere(s) centred on their bodies (no `center` of their own); the bench needs two or more",
            spheres.len()
        ));
    }
    println!("{origin}: {} spheres; to {} s first", spheres.len(), s.from);
    run_to(&mut sim, s.from, interval)?;
    let mut windows = Vec::new();
    let mut start = s.from;
    while start < s.to - 1e-12 {
        let end = (start + s.window).min(s.to);
        let at_start = sim.snapshot(Vec::new());
        let c0 = sim.counters();
        let e0 = sim.energies().map_err(|e| e.to_string())?;
        let mut cpu = Vec::new();
        for _ in 0..s.repeats.max(1) {
            sim.restore(&at_start).map_err(|e| e.to_string())?;
            let c0 = thread_cpu_seconds();
            run_to(&mut sim, end, interval)?;
            cpu.push(thread_cpu_seconds() - c0);
        }
        let c1 = sim.counters();
        sim.restore(&at_start).map_err(|e| e.to_string())?;
        let [pairs, cluster, island] = sample(&mut sim, &spheres, end, s.sample)?;
        let e1 = sim.energies().map_err(|e| e.to_string())?;
        if sim.counters().steps != c1.steps {
            return Err(format!(
                "{origin}: the sampled run took {} steps to {end} s, the timed one {}: the samples changed the trajectory",
                sim.counters().steps,
                c1.steps
            ));
        }
        windows.push(Window {
            start,
            end,
            cpu: super::median(&cpu),
            steps: c1.steps - c0.steps,
            rhs_evals: c1.rhs_evals - c0.rhs_evals,
            events: c1.events - c0.events,
            pairs,
            cluster,
            island,
            kinetic: e1.kinetic,
            potential_change: e1.potential - e0.potential,
            balance_change: e1.balance() - e0.balance(),
        });
        start = end;
    }
    report(&windows, &s.csv)
}

/// Prints the table and the totals, writes the CSV.
fn report(windows: &[Window], csv_path: &Path) -> Result<(), String> {
    let mut csv = Csv::new(&[
        "start",
        "end",
        "cpu_seconds",
        "real_time_factor",
        "steps",
        "rhs_evals",
        "events",
        "touching_pairs",
        "largest_cluster",
        "largest_island",
        "kinetic_energy_end",
        "potential_energy_change",
        "energy_balance_change",
    ]);
    println!(
        "{:>15} {:>8} {:>6} {:>8} {:>9} {:>7} {:>9} {:>6} {:>8} {:>7} {:>10} {:>10} {:>10}",
        "window [s]",
        "CPU [s]",
        "RT",
        "steps",
        "rhs",
        "events",
        "events/s",
        "pairs",
        "cluster",
        "island",
        "KE end [J]",
        "dPE [J]",
        "dbal [J]"
    );
    let (mut cpu, mut span, mut steps, mut events) = (0.0, 0.0, 0, 0);
    let (mut work_island, mut work_cluster) = (0.0, 0.0);
    for w in windows {
        let length = w.end - w.start;
        println!(
            "{:>7.3}-{:<7.3} {:>8.3} {:>6.2} {:>8} {:>9} {:>7} {:>9.0} {:>6.1} {:>8.1} {:>7.1} {:>10.3e} {:>10.3e} {:>10.3e}",
            w.start,
            w.end,
            w.cpu,
            length / w.cpu,
            w.steps,
            w.rhs_evals,
            w.events,
            w.events as f64 / length,
            w.pairs,
            w.cluster,
            w.island,
            w.kinetic,
            w.potential_change,
            w.balance_change
        );
        csv.push(vec![
            f(w.start),
            f(w.end),
            f(w.cpu),
            f(length / w.cpu),
            w.steps.to_string(),
            w.rhs_evals.to_string(),
            w.events.to_string(),
            f(w.pairs),
            f(w.cluster),
            f(w.island),
            f(w.kinetic),
            f(w.potential_change),
            f(w.balance_change),
        ]);
        cpu += w.cpu;
        span += length;
        steps += w.steps;
        events += w.events;
        work_island += w.steps as f64 * w.island;
        work_cluster += w.steps as f64 * w.cluster;
    }
    let gain = work_island / work_cluster;
    println!(
        "all: {span:.3} s simulated in {cpu:.3} s CPU ({:.2}x real time), {steps} steps, {events} events; \
         body steps of the largest island {:.3e}, of the largest touching cluster {:.3e}: steps local to the \
         cluster could gain at most about {gain:.2}x (to {:.2}x real time)",
        span / cpu,
        work_island,
        work_cluster,
        gain * span / cpu
    );
    csv.write(csv_path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn touching_spheres_form_clusters_through_chains() {
        // a chain of three touching balls (1 apart at radius 0.6), a fourth apart, a fifth
        // 1.25 from the fourth (beyond the sum of the radii, 1.2: not touching)
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [10.0, 0.0, 0.0],
            [11.25, 0.0, 0.0],
        ];
        let radii = [0.6; 5];
        assert_eq!(touching(&p, &radii), (2, 3));
        // radii of their own: the fourth's larger one (0.7) reaches the fifth
        let radii = [0.6, 0.6, 0.6, 0.7, 0.6];
        assert_eq!(touching(&p, &radii), (3, 3));
        let apart = [[0.0, 0.0, 0.0], [5.0, 0.0, 0.0]];
        assert_eq!(touching(&apart, &[1.0, 1.0]), (0, 1));
    }

    #[test]
    fn the_windows_add_up_to_the_straight_run() {
        let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/pile_of_balls/scene.toml");
        let dir = std::env::temp_dir().join(format!("contact_fmu_bench_pile_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let csv = dir.join("pile.csv");
        let s = Settings {
            scene: scene.clone(),
            from: 0.2,
            to: 0.26,
            window: 0.025,
            repeats: 1,
            sample: 1e-3,
            csv: csv.clone(),
        };
        run(&s).unwrap();
        let text = std::fs::read_to_string(&csv).unwrap();
        let rows: Vec<Vec<f64>> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows.len(), 3, "windows 0.2-0.225-0.25-0.26:\n{text}");
        assert_eq!(rows[2][1], 0.26);
        // the straight run from 0.2 to 0.26 s takes the steps and meets the events of the
        // windows together
        let mut sim = Simulation::from_file(&scene).unwrap();
        sim.initialize(0.0).unwrap();
        let interval = sim.scene().model.interval;
        run_to(&mut sim, 0.2, interval).unwrap();
        let (c0, e0) = (sim.counters(), sim.energies().unwrap());
        run_to(&mut sim, 0.26, interval).unwrap();
        let (c1, e1) = (sim.counters(), sim.energies().unwrap());
        let sum = |k: usize| rows.iter().map(|r| r[k]).sum::<f64>();
        assert_eq!(sum(4), (c1.steps - c0.steps) as f64);
        assert_eq!(sum(6), (c1.events - c0.events) as f64);
        assert!(sum(6) > 0.0, "the balls land on the floor before 0.26 s");
        // the windows' energies are those of the same trajectory: their potential energy
        // changes add up to the straight run's (to the CSV's 7 digits), the last kinetic
        // energy is its own
        let drop = e1.potential - e0.potential;
        assert!(
            (sum(11) - drop).abs() <= 1e-6 * drop.abs(),
            "{} against {drop}",
            sum(11)
        );
        assert!((rows[2][10] - e1.kinetic).abs() <= 1e-6 * e1.kinetic);
        // the balls fall, and the energy balance holds in each window within what the error
        // control allows: a local error of each step in proportion to rtol of the energy that
        // moves (the kinetic energy and the potential energy lost), added up over the window's
        // steps without any cancelling (a bound of the worst case, the drift far below it)
        let rtol = sim.scene().solver.rtol;
        for r in &rows {
            assert!(r[11] < 0.0, "{r:?}");
            let bound = r[4] * rtol * (r[10] + r[11].abs());
            assert!(
                r[12].abs() <= bound,
                "energy balance changed by {} J (bound {bound} J) in {r:?}",
                r[12]
            );
        }
        // touching balls share an island: the largest island holds the largest cluster (means
        // over the samples), and at most all 27 balls
        for r in &rows {
            assert!(r[8] >= 1.0 && r[9] >= r[8] && r[9] <= 27.0, "{r:?}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
