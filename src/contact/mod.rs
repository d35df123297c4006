//! Contact: detection (geometry, [`geometry`]) apart from response (force laws, [`laws`]).
//!
//! Every element is a sphere on one body against a shape on another (either may be the
//! ground). Detection gives the penetration δ, its rate δ̇, the normal `n` (pointing from
//! the other shape toward the sphere: the force on the sphere is `+F n`), the contact point
//! and the margin by which the sphere centre's projection lies inside the shape's patch.
//!
//! The gap rate is `δ̇ = −(v_sphere(p) − v_other(p)) · n` for the material points at the
//! contact point `p`, so the same coefficient vectors give δ̇, the Jacobian row of the
//! normal gap (for impulses) and the generalised contact force.

//!
//! Modes: a continuous-law contact is *active* from touch to separation (its force law acts
//! and it remembers δ̇⁻). An impulse-law contact is normally inactive (impacts are velocity
//! jumps, [`impulse`]); when it is hit slower than `min_impact_velocity` it becomes *resting*
//! (`active`): a unilateral constraint row `J q̈ = −J̇ q̇` (with Baumgarte stabilisation of δ)
//! holds it until its normal force would become tensile, or the sphere leaves the patch.

pub mod broad;
pub mod elements;
pub mod friction;
pub mod geometry;
pub mod groups;
pub mod impulse;
pub mod laws;

use crate::kinematics::{add_jacobian_row, frame, placement};
use crate::model::{Data, Model};
use crate::scene::Law;
use crate::spatial::{Placement, Spatial};

pub use crate::model::contact::{ContactElement, ContactMemory, ContactOutput, Friction, Shape};
pub use geometry::Gap;

/// Evaluates the geometry of contact `i` at the current kinematics.
pub fn gap(d: &Data, i: usize) -> Gap {
    gap_of(&d.contacts[i], d)
}

/// [`gap`] of a contact element `c`, listed in `d` or not, at the kinematics in `d`.
pub fn gap_of(c: &ContactElement, d: &Data) -> Gap {
    geometry::detect_placed(c, placement(d, c.sphere_body), placement(d, c.body))
}

/// Event function of contact `i`: positive exactly when the sphere is inside the shape's
/// patch with `0 < δ < δ_max`; continuous across every boundary.
pub fn event_function(c: &ContactElement, g: &Gap) -> f64 {
    g.delta.min(g.margin).min(c.max_penetration - g.delta)
}

/// Broad phase: when the sphere centre is farther from the other shape's bounding sphere than
/// `radius + max_penetration`, no part of the admissible region can be reached (δ < 0, or the
/// projection is off the patch, or δ > δ_max) and the exact detection is skipped. Returns
/// then a negative stand-in for the event function (minus the clearance \[m\]) and the rate at
/// which the clearance closes \[m/s\] (the stand-in for δ̇); `None` when the exact detection is
/// needed.
pub fn broad_phase(c: &ContactElement, d: &Data) -> Option<(f64, f64)> {
    if !c.bound_radius.is_finite() {
        return None;
    }
    let (fs, fo) = (placement(d, c.sphere_body), placement(d, c.body));
    let center = Placement::point(fs, &c.center);
    let other = Placement::point(fo, &geometry::bound_center(&c.shape));
    let apart = center - other;
    let distance = apart.norm();
    let clearance = distance - (c.bound_radius + c.radius + c.max_penetration);
    if clearance > 0.0 {
        let relative = Placement::point_velocity(fs, &center) - Placement::point_velocity(fo, &other);
        Some((-clearance, -apart.dot(&relative) / distance))
    } else {
        None
    }
}

/// The geometric event function of contact `i` at the current kinematics, with the broad
/// phase: the same sign as [`event_function`] of the exact gap.
pub fn gap_event(d: &Data, i: usize) -> f64 {
    let c = &d.contacts[i];
    match broad_phase(c, d) {
        Some((v, _)) => v,
        None => event_function(c, &gap(d, i)),
    }
}

/// Adds the Jacobian row of the separation rate `−δ̇` of gap `g` of contact `c` to `row`
/// (`dof_s`: the motion subspaces, `Data::dof_s`).
pub fn add_separation_row(m: &Model, dof_s: &[Spatial], c: &ContactElement, g: &Gap, row: &mut [f64]) {
    let (cs, co) = separation_coefficients(g);
    add_jacobian_row(m, dof_s, c.sphere_body, &cs, 1.0, row);
    add_jacobian_row(m, dof_s, c.body, &co, 1.0, row);
}

