//! Model compilation: a validated scene becomes a read-only [`Model`] (topology, joint
//! frames, constants, contact elements with their law constants) and a [`Data`] sized once
//! and set to the initial configuration.
//!
//! The joints form a spanning tree rooted at the ground: the first joint that names a body as
//! its child is that body's tree joint; a later joint with the same child closes a loop and
//! becomes a [`LoopConstraint`]. A body that is no joint's child gets a free joint to the
//! ground. Degrees of freedom are numbered tree by tree (depth first), so the joint-space mass
//! matrix is block diagonal with one dense block per independent tree.
//!
//! - `parameters`: the values a host may set (their defaults from the scene).
//! - `contact`: what a shape brings to a contact element, and a declared contact compiled as
//!   the pair of its two one-shape groups (the same path as a group pair's candidate).
//! - `groups`: the contact groups (group shapes, candidate pairs, their contact elements).
//! - `velocities`: the initial joint rates from the scene's body velocities.

mod contact;
mod groups;
pub mod parameters;
mod velocities;

pub use parameters::{contact_law_constants, group_law_constants, law_constants, Parameters};

use crate::kinematics::kinematics;
use crate::model::contact::ContactElement;
use crate::model::groups::{Candidate, Groups};
use crate::model::{nq_of, nv_of, Body, Data, Drive, Input, LoopConstraint, Model, Plan, SpringDamper, TreeJoint};
use crate::scene::{item_name, InputType, JointSpec, JointType, Law, Scene, SceneError};
use crate::spatial::triad;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

fn to_v(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

fn quat_of(a: [f64; 4]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(a[0], a[1], a[2], a[3]))
}

/// Compiles a validated scene with its own parameter values (see [`compile_with`]).
pub fn compile(scene: &Scene, origin: &str) -> Result<(Model, Data), SceneError> {
    compile_with(scene, &Parameters::of_scene(scene), origin)
}

/// Compiles a validated scene with parameter values `params` into a model and its data at
/// the initial configuration (positions, and velocities projected onto the joint
/// coordinates). The law constants are computed here, once.
pub fn compile_with(scene: &Scene, params: &Parameters, origin: &str) -> Result<(Model, Data), SceneError> {
    compile_with_candidates(scene, params, origin, None)
}

/// [`compile_with`], the contact groups' candidate pairs given (None: found by the broad
/// phase at the initial configuration).
pub fn compile_with_candidates(
    scene: &Scene,
    params: &Parameters,
    origin: &str,
    candidates: Option<&[Candidate]>,
) -> Result<(Model, Data), SceneError> {
    let mut model = compile_model(scene, params, origin, candidates)?;
    let mut data = Data::new(&model);
    // the drives' coordinates start at their inputs' q (0: the scene's configuration), their
    // rates at qd (the velocities below keep them)
    for dr in &model.drives {
        data.state[dr.qpos] = data.inputs[dr.value];
    }
    let (qvel, warnings) = velocities::initial_velocities(&model, &mut data, params);
    model.warnings.extend(warnings);
    data.state[model.nq..model.nq + model.nv].copy_from_slice(&qvel);
    data.eval_state.copy_from_slice(&data.state);
    kinematics(&model, &mut data);
    crate::contact::groups::take_reference_poses(&model, &mut data);
    Ok((model, data))
}

