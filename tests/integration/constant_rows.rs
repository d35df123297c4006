//! Constant rows of the mass matrix (`Plan::leaves`): a rotor (a wheel on its axle, `Rotor`)
//! whose axis keeps its direction relative to its ancestors' rotation axes (only prismatic,
//! fixed, or revolute joints about a parallel axis between them) has a constant row of M̄ and of
//! its factor; they are written once and the assembly and factorisation skip them. On random
//! states of scenes where that holds, the right-hand side and the full evaluation agree with
//! the general path (the same model without constant rows) to 1e-12, and a solve with the
//! factor solves the general path's M̄ to rounding (backward error ≤ 1e-14); where a rotor's
//! row varies, or a body is no rotor (multibody.rs: a lopsided wheel), it is not used.

use crate::common;
use contact_fmu::dynamics;
use contact_fmu::forward::{self, Rhs};
use contact_fmu::integrator::OdeSystem;
use contact_fmu::linalg::ConstantLeaves;
use contact_fmu::model::{Data, Model};
use contact_fmu::scene::{BodySpec, JointSpec, JointType, Scene};
use contact_fmu::scene_builder::SceneBuilder;
use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;

/// The same model with no constant rows: every row of M̄ assembled and factorised.
fn general(m: &Model) -> Model {
    let mut g = m.clone();
    g.plan.leaves.iter_mut().for_each(|l| *l = ConstantLeaves::default());
    g.plan.constant_row.iter_mut().for_each(|c| *c = false);
    g
}

/// The names of the joints whose rows are constant.
fn constant_joints(m: &Model) -> Vec<&str> {
    m.joints
        .iter()
        .zip(&m.plan.constant_row)
        .filter(|(_, &c)| c)
        .map(|(j, _)| j.name.as_str())
        .collect()
}

/// The names of the wheels' joints of a rail vehicle.
fn axles(m: &Model) -> Vec<&str> {
    let names = m.joints.iter().map(|j| j.name.as_str());
    names.filter(|n| n.starts_with("axle_")).collect()
}

/// A small xorshift generator: values in [-1, 1).
struct Random(u64);

impl Random {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// A random state near `start`: every joint coordinate moved (angles by up to `angle`, lengths
/// by up to `length`, quaternions turned at random), every velocity random (up to `speed`).
fn random_state(m: &Model, start: &[f64], seed: u64, angle: f64, length: f64, speed: f64) -> Vec<f64> {
    let mut r = Random(seed | 1);
    let mut y = start.to_vec();
    let turn = |r: &mut Random, q: &mut [f64]| {
        let t = UnitQuaternion::from_euler_angles(angle * r.next(), angle * r.next(), angle * r.next());
        let q0 = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]));
        let n = (q0 * t).into_inner();
        q.copy_from_slice(&[n.w, n.i, n.j, n.k]);
    };
    for j in &m.joints {
        let q = &mut y[j.qpos..j.qpos + j.nq()];
        match j.kind {
            JointType::Revolute => q[0] += 100.0 * angle * r.next(),
            JointType::Prismatic => q[0] += length * r.next(),
            JointType::Spherical => turn(&mut r, q),
            JointType::Free => {
                (0..3).for_each(|k| q[k] += length * r.next());
                turn(&mut r, &mut q[3..7]);
            }
            JointType::Fixed => {}
        }
    }
    y[m.nq..m.nq + m.nv].iter_mut().for_each(|v| *v = speed * r.next());
    y
}

/// Largest |a − b| over the largest |b|.
fn relative_difference(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0_f64, |s, x| s.max(x.abs()));
    a.iter().zip(b).fold(0.0_f64, |s, (x, y)| s.max((x - y).abs())) / scale
}

/// `M̄ x` with M̄ as the general path assembles it at the kinematics in `dg` (every row; the
/// lower entries on ancestor paths are those written), and `|M̄|` (its largest absolute row
/// sum).
fn general_mass_times(g: &Model, dg: &mut Data, x: &[f64]) -> (Vec<f64>, f64) {
    dynamics::mass_and_bias(g, dg);
    let (mut y, mut rows) = (vec![0.0; g.nv], vec![0.0; g.nv]);
    for (t, &(t0, n)) in g.trees.iter().enumerate() {
        let block = &dg.mass_blocks[g.tree_block[t]..g.tree_block[t] + n * n];
        for k in 0..n {
            y[t0 + k] += block[k * n + k] * x[t0 + k];
            rows[t0 + k] += block[k * n + k].abs();
            let mut i = g.dof_parent[t0 + k];
            while i != contact_fmu::linalg::NO_PARENT {
                let a = block[k * n + i];
                y[t0 + k] += a * x[t0 + i];
                y[t0 + i] += a * x[t0 + k];
                rows[t0 + k] += a.abs();
                rows[t0 + i] += a.abs();
                i = g.dof_parent[t0 + i];
            }
        }
    }
    (y, rows.iter().fold(0.0, |a: f64, &r| a.max(r)))
}

