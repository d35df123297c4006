//! Model compilation: the scene becomes a read-only [`Model`] (topology, joint frames,
//! constants) and a [`Data`] (state, work buffers, counters) sized once.
//!
//! The joints form a spanning tree rooted at the ground: the first joint that names a body as
//! its child is that body's tree joint; a later joint with the same child closes a loop and
//! becomes a [`LoopConstraint`]. A body that is no joint's child gets a free joint to the
//! ground. Degrees of freedom are numbered tree by tree (depth first), so the joint-space mass
//! matrix is block diagonal with one dense block per independent tree.

use crate::contact::{self, ContactElement, ContactMemory};
use crate::scene::{InputType, JointSpec, JointType, Scene, SceneError, GROUND};
use crate::spatial::{Inertia, Spatial};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// A rigid body.
#[derive(Debug, Clone)]
pub struct Body {
    /// Name.
    pub name: String,
    /// Mass [kg].
    pub mass: f64,
    /// Principal moments of inertia [kg m^2].
    pub inertia: Vector3<f64>,
    /// Index of its tree joint.
    pub joint: usize,
}

/// A joint of the spanning tree (the child's path to ground).
#[derive(Debug, Clone)]
pub struct TreeJoint {
    /// Name (the scene's, or `<body>.free` for an implicit free joint).
    pub name: String,
    /// Type.
    pub kind: JointType,
    /// Index in the scene's joint list (None for an implicit free joint).
    pub scene_index: Option<usize>,
    /// Parent body (None = ground).
    pub parent: Option<usize>,
    /// Child body.
    pub child: usize,
    /// First position coordinate.
    pub qpos: usize,
    /// First velocity coordinate.
    pub qvel: usize,
    /// Joint axis in the parent frame (revolute, prismatic).
    pub axis: Vector3<f64>,
    /// Joint point relative to the parent's centre of mass, parent frame (world for ground).
    pub anchor: Vector3<f64>,
    /// Kind-dependent offset to the child's centre of mass (see `dynamics::kinematics`).
    pub offset: Vector3<f64>,
    /// Constant rotation of the child relative to the joint frame.
    pub rot0: UnitQuaternion<f64>,
    /// Initial position coordinates.
    pub q0: [f64; 7],
    /// Index of the tree (independent block of the mass matrix).
    pub tree: usize,
}

impl TreeJoint {
    /// Number of position coordinates.
    pub fn nq(&self) -> usize {
        nq_of(self.kind)
    }
    /// Number of velocity coordinates (degrees of freedom).
    pub fn nv(&self) -> usize {
        nv_of(self.kind)
    }
}

/// Position coordinates of a joint type.
pub fn nq_of(k: JointType) -> usize {
    match k {
        JointType::Revolute | JointType::Prismatic => 1,
        JointType::Spherical => 4,
        JointType::Fixed => 0,
        JointType::Free => 7,
    }
}

/// Degrees of freedom of a joint type.
pub fn nv_of(k: JointType) -> usize {
    match k {
        JointType::Revolute | JointType::Prismatic => 1,
        JointType::Spherical => 3,
        JointType::Fixed => 0,
        JointType::Free => 6,
    }
}

/// A loop-closing joint, enforced as constraints Φ(q) = 0 with Lagrange multipliers (27)-(30).
#[derive(Debug, Clone)]
pub struct LoopConstraint {
    /// Name.
    pub name: String,
    /// Type.
    pub kind: JointType,
    /// First body (None = ground).
    pub body_a: Option<usize>,
    /// Second body.
    pub body_b: usize,
    /// Joint point in each body's frame (world for ground).
    pub anchor_a: Vector3<f64>,
    /// Joint point in body b's frame.
    pub anchor_b: Vector3<f64>,
    /// An orthonormal triad fixed in a (columns: axis, u1, u2), body frame.
    pub triad_a: Matrix3<f64>,
    /// The same triad at the initial configuration, fixed in b.
    pub triad_b: Matrix3<f64>,
    /// First row in the constraint vector.
    pub row: usize,
}