/// The model of [`compile_with_candidates`] alone: no data, so no initial state (for a caller
/// that sets every coordinate itself, such as an island taking the scene's).
pub fn compile_model(
    scene: &Scene,
    params: &Parameters,
    origin: &str,
    candidates: Option<&[Candidate]>,
) -> Result<Model, SceneError> {
    params.check(scene, origin)?;
    let nb = scene.body.len();
    // Name → index maps, built once: every lookup below is O(1), so compilation is linear in
    // the size of the scene.
    let body_index = scene.body_index();
    let body_idx = |name: &str| -> Option<usize> { body_index.get(name).copied() };
    let (pos0, rot0): (Vec<Vector3<f64>>, Vec<UnitQuaternion<f64>>) =
        (0..nb).map(|b| initial_pose(scene, Some(b))).unzip();

    // Spanning tree: first joint naming a child wins; later ones close loops.
    let mut parent_joint: Vec<Option<usize>> = vec![None; nb];
    let mut loop_joints = Vec::new();
    for (ji, j) in scene.joint.iter().enumerate() {
        let c = body_idx(&j.child)
            .ok_or_else(|| SceneError::new(origin, item_name("joint", &j.name), "child", "unknown body"))?;
        if parent_joint[c].is_none() {
            parent_joint[c] = Some(ji);
        } else {
            loop_joints.push(ji);
        }
    }
    // The parent body of each body in the tree (None: the ground, or no joint).
    let parent_body: Vec<Option<usize>> = parent_joint
        .iter()
        .map(|pj| pj.and_then(|ji| body_idx(&scene.joint[ji].parent)))
        .collect();
    check_paths_to_ground(scene, origin, &parent_joint, &parent_body)?;
    // Depth-first order from the ground; each root child starts a tree.
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); nb + 1]; // index nb = ground
    for (b, p) in parent_body.iter().enumerate() {
        children[p.unwrap_or(nb)].push(b);
    }
    let mut order = Vec::with_capacity(nb);
    let mut tree_of = vec![0usize; nb];
    let mut stack = Vec::new();
    for (t, &root) in children[nb].iter().enumerate() {
        stack.push(root);
        while let Some(b) = stack.pop() {
            order.push(b);
            tree_of[b] = t;
            for &c in children[b].iter().rev() {
                stack.push(c);
            }
        }
    }
    let ntrees = children[nb].len();

    let pose = |b: Option<usize>| -> (Vector3<f64>, UnitQuaternion<f64>) {
        match b {
            Some(i) => (pos0[i], rot0[i]),
            None => (Vector3::zeros(), UnitQuaternion::identity()),
        }
    };

    let mut joints = Vec::with_capacity(nb);
    let mut bodies: Vec<Body> = scene
        .body
        .iter()
        .zip(params.masses.iter().zip(&params.inertias))
        .map(|(b, (&mass, &inertia))| Body {
            name: b.name.clone(),
            mass,
            inertia: to_v(inertia),
            joint: 0,
        })
        .collect();
    let mut scene_joint: Vec<Result<usize, usize>> = vec![Err(usize::MAX); scene.joint.len()];
    let (mut nq, mut nv) = (0, 0);
    let mut trees = vec![(0usize, 0usize); ntrees];
    let mut tree_started = vec![false; ntrees];
    for &b in &order {
        let (kind, parent, spec, scene_index): (JointType, Option<usize>, Option<&JointSpec>, Option<usize>) =
            match parent_joint[b] {
                Some(ji) => {
                    let j = &scene.joint[ji];
                    (j.kind, body_idx(&j.parent), Some(j), Some(ji))
                }
                None => (JointType::Free, None, None, None),
            };
        let (rp, qp) = pose(parent);
        let rpm = qp.to_rotation_matrix();
        let anchor_w = spec.and_then(|s| s.anchor).map(to_v).unwrap_or(pos0[b]);
        let axis_w = spec.and_then(|s| s.axis).map(to_v).unwrap_or(Vector3::z()).normalize();
        let rel_rot = qp.inverse() * rot0[b];
        let mut q0 = [0.0; 7];
        let (axis, anchor, offset, r0) = match kind {
            JointType::Revolute => (
                rpm.inverse() * axis_w,
                rpm.inverse() * (anchor_w - rp),
                rpm.inverse() * (pos0[b] - anchor_w),
                rel_rot,
            ),
            JointType::Prismatic | JointType::Fixed => (
                rpm.inverse() * axis_w,
                rpm.inverse() * (anchor_w - rp),
                rpm.inverse() * (pos0[b] - rp),
                rel_rot,
            ),
            JointType::Spherical => {
                let qr = rel_rot.quaternion();
                q0[..4].copy_from_slice(&[qr.w, qr.i, qr.j, qr.k]);
                (
                    Vector3::z(),
                    rpm.inverse() * (anchor_w - rp),
                    rot0[b].inverse() * (pos0[b] - anchor_w),
                    UnitQuaternion::identity(),
                )
            }
            JointType::Free => {
                let x = rpm.inverse() * (pos0[b] - rp);
                let qr = rel_rot.quaternion();
                q0 = [x.x, x.y, x.z, qr.w, qr.i, qr.j, qr.k];
                (
                    Vector3::z(),
                    Vector3::zeros(),
                    Vector3::zeros(),
                    UnitQuaternion::identity(),
                )
            }
        };
        let t = tree_of[b];
        if !tree_started[t] {
            trees[t].0 = nv;
            tree_started[t] = true;
        }
        let name = spec
            .map(|s| s.name.clone())
            .unwrap_or_else(|| format!("{}.free", scene.body[b].name));
        let ji = joints.len();
        if let Some(si) = scene_index {
            scene_joint[si] = Ok(ji);
        }
        bodies[b].joint = ji;
        joints.push(TreeJoint {
            name,
            kind,
            scene_index,
            parent,
            child: b,
            qpos: nq,
            qvel: nv,
            axis: axis.normalize(),
            anchor,
            offset,
            rot0: r0,
            q0,
            tree: t,
        });
        nq += nq_of(kind);
        nv += nv_of(kind);
        trees[t].1 = nv - trees[t].0;
    }
    let (dof_joint, dof_parent, tree_block) = dof_maps(&joints, &bodies, &trees);

    // Loop constraints.
    let mut loops = Vec::new();
    let mut nc = 0;
    for (li, &ji) in loop_joints.iter().enumerate() {
        let j = &scene.joint[ji];
        let item = item_name("joint", &j.name);
        if j.kind == JointType::Free {
            return Err(SceneError::new(
                origin,
                item,
                "type",
                "a free joint cannot close a loop (it constrains nothing)",
            ));
        }
        let a = body_idx(&j.parent);
        let b = body_idx(&j.child).unwrap_or(0);
        let anchor_w = j.anchor.map(to_v).unwrap_or(pos0[b]);
        let axis_w = j.axis.map(to_v).unwrap_or(Vector3::z()).normalize();
        let (ra, qa) = pose(a);
        let (rb, qb) = (pos0[b], rot0[b]);
        let tri = triad(&axis_w);
        let lc = LoopConstraint {
            name: j.name.clone(),
            kind: j.kind,
            body_a: a,
            body_b: b,
            anchor_a: qa.inverse() * (anchor_w - ra),
            anchor_b: qb.inverse() * (anchor_w - rb),
            triad_a: qa.to_rotation_matrix().inverse().matrix() * tri,
            triad_b: qb.to_rotation_matrix().inverse().matrix() * tri,
            row: nc,
        };
        nc += lc.rows();
        scene_joint[ji] = Err(li);
        loops.push(lc);
    }

    let to_body = |name: &str| -> Option<usize> { body_idx(name) };
    let joint_index = scene.joint_index();

    // Driven joints: one constraint row each, after the loops' rows.
    let (input_value, _) = scene.input_values();
    let mut drives = Vec::new();
    for (i, inp) in scene.input.iter().enumerate() {
        if inp.kind != InputType::JointMotion {
            continue;
        }
        let ji = inp.joint_in(&joint_index);
        let Ok(t) = scene_joint[ji] else {
            return Err(SceneError::new(
                origin,
                item_name("input", &inp.name),
                "joint",
                "the joint closes a loop; a joint_motion needs a tree joint (one with a coordinate)",
            ));
        };
        drives.push(Drive {
            qpos: joints[t].qpos,
            qvel: joints[t].qvel,
            row: nc,
            value: input_value[i],
        });
        nc += 1;
    }
    let material_index = scene.material_index();
    let placing = contact::Placing {
        body_of: &|n| to_body(n),
        pose0: &|b| pose(b),
        material_of: &|n| material_index.get(n).copied(),
        materials: &params.materials,
    };
    let springs: Vec<SpringDamper> = scene
        .spring_damper
        .iter()
        .zip(&params.springs)
        .map(|(s, p)| {
            let (a, b) = (to_body(&s.body_a), to_body(&s.body_b));
            SpringDamper {
                name: s.name.clone(),
                body_a: a,
                point_a: placing.local_point(a, to_v(s.point_a)),
                body_b: b,
                point_b: placing.local_point(b, to_v(s.point_b)),
                stiffness: p.stiffness,
                damping: p.damping,
                free_length: p.free_length,
            }
        })
        .collect();

    let mut contacts = Vec::with_capacity(scene.contact.len());
    for (c, p) in scene.contact.iter().zip(&params.contacts) {
        contacts.push(contact::compile_contact(c, p, &placing, origin)?);
    }
    let (groups, group_contacts) = groups::compile_groups(scene, params, origin, contacts.len(), candidates, &placing)?;
    contacts.extend(group_contacts);
    // One constraint row per impulse-law contact after the loop rows (its resting mode).
    crate::contact::elements::reserve_constraint_rows(&mut contacts, nc);
    let warnings = contact_warnings(&contacts, &groups);

    let inputs = scene
        .input
        .iter()
        .map(|i| match i.kind {
            InputType::Force => Input::Force {
                body: i.body.as_deref().and_then(to_body).unwrap_or(0),
                direction: to_v(i.direction.unwrap_or([1.0, 0.0, 0.0])).normalize(),
            },
            InputType::Torque => Input::Torque {
                body: i.body.as_deref().and_then(to_body).unwrap_or(0),
                direction: to_v(i.direction.unwrap_or([1.0, 0.0, 0.0])).normalize(),
            },
            InputType::JointMotion => Input::JointMotion,
            InputType::JointForce => {
                let names = i.joint.iter().chain(i.joints.iter().flatten());
                let qvels = names
                    .map(
                        |n| match scene_joint[joint_index.get(n.as_str()).copied().unwrap_or(0)] {
                            Ok(t) => joints[t].qvel,
                            Err(_) => usize::MAX,
                        },
                    )
                    .collect();
                Input::JointForce { qvels }
            }
        })
        .collect();
    let quaternions = crate::model::quaternion_coordinates(&joints);

    let plan = Plan::of(&bodies, &joints, &loops, &springs, &contacts, &groups, &trees);
    let model = Model {
        name: scene.model.name.clone(),
        gravity: to_v(scene.model.gravity),
        bodies,
        joints,
        scene_joint,
        loops,
        springs,
        initial_contacts: contacts,
        groups,
        inputs,
        input_value,
        drives,
        input_start: params.input_start.clone(),
        nq,
        nv,
        quaternions,
        trees,
        tree_block,
        dof_joint,
        dof_parent,
        plan,
        solver: params.solver.clone(),
        baumgarte: 20.0,
        warnings,
    };
    for (i, inp) in scene.input.iter().enumerate() {
        if let (InputType::JointForce, Input::JointForce { qvels }) = (inp.kind, &model.inputs[i]) {
            if !qvels.contains(&usize::MAX) {
                continue;
            }
            return Err(SceneError::new(
                origin,
                item_name("input", &inp.name),
                "joint",
                "the joint closes a loop; a joint force needs a tree joint",
            ));
        }
    }
    Ok(model)
}

