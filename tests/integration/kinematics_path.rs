//! `kinematics::kinematics_path` (used by event location) against the full `kinematics::kinematics`:
//! along a body's path to the ground it must give the same poses, velocities, bias
//! accelerations, inertias and motion subspaces bit for bit, and touch no other body.

use crate::common;

use contact_fmu::compile::compile;
use contact_fmu::kinematics;
use contact_fmu::model::{Data, Model};
use contact_fmu::scene::Scene;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// The rail vehicle's compiled model and data.
fn compiled() -> (Model, Data) {
    let scene = Scene::from_file(&common::bundled("rail_vehicle")).unwrap();
    compile(&scene, "rail_vehicle").unwrap()
}

/// The rail vehicle (car → bogies (prismatic) → wheels (revolute): paths of depth 3) at a
/// state away from the start: every coordinate shifted, every velocity nonzero.
fn rail_vehicle() -> (Model, Data, Vec<f64>) {
    let (m, d) = compiled();
    let mut state = d.state.clone();
    for (k, x) in state[..m.nq].iter_mut().enumerate() {
        *x += 0.01 * ((k % 7) as f64 - 3.0);
    }
    for (k, x) in state[m.nq..m.nq + m.nv].iter_mut().enumerate() {
        *x = 0.3 * ((k * 5 % 11) as f64 - 5.0) + 0.05;
    }
    (m, d, state)
}

/// Overwrites every body and motion-subspace entry with NaN.
fn poison(d: &mut Data) {
    let nan3 = Vector3::repeat(f64::NAN);
    for b in 0..d.body_pos.len() {
        d.body_pos[b] = nan3;
        d.body_rot[b] = Matrix3::repeat(f64::NAN);
        d.body_quat[b] = UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(f64::NAN, 0.0, 0.0, 0.0));
        d.body_vel[b].ang = nan3;
        d.body_vel[b].lin = nan3;
        d.body_acc_bias[b].ang = nan3;
        d.body_acc_bias[b].lin = nan3;
        d.body_inertia[b].mass = f64::NAN;
    }
    for s in d.dof_s.iter_mut().chain(d.dof_sdot.iter_mut()) {
        s.ang = nan3;
        s.lin = nan3;
    }
}

/// All numbers describing body `b` (and its joint's motion subspace) as bit patterns: its
/// motion (`motion_bits`), bias acceleration, inertia and the motion subspace's rates.
fn body_bits(m: &Model, d: &Data, b: usize) -> Vec<u64> {
    let j = &m.joints[m.bodies[b].joint];
    let mut v: Vec<f64> = Vec::new();
    v.extend(d.body_acc_bias[b].ang.iter().chain(d.body_acc_bias[b].lin.iter()));
    let i = &d.body_inertia[b];
    v.push(i.mass);
    v.extend(i.h.iter().chain(i.i_o.iter()));
    for s in &d.dof_sdot[j.qvel..j.qvel + j.nv()] {
        v.extend(s.ang.iter().chain(s.lin.iter()));
    }
    let mut bits = motion_bits(m, d, b);
    bits.extend(v.into_iter().map(f64::to_bits));
    bits
}

#[test]
fn path_kinematics_equals_full_kinematics_and_touches_only_the_path() {
    let (m, mut full, state) = rail_vehicle();
    full.eval_state.copy_from_slice(&state);
    kinematics::kinematics(&m, &mut full);
    let mut deepest = 0;
    for b in 0..m.bodies.len() {
        let mut ancestors = vec![b];
        while let Some(p) = m.joints[m.bodies[*ancestors.last().unwrap()].joint].parent {
            ancestors.push(p);
        }
        deepest = deepest.max(ancestors.len());
        let mut d = compiled().1;
        poison(&mut d);
        d.eval_state.copy_from_slice(&state);
        kinematics::kinematics_path(&m, &mut d, Some(b));
        for other in 0..m.bodies.len() {
            if ancestors.contains(&other) {
                assert_eq!(
                    body_bits(&m, &d, other),
                    body_bits(&m, &full, other),
                    "body {} on the path of {}",
                    m.bodies[other].name,
                    m.bodies[b].name
                );
            } else {
                assert!(
                    d.body_pos[other][0].is_nan(),
                    "body {} is off the path",
                    m.bodies[other].name
                );
                assert!(d.body_inertia[other].mass.is_nan());
            }
        }
    }
    assert_eq!(deepest, 3, "the test needs paths deeper than one joint");
    // Ground: nothing to evaluate.
    let mut d = compiled().1;
    poison(&mut d);
    d.eval_state.copy_from_slice(&state);
    kinematics::kinematics_path(&m, &mut d, None);
    assert!(d.body_pos.iter().all(|p| p[0].is_nan()));
}

/// A body's pose, orientation and spatial velocity (and its joint's motion subspace) as bit
/// patterns: what `kinematics::poses_and_velocities` computes.
fn motion_bits(m: &Model, d: &Data, b: usize) -> Vec<u64> {
    let j = &m.joints[m.bodies[b].joint];
    let q = d.body_quat[b].quaternion();
    let mut v: Vec<f64> = Vec::new();
    v.extend(d.body_pos[b].iter());
    v.extend(d.body_rot[b].iter());
    v.extend([q.w, q.i, q.j, q.k]);
    v.extend(d.body_vel[b].ang.iter().chain(d.body_vel[b].lin.iter()));
    for s in &d.dof_s[j.qvel..j.qvel + j.nv()] {
        v.extend(s.ang.iter().chain(s.lin.iter()));
    }
    v.into_iter().map(f64::to_bits).collect()
}

/// `kinematics::poses_and_velocities` (the contact groups' margin values after a new broad
/// phase) gives every body's pose, orientation, velocity and motion subspace bit for bit as
/// `kinematics::kinematics`: on the pile of balls (free bodies, every one turned and spinning)
/// and the rail vehicle (joints).
#[test]
fn poses_and_velocities_are_those_of_kinematics() {
    for name in ["pile_of_balls", "rail_vehicle"] {
        let scene = Scene::from_file(&common::bundled(name)).unwrap();
        let (m, d) = compile(&scene, name).unwrap();
        let mut state = d.state.clone();
        for (k, x) in state[..m.nq].iter_mut().enumerate() {
            *x += 0.01 * ((k % 7) as f64 - 3.0);
        }
        for (k, x) in state[m.nq..m.nq + m.nv].iter_mut().enumerate() {
            *x = 0.3 * ((k * 5 % 11) as f64 - 5.0) + 0.05;
        }
        let (mut full, mut lean) = (compile(&scene, name).unwrap().1, d);
        full.eval_state.copy_from_slice(&state);
        kinematics::kinematics(&m, &mut full);
        poison(&mut lean);
        lean.eval_state.copy_from_slice(&state);
        kinematics::poses_and_velocities(&m, &mut lean);
        if name == "pile_of_balls" {
            assert!(m.plan.free.len() == m.bodies.len(), "the pile's balls are free bodies");
        }
        for b in 0..m.bodies.len() {
            assert_eq!(
                motion_bits(&m, &lean, b),
                motion_bits(&m, &full, b),
                "{name}: body {}",
                m.bodies[b].name
            );
        }
    }
}
