//! Kinematics and dynamics in joint coordinates by the velocity transformation
//! (paper (31)-(34)): the Cartesian velocities are `Y = B q̇`, the mass matrix
//! `M̄ = Bᵀ M B` is assembled by the composite-rigid-body method, and the bias
//! `Bᵀ[f − M Ḃ q̇ − Ṁ B q̇]` by a recursive Newton-Euler pass with q̈ = 0. Loop constraints
//! add `Φ_qᵀ λ` and are solved through the Schur complement `Φ_q M̄⁻¹ Φ_qᵀ`, factorised
//! with diagonal pivoting so that redundant (dependent) rows are dropped.
//!
//! All spatial quantities are in world-frame Plücker coordinates at the world origin
//! (see [`crate::spatial`]); no frame transforms are needed between bodies.

use crate::linalg;
use crate::model::{Data, Input, Model};
use crate::scene::{JointType, Scene};
use crate::spatial::{point_acceleration, Inertia, Spatial};
use nalgebra::{DMatrix, DVector, Matrix3, Quaternion, Unit, UnitQuaternion, Vector3};

/// Pose and motion of a body, or of the ground.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    /// Centre of mass (origin for ground).
    pub pos: Vector3<f64>,
    /// Rotation body → world.
    pub rot: Matrix3<f64>,
    /// Orientation.
    pub quat: UnitQuaternion<f64>,
    /// Spatial velocity.
    pub vel: Spatial,
    /// Spatial bias acceleration.
    pub acc: Spatial,
}

/// The frame of body `b` (None = ground).
pub fn frame(d: &Data, b: Option<usize>) -> Frame {
    match b {
        Some(i) => Frame {
            pos: d.body_pos[i],
            rot: d.body_rot[i],
            quat: d.body_quat[i],
            vel: d.body_vel[i],
            acc: d.body_acc_bias[i],
        },
        None => Frame {
            pos: Vector3::zeros(),
            rot: Matrix3::identity(),
            quat: UnitQuaternion::identity(),
            vel: Spatial::zero(),
            acc: Spatial::zero(),
        },
    }
}

fn quat_at(q: &[f64]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
}

/// Position and velocity kinematics from the state: body poses, spatial velocities, bias
/// accelerations (q̈ = 0), motion subspaces and their rates, spatial inertias.
pub fn kinematics(m: &Model, d: &mut Data, state: &[f64]) {
    let (qpos, rest) = state.split_at(m.nq);
    let qvel = &rest[..m.nv];
    for ji in 0..m.joints.len() {
        joint_kinematics(m, d, ji, qpos, qvel);
    }
}

/// Kinematics of body `body` (None = ground: nothing to do) and of its ancestors only, root
/// first: after it, the body's pose, velocity, bias acceleration, inertia and the motion
/// subspaces of the joints on its path are those [`kinematics`] gives (bit for bit); every
/// other body's entries are left as they were (stale). The path is collected in the
/// preallocated `Data::path_joints` (no allocation).
pub fn kinematics_path(m: &Model, d: &mut Data, state: &[f64], body: Option<usize>) {
    let Some(mut b) = body else { return };
    let (qpos, rest) = state.split_at(m.nq);
    let qvel = &rest[..m.nv];
    let mut path = std::mem::take(&mut d.path_joints);
    path.clear();
    path.reserve(m.joints.len()); // a no-op once the buffer has its capacity
    loop {
        let ji = m.bodies[b].joint;
        path.push(ji);
        match m.joints[ji].parent {
            Some(p) => b = p,
            None => break,
        }
    }
    for &ji in path.iter().rev() {
        joint_kinematics(m, d, ji, qpos, qvel);
    }
    d.path_joints = path;
}

