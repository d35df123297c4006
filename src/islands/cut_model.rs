//! An island's model cut from the scene's compiled model: its bodies, joints, loops, springs,
//! declared contacts, inputs and group shapes (with what they bring to a contact element)
//! taken from the scene's model and numbered anew. It depends on the island's bodies alone:
//! the island's data lists its candidate pairs' contact elements
//! ([`crate::contact::elements::set_candidates`]). No scene is cut and nothing is compiled
//! from names: the model is the one compiling the island's part of the scene gives (the test
//! below compares them), at a fraction of the cost.
//!
//! Why the numbering carries over: compilation orders the tree joints depth first from the
//! ground, the trees by their root bodies and the children by body order. An island holds
//! every body of each of its trees, so its order is the scene's restricted to its bodies; its
//! loops, springs, contacts, inputs and shapes keep the scene's order too. Its dof maps and
//! its plan are the scene's restricted to it as well: both are decided tree by tree, from
//! what an island holds whole.

use super::cut::{driven_joint, items, SceneIndex};
use super::part::{alike_bodies, key_into, numbering, Key, Numbering};
use crate::compile::{contact_warnings, Parameters};
use crate::contact::elements::reserve_constraint_rows;
use crate::linalg::ConstantLeaves;
use crate::model::compiled::NOT_FREE;
use crate::model::contact::{ContactElement, OtherSide, SphereSide};
use crate::model::groups::{GroupShape, Groups};
use crate::model::{Body, Drive, FreeBody, Input, LoopConstraint, Model, Plan, SpringDamper, TreeJoint};

/// What cutting an island's model needs of the scene's compiled model, made once when the
/// islands are (none of it depends on the candidate pairs, which the data holds).
pub(super) struct ModelCutter {
    /// Per scene body, the scene items that name it.
    pub(super) index: SceneIndex,
    /// Per scene input, the tree joint it drives (a `joint_motion`).
    drive_joint: Vec<Option<usize>>,
    /// The plan of the whole scene as one island (with its declared contacts alone): an
    /// island's plan is its part ([`Plan::of`] decides each body, joint and tree from what
    /// the island holds whole: its trees, and the loops, springs, contacts and group shapes
    /// that name its bodies).
    plan: Plan,
    /// Scratch: per scene body its island index and per scene group its island index (both
    /// `usize::MAX` outside a cut), the island's tree joints, and its scene joints, inputs and
    /// springs.
    local_body: Vec<usize>,
    local_group: Vec<usize>,
    tree_joints: Vec<usize>,
    scene_joints: Vec<usize>,
    scene_inputs: Vec<usize>,
    scene_springs: Vec<usize>,
    /// The buffers of the names and of the joint force lists of the part cut into, for those
    /// of the part cut.
    names: Vec<String>,
    qvels: Vec<Vec<usize>>,
    /// Per scene body, the plain body it is alike to ([`alike_bodies`]).
    pub(super) alike: Vec<Option<usize>>,
}

impl ModelCutter {
    /// The cutter of the scene's compiled model `m`.
    pub(super) fn new(m: &Model) -> ModelCutter {
        let drive_joint = (0..m.inputs.len()).map(|g| driven_joint(m, g)).collect();
        let explicit = &m.initial_contacts[..m.groups.n_explicit];
        let plan = Plan::of(
            &m.bodies, &m.joints, &m.loops, &m.springs, explicit, &m.groups, &m.trees,
        );
        let index = SceneIndex::of_model(m);
        let alike = alike_bodies(&index, m, &plan);
        ModelCutter {
            index,
            drive_joint,
            plan,
            local_body: vec![usize::MAX; m.bodies.len()],
            local_group: vec![usize::MAX; m.groups.ngroups],
            tree_joints: Vec::new(),
            scene_joints: Vec::new(),
            scene_inputs: Vec::new(),
            scene_springs: Vec::new(),
            names: Vec::new(),
            qvels: Vec::new(),
            alike,
        }
    }