impl LoopConstraint {
    /// Number of constraint equations.
    pub fn rows(&self) -> usize {
        match self.kind {
            JointType::Revolute => 5,
            JointType::Prismatic => 5,
            JointType::Spherical => 3,
            JointType::Fixed => 6,
            JointType::Free => 0,
        }
    }
}

/// A spring-damper between two body points.
#[derive(Debug, Clone)]
pub struct SpringDamper {
    /// Name.
    pub name: String,
    /// Body a (None = ground).
    pub body_a: Option<usize>,
    /// Attachment in a's frame (world for ground).
    pub point_a: Vector3<f64>,
    /// Body b.
    pub body_b: Option<usize>,
    /// Attachment in b's frame.
    pub point_b: Vector3<f64>,
    /// Stiffness [N/m].
    pub stiffness: f64,
    /// Damping [N s/m].
    pub damping: f64,
    /// Free length [m].
    pub free_length: f64,
}

/// An input channel.
#[derive(Debug, Clone)]
pub enum Input {
    /// Force along a world direction at a body's centre of mass.
    Force {
        /// Body.
        body: usize,
        /// Unit direction.
        direction: Vector3<f64>,
    },
    /// Torque about a world direction.
    Torque {
        /// Body.
        body: usize,
        /// Unit direction.
        direction: Vector3<f64>,
    },
    /// Generalised force on a 1-DOF tree joint's coordinate, or on a loop joint (ignored).
    JointForce {
        /// Velocity index.
        qvel: usize,
    },
}

/// The compiled, read-only model.
#[derive(Debug, Clone)]
pub struct Model {
    /// Name.
    pub name: String,
    /// Gravity [m/s^2].
    pub gravity: Vector3<f64>,
    /// Bodies, in scene order.
    pub bodies: Vec<Body>,
    /// Tree joints, in processing order (parents before children).
    pub joints: Vec<TreeJoint>,
    /// For each scene joint: Ok(tree joint index) or Err(loop index).
    pub scene_joint: Vec<Result<usize, usize>>,
    /// Loop-closing constraints.
    pub loops: Vec<LoopConstraint>,
    /// Total constraint rows: the loops' rows, then one row per impulse-law contact (its
    /// resting mode; zero while the contact does not rest).
    pub nc: usize,
    /// Spring-dampers.
    pub springs: Vec<SpringDamper>,
    /// Contact elements.
    pub contacts: Vec<ContactElement>,
    /// Inputs, in scene order.
    pub inputs: Vec<Input>,
    /// Input start values.
    pub input_start: Vec<f64>,
    /// Number of position coordinates.
    pub nq: usize,
    /// Number of degrees of freedom.
    pub nv: usize,
    /// For each tree: first velocity index and size (a dense block of the mass matrix).
    pub trees: Vec<(usize, usize)>,
    /// Offset of each tree's block in the packed mass-matrix storage.
    pub tree_block: Vec<usize>,
    /// For each velocity index, the tree joint it belongs to.
    pub dof_joint: Vec<usize>,
    /// For each velocity index, the previous one on its path to the ground, local to its
    /// tree's block ([`crate::linalg::NO_PARENT`] at a tree's root): the sparsity of M̄.
    pub dof_parent: Vec<usize>,
    /// Initial velocity coordinates.
    pub qvel0: Vec<f64>,
    /// Solver settings.
    pub solver: crate::scene::SolverSection,
    /// Baumgarte stabilisation frequency for loop constraints [1/s].
    pub baumgarte: f64,
    /// Warnings produced during compilation (inconsistent initial velocities, ...).
    pub warnings: Vec<String>,
}

impl Model {
    /// Size of the state vector: positions, velocities, dissipated energy.
    pub fn nstate(&self) -> usize {
        self.nq + self.nv + 1
    }
    /// Index of the dissipated-energy state.
    pub fn dissipated_index(&self) -> usize {
        self.nq + self.nv
    }
    /// Body index by name (None for ground).
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }
}

