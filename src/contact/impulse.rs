//! Piecewise analysis: the exact generalised impulse-momentum solve (PHYSICS.md §3.1).
//!
//! For the impacting contacts with separation-rate rows `J` (so that `J q̇` is the rate at
//! which the surfaces separate), the velocity jump is `Δq̇ = G Jᵀ P` with
//! `G = M̄⁻¹ − M̄⁻¹Φ_qᵀ (Φ_q M̄⁻¹ Φ_qᵀ)⁺ Φ_q M̄⁻¹` (the loops stay closed), and the impulses
//! `P ≥ 0` satisfy Newton's law `J q̇⁺ = −e J q̇⁻`.

use crate::dynamics::{self, add_jacobian_row};
use crate::linalg;
use crate::model::{Data, Model};

/// Resolves simultaneous impacts of `contacts` at the current state. The data must have
/// been evaluated at this state (mass matrix factorised, constraints assembled). Updates the
/// velocities in `d.state`, counts the impacts and returns the kinetic energy lost [J].
pub fn resolve(m: &Model, d: &mut Data, contacts: &[usize]) -> Result<f64, String> {
    let nv = m.nv;
    let k = contacts.len();
    // Rows J (k × nv) and G Jᵀ columns (nv each).
    let mut jrows = vec![0.0; k * nv];
    let mut gj = vec![0.0; k * nv];
    for (r, &ci) in contacts.iter().enumerate() {
        let c = &m.contacts[ci];
        let g = super::gap(m, d, ci);
        let (cs, co) = super::separation_coefficients(&g);
        let row = &mut jrows[r * nv..(r + 1) * nv];
        add_jacobian_row(m, d, c.sphere_body, &cs, 1.0, row);
        add_jacobian_row(m, d, c.body, &co, 1.0, row);
        let col = &mut gj[r * nv..(r + 1) * nv];
        col.copy_from_slice(row);
        project_solve(m, d, col);
    }
    let ke_before = kinetic(m, d);
    let qvel: Vec<f64> = d.state[m.nq..m.nq + nv].to_vec();
    let mut active: Vec<bool> = vec![true; k];
    // Drop contacts that would need a pulling impulse, until all P ≥ 0.
    for _ in 0..=k {
        let idx: Vec<usize> = (0..k).filter(|&r| active[r]).collect();
        let n = idx.len();
        if n == 0 {
            break;
        }
        let mut w = vec![0.0; n * n];
        let mut rhs = vec![0.0; n];
        for (a, &ra) in idx.iter().enumerate() {
            for (b, &rb) in idx.iter().enumerate() {
                w[a * n + b] = linalg::dot(&jrows[ra * nv..(ra + 1) * nv], &gj[rb * nv..(rb + 1) * nv]);
            }
            let e = m.contacts[contacts[ra]].restitution;
            rhs[a] = -(1.0 + e) * linalg::dot(&jrows[ra * nv..(ra + 1) * nv], &qvel);
        }
        let mut perm = vec![0; n];
        let mut work = vec![0.0; n];
        let rank = linalg::pivoted_cholesky_in_place(&mut w, n, &mut perm, 1e-12);
        if rank == 0 {
            return Err("impact with zero effective mass (the contact cannot move)".into());
        }
        linalg::pivoted_cholesky_solve(&w, n, &perm, rank, &mut rhs, &mut work);
        if let Some(a) = (0..n).find(|&a| rhs[a] < 0.0) {
            active[idx[a]] = false;
            continue;
        }
        let v = &mut d.state[m.nq..m.nq + nv];
        for (a, &ra) in idx.iter().enumerate() {
            for (x, g) in v.iter_mut().zip(&gj[ra * nv..(ra + 1) * nv]) {
                *x += rhs[a] * g;
            }
            d.contact_memory[contacts[ra]].impacts += 1;
        }
        break;
    }
    let state = d.state.clone();
    dynamics::kinematics(m, d, &state);
    Ok(ke_before - kinetic(m, d))
}

fn kinetic(m: &Model, d: &Data) -> f64 {
    dynamics::kinetic_energy(m, d)
}

/// Applies G: solves M̄ x = b, then removes the part that would open the loops.
fn project_solve(m: &Model, d: &mut Data, x: &mut [f64]) {
    dynamics::solve_mass(m, &d.mass_blocks, x);
    let (nv, nc) = (m.nv, m.nc);
    if nc == 0 {
        return;
    }
    let mut b = vec![0.0; nc];
    for (r, br) in b.iter_mut().enumerate() {
        *br = linalg::dot(&d.phi_q[r * nv..(r + 1) * nv], x);
    }
    // d.schur holds the pivoted factor of Φ_q M̄⁻¹ Φ_qᵀ from the last evaluation.
    let r = schur_rank(d, nc);
    linalg::pivoted_cholesky_solve(&d.schur, nc, &d.schur_perm, r, &mut b, &mut d.work[..nc]);
    for (r, l) in b.iter().enumerate() {
        for (xi, g) in x.iter_mut().zip(&d.minv_phit[r * nv..(r + 1) * nv]) {
            *xi -= l * g;
        }
    }
}

fn schur_rank(d: &Data, nc: usize) -> usize {
    d.schur_rank.min(nc)
}
