//! Piecewise analysis: impacts as velocity jumps (docs/physics.md §3.1).
//!
//! **Exact method** (default). For the impacting contacts with separation-rate rows `J` (so
//! that `J q̇` is the rate at which the surfaces separate), the velocity jump is
//! `Δq̇ = G Jᵀ P` with `G = M̄⁻¹ − M̄⁻¹Φ_qᵀ (Φ_q M̄⁻¹ Φ_qᵀ)⁺ Φ_q M̄⁻¹` over the loop rows (the
//! loops stay closed), and the normal impulses solve the linear complementarity problem
//!
//! ```text
//! w = W P + (1 + e) J q̇⁻ ≥ 0,   P ≥ 0,   Pᵀ w = 0,   W = J G Jᵀ
//! ```
//!
//! i.e. Newton's law `J q̇⁺ = −e J q̇⁻` for every contact that takes an impulse, and no
//! contact pulls. Solved by Murty's principal pivoting (finite for positive definite `W`;
//! dependent rows are handled by the pivoted Cholesky of the active block).
//!
//! **Effective-mass method** (the paper's (17)-(19)). For each side of a contact, a unit
//! impulse along the contact normal gives velocity changes `Δv_k` of every body's centre of
//! mass and `Δv_p` of the side's contact point; the effective mass is
//! `m_eff = Σ_k m_k c·Δv_k / (c·Δv_p)` (17). With the two sides' effective masses, (18)-(19)
//! (with the corrected (19)) conserve `m_i v_i + m_j v_j` along the normal, so they amount to
//! the normal impulse `P = (1 + e) v⁻ m_i m_j / (m_i + m_j)` (`v⁻` the approach speed; a side
//! on the ground has infinite mass). That impulse is applied through `G`. (17) counts only the
//! translation of the centres of mass, not rotation, nor the reactions of joints to the
//! ground, so the rebound differs from `−e v⁻` unless the effective mass happens to be exact
//! (free bodies, or a pendulum struck at its centre of percussion); it may even create energy.
//! Simultaneous contacts are treated pair by pair.

use super::elements::contact_name;
use crate::dynamics;
use crate::kinematics::{self, for_each_path_dof};
use crate::linalg;
use crate::model::contact::ContactElement;
use crate::model::work::{FrictionWork, ImpulseWork, LcpWork, Projection};
use crate::model::{Data, Model};
use crate::scene::ImpulseMethod;
use crate::spatial::Spatial;

impl Projection {
    /// Factorises at this configuration. Needs `d.phi_q` and `d.minv_phit` of the loop rows
    /// (the last evaluation computed them).
    pub(crate) fn factor(&mut self, m: &Model, d: &Data) {
        let nv = m.nv;
        let nl = m.fixed_rows();
        if self.nl != nl {
            *self = Projection::with_rows(nl);
        }
        for r in 0..nl {
            for c in 0..nl {
                self.schur[r * nl + c] =
                    linalg::dot(&d.phi_q[r * nv..(r + 1) * nv], &d.minv_phit[c * nv..(c + 1) * nv]);
            }
        }
        self.perm.iter_mut().for_each(|p| *p = 0);
        self.rank = linalg::pivoted_cholesky_in_place(&mut self.schur, nl, &mut self.perm, dynamics::REDUNDANT_PIVOT);
    }

    /// `x ← G x`.
    pub(crate) fn apply(&mut self, m: &Model, d: &Data, x: &mut [f64]) {
        dynamics::solve_mass(m, &d.mass_blocks, x);
        let (nv, nl) = (m.nv, self.nl);
        if nl == 0 {
            return;
        }
        for (r, b) in self.b.iter_mut().enumerate() {
            *b = linalg::dot(&d.phi_q[r * nv..(r + 1) * nv], x);
        }
        self.work.iter_mut().for_each(|w| *w = 0.0);
        linalg::pivoted_cholesky_solve(&self.schur, nl, &self.perm, self.rank, &mut self.b, &mut self.work);
        for (r, l) in self.b.iter().enumerate() {
            for (xi, g) in x.iter_mut().zip(&d.minv_phit[r * nv..(r + 1) * nv]) {
                *xi -= l * g;
            }
        }
    }
}