    /// Writes into `key` what the model of the island of `bodies` (sorted) is cut for
    /// ([`Key`]): islands of the same key have the same model.
    pub(super) fn key_into(&self, bodies: &[usize], key: &mut Key) {
        key_into(&self.alike, bodies, key);
    }

    /// Writes into `own` the numbering against the scene's model `m` (compiled from `scene`;
    /// `joint_coords` as for [`ModelCutter::cut_into`]) of the island of scene bodies `bodies`
    /// (sorted) whose model is `model`: cut for them, or for bodies of the same key.
    pub(super) fn number_into(
        &mut self,
        m: &Model,
        joint_coords: &[(usize, usize)],
        bodies: &[usize],
        model: &Model,
        own: &mut Numbering,
    ) {
        self.lists(m, bodies, own);
        numbering(m, joint_coords, bodies, &self.scene_inputs, model, own);
    }

    /// Writes into `own` the island's declared contacts and group shapes (scene numbering),
    /// and into the scratch its scene inputs.
    fn lists(&mut self, m: &Model, bodies: &[usize], own: &mut Numbering) {
        let explicit = &m.initial_contacts[..m.groups.n_explicit];
        items(&self.index.contacts, explicit, bodies, &mut own.explicit);
        items(&self.index.inputs, &m.inputs, bodies, &mut self.scene_inputs);
        // (the island's shapes, then the ground's)
        let (ix, ground) = (&self.index.shapes, &self.index.ground_shapes);
        let shapes = renew(
            &mut own.shapes,
            bodies.iter().map(|&b| ix[b].len()).sum::<usize>() + ground.len(),
        );
        shapes.extend(bodies.iter().flat_map(|&b| ix[b].iter().copied()));
        shapes.sort_unstable();
        shapes.dedup();
        shapes.extend(ground);
        shapes.sort_unstable();
    }

