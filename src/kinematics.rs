//! Kinematics in joint coordinates: body poses, spatial velocities and bias accelerations
//! from the coordinates, by one pass down each tree (the velocity transformation `Y = B q̇`,
//! docs/physics.md (31)-(34)); the motion subspaces `S_k` (the columns of `B`) and their
//! rates; Jacobian rows of body-fixed quantities.
//!
//! Everything is evaluated at `Data::eval_state`, the state the caller put there; results go
//! to the kinematics part of [`Data`]. All spatial quantities are in world-frame Plücker
//! coordinates at the world origin (see [`crate::spatial`]).

use crate::model::{Data, FreeBody, Model, Rotor};
use crate::scene::JointType;
use crate::spatial::{Frame, Inertia, Placement, Spatial};
use nalgebra::{Matrix3, Quaternion, Unit, UnitQuaternion, Vector3};

/// The frame of body `b` (None = ground).
#[inline]
pub fn frame(d: &Data, b: Option<usize>) -> Frame {
    match b {
        Some(i) => Frame {
            pos: d.body_pos[i],
            rot: d.body_rot[i],
            quat: d.body_quat[i],
            vel: d.body_vel[i],
            acc: d.body_acc_bias[i],
        },
        None => Frame::ground(),
    }
}

/// The placement of body `b` (None = ground: None) at the evaluated kinematics.
#[inline]
pub fn placement(d: &Data, b: Option<usize>) -> Option<Placement<'_>> {
    b.map(|i| Placement {
        pos: &d.body_pos[i],
        rot: &d.body_rot[i],
        vel: &d.body_vel[i],
    })
}

/// The unit quaternion of four coordinates (w, x, y, z), normalised.
pub fn quat_at(q: &[f64]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
}

/// Position and velocity kinematics from the state: body poses, spatial velocities, bias
/// accelerations (q̈ = 0), motion subspaces and their rates, spatial inertias.
pub fn kinematics(m: &Model, d: &mut Data) {
    d.planned_kinematics = false;
    for ji in 0..m.joints.len() {
        joint_kinematics(m, d, ji);
    }
}

/// Kinematics of body `body` (None = ground: nothing to do) and of its ancestors only, root
/// first: after it, the body's pose, velocity, bias acceleration, inertia and the motion
/// subspaces of the joints on its path are those [`kinematics`] gives (bit for bit); every
/// other body's entries are left as they were (stale). The path is collected in the
/// preallocated `Data::path_joints` (no allocation).
pub fn kinematics_path(m: &Model, d: &mut Data, body: Option<usize>) {
    let Some(mut b) = body else { return };
    d.path_joints.clear();
    d.path_joints.reserve(m.joints.len()); // a no-op once the buffer has its capacity
    loop {
        let ji = m.bodies[b].joint;
        d.path_joints.push(ji);
        match m.joints[ji].parent {
            Some(p) => b = p,
            None => break,
        }
    }
    for k in (0..d.path_joints.len()).rev() {
        joint_kinematics(m, d, d.path_joints[k]);
    }
}

