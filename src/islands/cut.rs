//! What the islands are cut from: which bodies are coupled (the partition), the scene's items
//! per body (read off the scene's compiled model), and (the tests' oracle) the part of the
//! scene and of the parameter values that an island's model compiles from.

#[cfg(test)]
use crate::compile::Parameters;
use crate::model::groups::Candidate;
use crate::model::partition::Partition;
use crate::model::{Input, Model};
#[cfg(test)]
use crate::scene::{Scene, GROUND};
use crate::union_find::UnionFind;
#[cfg(test)]
use std::collections::HashMap;

/// Per scene body, the scene items that name it (to cut an island's part of the scene in
/// time proportional to its size).
#[cfg_attr(test, derive(Debug, PartialEq))]
pub(super) struct SceneIndex {
    pub(super) joints: Vec<Vec<usize>>,
    pub(super) springs: Vec<Vec<usize>>,
    pub(super) contacts: Vec<Vec<usize>>,
    pub(super) inputs: Vec<Vec<usize>>,
    pub(super) shapes: Vec<Vec<usize>>,
    /// Shapes on the ground (in every island).
    pub(super) ground_shapes: Vec<usize>,
}

impl SceneIndex {
    /// No items for `nb` bodies.
    fn empty(nb: usize) -> SceneIndex {
        SceneIndex {
            joints: vec![Vec::new(); nb],
            springs: vec![Vec::new(); nb],
            contacts: vec![Vec::new(); nb],
            inputs: vec![Vec::new(); nb],
            shapes: vec![Vec::new(); nb],
            ground_shapes: Vec::new(),
        }
    }

    /// The index of the scene whose compiled model is `m`, read off the model (its lists are
    /// in the scene's order: `m.scene_joint` by the scene's joints, the springs, the declared
    /// contacts, the inputs and the group shapes as the scene lists them).
    pub(super) fn of_model(m: &Model) -> SceneIndex {
        let nb = m.bodies.len();
        let mut ix = SceneIndex::empty(nb);
        for (si, joint) in m.scene_joint.iter().enumerate() {
            let child = match *joint {
                Ok(t) => m.joints[t].child,
                Err(l) => m.loops[l].body_b,
            };
            ix.joints[child].push(si);
        }
        for (i, s) in m.springs.iter().enumerate() {
            for b in [s.body_a, s.body_b].into_iter().flatten() {
                ix.springs[b].push(i);
            }
        }
        for (i, c) in m.initial_contacts[..m.groups.n_explicit].iter().enumerate() {
            for b in [c.sphere_body, c.body].into_iter().flatten() {
                ix.contacts[b].push(i);
            }
        }
        for (g, input) in m.inputs.iter().enumerate() {
            match input {
                Input::Force { body, .. } | Input::Torque { body, .. } => ix.inputs[*body].push(g),
                Input::JointForce { qvels } => {
                    for &v in qvels {
                        ix.inputs[m.joints[m.dof_joint[v]].child].push(g);
                    }
                }
                Input::JointMotion => {
                    if let Some(t) = driven_joint(m, g) {
                        ix.inputs[m.joints[t].child].push(g);
                    }
                }
            }
        }
        for (s, shape) in m.groups.shapes.iter().enumerate() {
            match shape.body {
                Some(b) => ix.shapes[b].push(s),
                None => ix.ground_shapes.push(s),
            }
        }
        ix
    }