/// Fills the constraint rows of the resting impulse contacts (a
/// [`crate::dynamics::ConstraintRows`]: called after the loop rows, before stabilisation,
/// with the rows zeroed): the row is the separation-rate Jacobian `J`, the value `Φ = −δ`,
/// and `γ = −J̇ q̇` (see [`geometry::separation_acceleration_bias`]). Rows of contacts that
/// do not rest stay zero (the pivoted factorisation drops them).
pub fn resting_rows(m: &Model, d: &mut Data) {
    let nv = m.nv;
    for (i, c) in d.contacts.iter().enumerate() {
        let Some(r) = c.constraint_row else { continue };
        if !d.contact_memory[i].active {
            continue;
        }
        let fs = frame(d, c.sphere_body);
        let fo = frame(d, c.body);
        let g = geometry::detect(c, &fs, &fo);
        add_separation_row(m, &d.dof_s, c, &g, &mut d.phi_q[r * nv..(r + 1) * nv]);
        d.phi[r] = -g.delta;
        d.gamma[r] = -geometry::separation_acceleration_bias(c, &fs, &fo, &g);
    }
}

/// Normal force \[N\] carried by resting contact `i` after a constrained solve (the multiplier
/// of its row with the sign of a push); 0 when it does not rest.
pub fn resting_force(d: &Data, i: usize) -> f64 {
    match d.contacts[i].constraint_row {
        Some(r) if d.contact_memory[i].active => -d.lambda[r],
        _ => 0.0,
    }
}

/// Writes the outputs of the resting impulse contacts after a constrained solve (the
/// friction fields are [`resting_friction`]'s).
pub fn resting_outputs(d: &mut Data) {
    for i in 0..d.contacts.len() {
        if d.contacts[i].constraint_row.is_some() && d.contact_memory[i].active {
            let g = gap(d, i);
            let force = resting_force(d, i);
            let out = &mut d.contact_out[i];
            out.delta = g.delta.max(0.0);
            out.delta_dot = g.delta_dot;
            out.force = force;
            out.elastic_energy = 0.0;
        }
    }
}

/// Most fixed-point iterations of [`resting_friction`].
const RESTING_FRICTION_ITERATIONS: usize = 50;

/// Friction of the resting impulse-law contacts (after the constrained solve, docs/friction.md):
/// the continuous friction law with the normal force of each resting contact, its constraint
/// multiplier. The friction force changes the multipliers, so the two are solved together by
/// fixed-point iteration: the generalised friction force is applied through the constrained
/// response `G` (accelerations and multipliers updated), and recomputed from the new normal
/// forces, until its change is at rounding level (a sphere on a plane: two rounds, its
/// normal force does not depend on friction). Returns the dissipated power \[W\]; 0 and
/// nothing done when no resting contact has friction.
pub fn resting_friction(m: &Model, d: &mut Data) -> f64 {
    let any = d
        .contacts
        .iter()
        .zip(&d.contact_memory)
        .any(|(c, mem)| mem.active && c.law == Law::Impulse && c.friction.is_on());
    if !any {
        return 0.0;
    }
    let mut applied = std::mem::take(&mut d.friction_applied);
    let mut step = std::mem::take(&mut d.friction_step);
    let mut dl = std::mem::take(&mut d.friction_dlambda);
    applied.iter_mut().for_each(|x| *x = 0.0);
    let mut power = 0.0;
    for _ in 0..RESTING_FRICTION_ITERATIONS {
        step.iter_mut().for_each(|x| *x = 0.0);
        power = 0.0;
        for i in 0..d.contacts.len() {
            let c = &d.contacts[i];
            if !(d.contact_memory[i].active && c.law == Law::Impulse && c.friction.is_on()) {
                continue;
            }
            let fs = frame(d, c.sphere_body);
            let fo = frame(d, c.body);
            let g = geometry::detect(c, &fs, &fo);
            let slip = friction::slip_velocity(&fs, &fo, &g);
            let ft = friction::force(&c.friction, resting_force(d, i), &slip);
            power -= ft.dot(&slip);
            let coef = Spatial::force_at(&ft, &g.point);
            add_jacobian_row(m, &d.dof_s, c.sphere_body, &coef, 1.0, &mut step);
            add_jacobian_row(m, &d.dof_s, c.body, &coef, -1.0, &mut step);
            d.contact_out[i].friction_force = ft;
            d.contact_out[i].slip_speed = slip.norm();
        }
        // the correction: what friction is now, less what was applied
        let mut change = 0.0_f64;
        let mut size = 0.0_f64;
        for (s, a) in step.iter_mut().zip(applied.iter_mut()) {
            *s -= *a;
            *a += *s;
            change = change.max(s.abs());
            size = size.max(a.abs());
        }
        if change <= 1e-15 * size {
            break;
        }
        crate::dynamics::constrained_response(m, d, &mut step, &mut dl);
        for (a, s) in d.qacc.iter_mut().zip(&step) {
            *a += s;
        }
        for (l, x) in d.lambda.iter_mut().zip(&dl) {
            *l += x;
        }
    }
    d.friction_applied = applied;
    d.friction_step = step;
    d.friction_dlambda = dl;
    power
}