/// Kinematics of tree joint `ji` and its child body, from its parent's (already evaluated)
/// frame: one iteration of [`kinematics`].
pub fn joint_kinematics(m: &Model, d: &mut Data, ji: usize) {
    let j = &m.joints[ji];
    let p = frame(d, j.parent);
    let c = j.child;
    let q = &d.eval_state[j.qpos..j.qpos + j.nq()];
    let w = &d.eval_state[m.nq + j.qvel..m.nq + j.qvel + j.nv()];
    let (pos, quat);
    let mut vel = p.vel;
    let mut acc = p.acc;
    match j.kind {
        JointType::Revolute | JointType::Prismatic => {
            // the motion subspace of the one degree of freedom
            let s = if j.kind == JointType::Revolute {
                let h = p.rot * j.axis;
                let pj = p.pos + p.rot * j.anchor;
                let rel = UnitQuaternion::from_axis_angle(&Unit::new_unchecked(j.axis), q[0]);
                quat = p.quat * rel * j.rot0;
                pos = pj + p.rot * (rel * j.offset);
                Spatial::new(h, pj.cross(&h))
            } else {
                let t = p.rot * j.axis;
                quat = p.quat * j.rot0;
                pos = p.pos + p.rot * (j.offset + j.axis * q[0]);
                Spatial::new(Vector3::zeros(), t)
            };
            vel = vel.add(&s.scale(w[0]));
            let sdot = p.vel.cross_motion(&s);
            acc = acc.add(&sdot.scale(w[0]));
            d.dof_s[j.qvel] = s;
            d.dof_sdot[j.qvel] = sdot;
        }
        JointType::Fixed => {
            quat = p.quat * j.rot0;
            pos = p.pos + p.rot * j.offset;
        }
        JointType::Spherical => {
            quat = p.quat * quat_at(q);
            let rot = *quat.to_rotation_matrix().matrix();
            let pj = p.pos + p.rot * j.anchor;
            pos = pj + rot * j.offset;
            for (k, &wk) in w.iter().enumerate() {
                let h = rot.column(k).into_owned();
                let s = Spatial::new(h, pj.cross(&h));
                d.dof_s[j.qvel + k] = s;
                vel = vel.add(&s.scale(wk));
            }
            for (k, &wk) in w.iter().enumerate() {
                let sdot = vel.cross_motion(&d.dof_s[j.qvel + k]);
                d.dof_sdot[j.qvel + k] = sdot;
                acc = acc.add(&sdot.scale(wk));
            }
        }
        JointType::Free => {
            let s = &mut d.dof_s[j.qvel..j.qvel + 6];
            (pos, quat, vel) = free_joint_motion(&p, q, w, s);
            for (k, &wk) in w.iter().enumerate() {
                // the translations' rates from the parent's velocity, the rotations' from the child's
                let sdot = if k < 3 { p.vel } else { vel }.cross_motion(&d.dof_s[j.qvel + k]);
                d.dof_sdot[j.qvel + k] = sdot;
                acc = acc.add(&sdot.scale(wk));
            }
        }
    }
    let rot = *quat.to_rotation_matrix().matrix();
    d.body_pos[c] = pos;
    d.body_rot[c] = rot;
    d.body_quat[c] = quat;
    d.body_vel[c] = vel;
    d.body_acc_bias[c] = acc;
    let b = &m.bodies[c];
    // R diag(I) Rᵀ as the sum of I_k r_k r_kᵀ over the columns r_k of R
    let mut i_c = Matrix3::zeros();
    for k in 0..3 {
        let r = rot.column(k);
        i_c += (r * b.inertia[k]) * r.transpose();
    }
    d.body_inertia[c] = Inertia::from_body(b.mass, &pos, &i_c);
}

/// The pose, orientation and spatial velocity of a free joint's child from its parent's frame
/// `p`, the joint's coordinates `q` and rates `w`, its motion subspace into `s` (six columns):
/// what [`joint_kinematics`] computes of them (it calls this, then adds the rates, bias
/// acceleration and inertia; [`poses_and_velocities`] does not).
fn free_joint_motion(
    p: &Frame,
    q: &[f64],
    w: &[f64],
    s: &mut [Spatial],
) -> (Vector3<f64>, UnitQuaternion<f64>, Spatial) {
    let quat = p.quat * quat_at(&q[3..7]);
    let rot = *quat.to_rotation_matrix().matrix();
    let pos = p.pos + p.rot * Vector3::new(q[0], q[1], q[2]);
    let mut vel = p.vel;
    for k in 0..3 {
        s[k] = Spatial::new(Vector3::zeros(), p.rot.column(k).into_owned());
        vel = vel.add(&s[k].scale(w[k]));
    }
    for k in 0..3 {
        let h = rot.column(k).into_owned();
        s[3 + k] = Spatial::new(h, pos.cross(&h));
        vel = vel.add(&s[3 + k].scale(w[3 + k]));
    }
    (pos, quat, vel)
}