    /// Makes `out` the model of the island of scene bodies `bodies` (sorted), cut from the
    /// scene's model `m` (compiled from `scene` with `params`; its own candidate pairs play no
    /// part), and `own` its numbering against the scene's (`joint_coords`: per scene body the
    /// first position and velocity index of its joint in the scene's state). `out` may be the
    /// model of any island, of any scene, or an empty one: every list of it and of `own` is
    /// emptied and filled anew, each name written into the buffer of a name it held, so that
    /// nothing is allocated where its buffers are large enough.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn cut_into(
        &mut self,
        params: &Parameters,
        m: &Model,
        joint_coords: &[(usize, usize)],
        bodies: &[usize],
        out: &mut Model,
        own: &mut Numbering,
    ) {
        self.lists(m, bodies, own);
        for (l, &b) in bodies.iter().enumerate() {
            self.local_body[b] = l;
        }
        let local = &self.local_body;
        let lb = |b: Option<usize>| b.map(|b| local[b]);
        // the names' buffers, the bodies' on top (taken first: a body's, then its joint's)
        let names = &mut self.names;
        names.extend(out.initial_contacts.drain(..).map(|c| c.name));
        names.extend(out.springs.drain(..).map(|s| s.name));
        names.extend(out.loops.drain(..).map(|l| l.name));
        names.extend(out.joints.drain(..).map(|j| j.name));
        names.extend(out.bodies.drain(..).map(|b| b.name));
        let qvels = &mut self.qvels;
        qvels.extend(out.inputs.drain(..).filter_map(|i| match i {
            Input::JointForce { qvels } => Some(qvels),
            _ => None,
        }));
        out.name.clone_from(&m.name);

        // tree joints, in the scene's order restricted to the island
        let tree_joints = &mut self.tree_joints;
        tree_joints.clear();
        tree_joints.extend(bodies.iter().map(|&b| m.bodies[b].joint));
        tree_joints.sort_unstable();
        let scene_joints = &mut self.scene_joints;
        items(&self.index.joints, &m.scene_joint, bodies, scene_joints);
        renew(&mut out.bodies, bodies.len()).extend(bodies.iter().map(|&b| Body {
            name: name_in(names, &m.bodies[b].name),
            joint: 0,
            ..m.bodies[b]
        }));
        // (the sizes first, so that every list below is made once at its size)
        let (mut ntrees, mut nquat, mut dofs, mut nfree) = (0, 0, 0, 0);
        let mut scene_tree = usize::MAX;
        for &t in tree_joints.iter() {
            let j = &m.joints[t];
            if j.tree != scene_tree {
                scene_tree = j.tree;
                ntrees += 1;
            }
            nquat += usize::from(j.quaternion().is_some());
            dofs += j.nv();
            nfree += usize::from(self.plan.free_of[j.child] != NOT_FREE);
        }
        let nt = tree_joints.len();
        let out_bodies = &mut out.bodies;
        let joints = renew(&mut out.joints, nt);
        let trees = renew(&mut out.trees, ntrees);
        let quaternions = renew(&mut out.quaternions, nquat);
        // the dof maps: a tree's parents are local to its block, as the scene's
        let dof_joint = renew(&mut out.dof_joint, dofs);
        let dof_parent = renew(&mut out.dof_parent, dofs);
        // the plan: the scene's, whose every entry the island's bodies and trees decide
        let sp = &self.plan;
        let plan = &mut out.plan;
        renew(&mut plan.free, nfree);
        plan.free_of.clear();
        plan.free_of.resize(bodies.len(), NOT_FREE);
        renew(&mut plan.rotors, nt);
        renew(&mut plan.constant_row, nt);
        plan.general.joints.clear();
        plan.general.bodies.clear();
        plan.general.trees.clear();
        plan.leaves.truncate(ntrees);
        let (mut nq, mut nv) = (0, 0);
        scene_tree = usize::MAX;
        for &t in tree_joints.iter() {
            let j = &m.joints[t];
            if j.tree != scene_tree {
                scene_tree = j.tree;
                let k = trees.len();
                trees.push((nv, 0));
                let leaves = &sp.leaves[j.tree];
                match plan.leaves.get_mut(k) {
                    Some(to) => copy_leaves(to, leaves),
                    // (most trees have no constant leaf: an empty set is made, not cloned)
                    None if leaves.is_leaf.is_empty() => plan.leaves.push(ConstantLeaves::default()),
                    None => plan.leaves.push(leaves.clone()),
                }
            }
            let (ji, child, tree) = (joints.len(), local[j.child], trees.len() - 1);
            out_bodies[child].joint = ji;
            joints.push(TreeJoint {
                name: name_in(names, &j.name),
                scene_index: j
                    .scene_index
                    .map(|si| scene_joints.binary_search(&si).unwrap_or(usize::MAX)),
                parent: lb(j.parent),
                child,
                qpos: nq,
                qvel: nv,
                tree,
                ..*j
            });
            quaternions.extend(joints[ji].quaternion());
            dof_joint.extend(std::iter::repeat_n(ji, j.nv()));
            dof_parent.extend_from_slice(&m.dof_parent[j.qvel..j.qvel + j.nv()]);
            match sp.free_body(j.child) {
                Some(f) => {
                    plan.free_of[child] = plan.free.len();
                    plan.free.push(FreeBody {
                        body: child,
                        qpos: nq,
                        qvel: nv,
                        ..f.clone()
                    });
                }
                None => {
                    plan.general.joints.push(ji);
                    plan.general.bodies.push(child);
                    if plan.general.trees.last() != Some(&tree) {
                        plan.general.trees.push(tree);
                    }
                }
            }
            plan.rotors.push(sp.rotors[t]);
            plan.constant_row.push(sp.constant_row[t]);
            nq += j.nq();
            nv += j.nv();
            trees[tree].1 = nv - trees[tree].0;
        }
        plan.general.bodies.sort_unstable();
        let tree_block = renew(&mut out.tree_block, trees.len());
        let mut off = 0;
        for &(_, n) in trees.iter() {
            tree_block.push(off);
            off += n * n;
        }
        // the island's tree joint of the scene's tree joint t
        let joint_of = |t: usize| out_bodies[local[m.joints[t].child]].joint;

        // loops, in the scene's joint order
        let scene_joint = renew(&mut out.scene_joint, scene_joints.len());
        let loops = &mut out.loops;
        let mut nc = 0;
        for &si in scene_joints.iter() {
            match m.scene_joint[si] {
                Ok(t) => scene_joint.push(Ok(joint_of(t))),
                Err(l) => {
                    let lc = &m.loops[l];
                    scene_joint.push(Err(loops.len()));
                    loops.push(LoopConstraint {
                        name: name_in(names, &lc.name),
                        body_a: lb(lc.body_a),
                        body_b: local[lc.body_b],
                        row: nc,
                        ..*lc
                    });
                    nc += lc.rows();
                }
            }
        }

        // inputs and drives
        let inputs = &self.scene_inputs;
        let drives = &mut out.drives;
        drives.clear();
        let input_value = renew(&mut out.input_value, inputs.len());
        let input_start = &mut out.input_start;
        input_start.clear();
        let out_inputs = &mut out.inputs;
        out_inputs.reserve(inputs.len());
        for &g in inputs.iter() {
            input_value.push(input_start.len());
            if let Some(t) = self.drive_joint[g] {
                let j = &joints[joint_of(t)];
                drives.push(Drive {
                    qpos: j.qpos,
                    qvel: j.qvel,
                    row: nc,
                    value: input_start.len(),
                });
                nc += 1;
            }
            input_start.extend_from_slice(&m.input_start[m.input_range(g)]);
            out_inputs.push(match &m.inputs[g] {
                Input::Force { body, direction } => Input::Force {
                    body: local[*body],
                    direction: *direction,
                },
                Input::Torque { body, direction } => Input::Torque {
                    body: local[*body],
                    direction: *direction,
                },
                Input::JointMotion => Input::JointMotion,
                Input::JointForce { qvels: scene_qvels } => {
                    let mut island_qvels = qvels.pop().unwrap_or_default();
                    island_qvels.clear();
                    island_qvels.extend(scene_qvels.iter().map(|&v| {
                        let t = m.dof_joint[v];
                        joints[joint_of(t)].qvel + (v - m.joints[t].qvel)
                    }));
                    Input::JointForce { qvels: island_qvels }
                }
            });
        }

        let springs = &mut self.scene_springs;
        items(&self.index.springs, &m.springs, bodies, springs);
        renew(&mut out.springs, springs.len()).extend(springs.iter().map(|&i| {
            let s = &m.springs[i];
            SpringDamper {
                name: name_in(names, &s.name),
                body_a: lb(s.body_a),
                body_b: lb(s.body_b),
                ..*s
            }
        }));

        // contacts: the declared ones (the data lists the candidate pairs' after them)
        let explicit = &own.explicit;
        let contacts = renew(&mut out.initial_contacts, explicit.len());
        contacts.extend(explicit.iter().map(|&i| {
            let c = &m.initial_contacts[i];
            ContactElement {
                name: name_in(names, &c.name),
                sphere_body: lb(c.sphere_body),
                body: lb(c.body),
                shape: c.shape.clone(),
                ..*c
            }
        }));
        let shapes = &own.shapes;
        reserve_constraint_rows(contacts, nc);

        if m.groups.pair_groups.is_empty() {
            out.groups = Groups {
                n_explicit: explicit.len(),
                stale_fraction: super::ISLAND_STALE_FRACTION,
                ..Groups::default()
            };
        } else {
            cut_groups(
                m,
                local,
                &mut self.local_group,
                bodies,
                shapes,
                explicit.len(),
                &mut out.groups,
            );
        }
        out.warnings = contact_warnings(contacts, &out.groups);
        out.gravity = m.gravity;
        out.nq = nq;
        out.nv = nv;
        out.solver = params.solver.clone();
        out.baumgarte = m.baumgarte;
        // (the names and joint force lists left over are kept for the next cut, up to a bound)
        names.truncate(SPARE_NAMES);
        qvels.truncate(SPARE_NAMES);
        numbering(m, joint_coords, bodies, inputs, out, own);
        // (left as it came: a body not of the island has no island index)
        for &b in bodies {
            self.local_body[b] = usize::MAX;
        }
    }
}