/// Resolves one round of simultaneous impacts of `contacts` with restitution coefficients
/// `restitution` (one each) at the current state. The data must have been evaluated at this
/// configuration (mass matrix factorised; loop Jacobian and `M̄⁻¹Φ_qᵀ` computed). Updates the
/// velocities in `d.state` and the kinematics (at `d.eval_state`, set to the new state),
/// counts the impacts that took an impulse and returns the energy dissipated and the drives'
/// work ([`ImpactEnergy`]); the impulses are left in [`ImpulseWork::impulses`]. Allocates nothing when `work` was made for
/// at least `contacts.len()` contacts of this model (except to report an error).
pub fn resolve_with(
    m: &Model,
    d: &mut Data,
    work: &mut ImpulseWork,
    contacts: &[usize],
    restitution: &[f64],
) -> Result<ImpactEnergy, String> {
    let nv = m.nv;
    let k = contacts.len();
    work.last = 0;
    if k == 0 {
        return Ok(ImpactEnergy {
            dissipated: 0.0,
            input_work: 0.0,
        });
    }
    work.reserve(m.nv, m.fixed_rows(), k);
    let ImpulseWork {
        proj,
        jrows,
        gj,
        qvel,
        rate,
        impulses,
        exact,
        w,
        q,
        p,
        lcp,
        row,
        free,
        x,
        friction,
        ..
    } = work;
    proj.factor(m, d);
    // Rows J (k × nv) and their images G Jᵀ.
    let jrows = &mut jrows[..k * nv];
    let gj = &mut gj[..k * nv];
    jrows.iter_mut().for_each(|v| *v = 0.0);
    for (r, &ci) in contacts.iter().enumerate() {
        let c = &d.contacts[ci];
        let g = super::gap(d, ci);
        let row = &mut jrows[r * nv..(r + 1) * nv];
        super::add_separation_row(m, &d.dof_s, c, &g, row);
        let col = &mut gj[r * nv..(r + 1) * nv];
        col.copy_from_slice(row);
        proj.apply(m, d, col);
    }
    let ke_before = dynamics::kinetic_energy(m, d);
    qvel.copy_from_slice(&d.state[m.nq..m.nq + nv]);
    // Pre-impact separation rates (negative: approaching).
    let rate = &mut rate[..k];
    for (r, v) in rate.iter_mut().enumerate() {
        *v = linalg::dot(&jrows[r * nv..(r + 1) * nv], qvel);
    }
    let impulses = &mut impulses[..k];
    impulses.iter_mut().for_each(|v| *v = 0.0);
    exact.clear();
    for (r, &ci) in contacts.iter().enumerate() {
        match d.contacts[ci].impulse_method {
            ImpulseMethod::Exact => exact.push(r),
            ImpulseMethod::EffectiveMass => {
                let c = &d.contacts[ci];
                let g = super::gap(d, ci);
                let mut bufs = MassBuffers {
                    row: &mut row[..],
                    free: &mut free[..],
                    x: &mut x[..],
                };
                let ms = effective_mass(m, d, proj, &mut bufs, c.sphere_body, &g.point, &g.normal)?;
                let mo = effective_mass(m, d, proj, &mut bufs, c.body, &g.point, &(-g.normal))?;
                let reduced = match (ms.is_finite(), mo.is_finite()) {
                    (true, true) => ms * mo / (ms + mo),
                    (true, false) => ms,
                    (false, true) => mo,
                    (false, false) => {
                        return Err(format!(
                            "contact {:?}: neither side can move along the normal (no impact possible)",
                            contact_name(m, d, ci)
                        ))
                    }
                };
                for (side, mass) in [("sphere_body", ms), ("body", mo)] {
                    if mass <= 0.0 {
                        return Err(format!(
                            "contact {:?}: the effective mass (17) of its {side} is {mass:.6e} kg (≤ 0: the paper's \
                             approximation ignores rotational inertia and joint reactions); use impulse_method = \"exact\"",
                            contact_name(m, d, ci)
                        ));
                    }
                }
                impulses[r] = -(1.0 + restitution[r]) * rate[r] * reduced;
            }
        }
    }
    if !exact.is_empty() {
        let n = exact.len();
        let (w, q, p) = (&mut w[..n * n], &mut q[..n], &mut p[..n]);
        for (a, &ra) in exact.iter().enumerate() {
            for (b, &rb) in exact.iter().enumerate() {
                w[a * n + b] = linalg::dot(&jrows[ra * nv..(ra + 1) * nv], &gj[rb * nv..(rb + 1) * nv]);
            }
            // include the effect of effective-mass impulses of this round on the exact ones
            let mut pre = rate[ra];
            for (rb, p) in impulses.iter().enumerate() {
                pre += p * linalg::dot(&jrows[ra * nv..(ra + 1) * nv], &gj[rb * nv..(rb + 1) * nv]);
            }
            q[a] = pre + restitution[ra] * rate[ra];
        }
        if !solve_lcp_with(w, q, n, lcp, p) {
            let names: Vec<_> = exact.iter().map(|&r| contact_name(m, d, contacts[r])).collect();
            return Err(format!(
                "simultaneous impact of contacts {names:?}: the impulse problem has no solution"
            ));
        }
        for (a, &ra) in exact.iter().enumerate() {
            impulses[ra] = p[a];
        }
    }
    friction_impulses(m, d, proj, contacts, impulses, gj, qvel, friction);
    {
        let v = &mut d.state[m.nq..m.nq + nv];
        for (r, &ci) in contacts.iter().enumerate() {
            if impulses[r] != 0.0 {
                for (x, g) in v.iter_mut().zip(&gj[r * nv..(r + 1) * nv]) {
                    *x += impulses[r] * g;
                }
                d.contact_memory[ci].impacts += 1;
            }
        }
        for i in 0..2 * friction.fric.len() {
            let p = friction.pt[i];
            for (x, g) in v.iter_mut().zip(&friction.gt[i * nv..(i + 1) * nv]) {
                *x += p * g;
            }
        }
    }
    d.eval_state.copy_from_slice(&d.state);
    kinematics::kinematics(m, d);
    // The effective-mass impulse may leave a contact still approaching: report it rather than
    // let the surfaces pass through each other.
    for (r, &ci) in contacts.iter().enumerate() {
        let c = &d.contacts[ci];
        if c.impulse_method == ImpulseMethod::EffectiveMass {
            let after = linalg::dot(&jrows[r * nv..(r + 1) * nv], &d.state[m.nq..m.nq + nv]);
            if after < -1e-9 * rate[r].abs() {
                return Err(format!(
                    "contact {:?}: the effective-mass impulse (17)-(19) leaves the bodies approaching at {:.6e} m/s \
                     (approach {:.6e} m/s); the approximation fails here, use impulse_method = \"exact\"",
                    contact_name(m, d, ci),
                    -after,
                    -rate[r]
                ));
            }
        }
    }
    work.last = k;
    let ke_gain = dynamics::kinetic_energy(m, d) - ke_before;
    if m.drives.is_empty() {
        return Ok(ImpactEnergy {
            dissipated: -ke_gain,
            input_work: 0.0,
        });
    }
    // With drives, whose impulses keep the driven rates, the kinetic energy changes by the
    // work of the contacts' impulses and the drives': the contacts' (each impulse times the
    // mean of its row's rate before and after) is what the impacts dissipate, the rest is the
    // drives' work.
    let v_after = &d.state[m.nq..m.nq + nv];
    let mut contact_work = 0.0;
    for (r, p) in impulses.iter().enumerate() {
        if *p != 0.0 {
            let after = linalg::dot(&jrows[r * nv..(r + 1) * nv], v_after);
            contact_work += p * 0.5 * (rate[r] + after);
        }
    }
    for i in 0..2 * friction.fric.len() {
        let row = &friction.trows[i * nv..(i + 1) * nv];
        let (before, after) = (linalg::dot(row, qvel), linalg::dot(row, v_after));
        contact_work += friction.pt[i] * 0.5 * (before + after);
    }
    Ok(ImpactEnergy {
        dissipated: -contact_work,
        input_work: ke_gain - contact_work,
    })
}

