//! Helpers shared by the integration tests: simulations of scenes built with
//! `contact_fmu::scene_builder`, outputs read by name, a stepping loop. Include with `mod common;`
//! (the counting allocator of the allocation tests is separate: `common/alloc_counter.rs`).

// Each test binary uses a part of these.
#![allow(dead_code)]

use contact_fmu::model::{Data, Model};
use contact_fmu::scene::Scene;
use contact_fmu::simulation::Simulation;
use contact_fmu::variables::{Causality, Variability};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use std::path::{Path, PathBuf};

/// Name of the scenes in messages.
pub const ORIGIN: &str = "test.toml";

/// The bundled scene `fmu/<name>/scene.toml`.
pub fn bundled(name: &str) -> PathBuf {
    fmu_dir().join(name).join("scene.toml")
}

/// Every bundled scene: (name, path), sorted by name.
pub fn bundled_scenes() -> Vec<(String, PathBuf)> {
    contact_fmu::bench::bundled_scenes(&fmu_dir()).unwrap_or_else(|e| panic!("{e}"))
}

fn fmu_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu")
}

/// Validates `scene` like a scene file (panics with the message if it is not valid).
pub fn checked(scene: impl Into<Scene>) -> Scene {
    let scene = scene.into();
    scene.validate(ORIGIN).unwrap_or_else(|e| panic!("{e}"));
    scene
}

/// A simulation of `scene`, not initialised (parameters may still be set).
pub fn open(scene: impl Into<Scene>) -> Simulation {
    Simulation::new(checked(scene), ORIGIN)
}

/// A simulation of `scene`, initialised at t = 0.
pub fn start(scene: impl Into<Scene>) -> Simulation {
    let mut s = open(scene);
    s.initialize(0.0).unwrap_or_else(|e| panic!("{e}"));
    s
}

/// The compiled model of `scene` and its data at the initial state.
pub fn compile(scene: impl Into<Scene>) -> (Model, Data) {
    contact_fmu::compile::compile(&checked(scene), ORIGIN).unwrap_or_else(|e| panic!("{e}"))
}

/// The value of variable `name`.
pub fn get(s: &mut Simulation, name: &str) -> f64 {
    let vr = s.table().index_of(name).unwrap_or_else(|| panic!("no variable {name}"));
    s.get(vr).unwrap()
}

/// The vector output `prefix[1]`, `prefix[2]`, `prefix[3]` (e.g. `ball.v`).
pub fn vec_out(s: &mut Simulation, prefix: &str) -> Vector3<f64> {
    Vector3::new(
        get(s, &format!("{prefix}[1]")),
        get(s, &format!("{prefix}[2]")),
        get(s, &format!("{prefix}[3]")),
    )
}

/// The orientation output `body.q[1..4]`.
pub fn quat_out(s: &mut Simulation, body: &str) -> UnitQuaternion<f64> {
    let q: Vec<f64> = (1..=4).map(|k| get(s, &format!("{body}.q[{k}]"))).collect();
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
}

/// Total plus dissipated energy [J]: constant when the energy balance holds.
pub fn energy_balance(s: &mut Simulation) -> f64 {
    get(s, "energy.total") + get(s, "energy.dissipated")
}

/// Runs `s` to `t_end` in steps of `dt`, calling `each` at every communication point
/// (the start included).
pub fn run(s: &mut Simulation, t_end: f64, dt: f64, mut each: impl FnMut(&mut Simulation, f64)) {
    each(s, 0.0);
    let n = (t_end / dt).round() as usize;
    for k in 1..=n {
        let t = k as f64 * dt;
        s.step_to(t).unwrap_or_else(|e| panic!("{e}"));
        each(s, t);
    }
}

