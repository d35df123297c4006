//! Piecewise analysis: impacts as velocity jumps (PHYSICS.md §3.1).
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

use super::ContactElement;
use crate::dynamics::{self, for_each_path_dof};
use crate::linalg;
use crate::model::{Data, Model};
use crate::scene::ImpulseMethod;
use crate::spatial::Spatial;

/// The loop-only projection `G`: the factor of `Φ_l M̄⁻¹ Φ_lᵀ` over the `nl` loop rows.
struct Projection {
    nl: usize,
    schur: Vec<f64>,
    perm: Vec<usize>,
    rank: usize,
}

impl Projection {
    /// Needs `d.phi_q` and `d.minv_phit` of the loop rows at this configuration (the last
    /// evaluation computed them).
    fn new(m: &Model, d: &Data) -> Projection {
        let nv = m.nv;
        let nl = super::loop_rows(m);
        let mut schur = vec![0.0; nl * nl];
        for r in 0..nl {
            for c in 0..nl {
                schur[r * nl + c] = linalg::dot(&d.phi_q[r * nv..(r + 1) * nv], &d.minv_phit[c * nv..(c + 1) * nv]);
            }
        }
        let mut perm = vec![0; nl];
        let rank = linalg::pivoted_cholesky_in_place(&mut schur, nl, &mut perm, dynamics::REDUNDANT_PIVOT);
        Projection { nl, schur, perm, rank }
    }

    /// `x ← G x`.
    fn apply(&self, m: &Model, d: &Data, x: &mut [f64]) {
        dynamics::solve_mass(m, &d.mass_blocks, x);
        let (nv, nl) = (m.nv, self.nl);
        if nl == 0 {
            return;
        }
        let mut b: Vec<f64> = (0..nl)
            .map(|r| linalg::dot(&d.phi_q[r * nv..(r + 1) * nv], x))
            .collect();
        let mut work = vec![0.0; nl];
        linalg::pivoted_cholesky_solve(&self.schur, nl, &self.perm, self.rank, &mut b, &mut work);
        for (r, l) in b.iter().enumerate() {
            for (xi, g) in x.iter_mut().zip(&d.minv_phit[r * nv..(r + 1) * nv]) {
                *xi -= l * g;
            }
        }
    }
}

/// What one round of impacts did.
#[derive(Debug, Clone, PartialEq)]
pub struct Resolution {
    /// Kinetic energy lost [J] (negative if the effective-mass approximation created energy).
    pub energy_lost: f64,
    /// Normal impulse of each contact, in the order given [N s].
    pub impulses: Vec<f64>,
}