/// At most this many names' buffers (and joint force lists) left over from one cut are kept
/// for the next.
const SPARE_NAMES: usize = 64;

/// `list` emptied, its buffer kept, with room for `n` items.
fn renew<T>(list: &mut Vec<T>, n: usize) -> &mut Vec<T> {
    list.clear();
    list.reserve(n);
    list
}

/// `name` written into a buffer taken from `spare` (a new one when it is empty).
fn name_in(spare: &mut Vec<String>, name: &str) -> String {
    let mut s = spare.pop().unwrap_or_default();
    s.clear();
    s.push_str(name);
    s
}

/// Makes `to` the constant leaves `from`, in `to`'s buffers.
fn copy_leaves(to: &mut ConstantLeaves, from: &ConstantLeaves) {
    to.is_leaf.clone_from(&from.is_leaf);
    to.pivots.clone_from(&from.pivots);
    to.factor.clone_from(&from.factor);
    to.update.clone_from(&from.update);
}

/// Writes into `out` the contact groups of the island of scene bodies `bodies` (sorted;
/// `local`: per scene body its island index) whose group shapes are the scene's `shapes`
/// (sorted), with `n_explicit` declared contacts, from the scene's model `m` (`out`'s buffers
/// kept). `local_group`: scratch per scene group, left as it came (`usize::MAX` throughout).
#[allow(clippy::too_many_arguments)]
fn cut_groups(
    m: &Model,
    local: &[usize],
    local_group: &mut [usize],
    bodies: &[usize],
    shapes: &[usize],
    n_explicit: usize,
    out: &mut Groups,
) {
    let lb = |b: Option<usize>| b.map(|b| local[b]);
    // the island's group numbering: its shapes' groups, then those the pairs name
    let mut ngroups = 0;
    let mut number = |g: usize, local_group: &mut [usize]| {
        if local_group[g] == usize::MAX {
            local_group[g] = ngroups;
            ngroups += 1;
        }
    };
    let pair_groups = &m.groups.pair_groups;
    for &s in shapes {
        number(m.groups.shapes[s].group, local_group);
    }
    for &(a, b) in pair_groups {
        number(a, local_group);
        number(b, local_group);
    }
    out.touch.clear();
    out.touch.resize(ngroups * ngroups, None);
    for (p, &(a, b)) in pair_groups.iter().enumerate() {
        out.touch[local_group[a] * ngroups + local_group[b]] = Some(p);
    }
    renew(&mut out.pair_groups, pair_groups.len())
        .extend(pair_groups.iter().map(|&(a, b)| (local_group[a], local_group[b])));
    renew(&mut out.shapes, shapes.len()).extend(shapes.iter().map(|&s| {
        let gs = &m.groups.shapes[s];
        GroupShape {
            body: lb(gs.body),
            group: local_group[gs.group],
            ..gs.clone()
        }
    }));
    local_group.fill(usize::MAX);
    let g = &m.groups;
    out.ngroups = ngroups;
    out.pair_names.clone_from(&g.pair_names);
    out.n_explicit = n_explicit;
    out.initial_candidates.clear();
    out.margin = g.margin;
    out.method = g.method;
    renew(&mut out.reach, bodies.len()).extend(bodies.iter().map(|&b| g.reach[b]));
    renew(&mut out.has_shape, bodies.len()).extend(bodies.iter().map(|&b| g.has_shape[b]));
    out.stale_fraction = super::ISLAND_STALE_FRACTION;
    renew(&mut out.sphere_sides, shapes.len()).extend(shapes.iter().map(|&s| SphereSide {
        body: lb(g.sphere_sides[s].body),
        ..g.sphere_sides[s]
    }));
    renew(&mut out.other_sides, shapes.len()).extend(shapes.iter().map(|&s| OtherSide {
        body: lb(g.other_sides[s].body),
        ..g.other_sides[s].clone()
    }));
    out.laws.clone_from(&g.laws);
}