/// One classical Runge-Kutta step of size `h` of `ẍ = acc(x, ẋ)` from `(x, v)`: the new
/// `(x, v)` (for scalar reference solutions written independently of the library).
pub fn rk4_step(acc: impl Fn(f64, f64) -> f64, x: f64, v: f64, h: f64) -> (f64, f64) {
    let (k1x, k1v) = (v, acc(x, v));
    let (k2x, k2v) = (v + 0.5 * h * k1v, acc(x + 0.5 * h * k1x, v + 0.5 * h * k1v));
    let (k3x, k3v) = (v + 0.5 * h * k2v, acc(x + 0.5 * h * k2x, v + 0.5 * h * k2v));
    let (k4x, k4v) = (v + h * k3v, acc(x + h * k3x, v + h * k3v));
    let xn = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
    let vn = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
    (xn, vn)
}

/// Writes `text` into the file `name` of a temporary folder of this process for the tests of
/// `group`; returns the file's path.
pub fn temp_scene(group: &str, name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("contact_fmu_{group}_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Runs the command line `contact-fmu args…` (with backtraces, so that a panic would show);
/// returns (success, stderr).
pub fn run_command(args: &[&str]) -> (bool, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_contact-fmu"))
        .args(args)
        .env("RUST_BACKTRACE", "1")
        .output()
        .expect("cannot run contact-fmu");
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// Runs `contact-fmu export <scene> -o <out>` for linux64 alone with `library` as its library
/// (any file: tests of the scene and the names, not of the library); returns (success, stderr).
pub fn export_linux64_with(scene: &Path, out: &Path, library: &Path) -> (bool, String) {
    let binary = format!("linux64={}", library.display());
    run_command(&[
        "export",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--platforms",
        "linux64",
        "--binary",
        &binary,
    ])
}

/// Asserts that a command's `(success, stderr)` (of `run_command` on the scene file `scene`) is
/// a refusal in one line naming the file and holding every fragment, without a panic; `label`
/// names the case.
pub fn assert_refused_in_one_line(label: &str, scene: &Path, (ok, err): (bool, String), fragments: &[&str]) {
    eprintln!("{label}: {}", err.trim());
    assert!(!ok, "{label}: exit status 0");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{label}: expected one line, got {err:?}");
    assert!(
        !err.contains("panicked") && !err.contains("backtrace"),
        "{label}: {err}"
    );
    assert!(
        lines[0].starts_with(&format!("error: {}: ", scene.display())),
        "{label}: the message does not start with the file: {err}"
    );
    for f in fragments {
        assert!(err.contains(f), "{label}: {err:?} lacks {f:?}");
    }
}

/// Relative difference `|a − b| / |b|`.
pub fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// xorshift64: a deterministic generator, its numbers depending on the seed only.
pub struct Rng(pub u64);

impl Rng {
    /// The next 64 bits.
    pub fn bits(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// A number in [0, 1).
    pub fn next(&mut self) -> f64 {
        (self.bits() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A number in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }

    /// A whole number below `n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.bits() % n.max(1) as u64) as usize
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        self.next() < p
    }

    /// A point of the cube [−half, half)³.
    pub fn vector(&mut self, half: f64) -> [f64; 3] {
        [
            self.range(-half, half),
            self.range(-half, half),
            self.range(-half, half),
        ]
    }

    /// A unit vector: a point of the cube whose norm is in (0.1, 1), normalised.
    pub fn unit(&mut self) -> Vector3<f64> {
        loop {
            let v = Vector3::from(self.vector(1.0));
            if v.norm() > 0.1 && v.norm() < 1.0 {
                return v.normalize();
            }
        }
    }
}

/// The variables a host may set after initialisation: the tunable parameters and the inputs.
pub fn settable(sim: &Simulation) -> Vec<usize> {
    sim.variables()
        .iter()
        .enumerate()
        .filter(|(_, v)| {
            v.causality == Causality::Input
                || (v.causality == Causality::Parameter && v.variability == Variability::Tunable)
        })
        .map(|(vr, _)| vr)
        .collect()
}