/// Resolves one round of simultaneous impacts of `contacts` with restitution coefficients
/// `restitution` (one each) at the current state. The data must have been evaluated at this
/// configuration (mass matrix factorised; loop Jacobian and `M̄⁻¹Φ_qᵀ` computed). Updates the
/// velocities in `d.state` and the kinematics, counts the impacts that took an impulse and
/// returns the energy lost and the impulses.
pub fn resolve(m: &Model, d: &mut Data, contacts: &[usize], restitution: &[f64]) -> Result<Resolution, String> {
    let nv = m.nv;
    let k = contacts.len();
    if k == 0 {
        return Ok(Resolution {
            energy_lost: 0.0,
            impulses: Vec::new(),
        });
    }
    let proj = Projection::new(m, d);
    // Rows J (k × nv) and their images G Jᵀ.
    let mut jrows = vec![0.0; k * nv];
    let mut gj = vec![0.0; k * nv];
    for (r, &ci) in contacts.iter().enumerate() {
        let c = &m.contacts[ci];
        let g = super::gap(m, d, ci);
        let row = &mut jrows[r * nv..(r + 1) * nv];
        super::add_separation_row(m, d, c, &g, row);
        let col = &mut gj[r * nv..(r + 1) * nv];
        col.copy_from_slice(row);
        proj.apply(m, d, col);
    }
    let ke_before = dynamics::kinetic_energy(m, d);
    let qvel: Vec<f64> = d.state[m.nq..m.nq + nv].to_vec();
    // Pre-impact separation rates (negative: approaching).
    let rate: Vec<f64> = (0..k)
        .map(|r| linalg::dot(&jrows[r * nv..(r + 1) * nv], &qvel))
        .collect();
    let mut impulses = vec![0.0; k];
    let mut exact: Vec<usize> = Vec::new();
    for (r, &ci) in contacts.iter().enumerate() {
        match m.contacts[ci].impulse_method {
            ImpulseMethod::Exact => exact.push(r),
            ImpulseMethod::EffectiveMass => {
                let c = &m.contacts[ci];
                let g = super::gap(m, d, ci);
                let ms = effective_mass(m, d, &proj, c.sphere_body, &g.point, &g.normal)?;
                let mo = effective_mass(m, d, &proj, c.body, &g.point, &(-g.normal))?;
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
        let mut w = vec![0.0; n * n];
        let mut q = vec![0.0; n];
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
        let p = solve_lcp(&w, &q, n).ok_or_else(|| {
            let names: Vec<&str> = exact.iter().map(|&r| m.contacts[contacts[r]].name.as_str()).collect();
            format!("simultaneous impact of contacts {names:?}: the impulse problem has no solution")
        })?;
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
    let state = d.state.clone();
    dynamics::kinematics(m, d, &state);
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
    Ok(Resolution {
        energy_lost: ke_before - dynamics::kinetic_energy(m, d),
        impulses,
    })
}

/// Effective mass (17) of one side of a contact: body `body` pushed at `point` along `dir`.
/// Infinite for the ground or a side that cannot move along `dir`.
fn effective_mass(
    m: &Model,
    d: &Data,
    proj: &Projection,
    body: Option<usize>,
    point: &nalgebra::Vector3<f64>,
    dir: &nalgebra::Vector3<f64>,
) -> Result<f64, String> {
    let Some(b) = body else { return Ok(f64::INFINITY) };
    let nv = m.nv;
    let coef = Spatial::point_direction(point, dir);
    let mut row = vec![0.0; nv];
    dynamics::add_jacobian_row(m, d, Some(b), &coef, 1.0, &mut row);
    let mut free = row.clone();
    dynamics::solve_mass(m, &d.mass_blocks, &mut free);
    let free_mobility = linalg::dot(&row, &free);
    let mut x = row.clone();
    proj.apply(m, d, &mut x);
    let mobility = linalg::dot(&row, &x);
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
/// converge.
pub fn solve_lcp(w: &[f64], q: &[f64], n: usize) -> Option<Vec<f64>> {
    let scale_q = q.iter().fold(0.0_f64, |a, b| a.max(b.abs())).max(1e-300);
    let mut active = vec![true; n];
    let max_iter = 50 * n + 50;
    for _ in 0..max_iter {
        let idx: Vec<usize> = (0..n).filter(|&i| active[i]).collect();
        let na = idx.len();
        let mut p = vec![0.0; n];
        if na > 0 {
            let mut a = vec![0.0; na * na];
            let mut rhs = vec![0.0; na];
            for (x, &i) in idx.iter().enumerate() {
                for (y, &j) in idx.iter().enumerate() {
                    a[x * na + y] = w[i * n + j];
                }
                rhs[x] = -q[i];
            }
            let mut perm = vec![0; na];
            let mut work = vec![0.0; na];
            let rank = linalg::pivoted_cholesky_in_place(&mut a, na, &mut perm, 1e-12);
            linalg::pivoted_cholesky_solve(&a, na, &perm, rank, &mut rhs, &mut work);
            for (x, &i) in idx.iter().enumerate() {
                p[i] = rhs[x];
            }
        }
        let scale_p = p.iter().fold(0.0_f64, |a, b| a.max(b.abs())).max(1e-300);
        let wv: Vec<f64> = (0..n)
            .map(|i| q[i] + (0..n).map(|j| w[i * n + j] * p[j]).sum::<f64>())
            .collect();
        let violated = (0..n).find(|&i| {
            if active[i] {
                p[i] < -1e-12 * scale_p
            } else {
                wv[i] < -1e-12 * scale_q
            }
        });
        match violated {
            None => {
                for x in p.iter_mut() {
                    *x = x.max(0.0);
                }
                return Some(p);
            }
            Some(i) => active[i] = !active[i],
        }
    }
    None
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