    /// The index of `scene` read off the scene (the tests compare it with
    /// [`SceneIndex::of_model`]).
    #[cfg(test)]
    pub(super) fn of(scene: &Scene) -> SceneIndex {
        let nb = scene.body.len();
        let body = scene.body_index();
        let joint_child: HashMap<&str, usize> = scene
            .joint
            .iter()
            .filter_map(|j| Some((j.name.as_str(), *body.get(j.child.as_str())?)))
            .collect();
        let mut ix = SceneIndex::empty(nb);
        let put = |list: &mut Vec<Vec<usize>>, name: &str, i: usize| {
            if let Some(&b) = body.get(name) {
                list[b].push(i);
            }
        };
        for (i, j) in scene.joint.iter().enumerate() {
            put(&mut ix.joints, &j.child, i);
        }
        for (i, s) in scene.spring_damper.iter().enumerate() {
            put(&mut ix.springs, &s.body_a, i);
            put(&mut ix.springs, &s.body_b, i);
        }
        for (i, c) in scene.contact.iter().enumerate() {
            put(&mut ix.contacts, &c.sphere_body, i);
            put(&mut ix.contacts, &c.body, i);
        }
        for (i, inp) in scene.input.iter().enumerate() {
            if let Some(b) = &inp.body {
                put(&mut ix.inputs, b, i);
            }
            for n in inp.joint.iter().chain(inp.joints.iter().flatten()) {
                if let Some(&b) = joint_child.get(n.as_str()) {
                    ix.inputs[b].push(i);
                }
            }
        }
        for (i, s) in scene.shape.iter().enumerate() {
            if s.body == GROUND {
                ix.ground_shapes.push(i);
            } else {
                put(&mut ix.shapes, &s.body, i);
            }
        }
        ix
    }
}

/// The tree joint that the input `g` of the model `m` drives, if it is a `joint_motion` (its
/// drive holds the input's first value; its degree of freedom is the joint's).
pub(super) fn driven_joint(m: &Model, g: usize) -> Option<usize> {
    if !matches!(m.inputs.get(g), Some(Input::JointMotion)) {
        return None;
    }
    let value = *m.input_value.get(g)?;
    let drive = m.drives.iter().find(|d| d.value == value)?;
    m.dof_joint.get(drive.qvel).copied()
}

/// The islands of model `m` with the candidate pairs `candidates`.
pub fn partition(m: &Model, candidates: &[Candidate]) -> Partition {
    let nb = m.bodies.len();
    let mut sets = UnionFind::new(nb);
    for j in &m.joints {
        sets.join(j.parent, Some(j.child));
    }
    for l in &m.loops {
        sets.join(l.body_a, Some(l.body_b));
    }
    for s in &m.springs {
        sets.join(s.body_a, s.body_b);
    }
    for c in &m.initial_contacts[..m.groups.n_explicit] {
        sets.join(c.sphere_body, c.body);
    }
    let shapes = &m.groups.shapes;
    for k in candidates {
        sets.join(shapes[k.sphere].body, shapes[k.other].body);
    }
    for input in &m.inputs {
        if let Input::JointForce { qvels } = input {
            let mut bodies = qvels
                .iter()
                .filter(|&&v| v < m.nv)
                .map(|&v| m.joints[m.dof_joint[v]].child);
            if let Some(first) = bodies.next() {
                for b in bodies {
                    sets.join(Some(first), Some(b));
                }
            }
        }
    }
    // (a set's root is its first body: the islands are numbered in the order of their first
    // bodies, and each island's bodies are listed in scene order)
    let mut island_of = vec![0; nb];
    let mut n = 0;
    for b in 0..nb {
        let r = sets.root(b);
        if r == b {
            island_of[b] = n;
            n += 1;
        } else {
            island_of[b] = island_of[r];
        }
    }
    Partition::new(island_of, candidates, |c| candidate_body(m, c))
}

/// True when model `m` runs as islands: the scene asks for them (`solver.islands`, the
/// default) and either has contact groups (whose islands change as the bodies move) or more
/// than one island.
pub fn wanted(m: &Model) -> bool {
    m.solver.islands
        && !m.bodies.is_empty()
        && (m.groups.is_active() || partition(m, &m.groups.initial_candidates).len() > 1)
}

/// The body of a candidate pair that is not the ground.
pub(super) fn candidate_body(m: &Model, k: &Candidate) -> Option<usize> {
    let shapes = &m.groups.shapes;
    shapes[k.sphere].body.or(shapes[k.other].body)
}

