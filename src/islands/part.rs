//! The compiled part of an island: its model, cut from the scene's (`cut_model.rs`) and
//! shared by the islands of alike bodies, and how its coordinates, inputs, contacts and shapes
//! map onto the scene's.

use super::cut::SceneIndex;
use crate::compile::Parameters;
use crate::model::compiled::NOT_FREE;
use crate::model::contact::{OtherSide, Shape, SphereSide};
use crate::model::groups::{Bound, GroupShape};
use crate::model::{nq_of, nv_of, Body, FreeBody, Model, Plan, TreeJoint};
use rustc_hash::FxHashMap as HashMap;
use std::sync::Arc;

/// An island's model and its numbering against the scene's.
pub(super) struct Compiled {
    /// The island's model (shared: the islands of alike bodies, and the pool, hold the same).
    pub(super) model: Arc<Model>,
    /// Its numbering against the scene's, for the island's own bodies.
    pub(super) numbering: Numbering,
}

/// How an island's coordinates, inputs, contacts and shapes map onto the scene's.
#[derive(Debug, Default, PartialEq)]
pub(super) struct Numbering {
    /// (island, scene) index pairs of the position and velocity coordinates.
    pub(super) coords: Vec<(usize, usize)>,
    /// The scene's index of each of the island's declared contacts.
    pub(super) explicit: Vec<usize>,
    /// (island, scene) index pairs of the input values.
    pub(super) inputs: Vec<(usize, usize)>,
    /// (island, scene) index pairs of the driven joints' coordinates and rates.
    pub(super) driven: Vec<(usize, usize)>,
    /// The scene's index of each of the island's group shapes (sorted).
    pub(super) shapes: Vec<usize>,
}

/// What an island's model is cut for: its bodies (scene numbering, sorted), or, where every
/// one of them is plain ([`alike_bodies`]), the body each is alike to, in their order.
pub(super) type Key = Vec<usize>;

/// An empty model with the islands' solver settings (to cut into).
pub(super) fn empty_model(params: &Parameters) -> Model {
    Model {
        solver: params.solver.clone(),
        ..Model::default()
    }
}

/// Per scene body of the scene's model `m` (with its plan `plan` and the scene's index of the
/// items naming each body `index`), the first body alike to it, if it is *plain*: a free body
/// alone in its tree on the lean path, with no spring, declared contact or input, and no ground
/// shape between its group shapes. Alike bodies differ only in their names, their initial
/// coordinates (an island's state is the scene's) and their place in the scene, so an island
/// of plain bodies has the model of the island of the bodies they are alike to, in the same
/// order: that of its key ([`key_into`]). Everything a cut takes of a plain body is compared
/// bit for bit ([`kind_bits`]: a −0 is not a +0), and what the plan computed from it with
/// `==` ([`same_plan`]). None throughout when the plain bodies' joints or
/// shapes are listed in the scene in another order than the bodies (an island's order would
/// then depend on which bodies it holds).
pub(super) fn alike_bodies(index: &SceneIndex, m: &Model, plan: &Plan) -> Vec<Option<usize>> {
    let nb = m.bodies.len();
    let mut has_child = vec![false; nb];
    for j in &m.joints {
        if let Some(p) = j.parent {
            has_child[p] = true;
        }
    }
    // (the ground shapes listed before a shape)
    let rank = |s: usize| index.ground_shapes.partition_point(|&g| g < s);
    let plain = |b: usize| {
        let t = m.bodies[b].joint;
        let shapes = &index.shapes[b];
        m.joints[t].parent.is_none()
            && !has_child[b]
            && plan.free_of[b] != NOT_FREE
            && index.joints[b].iter().all(|&si| m.scene_joint.get(si) == Some(&Ok(t)))
            && index.springs[b].is_empty()
            && index.contacts[b].is_empty()
            && index.inputs[b].is_empty()
            && shapes.first().map(|&s| rank(s)) == shapes.last().map(|&s| rank(s))
    };
    let mut alike = vec![None; nb];
    let (mut last_joint, mut last_shape) = (None, None);
    // (the first bodies of each kind, by their numbers bit for bit)
    let mut firsts: HashMap<Vec<u64>, Vec<usize>> = HashMap::default();
    for b in (0..nb).filter(|&b| plain(b)) {
        if let Some(si) = m.joints[m.bodies[b].joint].scene_index {
            if last_joint.is_some_and(|l| l >= si) {
                return vec![None; nb];
            }
            last_joint = Some(si);
        }
        if let (Some(&first), Some(&last)) = (index.shapes[b].first(), index.shapes[b].last()) {
            if last_shape.is_some_and(|l| l >= first) {
                return vec![None; nb];
            }
            last_shape = Some(last);
        }
        let kind = firsts.entry(kind_bits(index, m, &rank, b)).or_default();
        let first = match kind.iter().copied().find(|&a| same_plan(m, plan, a, b)) {
            Some(a) => a,
            None => {
                kind.push(b);
                b
            }
        };
        alike[b] = Some(first);
    }
    alike
}