/// Kinematics of tree joint `ji` and its child body, from its parent's (already evaluated)
/// frame: one iteration of [`kinematics`].
pub fn joint_kinematics(m: &Model, d: &mut Data, ji: usize, qpos: &[f64], qvel: &[f64]) {
    let j = &m.joints[ji];
    let p = frame(d, j.parent);
    let c = j.child;
    let q = &qpos[j.qpos..j.qpos + j.nq()];
    let w = &qvel[j.qvel..j.qvel + j.nv()];
    let (pos, quat);
    let mut vel = p.vel;
    let mut acc = p.acc;
    match j.kind {
        JointType::Revolute => {
            let h = p.rot * j.axis;
            let pj = p.pos + p.rot * j.anchor;
            let rel = UnitQuaternion::from_axis_angle(&Unit::new_unchecked(j.axis), q[0]);
            quat = p.quat * rel * j.rot0;
            pos = pj + p.rot * (rel * j.offset);
            let s = Spatial::new(h, pj.cross(&h));
            vel = vel.add(&s.scale(w[0]));
            let sdot = p.vel.cross_motion(&s);
            acc = acc.add(&sdot.scale(w[0]));
            d.dof_s[j.qvel] = s;
            d.dof_sdot[j.qvel] = sdot;
        }
        JointType::Prismatic => {
            let t = p.rot * j.axis;
            quat = p.quat * j.rot0;
            pos = p.pos + p.rot * (j.offset + j.axis * q[0]);
            let s = Spatial::new(Vector3::zeros(), t);
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
            quat = p.quat * quat_at(&q[3..7]);
            let rot = *quat.to_rotation_matrix().matrix();
            pos = p.pos + p.rot * Vector3::new(q[0], q[1], q[2]);
            for (k, &wk) in w[..3].iter().enumerate() {
                let s = Spatial::new(Vector3::zeros(), p.rot.column(k).into_owned());
                let sdot = p.vel.cross_motion(&s);
                d.dof_s[j.qvel + k] = s;
                d.dof_sdot[j.qvel + k] = sdot;
                vel = vel.add(&s.scale(wk));
                acc = acc.add(&sdot.scale(wk));
            }
            for k in 0..3 {
                let h = rot.column(k).into_owned();
                let s = Spatial::new(h, pos.cross(&h));
                d.dof_s[j.qvel + 3 + k] = s;
                vel = vel.add(&s.scale(w[3 + k]));
            }
            for k in 0..3 {
                let sdot = vel.cross_motion(&d.dof_s[j.qvel + 3 + k]);
                d.dof_sdot[j.qvel + 3 + k] = sdot;
                acc = acc.add(&sdot.scale(w[3 + k]));
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
    let i_c = rot * Matrix3::from_diagonal(&b.inertia) * rot.transpose();
    d.body_inertia[c] = Inertia::from_body(b.mass, &pos, &i_c);
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
                qpos_dot[a..a + 3].copy_from_slice(&qvel[v..v + 3]);
                quat_rate(&state[a + 3..a + 7], &qvel[v + 3..v + 6], &mut qpos_dot[a + 3..a + 7]);
            }
        }
    }
}