/// What a round of impacts did to the energy balance \[J\].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpactEnergy {
    /// The energy the impacts dissipated (the kinetic energy lost, without drives).
    pub dissipated: f64,
    /// The work of the drives' impulses (0 without drives).
    pub input_work: f64,
}

/// The tangential impulses of the contacts with friction of a round, the normal impulses
/// `pn` given (their images `G Jᵀ` in `gj`, the velocities before the round in `qvel`): the
/// impulses `P_t` (two per contact, along [`super::friction::tangents`]) that minimise the
/// kinetic energy after the impact, `½ P_tᵀ W_tt P_t + P_tᵀ u_t`, over the Coulomb discs
/// `|P_t,c| ≤ μ_c P_n,c` (`W_tt = T G Tᵀ`, `u_t` the tangential velocities after the normal
/// impulses). Inside its disc a contact sticks (its tangential velocity after the impact is
/// zero); on the rim it slips with the largest impulse the cone allows. Solved by block
/// Gauss-Seidel over the contacts, each block (a 2 × 2 problem on a disc) exactly; every
/// sweep lowers the energy from `P_t = 0`, so friction never adds kinetic energy to what the
/// normal impulses leave. Results in `w.pt` (2 per contact in `w.fric`).
#[allow(clippy::too_many_arguments)]
fn friction_impulses(
    m: &Model,
    d: &Data,
    proj: &mut Projection,
    contacts: &[usize],
    pn: &[f64],
    gj: &[f64],
    qvel: &[f64],
    w: &mut FrictionWork,
) {
    let nv = m.nv;
    w.fric.clear();
    for (r, &ci) in contacts.iter().enumerate() {
        if d.contacts[ci].friction.mu > 0.0 && pn[r] > 0.0 {
            w.fric.push(r);
        }
    }
    let nf = w.fric.len();
    if nf == 0 {
        return;
    }
    let nt = 2 * nf;
    for (a, &r) in w.fric.iter().enumerate() {
        let ci = contacts[r];
        let g = super::gap(d, ci);
        let (t1, t2) = super::friction::tangents(&g.normal);
        for (k, t) in [t1, t2].iter().enumerate() {
            let i = 2 * a + k;
            let row = &mut w.trows[i * nv..(i + 1) * nv];
            row.iter_mut().for_each(|v| *v = 0.0);
            super::friction::add_tangent_row(m, &d.dof_s, &d.contacts[ci], &g, t, row);
            let col = &mut w.gt[i * nv..(i + 1) * nv];
            col.copy_from_slice(row);
            proj.apply(m, d, col);
        }
    }
    for i in 0..nt {
        let row = &w.trows[i * nv..(i + 1) * nv];
        let mut u = linalg::dot(row, qvel);
        for (r, p) in pn.iter().enumerate() {
            if *p != 0.0 {
                u += p * linalg::dot(row, &gj[r * nv..(r + 1) * nv]);
            }
        }
        w.bt[i] = u;
        for j in 0..nt {
            w.wtt[i * nt + j] = linalg::dot(row, &w.gt[j * nv..(j + 1) * nv]);
        }
    }
    let pt = &mut w.pt[..nt];
    pt.iter_mut().for_each(|p| *p = 0.0);
    let scale = w.bt[..nt].iter().fold(0.0_f64, |a, b| a.max(b.abs()));
    for _sweep in 0..200 {
        let mut change = 0.0_f64;
        for (a, &r) in w.fric.iter().enumerate() {
            let (i, j) = (2 * a, 2 * a + 1);
            let mut b = [w.bt[i], w.bt[j]];
            for (k, p) in pt.iter().enumerate() {
                if k != i && k != j {
                    b[0] += w.wtt[i * nt + k] * p;
                    b[1] += w.wtt[j * nt + k] * p;
                }
            }
            let block = [w.wtt[i * nt + i], w.wtt[i * nt + j], w.wtt[j * nt + j]];
            let radius = d.contacts[contacts[r]].friction.mu * pn[r];
            let p = disc_minimum(block, b, radius);
            change = change.max((p[0] - pt[i]).abs()).max((p[1] - pt[j]).abs());
            pt[i] = p[0];
            pt[j] = p[1];
        }
        if nf == 1 || change * block_scale(&w.wtt[..nt * nt], nt) <= 1e-15 * scale.max(1e-300) {
            break;
        }
    }
}