/// Per velocity index its tree joint and its parent dof local to its tree's block, and the
/// offset of each tree's block in the packed mass-matrix storage (the joints in depth-first
/// order, `trees`: each tree's first velocity index and size).
pub(crate) fn dof_maps(
    joints: &[TreeJoint],
    bodies: &[Body],
    trees: &[(usize, usize)],
) -> (Vec<usize>, Vec<usize>, Vec<usize>) {
    let nv = trees.iter().map(|t| t.1).sum();
    let mut dof_joint = vec![0; nv];
    for (ji, j) in joints.iter().enumerate() {
        for k in 0..j.nv() {
            dof_joint[j.qvel + k] = ji;
        }
    }
    let mut dof_parent = vec![crate::linalg::NO_PARENT; nv];
    // Per joint: the last dof of the joint itself or, when it has none, of its nearest
    // ancestor that has any (joints are in depth-first order: a parent's entry comes first).
    let mut last_dof: Vec<Option<usize>> = Vec::with_capacity(joints.len());
    for j in joints {
        let t0 = trees[j.tree].0;
        // the last dof of the nearest ancestor joint that has any
        let above = j.parent.and_then(|p| last_dof[bodies[p].joint]);
        let up = above.map_or(crate::linalg::NO_PARENT, |k| k - t0);
        for k in 0..j.nv() {
            dof_parent[j.qvel + k] = if k == 0 { up } else { j.qvel + k - 1 - t0 };
        }
        last_dof.push(if j.nv() > 0 { Some(j.qvel + j.nv() - 1) } else { above });
    }
    let mut tree_block = Vec::with_capacity(trees.len());
    let mut off = 0;
    for &(_, n) in trees {
        tree_block.push(off);
        off += n * n;
    }
    (dof_joint, dof_parent, tree_block)
}