fn quat_rate(q: &[f64], w: &[f64], out: &mut [f64]) {
    let (qw, qx, qy, qz) = (q[0], q[1], q[2], q[3]);
    out[0] = 0.5 * (-qx * w[0] - qy * w[1] - qz * w[2]);
    out[1] = 0.5 * (qw * w[0] + qy * w[2] - qz * w[1]);
    out[2] = 0.5 * (qw * w[1] + qz * w[0] - qx * w[2]);
    out[3] = 0.5 * (qw * w[2] + qx * w[1] - qy * w[0]);
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
/// Jacobian of the scalar rate `coef · V_body`.
pub fn add_jacobian_row(m: &Model, d: &Data, body: Option<usize>, coef: &Spatial, sign: f64, row: &mut [f64]) {
    if let Some(b) = body {
        for_each_path_dof(m, b, |k| row[k] += sign * coef.dot(&d.dof_s[k]));
    }
}

/// Applied forces: gravity, spring-dampers, inputs (contacts are added by the contact
/// module). Returns the dissipated power of the dampers [W].
pub fn applied_forces(m: &Model, d: &mut Data) -> f64 {
    for (b, body) in m.bodies.iter().enumerate() {
        d.body_force[b] = Spatial::force_at(&(m.gravity * body.mass), &d.body_pos[b]);
    }
    d.tau.iter_mut().for_each(|x| *x = 0.0);
    let mut power = 0.0;
    for s in &m.springs {
        let fa = frame(d, s.body_a);
        let fb = frame(d, s.body_b);
        let pa = fa.pos + fa.rot * s.point_a;
        let pb = fb.pos + fb.rot * s.point_b;
        let diff = pb - pa;
        let len = diff.norm();
        if len < 1e-15 {
            continue;
        }
        let e = diff / len;
        let rate = (fb.vel.point_velocity(&pb) - fa.vel.point_velocity(&pa)).dot(&e);
        let tension = s.stiffness * (len - s.free_length) + s.damping * rate;
        power += s.damping * rate * rate;
        if let Some(a) = s.body_a {
            d.body_force[a] = d.body_force[a].add(&Spatial::force_at(&(e * tension), &pa));
        }
        if let Some(b) = s.body_b {
            d.body_force[b] = d.body_force[b].add(&Spatial::force_at(&(-e * tension), &pb));
        }
    }
    for (i, inp) in m.inputs.iter().enumerate() {
        let u = d.inputs[i];
        match inp {
            Input::Force { body, direction } => {
                d.body_force[*body] = d.body_force[*body].add(&Spatial::force_at(&(direction * u), &d.body_pos[*body]));
            }
            Input::Torque { body, direction } => {
                d.body_force[*body].ang += direction * u;
            }
            Input::JointForce { qvel } => d.tau[*qvel] += u,
        }
    }
    power
}

/// Assembles the packed mass-matrix blocks M̄ (composite-rigid-body method) and the
/// right-hand side `τ − C(q, q̇)` into `d.qacc` (recursive Newton-Euler with q̈ = 0).
pub fn mass_and_bias(m: &Model, d: &mut Data) {
    // Bias forces.
    for b in 0..m.bodies.len() {
        let i = &d.body_inertia[b];
        let v = &d.body_vel[b];
        let f = i
            .mul(&d.body_acc_bias[b])
            .add(&v.cross_force(&i.mul(v)))
            .sub(&d.body_force[b]);
        d.body_wrench[b] = f;
        d.composite[b] = *i;
    }
    for j in m.joints.iter().rev() {
        let c = j.child;
        let f = d.body_wrench[c];
        for k in j.qvel..j.qvel + j.nv() {
            d.qacc[k] = d.tau[k] - d.dof_s[k].dot(&f);
        }
        if let Some(p) = j.parent {
            d.body_wrench[p] = d.body_wrench[p].add(&f);
            let ic = d.composite[c];
            d.composite[p].add_assign(&ic);
        }
    }
    // Mass matrix, block by tree. Only entries on ancestor paths are written (and read by the
    // tree-sparse factorisation); entries between sibling branches stay zero.
    for j in m.joints.iter() {
        let tree = j.tree;
        let (t0, n) = m.trees[tree];
        let off = m.tree_block[tree];
        let ic = d.composite[j.child];
        for k in j.qvel..j.qvel + j.nv() {
            let f = ic.mul(&d.dof_s[k]);
            let mut cur = Some(j.child);
            while let Some(b) = cur {
                let ja = &m.joints[m.bodies[b].joint];
                for k2 in ja.qvel..ja.qvel + ja.nv() {
                    let v = d.dof_s[k2].dot(&f);
                    d.mass_blocks[off + (k - t0) * n + (k2 - t0)] = v;
                    d.mass_blocks[off + (k2 - t0) * n + (k - t0)] = v;
                }
                cur = ja.parent;
            }
        }
    }
}

/// Factorises every mass-matrix block in place (Cholesky). Returns false when a block is not
/// positive definite.
/// The factorisation is the tree-sparse `LᵀDL` ([`linalg::ltdl_in_place`]): no fill-in, cost
/// O(n d²) for a tree of depth d.
pub fn factor_mass(m: &Model, d: &mut Data) -> bool {
    for (t, &(t0, n)) in m.trees.iter().enumerate() {
        let off = m.tree_block[t];
        if !linalg::ltdl_in_place(&mut d.mass_blocks[off..off + n * n], n, &m.dof_parent[t0..t0 + n]) {
            return false;
        }
    }
    true
}

/// Solves M̄ x = x in place with the factorised blocks.
pub fn solve_mass(m: &Model, mass_blocks: &[f64], x: &mut [f64]) {
    for (t, &(t0, n)) in m.trees.iter().enumerate() {
        let off = m.tree_block[t];
        linalg::ltdl_solve(
            &mass_blocks[off..off + n * n],
            n,
            &m.dof_parent[t0..t0 + n],
            &mut x[t0..t0 + n],
        );
    }
}

/// One constraint row: rate coefficients on bodies a and b, the value Φ and the bias
/// `Φ̈|q̈=0`.
struct Row {
    coef_a: Spatial,
    coef_b: Spatial,
    value: f64,
    bias: f64,
}

fn loop_rows(m: &Model, d: &Data, li: usize, mut emit: impl FnMut(usize, Row)) {
    let lc = &m.loops[li];
    let fa = frame(d, lc.body_a);
    let fb = frame(d, Some(lc.body_b));
    let pa = fa.pos + fa.rot * lc.anchor_a;
    let pb = fb.pos + fb.rot * lc.anchor_b;
    let (va, vb) = (fa.vel.point_velocity(&pa), fb.vel.point_velocity(&pb));
    let (aa, ab) = (
        point_acceleration(&fa.acc, &fa.vel, &pa),
        point_acceleration(&fb.acc, &fb.vel, &pb),
    );
    let ta = fa.rot * lc.triad_a;
    let tb = fb.rot * lc.triad_b;
    let (wa, wb) = (fa.vel.ang, fb.vel.ang);
    let (ala, alb) = (fa.acc.ang, fb.acc.ang);
    let mut row = lc.row;
    let point_rows = |emit: &mut dyn FnMut(usize, Row), row: &mut usize| {
        for k in 0..3 {
            let e = Vector3::ith(k, 1.0);
            emit(
                *row,
                Row {
                    coef_a: Spatial::point_direction(&pa, &e).scale(-1.0),
                    coef_b: Spatial::point_direction(&pb, &e),
                    value: (pb - pa)[k],
                    bias: (ab - aa)[k],
                },
            );
            *row += 1;
        }
    };
    // φ = u_a · w_b for vectors fixed in a and b.
    let dot_row = |u: Vector3<f64>, w: Vector3<f64>| -> Row {
        let c = u.cross(&w);
        let cdot = wa.cross(&u).cross(&w) + u.cross(&wb.cross(&w));
        Row {
            coef_a: Spatial::new(c, Vector3::zeros()),
            coef_b: Spatial::new(-c, Vector3::zeros()),
            value: u.dot(&w),
            bias: cdot.dot(&(wa - wb)) + c.dot(&(ala - alb)),
        }
    };
    let col = |t: &Matrix3<f64>, k: usize| -> Vector3<f64> { t.column(k).into_owned() };
    match lc.kind {
        JointType::Spherical => point_rows(&mut emit, &mut row),
        JointType::Revolute => {
            point_rows(&mut emit, &mut row);
            emit(row, dot_row(col(&ta, 0), col(&tb, 1)));
            emit(row + 1, dot_row(col(&ta, 0), col(&tb, 2)));
        }
        JointType::Fixed | JointType::Prismatic => {
            if lc.kind == JointType::Fixed {
                point_rows(&mut emit, &mut row);
            } else {
                let dvec = pb - pa;
                for k in 1..3 {
                    let u = col(&ta, k);
                    let wu = wa.cross(&u);
                    emit(
                        row,
                        Row {
                            coef_a: Spatial::point_direction(&pa, &u)
                                .scale(-1.0)
                                .add(&Spatial::new(u.cross(&dvec), Vector3::zeros())),
                            coef_b: Spatial::point_direction(&pb, &u),
                            value: dvec.dot(&u),
                            bias: (ab - aa).dot(&u)
                                + 2.0 * (vb - va).dot(&wu)
                                + dvec.dot(&(ala.cross(&u) + wa.cross(&wu))),
                        },
                    );
                    row += 1;
                }
            }
            emit(row, dot_row(col(&ta, 0), col(&tb, 1)));
            emit(row + 1, dot_row(col(&ta, 1), col(&tb, 2)));
            emit(row + 2, dot_row(col(&ta, 2), col(&tb, 0)));
        }
        JointType::Free => {}
    }
}

/// Evaluates Φ, Φ_q (row-major), Φ_q q̇ and the stabilised γ (Baumgarte) for every loop.
pub fn constraints(m: &Model, d: &mut Data, qvel: &[f64]) {
    let nv = m.nv;
    d.phi_q.iter_mut().for_each(|x| *x = 0.0);
    let mut phi_q = std::mem::take(&mut d.phi_q);
    let mut phi = std::mem::take(&mut d.phi);
    let mut gamma = std::mem::take(&mut d.gamma);
    for li in 0..m.loops.len() {
        let lc = &m.loops[li];
        loop_rows(m, d, li, |r, row| {
            let jr = &mut phi_q[r * nv..(r + 1) * nv];
            add_jacobian_row(m, d, lc.body_a, &row.coef_a, 1.0, jr);
            add_jacobian_row(m, d, Some(lc.body_b), &row.coef_b, 1.0, jr);
            phi[r] = row.value;
            gamma[r] = -row.bias;
        });
    }
    crate::contact::resting_rows(m, d, &mut phi_q, &mut phi, &mut gamma);
    let alpha = m.baumgarte;
    for r in 0..m.nc {
        let rate: f64 = phi_q[r * nv..(r + 1) * nv].iter().zip(qvel).map(|(a, b)| a * b).sum();
        d.phi_dot[r] = rate;
        gamma[r] -= 2.0 * alpha * rate + alpha * alpha * phi[r];
    }
    d.phi_q = phi_q;
    d.phi = phi;
    d.gamma = gamma;
}

/// Relative threshold below which a pivot of the constraint Schur complement marks a
/// redundant constraint row.
pub const REDUNDANT_PIVOT: f64 = 1e-10;

/// Solves the constrained equations of motion (33): on entry `d.qacc` holds `τ − C` and the
/// mass blocks are factorised; on exit `d.qacc` holds q̈ and `d.lambda` the multipliers.
pub fn solve_constrained(m: &Model, d: &mut Data) {
    solve_mass(m, &d.mass_blocks, &mut d.qacc);
    let (nv, nc) = (m.nv, m.nc);
    if nc == 0 {
        return;
    }
    factor_schur(m, d);
    for r in 0..nc {
        let jr = &d.phi_q[r * nv..(r + 1) * nv];
        d.lambda[r] = linalg::dot(jr, &d.qacc) - d.gamma[r];
    }
    linalg::pivoted_cholesky_solve(
        &d.schur,
        nc,
        &d.schur_perm,
        d.schur_rank,
        &mut d.lambda,
        &mut d.work[..nc],
    );
    for r in 0..nc {
        let l = d.lambda[r];
        if l != 0.0 {
            for (a, b) in d.qacc.iter_mut().zip(&d.minv_phit[r * nv..(r + 1) * nv]) {
                *a -= l * b;
            }
        }
    }
}

/// Forms `M̄⁻¹ Φ_qᵀ` and the Schur complement `Φ_q M̄⁻¹ Φ_qᵀ` from the factorised mass blocks
/// and factorises it with diagonal pivoting; dependent (redundant) rows are left out of the
/// leading `d.schur_rank` pivots.
fn factor_schur(m: &Model, d: &mut Data) {
    let (nv, nc) = (m.nv, m.nc);
    for r in 0..nc {
        let col = &mut d.minv_phit[r * nv..(r + 1) * nv];
        col.copy_from_slice(&d.phi_q[r * nv..(r + 1) * nv]);
        solve_mass(m, &d.mass_blocks, col);
    }
    for r in 0..nc {
        let jr = &d.phi_q[r * nv..(r + 1) * nv];
        for c in 0..nc {
            d.schur[r * nc + c] = linalg::dot(jr, &d.minv_phit[c * nv..(c + 1) * nv]);
        }
    }
    d.schur_rank = linalg::pivoted_cholesky_in_place(&mut d.schur, nc, &mut d.schur_perm, REDUNDANT_PIVOT);
}

/// Loop-constraint residual `|Φ|` above which [`project_state`] corrects the state, in m
/// (point rows) or rad (orientation rows).
pub const PROJECTION_TOL: f64 = 1e-10;

/// The velocity residual `|Φ_q q̇|` that also triggers a projection, per unit of the position
/// tolerance [1/s]: 100 × 1e-10 = 1e-8 m/s or rad/s. Baumgarte stabilisation holds
/// `|Φ_q q̇| ≈ α |Φ|` (α = 20/s), so a tighter trigger would project after nearly every step
/// without making the positions any better.
pub const RATE_TOL_PER_SECOND: f64 = 100.0;

/// Newton iterations of the position projection.
const PROJECTION_ITERATIONS: usize = 4;

/// Position correction (largest coordinate change) beyond which the velocity projection
/// refactorises at the corrected positions.
const REFACTOR_AFTER: f64 = 1e-6;

/// Number of loop-constraint rows: the first rows of Φ (rows of resting contacts follow).
fn loop_row_count(m: &Model) -> usize {
    m.loops.last().map(|l| l.row + l.rows()).unwrap_or(0)
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0_f64, |a, b| a.max(b.abs()))
}

