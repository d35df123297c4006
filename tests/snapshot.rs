//! A saved state restored into a fresh simulation continues bit for bit like the original,
//! for every bundled scene (the property `fmi2SetFMUstate` and serialisation rely on).

use contact_fmu::simulation::{Simulation, Snapshot};
use contact_fmu::variables::Causality;
use std::path::Path;

fn outputs(sim: &mut Simulation) -> Vec<u64> {
    let idx: Vec<usize> = sim
        .variables()
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == Causality::Output)
        .map(|(i, _)| i)
        .collect();
    idx.iter().map(|&i| sim.get(i).unwrap().to_bits()).collect()
}

fn check_scene(path: &Path) {
    let mut a = Simulation::from_file(path).unwrap();
    let stop = a.scene().model.stop_time.min(0.6);
    let h = a.scene().model.interval.max(stop / 400.0);
    a.initialize(0.0).unwrap();
    let n = (stop / h).round() as usize;
    let split = n / 3;
    for k in 1..=split {
        a.step_to(k as f64 * h).unwrap();
    }
    let bytes = a.snapshot().to_bytes();
    let mut b = Simulation::from_file(path).unwrap();
    b.restore(&Snapshot::from_bytes(&bytes).unwrap()).unwrap();
    assert_eq!(
        outputs(&mut a),
        outputs(&mut b),
        "{}: outputs differ right after restore",
        path.display()
    );
    for k in split + 1..=n {
        let t = k as f64 * h;
        a.step_to(t).unwrap();
        b.step_to(t).unwrap();
        assert_eq!(
            outputs(&mut a),
            outputs(&mut b),
            "{}: restored run differs from the original at t = {t}",
            path.display()
        );
    }
}

#[test]
fn restored_state_continues_bit_identically_for_every_bundled_scene() {
    let mut n = 0;
    for entry in std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/fmu")).unwrap() {
        let p = entry.unwrap().path().join("scene.toml");
        if p.is_file() {
            check_scene(&p);
            n += 1;
        }
    }
    assert!(n >= 4, "expected the bundled scenes, found {n}");
}
