//! The integrator continues across communication points (the default): with no input or
//! parameter changed, the work does not depend on the communication step, and the results
//! agree within the tolerance.

use crate::common;

use common::bundled_scenes;
use contact_fmu::simulation::Simulation;

/// Runs `path` to its stop time at communication step `interval`; returns the RHS count and
/// the outputs at the multiples of 0.01 s (every output, in table order).
fn run(path: &std::path::Path, interval: f64) -> (u64, Vec<Vec<f64>>) {
    let mut s = Simulation::from_file(path).unwrap_or_else(|e| panic!("{e}"));
    s.initialize(0.0).unwrap();
    let stop = s.scene().model.stop_time;
    // every output but the work counters (which differ by design)
    let outputs: Vec<usize> = s
        .output_indices()
        .into_iter()
        .filter(|&i| !s.table().vars[i].name.starts_with("solver."))
        .collect();
    let every = (0.01 / interval).round() as u64;
    let mut rows = Vec::new();
    let mut k = 0u64;
    s.run(stop, interval, |s| {
        k += 1;
        if k.is_multiple_of(every) {
            rows.push(outputs.iter().map(|&i| s.get(i).unwrap()).collect());
        }
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (s.counters().rhs_evals, rows)
}

#[test]
fn work_does_not_depend_on_the_communication_step() {
    for (name, path) in bundled_scenes() {
        let (fine, a) = run(&path, 1e-4);
        let (coarse, b) = run(&path, 1e-2);
        let ratio = fine as f64 / coarse as f64;
        // the largest difference of any output at the common points, relative to the range
        // of that output over the run
        let mut worst: f64 = 0.0;
        for j in 0..a[0].len() {
            let col = a.iter().map(|r| r[j]);
            let range = col.clone().fold(f64::NEG_INFINITY, f64::max) - col.clone().fold(f64::INFINITY, f64::min);
            let magnitude = col.fold(0.0_f64, |m, v| m.max(v.abs()));
            for (ra, rb) in a.iter().zip(&b) {
                // An output that is constant up to rounding has no range to compare with: one
                // that is zero (the contact torque of a frictionless sphere, ~1e-19 N m) is
                // held to 1e-15 absolute, 1e-5 of a range of 1e-10; one that is not (a wheel's
                // height on a straight track, 0.75 m, whose range is a few ulps) to 1e-15 of
                // its magnitude, 1e-5 of a range of 1e-10 of it.
                let scale = range.max(1e-10 * magnitude).max(1e-10);
                worst = worst.max((ra[j] - rb[j]).abs() / scale);
            }
        }
        println!("{name}: {fine} RHS at 1e-4 s, {coarse} at 1e-2 s (ratio {ratio:.3}); largest difference {worst:.1e} of the range");
        assert_eq!(a.len(), b.len(), "{name}: rows");
        assert!(
            (1.0 / 1.2..=1.2).contains(&ratio),
            "{name}: RHS {fine} at 1e-4 s against {coarse} at 1e-2 s"
        );
        assert!(worst < 1e-5, "{name}: outputs differ by {worst:.1e} of their range");
    }
}