/// The smallest correction in the mass metric that removes `rhs` (the first `nl` rows of
/// `d.lambda` on entry; the other rows are held): `Δv = M̄⁻¹ Φ_qᵀ (Φ_q M̄⁻¹ Φ_qᵀ)⁺ rhs`,
/// written to `d.work2`.
fn mass_metric_correction(m: &Model, d: &mut Data, nl: usize) {
    let (nv, nc) = (m.nv, m.nc);
    d.lambda[nl..nc].iter_mut().for_each(|x| *x = 0.0);
    linalg::pivoted_cholesky_solve(
        &d.schur,
        nc,
        &d.schur_perm,
        d.schur_rank,
        &mut d.lambda,
        &mut d.work[..nc],
    );
    d.work2.iter_mut().for_each(|x| *x = 0.0);
    for r in 0..nc {
        let l = d.lambda[r];
        if l != 0.0 {
            for (a, b) in d.work2.iter_mut().zip(&d.minv_phit[r * nv..(r + 1) * nv]) {
                *a += l * b;
            }
        }
    }
}

/// Moves the position coordinates by the velocity-space increment `dv` (a rotation vector in
/// the child frame for spherical and free joints, applied as `Q ← Q ⊗ exp(dv/2)`).
fn displace_positions(m: &Model, qpos: &mut [f64], dv: &[f64]) {
    for j in &m.joints {
        let (a, v) = (j.qpos, j.qvel);
        let rotate = |q: &mut [f64], w: &[f64]| {
            let dq = UnitQuaternion::from_scaled_axis(Vector3::new(w[0], w[1], w[2]));
            let r = Quaternion::new(q[0], q[1], q[2], q[3]) * dq.quaternion();
            q.copy_from_slice(&[r.w, r.i, r.j, r.k]);
        };
        match j.kind {
            JointType::Revolute | JointType::Prismatic => qpos[a] += dv[v],
            JointType::Fixed => {}
            JointType::Spherical => rotate(&mut qpos[a..a + 4], &dv[v..v + 3]),
            JointType::Free => {
                for k in 0..3 {
                    qpos[a + k] += dv[v + k];
                }
                rotate(&mut qpos[a + 3..a + 7], &dv[v + 3..v + 6]);
            }
        }
    }
}