/// At state `y`: the relative differences between the model `m` (with its constant rows) and
/// the general model `g` of the accelerations of the right-hand side and of the full
/// evaluation, and the backward error `|M̄ x − b| / (|M̄| |x| + |b|)` (maximum norms) of a solve
/// `x = M̄⁻¹ b` with `m`'s factor, M̄ the general path's.
fn differences(m: &Model, dm: &mut Data, g: &Model, dg: &mut Data, y: &[f64], seed: u64) -> [f64; 3] {
    let n = m.nstate();
    let (mut fast, mut slow) = (vec![0.0; n], vec![0.0; n]);
    Rhs { model: m, data: dm }.rhs(0.0, y, &mut fast);
    Rhs { model: g, data: dg }.rhs(0.0, y, &mut slow);
    let accelerations = m.nq..m.nq + m.nv;
    let rhs = relative_difference(&fast[accelerations.clone()], &slow[accelerations]);
    for (model, data) in [(m, &mut *dm), (g, &mut *dg)] {
        data.eval_state.copy_from_slice(y);
        assert!(forward::evaluate(model, data));
    }
    let full = relative_difference(&dm.qacc, &dg.qacc);
    let mut r = Random(seed.wrapping_mul(31) | 1);
    let b: Vec<f64> = (0..m.nv).map(|_| r.next()).collect();
    let mut x = b.clone();
    dynamics::solve_mass(m, &dm.mass_blocks, &mut x);
    let (mx, norm) = general_mass_times(g, dg, &x);
    let largest = |v: &[f64]| v.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
    let residual = mx.iter().zip(&b).fold(0.0_f64, |a, (p, q)| a.max((p - q).abs()));
    [rhs, full, residual / (norm * largest(&x) + largest(&b))]
}