/// The poses, orientations and spatial velocities of every body, bit for bit as [`kinematics`]
/// gives them (and the motion subspaces): the plan's general joints by [`joint_kinematics`],
/// its free bodies without their motion subspaces' rates, bias accelerations and inertias
/// (left as they were: code that reads those calls [`kinematics`]). For what reads poses and
/// velocities only, where the velocities must be those of [`kinematics`] (the lean
/// [`free_body_kinematics`] rounds them otherwise).
pub fn poses_and_velocities(m: &Model, d: &mut Data) {
    d.planned_kinematics = false;
    for &ji in &m.plan.general.joints {
        joint_kinematics(m, d, ji);
    }
    let ground = Frame::ground();
    for fb in &m.plan.free {
        let (q, w) = (
            &d.eval_state[fb.qpos..fb.qpos + 7],
            &d.eval_state[m.nq + fb.qvel..m.nq + fb.qvel + 6],
        );
        let (pos, quat, vel) = free_joint_motion(&ground, q, w, &mut d.dof_s[fb.qvel..fb.qvel + 6]);
        let b = fb.body;
        d.body_pos[b] = pos;
        d.body_rot[b] = *quat.to_rotation_matrix().matrix();
        d.body_quat[b] = quat;
        d.body_vel[b] = vel;
    }
}

/// [`poses_and_velocities`] at the data's state (`d.state`, copied into `d.eval_state`).
pub fn poses_and_velocities_at_state(m: &Model, d: &mut Data) {
    d.eval_state.copy_from_slice(&d.state);
    poses_and_velocities(m, d);
}

/// The lean kinematics of a rotor joint ([`Rotor`]): as [`joint_kinematics`] without the
/// rotation by the joint angle, which moves nothing the right-hand side reads (the child's
/// centre of mass and its spheres lie on the axis, its inertia is symmetric about it): the
/// child's orientation is left at the joint frame's (`body_rot`, `body_quat` are not the
/// body's; code that reads them calls [`kinematics`]), its world inertia is
/// `I_t 1 + (I_a − I_t) h hᵀ`.
pub fn rotor_kinematics(m: &Model, d: &mut Data, ji: usize, r: &Rotor) {
    let j = &m.joints[ji];
    let p = frame(d, j.parent);
    let c = j.child;
    let w = d.eval_state[m.nq + j.qvel];
    let h = p.rot * j.axis;
    let pj = p.pos + p.rot * j.anchor;
    let pos = pj + p.rot * j.offset;
    let s = Spatial::new(h, pj.cross(&h));
    let sdot = p.vel.cross_motion(&s);
    d.dof_s[j.qvel] = s;
    d.dof_sdot[j.qvel] = sdot;
    d.body_pos[c] = pos;
    d.body_rot[c] = p.rot * r.rot0;
    d.body_quat[c] = p.quat * j.rot0;
    d.body_vel[c] = p.vel.add(&s.scale(w));
    d.body_acc_bias[c] = p.acc.add(&sdot.scale(w));
    let i_c = Matrix3::from_diagonal_element(r.transverse) + (h * (r.axial - r.transverse)) * h.transpose();
    d.body_inertia[c] = Inertia::from_body(m.bodies[c].mass, &pos, &i_c);
}

/// The lean kinematics of a free body ([`FreeBody`]): its pose and spatial velocity only
/// (the pose bit for bit as [`joint_kinematics`] gives it). Its motion subspaces, bias
/// acceleration and spatial inertia are not computed: Newton-Euler
/// ([`crate::dynamics::free_body_accelerations`]) needs none of them.
#[inline]
pub fn free_body_kinematics(m: &Model, d: &mut Data, fb: &FreeBody) {
    let q = &d.eval_state[fb.qpos..fb.qpos + 7];
    let w = &d.eval_state[m.nq + fb.qvel..m.nq + fb.qvel + 6];
    let pos = Vector3::new(q[0], q[1], q[2]);
    let quat = quat_at(&q[3..7]);
    let rot = *quat.to_rotation_matrix().matrix();
    let omega = rot * Vector3::new(w[3], w[4], w[5]);
    let v = Vector3::new(w[0], w[1], w[2]);
    let b = fb.body;
    d.body_pos[b] = pos;
    d.body_rot[b] = rot;
    d.body_quat[b] = quat;
    d.body_vel[b] = Spatial::new(omega, v + pos.cross(&omega));
}