/// Deviation of a joint quaternion's norm from 1 above which [`project_state`] rescales it.
/// `Q̇ = ½ Q ⊗ w` keeps |Q| constant in exact arithmetic and the kinematics normalise, so the
/// drift (about `rtol` per second) is harmless; rescaling only keeps it bounded in long runs.
pub const QUATERNION_NORM_TOL: f64 = 1e-8;

/// Rescales the quaternions of spherical and free joints whose norm drifted from 1 by more than
/// `tol`. Returns true when one changed.
fn normalise_quaternions(m: &Model, qpos: &mut [f64], tol: f64) -> bool {
    let mut changed = false;
    for j in &m.joints {
        let a = match j.kind {
            JointType::Spherical => j.qpos,
            JointType::Free => j.qpos + 3,
            _ => continue,
        };
        let q = &mut qpos[a..a + 4];
        let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
        if (n - 1.0).abs() > tol && n > 0.0 {
            q.iter_mut().for_each(|x| *x /= n);
            changed = true;
        }
    }
    changed
}

/// Projects `d.state` back onto the loop constraints when their residual exceeds `tol`:
/// Newton iterations on `Φ(q) = 0`, then `Φ_q q̇ = 0`, each the smallest change in the mass
/// metric (the redundant rows dropped by the pivoted factorisation). Baumgarte stabilisation
/// keeps the drift small between projections; this removes it. Rows of resting contacts are
/// held unchanged. Also rescales drifted joint quaternions ([`QUATERNION_NORM_TOL`]).
/// Returns true when the state changed (the caller must restart its integrator). Allocates
/// nothing.
pub fn project_state(m: &Model, d: &mut Data, tol: f64) -> bool {
    let rescaled = normalise_quaternions(m, &mut d.state[..m.nq], QUATERNION_NORM_TOL);
    rescaled | project_loops(m, d, tol)
}

