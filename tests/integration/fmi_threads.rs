//! Eight FMU instances stepped at the same time from eight threads through the C functions
//! give, bit for bit, the outputs of the same eight sessions run one after another: every
//! bundled scene, each with its own parameters and with changed ones, so that no two threads
//! run the same computation.

use crate::fmu_session;

use fmu_session::{linked_api, run_session, SceneDir};
use std::sync::Barrier;

/// One session: the scene, its parameter settings, the step size and the number of steps.
struct Case {
    dir: SceneDir,
    parameters: Vec<(u32, f64)>,
    h: f64,
    steps: usize,
}

fn cases() -> Vec<Case> {
    let mut cases = Vec::new();
    for name in ["bouncing_ball", "rail_vehicle", "slider_crank", "two_spheres"] {
        for variant in 0..2 {
            let dir = SceneDir::bundled(name, &format!("threads {name} {variant}"));
            let sim = dir.simulation();
            let h = sim.scene().model.interval;
            // the second variant integrates to another tolerance and with another step limit
            let parameters = if variant == 0 {
                Vec::new()
            } else {
                vec![(dir.vr("solver.rtol"), 1e-6), (dir.vr("solver.max_step"), 2.5e-4)]
            };
            cases.push(Case {
                dir,
                parameters,
                h,
                steps: 150,
            });
        }
    }
    cases
}

#[test]
fn eight_instances_on_eight_threads_equal_serial_runs_bit_for_bit() {
    let api = linked_api();
    let cases = cases();
    assert_eq!(cases.len(), 8);
    let serial: Vec<Vec<Vec<u64>>> = cases
        .iter()
        .map(|c| run_session(&api, &c.dir, "serial", &c.parameters, c.h, c.steps))
        .collect();
    // the variants differ from their scene's default run: the threads compute different things
    for pair in serial.chunks(2) {
        assert_ne!(pair[0], pair[1]);
    }
    let start = Barrier::new(cases.len());
    let parallel: Vec<Vec<Vec<u64>>> = std::thread::scope(|s| {
        let threads: Vec<_> = cases
            .iter()
            .map(|c| {
                let start = &start;
                s.spawn(move || {
                    start.wait();
                    run_session(&api, &c.dir, "parallel", &c.parameters, c.h, c.steps)
                })
            })
            .collect();
        threads.into_iter().map(|t| t.join().unwrap()).collect()
    });
    for (k, (p, s)) in parallel.iter().zip(&serial).enumerate() {
        let first = p.iter().zip(s).position(|(a, b)| a != b);
        assert_eq!(first, None, "case {k} differs first after step {first:?}");
    }
}