/// Mutable simulation data: the state, contact memory, work buffers and counters. Sized at
/// compilation; nothing here is allocated during a step.
#[derive(Debug, Clone)]
pub struct Data {
    /// Time [s].
    pub time: f64,
    /// State: `[qpos (nq), qvel (nv), dissipated energy]`.
    pub state: Vec<f64>,
    /// Input values.
    pub inputs: Vec<f64>,
    /// Contact memory (part of the state): active flags, δ̇⁻, impact counts.
    pub contact_memory: Vec<ContactMemory>,
    // --- kinematics (per body, scene order) ---
    /// Centre-of-mass positions [m].
    pub body_pos: Vec<Vector3<f64>>,
    /// Rotation matrices body → world.
    pub body_rot: Vec<Matrix3<f64>>,
    /// Orientation quaternions.
    pub body_quat: Vec<UnitQuaternion<f64>>,
    /// Spatial velocities.
    pub body_vel: Vec<Spatial>,
    /// Spatial accelerations with q̈ = 0 (velocity-product terms).
    pub body_acc_bias: Vec<Spatial>,
    /// Spatial inertia about the origin.
    pub body_inertia: Vec<Inertia>,
    /// External forces on each body (gravity, springs, contacts, inputs).
    pub body_force: Vec<Spatial>,
    /// Motion subspace column of each degree of freedom.
    pub dof_s: Vec<Spatial>,
    /// Its time derivative.
    pub dof_sdot: Vec<Spatial>,
    // --- dynamics ---
    /// Composite inertias (work).
    pub composite: Vec<Inertia>,
    /// Back-propagated forces (work).
    pub body_wrench: Vec<Spatial>,
    /// Packed mass-matrix blocks; factorised in place.
    pub mass_blocks: Vec<f64>,
    /// Generalised forces minus bias: right-hand side, then q̈.
    pub qacc: Vec<f64>,
    /// Generalised applied forces (joint inputs).
    pub tau: Vec<f64>,
    /// Constraint values Φ.
    pub phi: Vec<f64>,
    /// Constraint rates Φ_q q̇.
    pub phi_dot: Vec<f64>,
    /// Constraint Jacobian, row-major nc × nv.
    pub phi_q: Vec<f64>,
    /// γ (with stabilisation).
    pub gamma: Vec<f64>,
    /// M̄⁻¹ Φ_qᵀ, column-major nv × nc (work).
    pub minv_phit: Vec<f64>,
    /// Φ_q M̄⁻¹ Φ_qᵀ (work), nc × nc.
    pub schur: Vec<f64>,
    /// Pivot order of the Schur factorisation.
    pub schur_perm: Vec<usize>,
    /// Rank of the Schur complement (independent constraint rows).
    pub schur_rank: usize,
    /// Lagrange multipliers.
    pub lambda: Vec<f64>,
    /// Work vector of size max(nv, nc).
    pub work: Vec<f64>,
    /// Work vector of size nv.
    pub work2: Vec<f64>,
    /// Dissipated power at the last RHS evaluation [W].
    pub dissipation: f64,
    /// Per-contact outputs of the last evaluation.
    pub contact_out: Vec<contact::ContactOutput>,
    /// Work: tree joints on one body's path to the ground (capacity: all joints), for
    /// [`crate::dynamics::kinematics_path`].
    pub path_joints: Vec<usize>,
    /// Counters.
    pub counters: Counters,
}

/// Work counters since initialisation.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Accepted steps.
    pub steps: u64,
    /// Rejected steps.
    pub rejected: u64,
    /// Right-hand-side evaluations.
    pub rhs_evals: u64,
    /// Jacobian evaluations (implicit methods).
    pub jac_evals: u64,
    /// Events located (touch, separation).
    pub events: u64,
}

fn to_v(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

fn quat_of(a: [f64; 4]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(a[0], a[1], a[2], a[3]))
}

/// An orthonormal triad whose first column is `axis`.
pub fn triad(axis: &Vector3<f64>) -> Matrix3<f64> {
    let a = axis.normalize();
    let t = if a.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
    let u1 = a.cross(&t).normalize();
    let u2 = a.cross(&u1);
    Matrix3::from_columns(&[a, u1, u2])
}