/// The loop-constraint part of [`project_state`]. One factorisation of `M̄` and of the Schur
/// complement at the drifted positions serves every correction (simplified Newton: the
/// Jacobian is off by O(|Δq|), which only slows the already tiny corrections).
fn project_loops(m: &Model, d: &mut Data, tol: f64) -> bool {
    let nl = loop_row_count(m);
    if nl == 0 {
        return false;
    }
    let (nq, nv) = (m.nq, m.nv);
    let mut state = std::mem::take(&mut d.state);
    kinematics(m, d, &state);
    constraints(m, d, &state[nq..nq + nv]);
    if max_abs(&d.phi[..nl]) <= tol && max_abs(&d.phi_dot[..nl]) <= RATE_TOL_PER_SECOND * tol {
        d.state = state;
        return false;
    }
    mass_and_bias(m, d);
    if !factor_mass(m, d) {
        d.state = state;
        return false;
    }
    factor_schur(m, d);
    let mut moved = 0.0_f64;
    for _ in 0..PROJECTION_ITERATIONS {
        if max_abs(&d.phi[..nl]) <= 1e-3 * tol {
            break;
        }
        d.lambda[..nl].copy_from_slice(&d.phi[..nl]);
        mass_metric_correction(m, d, nl);
        d.work2.iter_mut().for_each(|x| *x = -*x);
        moved += max_abs(&d.work2);
        displace_positions(m, &mut state[..nq], &d.work2);
        kinematics(m, d, &state);
        constraints(m, d, &state[nq..nq + nv]);
    }
    // velocities: Φ_q q̇ = 0 with the Jacobian at the corrected positions (and a fresh
    // factorisation after a large position correction, e.g. from inconsistent initial data)
    if moved > REFACTOR_AFTER {
        mass_and_bias(m, d);
        if factor_mass(m, d) {
            factor_schur(m, d);
        }
    }
    d.lambda[..nl].copy_from_slice(&d.phi_dot[..nl]);
    mass_metric_correction(m, d, nl);
    for (q, dq) in state[nq..nq + nv].iter_mut().zip(&d.work2) {
        *q -= dq;
    }
    d.state = state;
    true
}

