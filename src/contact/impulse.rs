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

use super::element::ContactElement;
use super::work::{ImpulseWork, LcpWork, Projection};
use crate::dynamics;
use crate::kinematics::{self, for_each_path_dof};
use crate::linalg;
use crate::model::{Data, Model};
use crate::scene::ImpulseMethod;
use crate::spatial::Spatial;

impl Projection {
    /// Factorises at this configuration. Needs `d.phi_q` and `d.minv_phit` of the loop rows
    /// (the last evaluation computed them).
    pub(crate) fn factor(&mut self, m: &Model, d: &Data) {
        let nv = m.nv;
        let nl = m.loop_rows();
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
/// counts the impacts that took an impulse and returns the kinetic energy lost [J]; the
/// impulses are left in [`ImpulseWork::impulses`]. Allocates nothing when `work` was made for
/// at least `contacts.len()` contacts of this model (except to report an error).
pub fn resolve_with(
    m: &Model,
    d: &mut Data,
    work: &mut ImpulseWork,
    contacts: &[usize],
    restitution: &[f64],
) -> Result<f64, String> {
    let nv = m.nv;
    let k = contacts.len();
    work.last = 0;
    if k == 0 {
        return Ok(0.0);
    }
    work.reserve(m.nv, m.loop_rows(), k);
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
        ..
    } = work;
    proj.factor(m, d);
    // Rows J (k × nv) and their images G Jᵀ.
    let jrows = &mut jrows[..k * nv];
    let gj = &mut gj[..k * nv];
    jrows.iter_mut().for_each(|v| *v = 0.0);
    for (r, &ci) in contacts.iter().enumerate() {
        let c = &m.contacts[ci];
        let g = super::gap(m, d, ci);
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
        match m.contacts[ci].impulse_method {
            ImpulseMethod::Exact => exact.push(r),
            ImpulseMethod::EffectiveMass => {
                let c = &m.contacts[ci];
                let g = super::gap(m, d, ci);
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
                            c.name
                        ))
                    }
                };
                for (side, mass) in [("sphere_body", ms), ("body", mo)] {
                    if mass <= 0.0 {
                        return Err(format!(
                            "contact {:?}: the effective mass (17) of its {side} is {mass:.6e} kg (≤ 0: the paper's \
                             approximation ignores rotational inertia and joint reactions); use impulse_method = \"exact\"",
                            c.name
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
            let names: Vec<&str> = exact.iter().map(|&r| m.contacts[contacts[r]].name.as_str()).collect();
            return Err(format!(
                "simultaneous impact of contacts {names:?}: the impulse problem has no solution"
            ));
        }
        for (a, &ra) in exact.iter().enumerate() {
            impulses[ra] = p[a];
        }
    }
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
    }
    d.eval_state.copy_from_slice(&d.state);
    kinematics::kinematics(m, d);
    // The effective-mass impulse may leave a contact still approaching: report it rather than
    // let the surfaces pass through each other.
    for (r, &ci) in contacts.iter().enumerate() {
        let c = &m.contacts[ci];
        if c.impulse_method == ImpulseMethod::EffectiveMass {
            let after = linalg::dot(&jrows[r * nv..(r + 1) * nv], &d.state[m.nq..m.nq + nv]);
            if after < -1e-9 * rate[r].abs() {
                return Err(format!(
                    "contact {:?}: the effective-mass impulse (17)-(19) leaves the bodies approaching at {:.6e} m/s \
                     (approach {:.6e} m/s); the approximation fails here, use impulse_method = \"exact\"",
                    c.name, -after, -rate[r]
                ));
            }
        }
    }
    work.last = k;
    Ok(ke_before - dynamics::kinetic_energy(m, d))
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

/// Restitution to use for contact `c` hit at approach speed `approach` [m/s]: its
/// coefficient, or 0 (a plastic impact that ends in resting contact) below
/// `min_impact_velocity`.
pub fn restitution_for(c: &ContactElement, approach: f64) -> f64 {
    if approach < c.min_impact_velocity {
        0.0
    } else {
        c.restitution
    }
}