/// Time derivative of the position coordinates (quaternion rates for spherical and free
/// joints: `Q̇ = ½ Q ⊗ (0, w)`, which keeps |Q| constant in exact arithmetic).
pub fn position_derivative(m: &Model, state: &[f64], qpos_dot: &mut [f64]) {
    let qvel = &state[m.nq..m.nq + m.nv];
    for j in &m.joints {
        let (a, v) = (j.qpos, j.qvel);
        match j.kind {
            JointType::Revolute | JointType::Prismatic => qpos_dot[a] = qvel[v],
            JointType::Fixed => {}
            JointType::Spherical => quat_rate(&state[a..a + 4], &qvel[v..v + 3], &mut qpos_dot[a..a + 4]),
            JointType::Free => {
                // (as arrays: the indices below need no bounds checks)
                let q: &[f64; 7] = state[a..a + 7].try_into().expect("a free joint has 7 coordinates");
                let w: &[f64; 6] = qvel[v..v + 6].try_into().expect("a free joint has 6 rates");
                let out: &mut [f64; 7] = (&mut qpos_dot[a..a + 7])
                    .try_into()
                    .expect("a free joint has 7 coordinates");
                let [_, _, _, qw, qx, qy, qz] = *q;
                let [vx, vy, vz, wx, wy, wz] = *w;
                let [rw, rx, ry, rz] = quat_rate_of([qw, qx, qy, qz], [wx, wy, wz]);
                *out = [vx, vy, vz, rw, rx, ry, rz];
            }
        }
    }
}

/// The quaternion rate `½ Q ⊗ (0, w)` of `Q` = (w, x, y, z) at the body-frame angular
/// velocity `w`.
#[inline]
fn quat_rate_of([qw, qx, qy, qz]: [f64; 4], w: [f64; 3]) -> [f64; 4] {
    [
        0.5 * (-qx * w[0] - qy * w[1] - qz * w[2]),
        0.5 * (qw * w[0] + qy * w[2] - qz * w[1]),
        0.5 * (qw * w[1] + qz * w[0] - qx * w[2]),
        0.5 * (qw * w[2] + qx * w[1] - qy * w[0]),
    ]
}

fn quat_rate(q: &[f64], w: &[f64], out: &mut [f64]) {
    out[..4].copy_from_slice(&quat_rate_of([q[0], q[1], q[2], q[3]], [w[0], w[1], w[2]]));
}

/// Calls `f(k)` for every degree of freedom on the path from `body` to the ground.
#[inline]
pub fn for_each_path_dof(m: &Model, body: usize, mut f: impl FnMut(usize)) {
    let mut cur = Some(body);
    while let Some(b) = cur {
        let j = &m.joints[m.bodies[b].joint];
        for k in j.qvel..j.qvel + j.nv() {
            f(k);
        }
        cur = j.parent;
    }
}

/// Adds `sign · coef · S_k` to `row[k]` for the dofs on the path of `body`: the row of the
/// Jacobian of the scalar rate `coef · V_body`; `dof_s` are the motion subspaces
/// (`Data::dof_s`).
pub fn add_jacobian_row(m: &Model, dof_s: &[Spatial], body: Option<usize>, coef: &Spatial, sign: f64, row: &mut [f64]) {
    if let Some(b) = body {
        for_each_path_dof(m, b, |k| row[k] += sign * coef.dot(&dof_s[k]));
    }
}

/// Centre-of-mass velocity of body `b`.
pub fn com_velocity(d: &Data, b: usize) -> Vector3<f64> {
    d.body_vel[b].point_velocity(&d.body_pos[b])
}