#[cfg(test)]
mod tests {
    use super::super::cut::SceneIndex;
    use super::super::part::compile_cut_scene;
    use super::super::pool::fresh_cut;
    use super::super::pool::tests::assert_same_part;
    use super::super::{partition, Islands, Source};
    use crate::bench::islands::grouped;
    use crate::compile::{compile as compile_scene, compile_model, Parameters};
    use crate::contact::elements::set_candidates;
    use crate::model::groups::Candidate;
    use crate::model::{Data, Model};
    use crate::scene::{Law, Scene};
    use std::path::Path;

    /// An island's bodies and candidate pairs (scene numbering).
    type Part = (Vec<usize>, Vec<Candidate>);

    /// Asserts that the part of the bodies of `key` cut from the scene's model `m` is the one
    /// compiling the island's part of the scene gives, and that the contact list its data
    /// makes for the candidate pairs of `key` is the one compiling that part with them gives.
    fn assert_same(src: &Source, is: &mut Islands, m: &Model, key: &Part) {
        let (bodies, candidates) = key;
        let cut = fresh_cut(is, m, bodies);
        // (the oracle reads the scene itself: its index too)
        let index = SceneIndex::of(src.scene);
        let oracle = compile_cut_scene(src, &is.params, &index, m, &is.joint_coords, bodies).unwrap();
        assert_same_part(&cut, &oracle, bodies);
        let part = super::super::cut::cut(src.scene, &is.params, &index, bodies, candidates);
        let with = compile_model(&part.scene, &part.params, src.origin, Some(&part.candidates)).unwrap();
        let mut data = Data::new(&cut.model);
        set_candidates(&cut.model, &mut data, &part.candidates).unwrap();
        assert_eq!(
            format!("{:?}", data.contacts),
            format!("{:?}", with.initial_contacts),
            "bodies {bodies:?}"
        );
        assert_eq!(
            data.nc,
            with.fixed_rows() + (data.contacts.iter().filter(|c| c.constraint_row.is_some())).count()
        );
    }