/// Checks [`differences`] (≤ 1e-12, 1e-12, 1e-14) at `cases` random states of `scene` (contacts as they are at
/// its start, or all touching with `touching`).
fn agree(scene: &Scene, seed: u64, cases: u64, touching: bool, (angle, length, speed): (f64, f64, f64)) {
    let (m, mut dm) = common::compile(scene.clone());
    let g = general(&m);
    let mut dg = Data::new(&g);
    dg.state.copy_from_slice(&dm.state);
    for d in [&mut dm, &mut dg] {
        for mem in d.contact_memory.iter_mut().filter(|_| touching) {
            mem.active = true;
            mem.impact_velocity = 0.05;
        }
    }
    for k in 0..cases {
        let s = seed.wrapping_add(k.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let y = random_state(&m, &dm.state, s, angle, length, speed);
        let [rhs, full, solve] = differences(&m, &mut dm, &g, &mut dg, &y, s);
        assert!(
            rhs <= 1e-12 && full <= 1e-12 && solve <= 1e-14,
            "{}, state {s:#x}: right-hand side {rhs:.2e}, evaluation {full:.2e}, backward error {solve:.2e}",
            m.name
        );
    }
}

fn rail_vehicle() -> Scene {
    Scene::from_file(&common::bundled("rail_vehicle")).unwrap()
}

/// A wheel (mass 2 kg, moments 0.03 about its axle and 0.02 across) on `axis` at `position`:
/// its body y axis along the axle.
fn wheel(name: &str, position: [f64; 3], axis: [f64; 3]) -> BodySpec {
    let turn = UnitQuaternion::rotation_between(&Vector3::y(), &Vector3::from(axis).normalize()).unwrap();
    BodySpec::new(name, 2.0, [0.02, 0.03, 0.02], position)
        .orientation(turn * UnitQuaternion::from_euler_angles(0.0, 0.4, 0.0))
}

fn link(name: &str, position: [f64; 3], turn: [f64; 3]) -> BodySpec {
    BodySpec::new(name, 3.0, [0.05, 0.07, 0.11], position)
        .orientation(UnitQuaternion::from_euler_angles(turn[0], turn[1], turn[2]))
}

/// Rotors behind every kind of ancestor, with body frames turned against the world's:
/// - a free `base` carrying `wheel_a` through a prismatic `slide` (constant), `wheel_b` through
///   a revolute `arm` (varies: the arm turns the axle against the base's rotation axes),
///   `wheel_c` through a revolute `rocker` about an axis parallel to its axle (constant);
/// - a `pendulum` on a revolute joint to the ground carrying `wheel_d` (constant);
/// - a `ball` on a spherical joint to the ground, a prismatic `rod` on it, `wheel_e` on the rod
///   (constant).
fn rotor_zoo() -> Scene {
    let (a, b, c) = ([0.3, -0.5, 0.81], [0.9, 0.2, -0.1], [-0.2, 0.7, 0.4]);
    let bodies = [
        link("base", [1.0, 2.0, 3.0], [0.3, -0.2, 0.5]),
        link("slide", [1.4, 2.1, 3.2], [-0.4, 0.1, 0.2]),
        wheel("wheel_a", [1.5, 2.3, 3.1], a),
        link("arm", [0.6, 1.8, 3.3], [0.2, 0.6, -0.3]),
        wheel("wheel_b", [0.4, 1.7, 3.5], b),
        link("rocker", [1.2, 2.6, 2.8], [0.1, 0.0, 0.9]),
        wheel("wheel_c", [1.3, 2.9, 2.7], c),
        link("pendulum", [-1.0, 0.0, 1.0], [0.7, 0.1, 0.0]),
        wheel("wheel_d", [-1.0, 0.3, 0.5], b),
        link("ball", [3.0, 0.0, 1.0], [0.0, 0.5, 0.5]),
        link("rod", [3.1, 0.2, 0.8], [0.2, 0.2, 0.2]),
        wheel("wheel_e", [3.2, 0.4, 0.6], a),
    ];
    use JointType::{Prismatic, Revolute, Spherical};
    let (slide, arm, rod, x, z) = (
        [0.6, 0.0, 0.8],
        [0.0, 0.3, 1.0],
        [0.0, 0.6, -0.8],
        [1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
    );
    // name, type, parent, child, anchor, axis (a spherical joint's is not used)
    let joints = [
        ("slide_guide", Prismatic, "base", "slide", [1.4, 2.1, 3.2], slide),
        ("axle_a", Revolute, "slide", "wheel_a", [1.5, 2.3, 3.1], a),
        ("arm_pivot", Revolute, "base", "arm", [0.8, 1.9, 3.2], arm),
        ("axle_b", Revolute, "arm", "wheel_b", [0.4, 1.7, 3.5], b),
        ("rocker_pivot", Revolute, "base", "rocker", [1.1, 2.4, 2.9], c),
        ("axle_c", Revolute, "rocker", "wheel_c", [1.3, 2.9, 2.7], c),
        ("pivot", Revolute, "ground", "pendulum", [-1.0, 0.0, 2.0], x),
        ("axle_d", Revolute, "pendulum", "wheel_d", [-1.0, 0.3, 0.5], b),
        ("ball_joint", Spherical, "ground", "ball", [3.0, 0.0, 1.5], z),
        ("rod_guide", Prismatic, "ball", "rod", [3.1, 0.2, 0.8], rod),
        ("axle_e", Revolute, "rod", "wheel_e", [3.2, 0.4, 0.6], a),
    ];
    SceneBuilder::new("rotor_zoo")
        .gravity([0.0, 0.0, -9.81])
        .bodies(bodies)
        .joints(joints.map(|(name, kind, parent, child, anchor, axis)| {
            JointSpec::new(name, kind, parent, child).anchor(anchor).axis(axis)
        }))
        .build()
}

#[test]
fn constant_rows_are_the_rotors_whose_axle_keeps_its_direction() {
    let (m, d) = common::compile(rail_vehicle());
    assert_eq!(constant_joints(&m), axles(&m));
    // one tree: each wheel's row is its spin inertia, and 1 at the car body's pitch (its axle
    // is the car's y axis), written into the factor at the start
    let leaves = &m.plan.leaves[0];
    assert_eq!(leaves.pivots.len(), 8);
    assert!(leaves.pivots.iter().all(|&(_, p)| p == 55.0));
    let car = m.joints.iter().find(|j| j.parent.is_none()).unwrap();
    assert!(
        leaves.factor.iter().all(|&(_, i, l)| i == car.qvel + 4 && l == 1.0),
        "{:?}",
        leaves.factor
    );
    assert_eq!(leaves.update, vec![(car.qvel + 4, car.qvel + 4, 8.0 * 55.0)]);
    let n = m.nv;
    for &(k, p) in &leaves.pivots {
        assert_eq!(d.mass_blocks[k * n + k], p);
    }

    // the track scene's wheels sit on side frames that pitch about an axis parallel to the
    // axles: their rows are constant too
    let (m, _) = common::compile(Scene::from_file(&common::bundled("rail_vehicle_track")).unwrap());
    assert_eq!((constant_joints(&m), axles(&m).len()), (axles(&m), 8));

    let (m, _) = common::compile(rotor_zoo());
    assert_eq!(constant_joints(&m), ["axle_a", "axle_c", "axle_d", "axle_e"]);
    let rotors = m.plan.rotors.iter().filter(|r| r.is_some()).count();
    assert_eq!(rotors, 5, "wheel_b is a rotor, its row varies");

    // no rotors, no constant rows
    for name in ["slider_crank", "bouncing_ball", "two_spheres", "pile_of_balls"] {
        let (m, _) = common::compile(Scene::from_file(&common::bundled(name)).unwrap());
        assert!(m.plan.leaves.iter().all(ConstantLeaves::is_empty), "{name}");
        assert!(constant_joints(&m).is_empty(), "{name}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    /// The rail vehicle: wheels turned by hundreds of radians, the car body and the bogies
    /// displaced, tilted by up to 0.1 rad and moving, every contact touching or none.
    #[test]
    fn rail_vehicle_agrees_with_the_general_path(seed in any::<u64>(), touching in any::<bool>()) {
        agree(&rail_vehicle(), seed, 4, touching, (0.1, 0.05, 2.0));
    }

    /// Every kind of ancestor, every joint turned at random by up to 3 rad.
    #[test]
    fn rotors_behind_any_joints_agree_with_the_general_path(seed in any::<u64>()) {
        agree(&rotor_zoo(), seed, 4, false, (3.0, 0.3, 5.0));
    }
}
