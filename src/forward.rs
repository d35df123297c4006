//! Forward dynamics: the right-hand side `y' = f(t, y)` of the equations of motion, one
//! pipeline from the state to the accelerations (in the manner of MuJoCo's `mj_forward`):
//!
//! 1. [`kinematics`]: body poses, velocities, motion subspaces;
//! 2. [`applied_forces`](dynamics::applied_forces): gravity, springs, inputs;
//! 3. [`contact::apply_forces`]: the continuous contact laws of the active contacts;
//! 4. [`mass_and_bias`](dynamics::mass_and_bias) and [`factor_mass`](dynamics::factor_mass):
//!    `M̄` and `τ − C`;
//! 5. the accelerations: `M̄ q̈ = τ − C`, or with constraint rows (loops, resting contacts)
//!    the constrained solve for `q̈` and `λ`.
//!
//! The contact *mode* (which contacts are active) is frozen during an evaluation; the engine
//! changes it at located events.
//!
//! The integrators call [`evaluate_rhs`], which follows the model's [`Plan`](crate::model::Plan):
//! free bodies (a free joint to the ground, nothing attached by a loop) skip the general path
//! — no motion subspaces, spatial inertias, mass-matrix assembly or factorisation — and get
//! their accelerations from Newton-Euler with their constant body-frame mass matrix; the rest
//! of the model takes the general path above. [`evaluate`] (outputs, events, mode changes,
//! projection) always takes the general path over the whole model, so that everything in
//! [`Data`] is filled.

use crate::contact::{self, any_resting};
use crate::dynamics;
use crate::integrator::OdeSystem;
use crate::kinematics::{free_body_kinematics, joint_kinematics, kinematics, position_derivative, rotor_kinematics};
use crate::model::{Data, Model};

/// Evaluates everything at `d.eval_state`: kinematics, forces, accelerations (`d.qacc`), the
/// dissipated power (`d.dissipation`) and the contact outputs. Returns false when the mass
/// matrix is not positive definite (the accelerations are then NaN).
pub fn evaluate(m: &Model, d: &mut Data) -> bool {
    evaluate_all(m, d, false)
}

/// [`evaluate`]; `rotors`: the rotor joints by their lean kinematics
/// ([`crate::kinematics::rotor_kinematics`]), for the right-hand side only.
fn evaluate_all(m: &Model, d: &mut Data, rotors: bool) -> bool {
    if rotors {
        for ji in 0..m.joints.len() {
            match &m.plan.rotors[ji] {
                Some(r) => rotor_kinematics(m, d, ji, r),
                None => joint_kinematics(m, d, ji),
            }
        }
    } else {
        kinematics(m, d);
    }
    let mut power = dynamics::applied_forces(m, d);
    if !d.contacts.is_empty() {
        power += contact_forces(d);
    }
    d.dissipation = power;
    dynamics::mass_and_bias(m, d);
    let ok = dynamics::factor_mass(m, d);
    if ok {
        // The constraint rows: the loops, and the rows of resting impulse contacts (skipped
        // when there are no loops and nothing rests).
        // (an engine's list of the step's force contacts means that none rests)
        let resting = !d.force_contacts_listed && any_resting(d);
        if d.nc > 0 && (resting || m.fixed_rows() > 0) {
            constrained_accelerations(m, d);
            if resting {
                let friction = contact::resting_friction(m, d);
                if friction != 0.0 {
                    d.dissipation += friction;
                }
                contact::resting_outputs(d);
            }
        } else {
            dynamics::solve_mass(m, &d.mass_blocks, &mut d.qacc);
        }
    } else {
        d.qacc.iter_mut().for_each(|x| *x = f64::NAN);
    }
    ok
}

/// q̈ from the constrained equations of motion at `d.eval_state` (the loops' rows, the drives'
/// and the resting contacts'), and the drives' power, which only that solve yields (their
/// forces are its multipliers).
fn constrained_accelerations(m: &Model, d: &mut Data) {
    dynamics::constraints(m, d, contact::resting_rows);
    dynamics::solve_constrained(m, d);
    if !m.drives.is_empty() {
        d.input_power += dynamics::drive_power(m, d);
    }
}