/// A body's pose in the scene's initial configuration (None: the ground's, the world frame).
pub(crate) fn initial_pose(scene: &Scene, b: Option<usize>) -> (Vector3<f64>, UnitQuaternion<f64>) {
    match b {
        Some(i) => (to_v(scene.body[i].position), quat_of(scene.body[i].orientation)),
        None => (Vector3::zeros(), UnitQuaternion::identity()),
    }
}

/// The warnings a model's contacts give (a Kelvin-Voigt law with damping): its declared
/// contacts' (the first `groups.n_explicit` of `contacts`) and its group pairs'.
pub(crate) fn contact_warnings(contacts: &[ContactElement], groups: &Groups) -> Vec<String> {
    let pulls = |law: Law, damping: f64| law == Law::KelvinVoigt && damping > 0.0;
    let warning = |item: String| {
        format!(
            "{item}: kelvin_voigt jumps to c·δ̇⁻ at touch and would pull before separation; the force is cut \
             at zero there (docs/contact.md)"
        )
    };
    let declared = contacts[..groups.n_explicit.min(contacts.len())]
        .iter()
        .filter(|c| pulls(c.law, c.damping))
        .map(|c| warning(format!("contact {:?}", c.name)));
    let pairs = (groups.laws.iter().zip(&groups.pair_names))
        .filter(|(l, _)| pulls(l.law, l.damping))
        .map(|(_, name)| warning(format!("contact_group {name:?}")));
    declared.chain(pairs).collect()
}

