//! Kinematics and dynamics in joint coordinates by the velocity transformation
//! (paper (31)-(34)): the Cartesian velocities are `Y = B q̇`, the mass matrix
//! `M̄ = Bᵀ M B` is assembled by the composite-rigid-body method, and the bias
//! `Bᵀ[f − M Ḃ q̇ − Ṁ B q̇]` by a recursive Newton-Euler pass with q̈ = 0. Loop constraints
//! add `Φ_qᵀ λ` and are solved through the Schur complement `Φ_q M̄⁻¹ Φ_qᵀ`, factorised
//! with diagonal pivoting so that redundant (dependent) rows are dropped.
//!
//! All spatial quantities are in world-frame Plücker coordinates at the world origin
//! (see [`crate::spatial`]); no frame transforms are needed between bodies. The kinematics
//! these functions read come from [`crate::kinematics`]. Constraint rows other than the
//! loops' (the resting contacts') are added by a function the caller passes
//! ([`ConstraintRows`]), so that this layer knows nothing of contact.

use crate::kinematics::{add_jacobian_row, frame, kinematics};
use crate::linalg;
use crate::model::{Data, FreeBody, Input, Model, Part, TreeJoint};
use crate::scene::JointType;
use crate::spatial::{point_acceleration, Spatial};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// Fills the constraint rows after the loops' (rows `m.fixed_rows()..d.nc` of `d.phi_q`,
/// `d.phi`, `d.gamma`, already zeroed) at the evaluated kinematics.
pub type ConstraintRows = fn(&Model, &mut Data);

/// Applied forces: gravity, spring-dampers, inputs (contacts are added by the contact
/// module). Returns the dissipated power of the dampers \[W\].
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
    let mut input_power = 0.0;
    for (i, inp) in m.inputs.iter().enumerate() {
        let u = d.inputs[m.input_value[i]];
        match inp {
            Input::Force { body, direction } => {
                let b = *body;
                d.body_force[b] = d.body_force[b].add(&Spatial::force_at(&(direction * u), &d.body_pos[b]));
                input_power += u * direction.dot(&d.body_vel[b].point_velocity(&d.body_pos[b]));
            }
            Input::Torque { body, direction } => {
                d.body_force[*body].ang += direction * u;
                input_power += u * direction.dot(&d.body_vel[*body].ang);
            }
            Input::JointForce { qvels } => {
                for &k in qvels {
                    d.tau[k] += u;
                    input_power += u * d.eval_state[m.nq + k];
                }
            }
            // a drive's force is a multiplier of the constrained solve: its power is added
            // there ([`drive_power`])
            Input::JointMotion => {}
        }
    }
    d.input_power = input_power;
    power
}

/// The generalised force of drive `k` at the last constrained solve (N or N m, along or
/// about its joint's axis): minus the multiplier of its row (`M̄ q̈ = τ − C − Φ_qᵀ λ`).
pub fn drive_force(m: &Model, d: &Data, k: usize) -> f64 {
    -d.lambda[m.drives[k].row]
}

/// The power of the drives at the last constrained solve \[W\]: their forces times their rates.
pub fn drive_power(m: &Model, d: &Data) -> f64 {
    (0..m.drives.len())
        .map(|k| drive_force(m, d, k) * d.eval_state[m.nq + m.drives[k].qvel])
        .sum()
}

/// Assembles the packed mass-matrix blocks M̄ (composite-rigid-body method) and the
/// right-hand side `τ − C(q, q̇)` into `d.qacc` (recursive Newton-Euler with q̈ = 0).
pub fn mass_and_bias(m: &Model, d: &mut Data) {
    mass_and_bias_of(m, d, 0..m.bodies.len(), m.joints.iter());
}

/// [`mass_and_bias`] for the joints and bodies of `part` only (a set of whole trees).
pub fn mass_and_bias_part(m: &Model, d: &mut Data, part: &Part) {
    mass_and_bias_of(
        m,
        d,
        part.bodies.iter().copied(),
        part.joints.iter().map(|&ji| &m.joints[ji]),
    );
}