/// Adds the forces of the active continuous contacts to the bodies (normal force and
/// friction), updates the contact outputs and their gaps' `d.events.stage_gaps`, and returns
/// the dissipated power \[W\].
pub fn apply_forces(d: &mut Data) -> f64 {
    let mut power = 0.0;
    for i in 0..d.contacts.len() {
        if !exerts_force(d, i) {
            d.contact_out[i] = ContactOutput::default();
            continue;
        }
        apply_force(d, i, d.contact_memory[i], &mut power);
    }
    power
}

/// True when contact `i` exerts its law's force: active under a continuous law (an impulse-law
/// contact acts by impulses, and while it rests by its constraint row).
pub fn exerts_force(d: &Data, i: usize) -> bool {
    d.contact_memory[i].active && d.contacts[i].law != Law::Impulse
}

/// True when some impulse-law contact is resting (its constraint row is on).
pub fn any_resting(d: &Data) -> bool {
    d.contacts
        .iter()
        .zip(&d.contact_memory)
        .any(|(c, mem)| mem.active && c.law == Law::Impulse)
}

/// Lists the contacts whose forces [`apply_forces`] computes (the active continuous ones) in
/// `d.force_contacts`, in their order, and zeroes the outputs of the others, as
/// [`apply_forces`] does: while the modes and the contact list stay as they are (one
/// integrator step), [`apply_listed_forces`] then gives what [`apply_forces`] gives. False
/// (and nothing listed) while an impulse-law contact rests: the right-hand side then takes
/// the full evaluation.
pub fn list_force_contacts(d: &mut Data) -> bool {
    d.force_contacts.clear();
    if any_resting(d) {
        return false;
    }
    for i in 0..d.contacts.len() {
        if exerts_force(d, i) {
            // (within the capacity of the contact list's length: no allocation)
            d.force_contacts.push(i);
        } else {
            d.contact_out[i] = ContactOutput::default();
        }
    }
    true
}

/// [`apply_forces`] over the contacts [`list_force_contacts`] listed (the others' outputs are
/// zero already): the same numbers, without a look at the contacts apart.
pub fn apply_listed_forces(d: &mut Data) -> f64 {
    let mut power = 0.0;
    for k in 0..d.force_contacts.len() {
        let i = d.force_contacts[k];
        let mem = d.contact_memory[i];
        apply_force(d, i, mem, &mut power);
    }
    power
}

/// The force of active continuous contact `i` (memory `mem`) on its bodies, its outputs and
/// `d.events.stage_gaps` entry; its dissipated power added to `power`.
fn apply_force(d: &mut Data, i: usize, mem: ContactMemory, power: &mut f64) {
    let c = &d.contacts[i];
    let g = gap(d, i);
    d.events.stage_gaps[i] = (g.delta, g.delta_dot, g.margin);
    let f = laws::force(c, g.delta, g.delta_dot, mem.impact_velocity);
    *power += (f.total - f.elastic) * g.delta_dot;
    let mut force = g.normal * f.total;
    let mut out = ContactOutput {
        delta: g.delta.max(0.0),
        delta_dot: g.delta_dot,
        force: f.total,
        elastic_energy: f.energy,
        ..ContactOutput::default()
    };
    if c.friction.is_on() {
        let slip = friction::slip_velocity(&frame(d, c.sphere_body), &frame(d, c.body), &g);
        let ft = friction::force(&c.friction, f.total, &slip);
        *power -= ft.dot(&slip);
        force += ft;
        out.friction_force = ft;
        out.slip_speed = slip.norm();
    }
    if let Some(b) = c.sphere_body {
        d.body_force[b] = d.body_force[b].add(&Spatial::force_at(&force, &g.point));
    }
    if let Some(b) = c.body {
        d.body_force[b] = d.body_force[b].add(&Spatial::force_at(&(-force), &g.point));
    }
    d.contact_out[i] = out;
}

/// Coefficient vectors (sphere body, other body) whose pairing with the bodies' spatial
/// velocities gives the separation rate `−δ̇` at gap `g`.
pub fn separation_coefficients(g: &Gap) -> (Spatial, Spatial) {
    let s = Spatial::point_direction(&g.point, &g.normal);
    (s, s.scale(-1.0))
}