/// What an island is cut from the scene: its part of the scene and of the parameter values,
/// its candidates in its own shape numbering, the scene indices of its declared contacts and
/// inputs.
#[cfg(test)]
pub(super) struct Cut {
    pub(super) scene: Scene,
    pub(super) params: Parameters,
    pub(super) candidates: Vec<Candidate>,
    pub(super) explicit: Vec<usize>,
    pub(super) inputs: Vec<usize>,
    pub(super) shapes: Vec<usize>,
}

/// The candidate pairs `candidates` (scene numbering) numbered by an island's shapes `shapes`
/// (their scene indices, sorted).
pub(super) fn local_candidates(shapes: &[usize], candidates: &[Candidate]) -> Vec<Candidate> {
    let local = |s: usize| shapes.binary_search(&s).unwrap_or(usize::MAX);
    candidates
        .iter()
        .map(|k| Candidate {
            pair: k.pair,
            sphere: local(k.sphere),
            other: local(k.other),
        })
        .collect()
}

/// Writes into `out` the sorted, deduplicated items of `lists` over `bodies`, of the scene's
/// `all` (none without looking when there is none).
pub(super) fn items<T>(lists: &[Vec<usize>], all: &[T], bodies: &[usize], out: &mut Vec<usize>) {
    out.clear();
    if all.is_empty() {
        return;
    }
    out.reserve(bodies.iter().map(|&b| lists[b].len()).sum());
    for &b in bodies {
        out.extend_from_slice(&lists[b]);
    }
    out.sort_unstable();
    out.dedup();
}

#[cfg(test)]
pub(super) fn cut(scene: &Scene, p: &Parameters, ix: &SceneIndex, bodies: &[usize], candidates: &[Candidate]) -> Cut {
    fn of<T>(lists: &[Vec<usize>], all: &[T], bodies: &[usize]) -> Vec<usize> {
        let mut v = Vec::new();
        items(lists, all, bodies, &mut v);
        v
    }
    let joints = of(&ix.joints, &scene.joint, bodies);
    let springs = of(&ix.springs, &scene.spring_damper, bodies);
    let explicit = of(&ix.contacts, &scene.contact, bodies);
    let inputs = of(&ix.inputs, &scene.input, bodies);
    let (first_value, _) = scene.input_values();
    let mut shapes = of(&ix.shapes, &scene.shape, bodies);
    shapes.extend(&ix.ground_shapes);
    shapes.sort_unstable();
    let s = Scene {
        model: scene.model.clone(),
        solver: scene.solver.clone(),
        material: scene.material.clone(),
        body: bodies.iter().map(|&b| scene.body[b].clone()).collect(),
        joint: joints.iter().map(|&i| scene.joint[i].clone()).collect(),
        spring_damper: springs.iter().map(|&i| scene.spring_damper[i].clone()).collect(),
        contact: explicit.iter().map(|&i| scene.contact[i].clone()).collect(),
        input: inputs.iter().map(|&i| scene.input[i].clone()).collect(),
        shape: shapes.iter().map(|&i| scene.shape[i].clone()).collect(),
        contact_group: scene.contact_group.clone(),
        broad_phase: scene.broad_phase.clone(),
    };
    let params = Parameters {
        materials: p.materials.clone(),
        masses: bodies.iter().map(|&b| p.masses[b]).collect(),
        inertias: bodies.iter().map(|&b| p.inertias[b]).collect(),
        velocities: bodies.iter().map(|&b| p.velocities[b]).collect(),
        angular_velocities: bodies.iter().map(|&b| p.angular_velocities[b]).collect(),
        springs: springs.iter().map(|&i| p.springs[i]).collect(),
        contacts: explicit.iter().map(|&i| p.contacts[i]).collect(),
        groups: p.groups.clone(),
        solver: p.solver.clone(),
        input_start: inputs
            .iter()
            .flat_map(|&i| {
                (0..scene.input[i].values())
                    .map(|k| first_value[i] + k)
                    .collect::<Vec<_>>()
            })
            .map(|v| p.input_start[v])
            .collect(),
    };
    let candidates = local_candidates(&shapes, candidates);
    Cut {
        scene: s,
        params,
        candidates,
        explicit,
        inputs,
        shapes,
    }
}