/// [`mass_and_bias`] over `bodies` and `joints` (parents first), generic so that the whole
/// model's pass iterates its own arrays.
fn mass_and_bias_of<'a, J>(m: &'a Model, d: &mut Data, bodies: impl Iterator<Item = usize>, joints: J)
where
    J: DoubleEndedIterator<Item = &'a TreeJoint> + Clone,
{
    // Bias forces.
    for b in bodies {
        let i = &d.body_inertia[b];
        let v = &d.body_vel[b];
        let f = i
            .mul(&d.body_acc_bias[b])
            .add(&v.cross_force(&i.mul(v)))
            .sub(&d.body_force[b]);
        d.body_wrench[b] = f;
        d.composite[b] = *i;
    }
    for j in joints.clone().rev() {
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
    // Mass matrix, block by tree. Only the lower entries on ancestor paths are written, the
    // only ones the tree-sparse factorisation reads (M̄[max][min]; of a pair of the same joint
    // the value of the later row stays, as when both entries were written); the rest of the
    // block is never read. The rows of constant leaves are not written.
    for j in joints {
        // a rotor's constant row is the factor's already (`Plan::leaves`)
        if m.plan.constant_row[m.bodies[j.child].joint] {
            continue;
        }
        let tree = j.tree;
        let (t0, n) = m.trees[tree];
        let block = &mut d.mass_blocks[m.tree_block[tree]..m.tree_block[tree] + n * n];
        let ic = d.composite[j.child];
        for k in j.qvel..j.qvel + j.nv() {
            let f = ic.mul(&d.dof_s[k]);
            let mut cur = Some(j.child);
            while let Some(b) = cur {
                let ja = &m.joints[m.bodies[b].joint];
                for k2 in ja.qvel..ja.qvel + ja.nv() {
                    let (r, c) = if k2 <= k { (k, k2) } else { (k2, k) };
                    block[(r - t0) * n + (c - t0)] = d.dof_s[k2].dot(&f);
                }
                cur = ja.parent;
            }
        }
    }
}

/// The accelerations of a free body ([`FreeBody`]) into `d.qacc`, by Newton-Euler at its
/// centre of mass: `a = f/m` (world frame) and `I ω̇ = τ − ω × I ω` (body frame), from the
/// forces on it (`d.body_force`, at the origin) and generalised forces on its coordinates
/// (`d.tau`). Reads the pose [`crate::kinematics::free_body_kinematics`] wrote.
#[inline]
pub fn free_body_accelerations(m: &Model, d: &mut Data, fb: &FreeBody) {
    let (b, v) = (fb.body, fb.qvel);
    let f = &d.body_force[b];
    let w = &d.eval_state[m.nq + v + 3..m.nq + v + 6];
    let omega = Vector3::new(w[0], w[1], w[2]);
    let tau = &d.tau[v..v + 6];
    let force = f.lin + Vector3::new(tau[0], tau[1], tau[2]);
    // the moment about the centre of mass, in the body frame
    let moment = d.body_rot[b].tr_mul(&(f.ang - d.body_pos[b].cross(&f.lin))) + Vector3::new(tau[3], tau[4], tau[5]);
    let alpha = (moment - omega.cross(&fb.inertia.component_mul(&omega))).component_mul(&fb.inv_inertia);
    let acc = &mut d.qacc[v..v + 6];
    acc[..3].copy_from_slice((force * fb.inv_mass).as_slice());
    acc[3..].copy_from_slice(alpha.as_slice());
}

/// Factorises every mass-matrix block in place (Cholesky). Returns false when a block is not
/// positive definite.
/// The factorisation is the tree-sparse `LᵀDL` ([`linalg::ltdl_in_place`]): no fill-in, cost
/// O(n d²) for a tree of depth d; the rows of constant leaves (rotors, `Plan::leaves`) are the
/// factor's already and are skipped.
pub fn factor_mass(m: &Model, d: &mut Data) -> bool {
    for (t, &(t0, n)) in m.trees.iter().enumerate() {
        let off = m.tree_block[t];
        if !factor_block(m, &mut d.mass_blocks[off..off + n * n], t, t0, n) {
            return false;
        }
    }
    true
}

/// [`factor_mass`] for the blocks of `trees` only (the lean path's general part).
pub fn factor_mass_trees(m: &Model, d: &mut Data, trees: &[usize]) -> bool {
    trees.iter().all(|&t| {
        let ((t0, n), off) = (m.trees[t], m.tree_block[t]);
        factor_block(m, &mut d.mass_blocks[off..off + n * n], t, t0, n)
    })
}

/// The tree-sparse `LᵀDL` of tree `t`'s block (first dof `t0`, size `n`), its constant leaves
/// skipped ([`linalg::ltdl_in_place_leaves`]).
#[inline(always)]
fn factor_block(m: &Model, block: &mut [f64], t: usize, t0: usize, n: usize) -> bool {
    linalg::ltdl_in_place_leaves(block, n, &m.dof_parent[t0..t0 + n], &m.plan.leaves[t])
}

/// Solves with tree `t`'s factorised block ([`linalg::ltdl_solve_leaves`]).
#[inline(always)]
fn solve_block(m: &Model, mass_blocks: &[f64], t: usize, x: &mut [f64]) {
    let ((t0, n), off) = (m.trees[t], m.tree_block[t]);
    linalg::ltdl_solve_leaves(
        &mass_blocks[off..off + n * n],
        n,
        &m.dof_parent[t0..t0 + n],
        &m.plan.leaves[t],
        &mut x[t0..t0 + n],
    );
}

/// Solves M̄ x = x in place with the factorised blocks.
pub fn solve_mass(m: &Model, mass_blocks: &[f64], x: &mut [f64]) {
    for t in 0..m.trees.len() {
        solve_block(m, mass_blocks, t, x);
    }
}

/// [`solve_mass`] with the blocks of `trees` only (the other entries of `x` are left as they
/// are).
pub fn solve_mass_trees(m: &Model, trees: &[usize], mass_blocks: &[f64], x: &mut [f64]) {
    for &t in trees {
        solve_block(m, mass_blocks, t, x);
    }
}

/// One constraint row: rate coefficients on bodies a and b, the value Φ and the bias
/// `Φ̈|q̈=0`.
#[derive(Debug, Clone, Copy, Default)]
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

/// Evaluates Φ, Φ_q (row-major), Φ_q q̇ and the stabilised γ (Baumgarte) at the evaluated
/// kinematics: the loops' rows here, the rest by `extra_rows`.
pub fn constraints(m: &Model, d: &mut Data, extra_rows: ConstraintRows) {
    let nv = m.nv;
    let nl = m.fixed_rows();
    d.phi_q.iter_mut().for_each(|x| *x = 0.0);
    d.phi[nl..].iter_mut().for_each(|x| *x = 0.0);
    d.gamma[nl..].iter_mut().for_each(|x| *x = 0.0);
    for li in 0..m.loops.len() {
        let lc = &m.loops[li];
        let mut rows = [(0usize, Row::default()); 6];
        let mut n = 0;
        loop_rows(m, d, li, |r, row| {
            rows[n] = (r, row);
            n += 1;
        });
        for &(r, row) in &rows[..n] {
            let jr = &mut d.phi_q[r * nv..(r + 1) * nv];
            add_jacobian_row(m, &d.dof_s, lc.body_a, &row.coef_a, 1.0, jr);
            add_jacobian_row(m, &d.dof_s, Some(lc.body_b), &row.coef_b, 1.0, jr);
            d.phi[r] = row.value;
            d.gamma[r] = -row.bias;
        }
    }
    // the drives: q̈_k = qdd (their coordinate and rate are the prescribed ones: Φ = Φ̇ = 0)
    for dr in &m.drives {
        d.phi_q[dr.row * nv + dr.qvel] = 1.0;
        d.phi[dr.row] = 0.0;
        d.gamma[dr.row] = d.inputs[dr.value + 2];
    }
    extra_rows(m, d);
    let alpha = m.baumgarte;
    let qvel = &d.eval_state[m.nq..m.nq + nv];
    let drives = nl - m.drives.len()..nl;
    for r in 0..d.nc {
        if drives.contains(&r) {
            d.phi_dot[r] = 0.0;
            continue;
        }
        let rate: f64 = d.phi_q[r * nv..(r + 1) * nv].iter().zip(qvel).map(|(a, b)| a * b).sum();
        d.phi_dot[r] = rate;
        d.gamma[r] -= 2.0 * alpha * rate + alpha * alpha * d.phi[r];
    }
}

/// [`ConstraintRows`] for a system whose only constraints are its loops.
pub fn no_extra_rows(_m: &Model, _d: &mut Data) {}

/// Relative threshold below which a pivot of the constraint Schur complement marks a
/// redundant constraint row.
pub const REDUNDANT_PIVOT: f64 = 1e-10;

/// Solves the constrained equations of motion (31), in the block form (34): on entry `d.qacc` holds `τ − C` and the
/// mass blocks are factorised; on exit `d.qacc` holds q̈ and `d.lambda` the multipliers.
pub fn solve_constrained(m: &Model, d: &mut Data) {
    solve_mass(m, &d.mass_blocks, &mut d.qacc);
    let (nv, nc) = (m.nv, d.nc);
    if nc == 0 {
        return;
    }
    factor_schur(m, d);
    for r in 0..nc {
        let jr = &d.phi_q[r * nv..(r + 1) * nv];
        d.lambda[r] = linalg::dot(jr, &d.qacc) - d.gamma[r];
    }
    solve_schur(d, nc);
    for r in 0..nc {
        let l = d.lambda[r];
        if l != 0.0 {
            for (a, b) in d.qacc.iter_mut().zip(&d.minv_phit[r * nv..(r + 1) * nv]) {
                *a -= l * b;
            }
        }
    }
}

/// The response of the constrained system to an extra generalised force `x` (after
/// [`solve_constrained`], with the Schur complement factorised): `x ← G x` (the change of the
/// accelerations) and `dl ← (Φ_q M̄⁻¹ Φ_qᵀ)⁻¹ Φ_q M̄⁻¹ x` (the change of the multipliers).
pub fn constrained_response(m: &Model, d: &mut Data, x: &mut [f64], dl: &mut [f64]) {
    let (nv, nc) = (m.nv, d.nc);
    solve_mass(m, &d.mass_blocks, x);
    for (r, l) in dl.iter_mut().enumerate().take(nc) {
        *l = linalg::dot(&d.phi_q[r * nv..(r + 1) * nv], x);
    }
    linalg::pivoted_cholesky_solve(&d.schur, nc, &d.schur_perm, d.schur_rank, dl, &mut d.work[..nc]);
    for (r, &l) in dl.iter().enumerate().take(nc) {
        if l != 0.0 {
            for (a, b) in x.iter_mut().zip(&d.minv_phit[r * nv..(r + 1) * nv]) {
                *a -= l * b;
            }
        }
    }
}

/// Solves `(Φ_q M̄⁻¹ Φ_qᵀ) λ = λ` in place with the factorised Schur complement (dependent
/// rows dropped).
fn solve_schur(d: &mut Data, nc: usize) {
    linalg::pivoted_cholesky_solve(
        &d.schur,
        nc,
        &d.schur_perm,
        d.schur_rank,
        &mut d.lambda,
        &mut d.work[..nc],
    );
}

/// Forms `M̄⁻¹ Φ_qᵀ` and the Schur complement `Φ_q M̄⁻¹ Φ_qᵀ` from the factorised mass blocks
/// and factorises it with diagonal pivoting; dependent (redundant) rows are left out of the
/// leading `d.schur_rank` pivots.
pub fn factor_schur(m: &Model, d: &mut Data) {
    let (nv, nc) = (m.nv, d.nc);
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
/// tolerance \[1/s\]: 100 × 1e-10 = 1e-8 m/s or rad/s. Baumgarte stabilisation holds
/// `|Φ_q q̇| ≈ α |Φ|` (α = 20/s), so a tighter trigger would project after nearly every step
/// without making the positions any better.
pub const RATE_TOL_PER_SECOND: f64 = 100.0;

/// Newton iterations of the position projection.
const PROJECTION_ITERATIONS: usize = 4;

/// Position correction (largest coordinate change) beyond which the velocity projection
/// refactorises at the corrected positions.
const REFACTOR_AFTER: f64 = 1e-6;

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0_f64, |a, b| a.max(b.abs()))
}

