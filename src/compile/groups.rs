//! The contact groups of a scene: the group shapes in their bodies' frames, the candidate
//! pairs (found by the broad phase at the initial configuration, or given), and one contact
//! element per candidate: its sphere shape's sphere side, its other shape's other side and its
//! group pair's law (the path a declared `[[contact]]` takes too, see `contact.rs`).

use super::contact::{other_side, sphere_side, Placing};
use super::parameters::Parameters;
use crate::contact::elements::candidate_element;
use crate::model::contact::{ContactElement, OtherSide, Shape, SphereSide};
use crate::model::groups::{Bound, Candidate, GroupShape, Groups};
use crate::scene::{item_name, Scene, SceneError};
use std::collections::HashMap;

/// The scene's group numbering: the shapes' groups in their order, then those a group pair
/// names that no shape has (a part of a scene cut for an island may hold none of a group's
/// shapes). An island's model is cut with the same numbering.
fn group_numbering(scene: &Scene) -> HashMap<&str, usize> {
    let mut group_index: HashMap<&str, usize> = HashMap::new();
    let named = scene.contact_group.iter().flat_map(|g| g.groups.iter());
    for group in scene.shape.iter().map(|s| &s.group).chain(named) {
        let n = group_index.len();
        group_index.entry(group.as_str()).or_insert(n);
    }
    group_index
}

/// Builds the groups and the contact elements of `candidates` (None: the broad phase's pairs
/// at the initial configuration), the shapes placed by `placing`.
pub(super) fn compile_groups(
    scene: &Scene,
    params: &Parameters,
    origin: &str,
    n_explicit: usize,
    candidates: Option<&[Candidate]>,
    placing: &Placing,
) -> Result<(Groups, Vec<ContactElement>), SceneError> {
    // shapes that no group pair names touch nothing
    if scene.contact_group.is_empty() {
        return Ok((
            Groups {
                n_explicit,
                ..Groups::default()
            },
            Vec::new(),
        ));
    }
    let group_index = group_numbering(scene);
    let ngroups = group_index.len();
    let mut touch = vec![None; ngroups * ngroups];
    let pair_groups: Vec<(usize, usize)> = scene
        .contact_group
        .iter()
        .map(|g| (group_index[g.groups[0].as_str()], group_index[g.groups[1].as_str()]))
        .collect();
    for (p, &(a, b)) in pair_groups.iter().enumerate() {
        touch[a * ngroups + b] = Some(p);
    }
    let nb = scene.body.len();
    let mut reach = vec![0.0_f64; nb];
    let mut has_shape = vec![false; nb];
    // what each shape brings to a contact element, as the sphere and as the other shape
    let sphere_sides: Vec<SphereSide> = scene.shape.iter().map(|s| sphere_side(s, placing)).collect();
    let other_sides: Vec<OtherSide> = scene.shape.iter().map(|s| other_side(s, placing)).collect();
    // the broad phase's bound of each: that of the shape a sphere touches
    let shapes: Vec<GroupShape> = scene
        .shape
        .iter()
        .zip(&other_sides)
        .map(|(s, o)| {
            let (center, bound) = match &o.shape {
                Shape::Sphere { center, radius } => (*center, Bound::Ball(*radius)),
                Shape::Plane { origin, u, v, half, .. } => (*origin, Bound::Rectangle(u * half[0], v * half[1])),
                Shape::Cylinder { point, .. } => (*point, Bound::Ball(o.bound_radius)),
            };
            if let Some(b) = o.body {
                let extent = match bound {
                    Bound::Ball(r) => r,
                    Bound::Rectangle(u, w) => (u.norm_squared() + w.norm_squared()).sqrt(),
                };
                reach[b] = reach[b].max(center.norm() + extent);
                has_shape[b] = true;
            }
            GroupShape {
                body: o.body,
                group: group_index[s.group.as_str()],
                center,
                bound,
            }
        })
        .collect();
    let mut groups = Groups {
        shapes,
        ngroups,
        touch,
        pair_names: scene.contact_group.iter().map(|g| g.name.clone()).collect(),
        pair_groups,
        n_explicit,
        initial_candidates: Vec::new(),
        margin: scene.broad_phase_margin(),
        method: scene.broad_phase.method,
        reach,
        has_shape,
        stale_fraction: crate::contact::broad::STALE_FRACTION,
        sphere_sides,
        other_sides,
        laws: params.groups.clone(),
    };
    groups.initial_candidates = match candidates {
        Some(c) => {
            let (np, ns) = (scene.contact_group.len(), scene.shape.len());
            if let Some(bad) = c.iter().find(|k| k.pair >= np || k.sphere >= ns || k.other >= ns) {
                return Err(SceneError::new(
                    origin,
                    "[broad_phase]",
                    "candidates",
                    format!("candidate pair {bad:?} names a group pair or shape the scene does not have"),
                ));
            }
            c.to_vec()
        }
        None => groups.find(&|b| {
            let (p, q) = (placing.pose0)(b);
            (p, *q.to_rotation_matrix().matrix())
        }),
    };
    let mut elements = Vec::with_capacity(groups.initial_candidates.len());
    for c in &groups.initial_candidates {
        let e = candidate_element(&groups, c, String::new()).map_err(|message| {
            SceneError::new(
                origin,
                item_name("contact", &groups.element_name(c)),
                "stiffness",
                message,
            )
        })?;
        elements.push(e);
    }
    Ok((groups, elements))
}