/// Compiles a validated scene into a model and its data at the initial configuration.
pub fn compile(scene: &Scene, origin: &str) -> Result<(Model, Data), SceneError> {
    let nb = scene.body.len();
    let body_idx = |name: &str| -> Option<usize> { scene.body.iter().position(|b| b.name == name) };
    let pos0: Vec<Vector3<f64>> = scene.body.iter().map(|b| to_v(b.position)).collect();
    let rot0: Vec<UnitQuaternion<f64>> = scene.body.iter().map(|b| quat_of(b.orientation)).collect();

    // Spanning tree: first joint naming a child wins; later ones close loops.
    let mut parent_joint: Vec<Option<usize>> = vec![None; nb];
    let mut loop_joints = Vec::new();
    for (ji, j) in scene.joint.iter().enumerate() {
        let c = body_idx(&j.child)
            .ok_or_else(|| SceneError::new(origin, format!("joint {:?}", j.name), "child", "unknown body"))?;
        if parent_joint[c].is_none() {
            parent_joint[c] = Some(ji);
        } else {
            loop_joints.push(ji);
        }
    }
    // Every body must reach the ground.
    for b in 0..nb {
        let mut cur = b;
        let mut seen = 0;
        while let Some(ji) = parent_joint[cur] {
            let p = &scene.joint[ji].parent;
            if p == GROUND {
                break;
            }
            cur = body_idx(p).unwrap_or(cur);
            seen += 1;
            if seen > nb {
                return Err(SceneError::new(
                    origin,
                    format!("body {:?}", scene.body[b].name),
                    "joint",
                    format!(
                        "joint cycle through joint {:?}: this body has no path to ground",
                        scene.joint[ji].name
                    ),
                ));
            }
        }
    }
    // Depth-first order from the ground; each root child starts a tree.
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); nb + 1]; // index nb = ground
    for (b, pj) in parent_joint.iter().enumerate() {
        let p = match pj {
            Some(ji) => body_idx(&scene.joint[*ji].parent).unwrap_or(nb),
            None => nb,
        };
        children[p].push(b);
    }
    let mut order = Vec::with_capacity(nb);
    let mut tree_of = vec![0usize; nb];
    for (t, &root) in children[nb].iter().enumerate() {
        let mut stack = vec![root];
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
        .map(|b| Body {
            name: b.name.clone(),
            mass: b.mass,
            inertia: to_v(b.inertia),
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
    let mut dof_joint = vec![0; nv];
    for (ji, j) in joints.iter().enumerate() {
        for k in 0..j.nv() {
            dof_joint[j.qvel + k] = ji;
        }
    }
    let mut dof_parent = vec![crate::linalg::NO_PARENT; nv];
    for j in &joints {
        let t0 = trees[j.tree].0;
        // the last dof of the nearest ancestor joint that has any
        let mut up = crate::linalg::NO_PARENT;
        let mut cur = j.parent;
        while let Some(p) = cur {
            let pj = &joints[bodies[p].joint];
            if pj.nv() > 0 {
                up = pj.qvel + pj.nv() - 1 - t0;
                break;
            }
            cur = pj.parent;
        }
        for k in 0..j.nv() {
            dof_parent[j.qvel + k] = if k == 0 { up } else { j.qvel + k - 1 - t0 };
        }
    }
    let mut tree_block = Vec::with_capacity(ntrees);
    let mut off = 0;
    for &(_, n) in &trees {
        tree_block.push(off);
        off += n * n;
    }
    let mass_len = off;

    // Loop constraints.
    let mut loops = Vec::new();
    let mut nc = 0;
    for (li, &ji) in loop_joints.iter().enumerate() {
        let j = &scene.joint[ji];
        let item = format!("joint {:?}", j.name);
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
    let local_point = |b: Option<usize>, p: Vector3<f64>| -> Vector3<f64> {
        let (r, q) = pose(b);
        q.inverse() * (p - r)
    };
    let springs = scene
        .spring_damper
        .iter()
        .map(|s| {
            let (a, b) = (to_body(&s.body_a), to_body(&s.body_b));
            SpringDamper {
                name: s.name.clone(),
                body_a: a,
                point_a: local_point(a, to_v(s.point_a)),
                body_b: b,
                point_b: local_point(b, to_v(s.point_b)),
                stiffness: s.stiffness,
                damping: s.damping,
                free_length: s
                    .free_length
                    .unwrap_or_else(|| (to_v(s.point_b) - to_v(s.point_a)).norm()),
            }
        })
        .collect();

    let mut contacts = Vec::with_capacity(scene.contact.len());
    for c in &scene.contact {
        contacts.push(contact::compile_contact(
            scene,
            c,
            origin,
            &|n| to_body(n),
            &|b, p| local_point(b, p),
            &|b, v| {
                let (_, q) = pose(b);
                q.inverse() * v
            },
        )?);
    }
    // One constraint row per impulse-law contact after the loop rows (its resting mode).
    nc = contact::reserve_constraint_rows(&mut contacts, nc);

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
            InputType::JointForce => {
                let ji = scene
                    .joint
                    .iter()
                    .position(|j| Some(&j.name) == i.joint.as_ref())
                    .unwrap_or(0);
                match scene_joint[ji] {
                    Ok(t) => Input::JointForce { qvel: joints[t].qvel },
                    Err(_) => Input::JointForce { qvel: usize::MAX },
                }
            }
        })
        .collect();

    let mut model = Model {
        name: scene.model.name.clone(),
        gravity: to_v(scene.model.gravity),
        bodies,
        joints,
        scene_joint,
        loops,
        nc,
        springs,
        contacts,
        inputs,
        input_start: scene.input.iter().map(|i| i.start).collect(),
        nq,
        nv,
        trees,
        tree_block,
        dof_joint,
        dof_parent,
        qvel0: vec![0.0; nv],
        solver: scene.solver.clone(),
        baumgarte: 20.0,
        warnings: Vec::new(),
    };
    for (i, inp) in scene.input.iter().enumerate() {
        if let (InputType::JointForce, Input::JointForce { qvel: usize::MAX }) = (inp.kind, &model.inputs[i]) {
            return Err(SceneError::new(
                origin,
                format!("input {:?}", inp.name),
                "joint",
                "the joint closes a loop; a joint force needs a tree joint",
            ));
        }
    }
    let mut data = Data::new(&model, mass_len);
    crate::dynamics::initial_velocities(&mut model, &mut data, scene);
    Ok((model, data))
}

impl Data {
    /// Allocates every buffer for `model` and sets the initial positions.
    pub fn new(model: &Model, mass_len: usize) -> Data {
        let nb = model.bodies.len();
        let (nv, nc) = (model.nv, model.nc);
        let mut state = vec![0.0; model.nstate()];
        for j in &model.joints {
            state[j.qpos..j.qpos + j.nq()].copy_from_slice(&j.q0[..j.nq()]);
        }
        Data {
            time: 0.0,
            state,
            inputs: model.input_start.clone(),
            contact_memory: vec![ContactMemory::default(); model.contacts.len()],
            body_pos: vec![Vector3::zeros(); nb],
            body_rot: vec![Matrix3::identity(); nb],
            body_quat: vec![UnitQuaternion::identity(); nb],
            body_vel: vec![Spatial::zero(); nb],
            body_acc_bias: vec![Spatial::zero(); nb],
            body_inertia: vec![Inertia::zero(); nb],
            body_force: vec![Spatial::zero(); nb],
            dof_s: vec![Spatial::zero(); nv],
            dof_sdot: vec![Spatial::zero(); nv],
            composite: vec![Inertia::zero(); nb],
            body_wrench: vec![Spatial::zero(); nb],
            mass_blocks: vec![0.0; mass_len],
            qacc: vec![0.0; nv],
            tau: vec![0.0; nv],
            phi: vec![0.0; nc],
            phi_dot: vec![0.0; nc],
            phi_q: vec![0.0; nc * nv],
            gamma: vec![0.0; nc],
            minv_phit: vec![0.0; nc * nv],
            schur: vec![0.0; nc * nc],
            schur_perm: vec![0; nc],
            schur_rank: 0,
            lambda: vec![0.0; nc],
            work: vec![0.0; nv.max(nc)],
            work2: vec![0.0; nv],
            dissipation: 0.0,
            contact_out: vec![contact::ContactOutput::default(); model.contacts.len()],
            path_joints: Vec::with_capacity(model.joints.len()),
            counters: Counters::default(),
        }
    }
}