/// Kinetic energy ½ Σ Vᵀ I V [J].
pub fn kinetic_energy(m: &Model, d: &Data) -> f64 {
    (0..m.bodies.len())
        .map(|b| 0.5 * d.body_vel[b].dot(&d.body_inertia[b].mul(&d.body_vel[b])))
        .sum()
}

/// Potential energy of gravity and springs [J].
pub fn potential_energy(m: &Model, d: &Data) -> f64 {
    let mut e: f64 = m
        .bodies
        .iter()
        .enumerate()
        .map(|(b, body)| -body.mass * m.gravity.dot(&d.body_pos[b]))
        .sum();
    for s in &m.springs {
        let fa = frame(d, s.body_a);
        let fb = frame(d, s.body_b);
        let len = ((fb.pos + fb.rot * s.point_b) - (fa.pos + fa.rot * s.point_a)).norm();
        e += 0.5 * s.stiffness * (len - s.free_length).powi(2);
    }
    e
}

/// Centre-of-mass velocity of body `b`.
pub fn com_velocity(d: &Data, b: usize) -> Vector3<f64> {
    d.body_vel[b].point_velocity(&d.body_pos[b])
}

/// Initial joint rates from the scene's body velocities by least squares, per tree
/// (paper (35)-(37)), then projected onto the loop constraints (28). Inconsistent data gives
/// warnings in `m.warnings`.
pub fn initial_velocities(m: &mut Model, d: &mut Data, scene: &Scene) {
    let zero_v = vec![0.0; m.nstate()];
    let mut state = d.state.clone();
    state[m.nq..].copy_from_slice(&zero_v[m.nq..]);
    kinematics(m, d, &state);
    let mut qvel = vec![0.0; m.nv];
    for (t, &(t0, n)) in m.trees.iter().enumerate() {
        if n == 0 {
            continue;
        }
        let bodies: Vec<usize> = m.joints.iter().filter(|j| j.tree == t).map(|j| j.child).collect();
        let mut bmat = DMatrix::<f64>::zeros(6 * bodies.len(), n);
        let mut y = DVector::<f64>::zeros(6 * bodies.len());
        for (i, &b) in bodies.iter().enumerate() {
            let spec = &scene.body[b];
            for k in 0..3 {
                y[6 * i + k] = spec.velocity[k];
                y[6 * i + 3 + k] = spec.angular_velocity[k];
            }
            let c = d.body_pos[b];
            for_each_path_dof(m, b, |k| {
                let s = d.dof_s[k];
                let v = s.point_velocity(&c);
                for r in 0..3 {
                    bmat[(6 * i + r, k - t0)] = v[r];
                    bmat[(6 * i + 3 + r, k - t0)] = s.ang[r];
                }
            });
        }
        if y.norm() == 0.0 {
            continue;
        }
        let svd = bmat.clone().svd(true, true);
        let sol = svd.solve(&y, 1e-12).unwrap_or_else(|_| DVector::zeros(n));
        let resid = (&bmat * &sol - &y).norm();
        if resid > 1e-6 * (1.0 + y.norm()) {
            let names: Vec<&str> = bodies.iter().map(|&b| m.bodies[b].name.as_str()).collect();
            m.warnings.push(format!(
                "initial velocities of bodies {} are inconsistent with their joints (least-squares residual {resid:.3e} in [v; ω]); using the least-squares projection",
                names.join(", ")
            ));
        }
        qvel[t0..t0 + n].copy_from_slice(sol.as_slice());
    }
    if m.nc > 0 {
        state[m.nq..m.nq + m.nv].copy_from_slice(&qvel);
        kinematics(m, d, &state);
        constraints(m, d, &qvel);
        let j = DMatrix::from_row_slice(m.nc, m.nv, &d.phi_q);
        let v = DVector::from_column_slice(&qvel);
        let viol = &j * &v;
        if viol.norm() > 0.0 {
            let jjt = &j * j.transpose();
            let corr = jjt
                .svd(true, true)
                .solve(&viol, 1e-10)
                .unwrap_or_else(|_| DVector::zeros(m.nc));
            let fixed = v - j.transpose() * corr;
            if viol.norm() > 1e-9 * (1.0 + fixed.norm()) {
                m.warnings.push(format!(
                    "initial velocities violated the loop constraints by {:.3e}; projected",
                    viol.norm()
                ));
            }
            qvel.copy_from_slice(fixed.as_slice());
        }
        let phi_norm = d.phi.iter().map(|x| x * x).sum::<f64>().sqrt();
        if phi_norm > 1e-9 {
            m.warnings.push(format!(
                "the initial configuration violates the loop constraints by {phi_norm:.3e}"
            ));
        }
    }
    m.qvel0.clone_from(&qvel);
    d.state[m.nq..m.nq + m.nv].copy_from_slice(&qvel);
    kinematics(m, d, &d.state.clone());
}