/// Checks that every body reaches the ground through its tree joints (`parent_joint`,
/// `parent_body`: the tree as built from the joints). Each body is walked over once
/// (memoised), so this is linear in the number of bodies. The error names the first body,
/// in scene order, that has no path, and a joint of the cycle it hangs from.
fn check_paths_to_ground(
    scene: &Scene,
    origin: &str,
    parent_joint: &[Option<usize>],
    parent_body: &[Option<usize>],
) -> Result<(), SceneError> {
    #[derive(Clone, Copy, PartialEq)]
    enum Reach {
        Unknown,
        OnPath,
        Ground,
    }
    let nb = parent_body.len();
    let mut reach = vec![Reach::Unknown; nb];
    let mut path = Vec::new();
    for b in 0..nb {
        path.clear();
        let mut cur = b;
        loop {
            match reach[cur] {
                Reach::Ground => break,
                Reach::OnPath => {
                    // `cur` is reached a second time: a cycle of joints
                    let ji = parent_joint[cur].unwrap_or_default();
                    return Err(SceneError::new(
                        origin,
                        item_name("body", &scene.body[b].name),
                        "joint",
                        format!(
                            "joint cycle through joint {:?}: this body has no path to ground",
                            scene.joint[ji].name
                        ),
                    ));
                }
                Reach::Unknown => {
                    reach[cur] = Reach::OnPath;
                    path.push(cur);
                    match (parent_joint[cur], parent_body[cur]) {
                        (Some(_), Some(p)) => cur = p,
                        _ => break, // the ground, or a free body
                    }
                }
            }
        }
        for &p in &path {
            reach[p] = Reach::Ground;
        }
    }
    Ok(())
}