    /// Compares, for `scene`: the whole scene and each of its islands at the start, then
    /// every island and every pooled part after each of `advances` (communication points):
    /// returns how many parts were compared.
    fn compare_islands(scene: &Scene, advances: &[f64]) -> usize {
        let origin = "cut test";
        let (m, mut d) = compile_scene(scene, origin).unwrap();
        let src = Source { scene, origin };
        let mut is = Islands::new(Parameters::of_scene(scene), &m, &mut d).unwrap();
        let all: Part = ((0..m.bodies.len()).collect(), d.candidates.clone());
        assert_same(&src, &mut is, &m, &all);
        let mut compared = 1;
        for bodies in partition(&m, &d.candidates).iter() {
            let bodies = bodies.to_vec();
            let cands = d
                .candidates
                .iter()
                .filter(|c| super::super::cut::candidate_body(&m, c).is_some_and(|b| bodies.binary_search(&b).is_ok()))
                .copied()
                .collect();
            assert_same(&src, &mut is, &m, &(bodies, cands));
            compared += 1;
        }
        for &t in advances {
            is.advance(&m, &mut d, t, false).unwrap();
            let p = &d.partition;
            let mut keys: Vec<Part> = (0..p.len())
                .map(|k| (p.bodies(k).to_vec(), p.candidates(k).to_vec()))
                .collect();
            keys.extend(is.pool.keys().map(|(_, bodies)| (bodies.clone(), Vec::new())));
            for key in &keys {
                assert_same(&src, &mut is, &m, key);
            }
            compared += keys.len();
        }
        compared
    }

    fn bundled(name: &str) -> Scene {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fmu")
            .join(name)
            .join("scene.toml");
        Scene::from_file(&path).unwrap()
    }