/// The smallest correction in the mass metric that removes `rhs` (the first `nl` rows of
/// `d.lambda` on entry; the other rows are held): `Δv = M̄⁻¹ Φ_qᵀ (Φ_q M̄⁻¹ Φ_qᵀ)⁺ rhs`,
/// written to `d.work2`.
fn mass_metric_correction(m: &Model, d: &mut Data, nl: usize) {
    let (nv, nc) = (m.nv, d.nc);
    d.lambda[nl..nc].iter_mut().for_each(|x| *x = 0.0);
    solve_schur(d, nc);
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
    for &a in &m.quaternions {
        let q = &mut qpos[a..a + 4];
        let squared = q.iter().map(|x| x * x).sum::<f64>();
        // |n − 1| = |n² − 1| / (n + 1) < 0.96 tol here: the same decision without the root
        // (the check runs at every communication point)
        if (squared - 1.0).abs() <= 1.9 * tol {
            continue;
        }
        let n = squared.sqrt();
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
/// keeps the drift small between projections; this removes it. Rows added by `extra_rows`
/// (resting contacts) are held unchanged. Also rescales drifted joint quaternions
/// ([`QUATERNION_NORM_TOL`]). Returns true when the state changed (the caller must restart
/// its integrator). Allocates nothing.
pub fn project_state(m: &Model, d: &mut Data, tol: f64, extra_rows: ConstraintRows) -> bool {
    let rescaled = normalise_quaternions(m, &mut d.state[..m.nq], QUATERNION_NORM_TOL);
    rescaled | project_loops(m, d, tol, extra_rows)
}

/// The loop-constraint part of [`project_state`]. One factorisation of `M̄` and of the Schur
/// complement at the drifted positions serves every correction (simplified Newton: the
/// Jacobian is off by O(|Δq|), which only slows the already tiny corrections). Works on
/// `d.eval_state` and copies the result to `d.state`.
fn project_loops(m: &Model, d: &mut Data, tol: f64, extra_rows: ConstraintRows) -> bool {
    if m.loop_rows() == 0 {
        return false;
    }
    let nl = m.fixed_rows();
    let (nq, nv) = (m.nq, m.nv);
    d.eval_state.copy_from_slice(&d.state);
    kinematics(m, d);
    constraints(m, d, extra_rows);
    if max_abs(&d.phi[..nl]) <= tol && max_abs(&d.phi_dot[..nl]) <= RATE_TOL_PER_SECOND * tol {
        return false;
    }
    mass_and_bias(m, d);
    if !factor_mass(m, d) {
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
        displace_positions(m, &mut d.eval_state[..nq], &d.work2);
        kinematics(m, d);
        constraints(m, d, extra_rows);
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
    for (q, dq) in d.eval_state[nq..nq + nv].iter_mut().zip(&d.work2) {
        *q -= dq;
    }
    d.state.copy_from_slice(&d.eval_state);
    true
}

/// Kinetic energy ½ Σ Vᵀ I V \[J\] at the evaluated kinematics; the free bodies' part from their
/// centre-of-mass velocity and body-frame inertia (their spatial inertias are not computed on
/// the lean path).
pub fn kinetic_energy(m: &Model, d: &Data) -> f64 {
    let general: f64 = m
        .plan
        .general
        .bodies
        .iter()
        .map(|&b| 0.5 * d.body_vel[b].dot(&d.body_inertia[b].mul(&d.body_vel[b])))
        .sum();
    let free: f64 = m
        .plan
        .free
        .iter()
        .map(|fb| {
            let b = fb.body;
            let v = d.body_vel[b].point_velocity(&d.body_pos[b]);
            let w = d.body_rot[b].tr_mul(&d.body_vel[b].ang);
            0.5 * (m.bodies[b].mass * v.norm_squared() + w.dot(&fb.inertia.component_mul(&w)))
        })
        .sum();
    general + free
}

/// Potential energy of gravity and springs \[J\].
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

/// Coordinate and rate of a loop-closing 1-DOF joint, measured from the body poses:
/// revolute: the rotation of b relative to a about the axis \[rad\]; prismatic: the
/// displacement of b's joint point along a's axis \[m\]. Zero at the initial configuration.
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
            let angle = crate::math::atan2(ua.cross(&ub).dot(&axis), ua.dot(&ub));
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