/// What a cut takes of the plain body `b` but its names, numbers and initial coordinates, bit
/// for bit (alike bodies have the same): its mass and inertia, its joint's type and frame,
/// per group shape the ground shapes listed before it, its group, centre, bound and both its
/// sides (sphere, other shape, materials), and its reach.
fn kind_bits(index: &SceneIndex, m: &Model, rank: &dyn Fn(usize) -> usize, b: usize) -> Vec<u64> {
    // (every field named: a new one must be placed here or left out here)
    let Body {
        name: _,
        mass,
        inertia,
        joint,
    } = &m.bodies[b];
    let mut bits = vec![mass.to_bits()];
    let reals = |bits: &mut Vec<u64>, values: &[f64]| bits.extend(values.iter().map(|x| x.to_bits()));
    reals(&mut bits, inertia.as_slice());
    let TreeJoint {
        name: _,
        kind,
        scene_index,
        // (none: the body is plain)
        parent: _,
        child: _,
        qpos: _,
        qvel: _,
        axis,
        anchor,
        offset,
        rot0,
        q0: _,
        tree: _,
    } = &m.joints[*joint];
    bits.extend([*kind as u64, u64::from(scene_index.is_some())]);
    for v in [axis, anchor, offset] {
        reals(&mut bits, v.as_slice());
    }
    reals(&mut bits, rot0.coords.as_slice());
    let g = &m.groups;
    let material = |bits: &mut Vec<u64>, material: &Option<[f64; 2]>| match material {
        Some(values) => bits.extend([1].into_iter().chain(values.iter().map(|x| x.to_bits()))),
        None => bits.push(0),
    };
    bits.push(index.shapes[b].len() as u64);
    for &s in &index.shapes[b] {
        bits.push(rank(s) as u64);
        if let Some(GroupShape {
            body: _,
            group,
            center,
            bound,
        }) = g.shapes.get(s)
        {
            bits.push(*group as u64);
            reals(&mut bits, center.as_slice());
            match *bound {
                Bound::Ball(r) => bits.extend([0, r.to_bits()]),
                Bound::Rectangle(u, v) => {
                    bits.extend([1].into_iter().chain(u.iter().chain(v.iter()).map(|x| x.to_bits())))
                }
            }
        }
        if let Some(SphereSide {
            body: _,
            center,
            radius,
            material: values,
        }) = g.sphere_sides.get(s)
        {
            reals(&mut bits, center.as_slice());
            bits.push(radius.to_bits());
            material(&mut bits, values);
        }
        if let Some(OtherSide {
            body: _,
            kind,
            shape,
            bound_radius,
            material: values,
        }) = g.other_sides.get(s)
        {
            bits.push(*kind as u64);
            shape_bits(&mut bits, shape);
            bits.push(bound_radius.to_bits());
            material(&mut bits, values);
        }
    }
    bits.extend(g.reach.get(b).map(|x| x.to_bits()));
    bits.extend(g.has_shape.get(b).map(|&h| u64::from(h)));
    bits
}

/// Appends the numbers of `shape`, bit for bit.
fn shape_bits(bits: &mut Vec<u64>, shape: &Shape) {
    let mut reals = |values: &[f64]| bits.extend(values.iter().map(|x| x.to_bits()));
    match shape {
        Shape::Sphere { center, radius } => {
            reals(&[0.0]);
            reals(center.as_slice());
            reals(&[*radius]);
        }
        Shape::Plane {
            origin,
            normal,
            u,
            v,
            half,
        } => {
            reals(&[1.0]);
            for w in [origin, normal, u, v] {
                reals(w.as_slice());
            }
            reals(half);
        }
        Shape::Cylinder {
            point: on_axis,
            axis: along,
            reference: theta_zero,
            radius: rho,
            half_length: half,
            theta_range: range,
            inside,
        } => {
            reals(&[2.0, f64::from(u8::from(*inside))]);
            for w in [on_axis, along, theta_zero] {
                reals(w.as_slice());
            }
            reals(&[*rho, *half]);
            match range {
                Some(r) => reals(&[1.0, r[0], r[1]]),
                None => reals(&[0.0]),
            }
        }
    }
}

