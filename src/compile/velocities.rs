//! The initial joint rates: the scene gives body velocities in the world frame; they are
//! projected onto the joint coordinates by least squares (docs/physics.md (35)-(37)) and onto
//! the loop constraints; a driven joint's rate is its input's.

use super::parameters::Parameters;
use crate::contact::resting_rows;
use crate::dynamics::constraints;
use crate::kinematics::{for_each_path_dof, kinematics};
use crate::model::{Data, Model};
use nalgebra::{DMatrix, DVector};

/// Initial joint rates from the scene's body velocities by least squares, per tree
/// (docs/physics.md (35)-(37)), then projected onto the loop constraints (28). Returns them
/// with a warning for each inconsistency. Uses `d` as workspace.
pub(super) fn initial_velocities(m: &Model, d: &mut Data, params: &Parameters) -> (Vec<f64>, Vec<String>) {
    let mut warnings = Vec::new();
    d.eval_state.copy_from_slice(&d.state);
    d.eval_state[m.nq..].iter_mut().for_each(|x| *x = 0.0);
    kinematics(m, d);
    let mut qvel = vec![0.0; m.nv];
    // The bodies of each tree, in joint order (one pass over the joints).
    let mut tree_bodies: Vec<Vec<usize>> = vec![Vec::new(); m.trees.len()];
    for j in &m.joints {
        tree_bodies[j.tree].push(j.child);
    }
    for (t, &(t0, n)) in m.trees.iter().enumerate() {
        if n == 0 {
            continue;
        }
        let bodies = &tree_bodies[t];
        let mut y = DVector::<f64>::zeros(6 * bodies.len());
        for (i, &b) in bodies.iter().enumerate() {
            for k in 0..3 {
                y[6 * i + k] = params.velocities[b][k];
                y[6 * i + 3 + k] = params.angular_velocities[b][k];
            }
        }
        // A tree at rest has zero rates: no matrix to build (it is dense, 6 bodies × dofs).
        if y.norm() == 0.0 {
            continue;
        }
        let mut bmat = DMatrix::<f64>::zeros(6 * bodies.len(), n);
        for (i, &b) in bodies.iter().enumerate() {
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
        let svd = bmat.clone().svd(true, true);
        let sol = svd.solve(&y, 1e-12).unwrap_or_else(|_| DVector::zeros(n));
        let resid = (&bmat * &sol - &y).norm();
        if resid > 1e-6 * (1.0 + y.norm()) {
            let names: Vec<&str> = bodies.iter().map(|&b| m.bodies[b].name.as_str()).collect();
            warnings.push(format!(
                "initial velocities of bodies {} are inconsistent with their joints (least-squares residual {resid:.3e} in [v; ω]); using the least-squares projection",
                names.join(", ")
            ));
        }
        qvel[t0..t0 + n].copy_from_slice(sol.as_slice());
    }
    // a driven joint's rate is its input's qd
    for dr in &m.drives {
        qvel[dr.qvel] = d.inputs[dr.value + 1];
    }
    if d.nc > 0 {
        d.eval_state[m.nq..m.nq + m.nv].copy_from_slice(&qvel);
        kinematics(m, d);
        constraints(m, d, resting_rows);
        let j = DMatrix::from_row_slice(d.nc, m.nv, &d.phi_q);
        let v = DVector::from_column_slice(&qvel);
        // Φ_q q̇ = 0 for the loops, q̇_k = qd for the drives (kept: their rows hold them)
        let mut viol = &j * &v;
        for dr in &m.drives {
            viol[dr.row] -= d.inputs[dr.value + 1];
        }
        if viol.norm() > 0.0 {
            let jjt = &j * j.transpose();
            let corr = jjt
                .svd(true, true)
                .solve(&viol, 1e-10)
                .unwrap_or_else(|_| DVector::zeros(d.nc));
            let fixed = v - j.transpose() * corr;
            if viol.norm() > 1e-9 * (1.0 + fixed.norm()) {
                warnings.push(format!(
                    "initial velocities violated the loop constraints by {:.3e}; projected",
                    viol.norm()
                ));
            }
            qvel.copy_from_slice(fixed.as_slice());
        }
        let phi_norm = d.phi.iter().map(|x| x * x).sum::<f64>().sqrt();
        if phi_norm > 1e-9 {
            warnings.push(format!(
                "the initial configuration violates the loop constraints by {phi_norm:.3e}"
            ));
        }
    }
    (qvel, warnings)
}