    /// The models cut from the scene's model are those compiled from the cut scenes: groups
    /// of spheres in a box whose islands merge and split, the bundled pile, and scenes of
    /// joints, loops, springs, declared contacts, joint forces and driven joints.
    #[test]
    fn cut_models_are_those_compilation_gives() {
        let n = compare_islands(&grouped(64, 0.02, 0.0015, true), &[0.005, 0.01, 0.015, 0.02]);
        assert!(n > 200, "{n} parts compared");
        let mut pile = bundled("pile_of_balls");
        compare_islands(&pile, &[0.05, 0.1]);
        // a damped Kelvin-Voigt law (its models carry a warning per contact)
        for g in &mut pile.contact_group {
            g.law = Law::KelvinVoigt;
            g.damping = Some(20.0);
            g.stiffness = Some(1e7);
        }
        compare_islands(&pile, &[0.02]);
        for name in [
            "rail_vehicle",
            "rail_vehicle_track",
            "slider_crank",
            "two_spheres",
            "bouncing_ball",
        ] {
            compare_islands(&bundled(name), &[0.01]);
        }
    }

    /// The scene's items per body read off its compiled model are those read off the scene:
    /// grouped spheres, and the bundled scenes (joints, loops, springs, declared contacts,
    /// force, joint force and joint motion inputs, group shapes on bodies and on the ground).
    #[test]
    fn the_index_read_off_the_model_is_the_scenes() {
        let mut scenes = vec![grouped(64, 0.02, 0.0015, true)];
        scenes.extend(
            [
                "pile_of_balls",
                "rail_vehicle",
                "rail_vehicle_track",
                "slider_crank",
                "two_spheres",
                "bouncing_ball",
            ]
            .map(bundled),
        );
        for scene in &scenes {
            let (m, _) = compile_scene(scene, "index test").unwrap();
            let of_model = SceneIndex::of_model(&m);
            assert_eq!(of_model, SceneIndex::of(scene), "{}", scene.model.name);
            // (not vacuous: the inputs the scene has are listed)
            assert!(scene.input.is_empty() || of_model.inputs.iter().any(|l| !l.is_empty()));
        }
    }

    /// A part cut into the buffers of another part (of more bodies, fewer, as many, of the same
    /// scene or another) is the one cut anew: 64 grouped spheres, the bundled pile, and scenes
    /// of joints, loops, springs, declared contacts and inputs, every part cut into every
    /// other.
    #[test]
    fn parts_cut_into_used_buffers_are_those_cut_anew() {
        let mut scenes = vec![grouped(64, 0.02, 0.0015, true), bundled("pile_of_balls")];
        scenes.extend(["rail_vehicle", "slider_crank", "two_spheres"].map(bundled));
        let origin = "recycle test";
        let mut compiled: Vec<_> = scenes.iter().map(|s| compile_scene(s, origin).unwrap()).collect();
        // (per scene: its model and islands; the keys with their scene's index)
        let (mut cases, mut keyed) = (Vec::new(), Vec::new());
        for (scene, (m, d)) in scenes.iter().zip(&mut compiled) {
            let is = Islands::new(Parameters::of_scene(scene), m, d).unwrap();
            let mut keys: Vec<Vec<usize>> = partition(m, &d.candidates).iter().map(<[usize]>::to_vec).collect();
            keys.truncate(4);
            keys.push((0..m.bodies.len()).collect());
            if m.groups.is_active() {
                // (bodies that are no island at the start: any spheres are one)
                keys.push((1..m.bodies.len()).step_by(3).collect());
            }
            keyed.extend(keys.into_iter().map(|k| (cases.len(), k)));
            cases.push((m, is));
        }
        let mut compared = 0;
        for (from, a) in &keyed {
            for (to, b) in &keyed {
                let (m, is) = &mut cases[*from];
                let mut part = fresh_cut(is, m, a);
                let (m, is) = &mut cases[*to];
                let out = std::sync::Arc::make_mut(&mut part.model);
                is.cutter
                    .cut_into(&is.params, m, &is.joint_coords, b, out, &mut part.numbering);
                let fresh = fresh_cut(is, m, b);
                assert_same_part(&part, &fresh, b);
                compared += 1;
            }
        }
        assert!(compared > 300, "{compared} parts compared");
    }
}