/// Coordinate and rate of a loop-closing 1-DOF joint, measured from the body poses:
/// revolute: the rotation of b relative to a about the axis [rad]; prismatic: the
/// displacement of b's joint point along a's axis [m]. Zero at the initial configuration.
pub fn loop_joint_coordinate(m: &Model, d: &Data, li: usize) -> (f64, f64) {
    let lc = &m.loops[li];
    let fa = frame(d, lc.body_a);
    let fb = frame(d, Some(lc.body_b));
    let ta = fa.rot * lc.triad_a;
    let tb = fb.rot * lc.triad_b;
    let axis = ta.column(0).into_owned();
    match lc.kind {
        JointType::Revolute => {
            let (ua, ub) = (ta.column(1).into_owned(), tb.column(1).into_owned());
            let angle = ua.cross(&ub).dot(&axis).atan2(ua.dot(&ub));
            (angle, (fb.vel.ang - fa.vel.ang).dot(&axis))
        }
        JointType::Prismatic => {
            let pa = fa.pos + fa.rot * lc.anchor_a;
            let pb = fb.pos + fb.rot * lc.anchor_b;
            let dvec = pb - pa;
            let rate = (fb.vel.point_velocity(&pb) - fa.vel.point_velocity(&pa)).dot(&axis)
                + dvec.dot(&fa.vel.ang.cross(&axis));
            (dvec.dot(&axis), rate)
        }
        _ => (f64::NAN, f64::NAN),
    }
}