/// Whether the plain bodies `a` and `b`, of the same [`kind_bits`], have the same entries in
/// the plan (computed from those numbers): their free body, rotor, constant row and leaves,
/// and their joints' dof parents.
fn same_plan(m: &Model, plan: &Plan, a: usize, b: usize) -> bool {
    let free = |x: usize| FreeBody {
        body: 0,
        qpos: 0,
        qvel: 0,
        ..plan.free[plan.free_of[x]].clone()
    };
    let (ta, tb) = (m.bodies[a].joint, m.bodies[b].joint);
    let (ja, jb) = (&m.joints[ta], &m.joints[tb]);
    free(a) == free(b)
        && plan.rotors[ta] == plan.rotors[tb]
        && plan.constant_row[ta] == plan.constant_row[tb]
        && plan.leaves[ja.tree] == plan.leaves[jb.tree]
        && m.dof_parent[ja.qvel..ja.qvel + ja.nv()] == m.dof_parent[jb.qvel..jb.qvel + jb.nv()]
}

/// Writes into `key` what the model of the island of `bodies` (sorted) is cut for: the bodies
/// they are alike to (`alike`, of [`alike_bodies`]) where every one is plain, else the bodies.
pub(super) fn key_into(alike: &[Option<usize>], bodies: &[usize], key: &mut Key) {
    key.clear();
    if bodies.iter().all(|&b| alike[b].is_some()) {
        key.extend(bodies.iter().filter_map(|&b| alike[b]));
    } else {
        key.extend_from_slice(bodies);
    }
}

/// Writes into `numbering` (its buffers kept) the numbering against the scene's model `m` of
/// `model`, that of an island of `bodies` with the scene's inputs `scene_inputs`
/// ([`Numbering::coords`], [`Numbering::inputs`] and [`Numbering::driven`]).
pub(super) fn numbering(
    m: &Model,
    joint_coords: &[(usize, usize)],
    bodies: &[usize],
    scene_inputs: &[usize],
    model: &Model,
    numbering: &mut Numbering,
) {
    let Numbering {
        coords, inputs, driven, ..
    } = numbering;
    let nq = model.nq;
    coords.clear();
    coords.reserve(nq + model.nv);
    for j in &model.joints {
        let (qpos, qvel) = joint_coords[bodies[j.child]];
        coords.extend((0..nq_of(j.kind)).map(|k| (j.qpos + k, qpos + k)));
        coords.extend((0..nv_of(j.kind)).map(|k| (nq + j.qvel + k, qvel + k)));
    }
    inputs.clear();
    for &g in scene_inputs {
        for v in m.input_range(g) {
            inputs.push((inputs.len(), v));
        }
    }
    // a drive's coordinates: the scene's state index of the island's
    let scene_index = |l: usize| coords.iter().find(|&&(a, _)| a == l).map(|&(_, b)| b);
    driven.clear();
    driven.extend(
        model
            .drives
            .iter()
            .flat_map(|dr| [dr.qpos, nq + dr.qvel])
            .filter_map(|l| Some((l, scene_index(l)?))),
    );
}

/// The part a cut gives (the tests' `pool::fresh_cut`) for the island of `bodies`, made the former way: the island's part of the scene cut
/// (`cut.rs`) and compiled (the oracle of the tests).
#[cfg(test)]
pub(super) fn compile_cut_scene(
    src: &super::Source,
    params: &Parameters,
    index: &super::cut::SceneIndex,
    m: &Model,
    joint_coords: &[(usize, usize)],
    bodies: &[usize],
) -> Result<Compiled, String> {
    let cut = super::cut::cut(src.scene, params, index, bodies, &[]);
    let mut model = crate::compile::compile_model(&cut.scene, &cut.params, src.origin, Some(&[]))
        .map_err(|e| format!("an island could not be compiled: {e}"))?;
    model.groups.stale_fraction = super::ISLAND_STALE_FRACTION;
    let mut own = Numbering {
        explicit: cut.explicit,
        shapes: cut.shapes,
        ..Numbering::default()
    };
    numbering(m, joint_coords, bodies, &cut.inputs, &model, &mut own);
    Ok(Compiled {
        model: Arc::new(model),
        numbering: own,
    })
}