/// Largest diagonal entry of the `n × n` matrix `a` (for a convergence test in velocity
/// units).
fn block_scale(a: &[f64], n: usize) -> f64 {
    (0..n).fold(0.0_f64, |s, i| s.max(a[i * n + i].abs()))
}

/// The minimiser of `½ pᵀ A p + pᵀ b` over the disc `|p| ≤ radius`, `A = [[a0, a1], [a1, a2]]`
/// symmetric positive semi-definite. In the eigenbasis of `A` (eigenvalues `λ_i`, `b̃ = Eᵀ b`):
/// the unconstrained minimiser `p̃_i = −b̃_i/λ_i` (the least-norm one when `A` is singular and
/// `b` in its range) when it lies in the disc (stick), else `p̃_i = −b̃_i/(λ_i + κ)` with the
/// `κ > 0` that puts it on the rim (slip; `|p|` falls monotonically with κ, found by
/// bisection in `(0, |b|/radius]`).
pub fn disc_minimum([a0, a1, a2]: [f64; 3], b: [f64; 2], radius: f64) -> [f64; 2] {
    let bn = crate::math::hypot(b[0], b[1]);
    if radius <= 0.0 || bn == 0.0 || !radius.is_finite() {
        return [0.0; 2];
    }
    // eigen decomposition of the symmetric 2 × 2 matrix
    let (mean, half_diff) = (0.5 * (a0 + a2), 0.5 * (a0 - a2));
    let root = crate::math::hypot(half_diff, a1);
    let lambda = [(mean + root).max(0.0), (mean - root).max(0.0)];
    let angle = 0.5 * crate::math::atan2(a1, half_diff);
    let (sn, cs) = crate::math::sin_cos(angle);
    let e = [[cs, sn], [-sn, cs]];
    let bt = [e[0][0] * b[0] + e[0][1] * b[1], e[1][0] * b[0] + e[1][1] * b[1]];
    let small = 1e-12 * lambda[0].max(1e-300);
    let at = |k: f64| {
        let mut p = [0.0; 2];
        for i in 0..2 {
            let l = lambda[i] + k;
            p[i] = if l > small { -bt[i] / l } else { 0.0 };
        }
        p
    };
    let back = |p: [f64; 2]| [e[0][0] * p[0] + e[1][0] * p[1], e[0][1] * p[0] + e[1][1] * p[1]];
    let unbounded = (0..2).any(|i| lambda[i] <= small && bt[i].abs() > 1e-12 * bn);
    if !unbounded {
        let p = at(0.0);
        if crate::math::hypot(p[0], p[1]) <= radius {
            return back(p);
        }
    }
    let (mut lo, mut hi) = (0.0, bn / radius);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        let p = at(mid);
        if crate::math::hypot(p[0], p[1]) > radius {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let p = at(hi);
    let norm = crate::math::hypot(p[0], p[1]);
    if norm == 0.0 {
        return [0.0; 2];
    }
    back([p[0] * radius / norm, p[1] * radius / norm])
}

/// The nv-long buffers of [`effective_mass`].
struct MassBuffers<'a> {
    row: &'a mut [f64],
    free: &'a mut [f64],
    x: &'a mut [f64],
}