/// The right-hand side's evaluation at `d.eval_state`: `d.qacc` and `d.dissipation` as
/// [`evaluate`] computes them (up to rounding: the free bodies' accelerations come from
/// Newton-Euler instead of the factorised mass matrix), by the lean path of the model's plan.
/// Leaves the free bodies' motion subspaces, bias accelerations and spatial inertias, and
/// their blocks of the mass matrix, as they were: code that reads those calls [`evaluate`]
/// or [`kinematics`]. Takes the general path while an impulse-law contact rests (its
/// constraint row needs the motion subspaces).
pub fn evaluate_rhs(m: &Model, d: &mut Data) -> bool {
    let plan = &m.plan;
    d.planned_kinematics = false;
    // (nothing rests when the engine listed the contacts' forces for the step)
    if !d.force_contacts_listed && any_resting(d) {
        return evaluate(m, d);
    }
    if plan.free.is_empty() {
        return evaluate_all(m, d, true);
    }
    let general = &plan.general;
    planned_kinematics_and_forces(m, d);
    d.planned_kinematics = true;
    let mut ok = true;
    if !general.joints.is_empty() {
        dynamics::mass_and_bias_part(m, d, general);
        ok = dynamics::factor_mass_trees(m, d, &general.trees);
        if !ok {
            d.qacc.iter_mut().for_each(|x| *x = f64::NAN);
        } else if m.fixed_rows() > 0 {
            // A loop never touches a free body (the plan leaves such a body on the general
            // path), so the free bodies' columns of Φ_q are zero, and the solve over every block
            // leaves the general dofs as the solve over the general blocks would, given zeros
            // in the free bodies' entries of q̈ and a valid factor in their blocks (their entries
            // are overwritten below). Both are written here: a full evaluation since the last
            // one of these leaves its own factor there, or, should it fail (a body's inertia
            // near singular, whose world-frame block then has a negative pivot), a broken one
            // and NaN in q̈, which 0 × NaN would carry into every general dof.
            for fb in &plan.free {
                m.write_free_block(fb, &mut d.mass_blocks);
                d.qacc[fb.qvel..fb.qvel + 6].fill(0.0);
            }
            constrained_accelerations(m, d);
        } else {
            dynamics::solve_mass_trees(m, &general.trees, &d.mass_blocks, &mut d.qacc);
        }
    }
    for fb in &plan.free {
        dynamics::free_body_accelerations(m, d, fb);
    }
    ok
}

/// What the outputs read, at the current state `d.state`: body poses and velocities, the
/// contact forces and outputs (through the plan: the free bodies' lean kinematics). The mass
/// matrix and the accelerations are not computed (no output reads them), except in a model
/// with loops (the data after an output read then holds the constrained solve: its
/// multipliers and the rank of its constraint rows, as before) or while an impulse-law
/// contact rests (its force is a multiplier): then this is [`evaluate_current`].
pub fn evaluate_outputs(m: &Model, d: &mut Data) {
    if m.fixed_rows() > 0 || any_resting(d) {
        evaluate_current(m, d);
        return;
    }
    d.eval_state.copy_from_slice(&d.state);
    planned_kinematics_and_forces(m, d);
}

/// The kinematics part of [`evaluate_outputs`] alone (the same functions at the same state),
/// for reads of body positions, orientations and velocities; false (nothing done) when
/// [`evaluate_outputs`] would take the full evaluation for them (loops, resting contacts;
/// drives alone need it only for their forces).
pub fn evaluate_output_kinematics(m: &Model, d: &mut Data) -> bool {
    if m.loop_rows() > 0 || any_resting(d) {
        return false;
    }
    d.eval_state.copy_from_slice(&d.state);
    planned_kinematics(m, d);
    true
}

/// Kinematics at `d.eval_state` through the plan: the general joints', then the free bodies'
/// lean ones (poses and velocities; their motion subspaces, bias accelerations and spatial
/// inertias are left as they were: code that reads those calls [`kinematics`]).
pub fn planned_kinematics(m: &Model, d: &mut Data) {
    d.planned_kinematics = false;
    for &ji in &m.plan.general.joints {
        joint_kinematics(m, d, ji);
    }
    for fb in &m.plan.free {
        free_body_kinematics(m, d, fb);
    }
}

/// Kinematics through the plan (the general joints', then the free bodies' lean ones), the
/// applied and contact forces, and the dissipated power, at `d.eval_state`.
fn planned_kinematics_and_forces(m: &Model, d: &mut Data) {
    planned_kinematics(m, d);
    let mut power = dynamics::applied_forces(m, d);
    if !d.contacts.is_empty() {
        power += contact_forces(d);
    }
    d.dissipation = power;
}

/// [`contact::apply_forces`] for the right-hand side: over the contacts the engine listed for
/// the integrator's step when it did (the same numbers), else over all.
fn contact_forces(d: &mut Data) -> f64 {
    if d.force_contacts_listed {
        contact::apply_listed_forces(d)
    } else {
        contact::apply_forces(d)
    }
}

/// [`evaluate`] at the current state `d.state`.
pub fn evaluate_current(m: &Model, d: &mut Data) -> bool {
    d.eval_state.copy_from_slice(&d.state);
    evaluate(m, d)
}

/// Writes `y' = f(y)` for the state evaluated last (`d.eval_state`): position rates, `q̈`,
/// dissipated power, the inputs' power.
pub fn state_derivative(m: &Model, d: &Data, dy: &mut [f64]) {
    let (nq, nv) = (m.nq, m.nv);
    position_derivative(m, &d.eval_state, &mut dy[..nq]);
    dy[nq..nq + nv].copy_from_slice(&d.qacc);
    dy[nq + nv] = d.dissipation;
    if let Some(i) = m.input_work_index() {
        dy[i] = d.input_power;
    }
}

/// The right-hand side of a model as an [`OdeSystem`] for the integrators.
pub struct Rhs<'a> {
    /// Model.
    pub model: &'a Model,
    /// Data (the integrator is not in it while it steps).
    pub data: &'a mut Data,
}

impl OdeSystem for Rhs<'_> {
    fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        self.data.eval_state.copy_from_slice(y);
        evaluate_rhs(self.model, self.data);
        state_derivative(self.model, self.data, dy);
    }
}
