//! Contact groups at run time: the broad-phase stage (the candidate pairs found again at the
//! data's poses, [`super::broad`]), how far the bodies' group shapes moved since, and the bounds
//! that keep the candidate list sound.

use super::elements::{check_new_pairs, former_indices};
use crate::model::groups::Candidate;
use crate::model::{Data, Model};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// The broad phase as a stage of the data: the candidate pairs at the poses of `d` (its
/// kinematics evaluated) and each one's index in the list `listed` the data holds (or
/// `elements::NOT_LISTED`). A pair new to the list that touches already is an error: the bounds
/// on the step were broken (it cannot happen while no body is accelerated far beyond gravity
/// within one step). Nothing in `d` changes; [`take_reference_poses`] follows once the new list
/// is taken.
pub fn find_candidates(m: &Model, d: &Data, listed: &[Candidate]) -> Result<(Vec<Candidate>, Vec<usize>), String> {
    let found = m.groups.find(&|b| pose(d, b));
    let mut former = Vec::new();
    former_indices(listed, &found, &mut former);
    check_new_pairs(m, d, &found, &former)?;
    Ok((found, former))
}

/// Makes the bodies' present poses the reference the group shapes' displacements are measured
/// from (when the candidate pairs were found again).
pub fn take_reference_poses(m: &Model, d: &mut Data) {
    for b in 0..m.bodies.len() {
        d.broad_reference[b] = (d.body_pos[b], d.body_quat[b]);
    }
}

/// The pose of body `b` in `d` (the ground: the origin).
pub fn pose(d: &Data, b: Option<usize>) -> (Vector3<f64>, Matrix3<f64>) {
    match b {
        Some(i) => (d.body_pos[i], d.body_rot[i]),
        None => (Vector3::zeros(), Matrix3::identity()),
    }
}

/// How far a point of body `b`'s group shapes can have moved since the reference poses, at
/// the kinematics in `d` \[m\]: the displacement of the centre of mass plus the rotation angle
/// times the reach.
pub fn displacement(m: &Model, d: &Data, b: usize) -> f64 {
    let (p0, q0): &(Vector3<f64>, UnitQuaternion<f64>) = &d.broad_reference[b];
    (d.body_pos[b] - p0).norm() + q0.angle_to(&d.body_quat[b]) * m.groups.reach[b]
}

/// The largest displacement of any body's group shapes and the least time in which one
/// could reach half the margin, at its present speed (centre of mass plus the angular speed
/// times the reach) under the acceleration of gravity; (0, ∞) without groups.
pub fn margin_values(m: &Model, d: &Data) -> (f64, f64) {
    let g = &m.groups;
    if g.shapes.is_empty() {
        return (0.0, f64::INFINITY);
    }
    let a = m.gravity.norm();
    let (mut largest, mut time) = (0.0_f64, f64::INFINITY);
    for b in 0..m.bodies.len() {
        if !g.has_shape[b] {
            continue;
        }
        let moved = displacement(m, d, b);
        largest = largest.max(moved);
        let v = d.body_vel[b].point_velocity(&d.body_pos[b]).norm() + d.body_vel[b].ang.norm() * g.reach[b];
        // (past half the margin, a short step ends at once and the list is made again)
        let slack = (0.5 * g.margin - moved).max(1e-3 * g.margin);
        // the positive root of a t²/2 + v t − slack = 0, in a form exact for a = 0
        let t = 2.0 * slack / (v + (v * v + 2.0 * a * slack).sqrt());
        if t.is_finite() {
            time = time.min(t);
        }
    }
    (largest, time)
}

/// True when a body's group shapes have moved more than the stale fraction (a quarter) of
/// the margin since the candidate list was made (from the event values at the current
/// state): time to make it again.
pub fn stale(m: &Model, d: &Data) -> bool {
    m.groups.is_active() && d.events.aux[d.contacts.len()].1 > m.groups.stale_fraction * m.groups.margin
}

/// The least time in which a body's group shapes could move half the margin from the
/// reference poses (from the event values at the current state): a bound on the step.
pub fn time_to_margin(m: &Model, d: &Data) -> f64 {
    if m.groups.is_active() {
        d.events.aux[d.contacts.len()].0
    } else {
        f64::INFINITY
    }
}