/// Effective mass (17) of one side of a contact: body `body` pushed at `point` along `dir`.
/// Infinite for the ground or a side that cannot move along `dir`.
fn effective_mass(
    m: &Model,
    d: &Data,
    proj: &mut Projection,
    bufs: &mut MassBuffers,
    body: Option<usize>,
    point: &nalgebra::Vector3<f64>,
    dir: &nalgebra::Vector3<f64>,
) -> Result<f64, String> {
    let Some(b) = body else { return Ok(f64::INFINITY) };
    let coef = Spatial::point_direction(point, dir);
    let MassBuffers { row, free, x } = bufs;
    row.iter_mut().for_each(|v| *v = 0.0);
    kinematics::add_jacobian_row(m, &d.dof_s, Some(b), &coef, 1.0, row);
    free.copy_from_slice(row);
    dynamics::solve_mass(m, &d.mass_blocks, free);
    let free_mobility = linalg::dot(row, free);
    x.copy_from_slice(row);
    proj.apply(m, d, x);
    let mobility = linalg::dot(row, x);
    // A side that cannot move along the normal (no dofs, or locked by the loops).
    if free_mobility.is_nan() || free_mobility <= 0.0 || mobility <= 1e-10 * free_mobility {
        return Ok(f64::INFINITY);
    }
    let mut momentum = 0.0;
    for (k, body) in m.bodies.iter().enumerate() {
        let mut dv = Spatial::zero();
        for_each_path_dof(m, k, |j| dv = dv.add(&d.dof_s[j].scale(x[j])));
        momentum += body.mass * dir.dot(&dv.point_velocity(&d.body_pos[k]));
    }
    Ok(momentum / mobility)
}

/// Solves the LCP `w = W p + q ≥ 0, p ≥ 0, pᵀw = 0` for a symmetric positive semi-definite
/// `W` (row-major n × n) by Murty's least-index principal pivoting. None if it does not
/// converge. Allocates; see [`solve_lcp_with`].
pub fn solve_lcp(w: &[f64], q: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut work = LcpWork::new(n);
    let mut p = vec![0.0; n];
    solve_lcp_with(w, q, n, &mut work, &mut p).then_some(p)
}

/// [`solve_lcp`] into `p` (at least `n` long) on preallocated work arrays (no allocation when
/// `work` was made for at least `n` unknowns). False if it does not converge.
pub fn solve_lcp_with(w: &[f64], q: &[f64], n: usize, work: &mut LcpWork, p_out: &mut [f64]) -> bool {
    work.reserve(n);
    let LcpWork {
        active,
        idx,
        p,
        a,
        rhs,
        perm,
        work,
        wv,
        ..
    } = work;
    let (active, p, wv) = (&mut active[..n], &mut p[..n], &mut wv[..n]);
    let scale_q = q[..n].iter().fold(0.0_f64, |a, b| a.max(b.abs())).max(1e-300);
    active.iter_mut().for_each(|x| *x = true);
    let max_iter = 50 * n + 50;
    for _ in 0..max_iter {
        idx.clear();
        idx.extend((0..n).filter(|&i| active[i]));
        let na = idx.len();
        p.iter_mut().for_each(|x| *x = 0.0);
        if na > 0 {
            let (a, rhs, perm, work) = (&mut a[..na * na], &mut rhs[..na], &mut perm[..na], &mut work[..na]);
            for (x, &i) in idx.iter().enumerate() {
                for (y, &j) in idx.iter().enumerate() {
                    a[x * na + y] = w[i * n + j];
                }
                rhs[x] = -q[i];
            }
            perm.iter_mut().for_each(|x| *x = 0);
            work.iter_mut().for_each(|x| *x = 0.0);
            let rank = linalg::pivoted_cholesky_in_place(a, na, perm, 1e-12);
            linalg::pivoted_cholesky_solve(a, na, perm, rank, rhs, work);
            for (x, &i) in idx.iter().enumerate() {
                p[i] = rhs[x];
            }
        }
        let scale_p = p.iter().fold(0.0_f64, |a, b| a.max(b.abs())).max(1e-300);
        for (i, v) in wv.iter_mut().enumerate() {
            *v = q[i] + (0..n).map(|j| w[i * n + j] * p[j]).sum::<f64>();
        }
        let violated = (0..n).find(|&i| {
            if active[i] {
                p[i] < -1e-12 * scale_p
            } else {
                wv[i] < -1e-12 * scale_q
            }
        });
        match violated {
            None => {
                for (o, x) in p_out.iter_mut().zip(p.iter()) {
                    *o = x.max(0.0);
                }
                return true;
            }
            Some(i) => active[i] = !active[i],
        }
    }
    false
}

/// Restitution to use for contact `c` hit at approach speed `approach` \[m/s\]: its
/// coefficient, or 0 (a plastic impact that ends in resting contact) below
/// `min_impact_velocity`.
pub fn restitution_for(c: &ContactElement, approach: f64) -> f64 {
    if approach < c.min_impact_velocity {
        0.0
    } else {
        c.restitution
    }
}
