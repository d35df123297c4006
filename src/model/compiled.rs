//! The compiled, read-only [`Model`]: topology, joint frames, constants, contact elements.
//! Made once by [`crate::compile`] from a scene and its parameter values.
//!
//! The joints form a spanning tree rooted at the ground: the first joint that names a body as
//! its child is that body's tree joint; a later joint with the same child closes a loop and
//! becomes a [`LoopConstraint`]. A body that is no joint's child gets a free joint to the
//! ground. Degrees of freedom are numbered tree by tree (depth first), so the joint-space mass
//! matrix is block diagonal with one dense block per independent tree.

use crate::integrator::second_order::{Block, SecondOrder};
use crate::linalg::{ConstantLeaves, LeafRow};
use crate::model::contact::ContactElement;
use crate::model::groups::Groups;
use crate::scene::JointType;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// A rigid body.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    /// Name.
    pub name: String,
    /// Mass \[kg\].
    pub mass: f64,
    /// Principal moments of inertia \[kg m^2\].
    pub inertia: Vector3<f64>,
    /// Index of its tree joint.
    pub joint: usize,
}

/// A joint of the spanning tree (the child's path to ground).
#[derive(Debug, Clone, PartialEq)]
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
    /// First position coordinate of its unit quaternion (spherical and free joints).
    pub fn quaternion(&self) -> Option<usize> {
        match self.kind {
            JointType::Spherical => Some(self.qpos),
            JointType::Free => Some(self.qpos + 3),
            _ => None,
        }
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

/// [`Model::quaternions`] of `joints`: the first position coordinate of each joint
/// quaternion, in joint order.
pub fn quaternion_coordinates(joints: &[TreeJoint]) -> Vec<usize> {
    joints.iter().filter_map(|j| j.quaternion()).collect()
}

/// Per contact, `rtol` to its [`ContactElement::touch_power`] and
/// [`ContactElement::separation_power`] (the step after a touch and the floor of the steps
/// toward a separation, taken at every step in contact: computed once per contact list), into
/// `out` (its buffer kept).
pub fn step_rtol_powers(contacts: &[ContactElement], rtol: f64, out: &mut Vec<[f64; 2]>) {
    // (the powers depend on the law and its exponent alone, which the contacts of one pair of
    // groups share: a power already taken is reused, the same number)
    let mut taken = [([f64::NAN; 2], [0.0; 2]); 4];
    let mut next = 0;
    out.clear();
    out.extend(contacts.iter().map(|c| {
        let p = [c.touch_power(), c.separation_power()];
        match taken.iter().find(|(q, _)| *q == p) {
            Some(&(_, v)) => v,
            None => {
                let v = p.map(|p| crate::math::powf(rtol, p));
                taken[next] = (p, v);
                next = (next + 1) % taken.len();
                v
            }
        }
    }));
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
    /// Stiffness \[N/m\].
    pub stiffness: f64,
    /// Damping \[N s/m\].
    pub damping: f64,
    /// Free length \[m\].
    pub free_length: f64,
}

/// A driven 1-DOF tree joint (an input of type `joint_motion`): its coordinate follows the
/// host's `q + qd τ + qdd τ²/2` through one constraint row `q̈_k = qdd` after the loops' rows,
/// whose multiplier gives the drive force, and the host's `q`, `qd` written into the state
/// when it sets them.
#[derive(Debug, Clone)]
pub struct Drive {
    /// Position index of the driven coordinate.
    pub qpos: usize,
    /// Velocity index of the driven coordinate.
    pub qvel: usize,
    /// Its constraint row.
    pub row: usize,
    /// Index of its first input value (`q`; then `qd`, `qdd`) in `Data::inputs`.
    pub value: usize,
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
    /// Generalised force on the coordinates of 1-DOF tree joints (the same on each).
    JointForce {
        /// Velocity indices.
        qvels: Vec<usize>,
    },
    /// Prescribed motion of a 1-DOF tree joint (three input values; the joint and its
    /// constraint row are in [`Model::drives`]).
    JointMotion,
}

/// A free body on the lean path: a free joint to the ground with no child body and no loop
/// joint attached. Its velocity coordinates are the centre-of-mass velocity (world frame) and
/// the angular velocity (body frame), so its block of M̄ is the constant
/// `diag(m, m, m, I₁, I₂, I₃)` and its accelerations are Newton-Euler's, body by body:
/// `m a = f`, `I ω̇ + ω × I ω = τ` (see [`crate::forward`]).
#[derive(Debug, Clone, PartialEq)]
pub struct FreeBody {
    /// The body.
    pub body: usize,
    /// First position coordinate (centre of mass, then the quaternion).
    pub qpos: usize,
    /// First velocity coordinate.
    pub qvel: usize,
    /// 1 / mass \[1/kg\].
    pub inv_mass: f64,
    /// Principal moments of inertia \[kg m^2\].
    pub inertia: Vector3<f64>,
    /// Their reciprocals \[1/(kg m^2)\].
    pub inv_inertia: Vector3<f64>,
}

/// Tree joints, bodies and trees that one pass of the general path (kinematics, CRBA,
/// tree-sparse `LᵀDL`) covers, in processing order (parents before children).
#[derive(Debug, Clone, Default)]
pub struct Part {
    /// Tree joints.
    pub joints: Vec<usize>,
    /// Bodies.
    pub bodies: Vec<usize>,
    /// Trees (blocks of M̄).
    pub trees: Vec<usize>,
}

/// How the right-hand side is evaluated, decided at compilation: the free bodies take the
/// lean path, everything else the general one.
#[derive(Debug, Clone, Default)]
pub struct Plan {
    /// What the lean right-hand side leaves to the general path (everything but `free`).
    pub general: Part,
    /// Free bodies (Newton-Euler, no mass matrix).
    pub free: Vec<FreeBody>,
    /// Per body, its index in `free` ([`NOT_FREE`] for a body on the general path).
    pub free_of: Vec<usize>,
    /// Per tree joint, the rotor it turns, if it is one ([`Rotor`]).
    pub rotors: Vec<Option<Rotor>>,
    /// Per tree, the rotors whose rows of M̄ are constant ([`constant_rotor_row`]), as leaves of
    /// its block: the assembly of M̄ and its factorisation skip them, and their rows of the
    /// factor are written once ([`crate::model::Data::new`]).
    pub leaves: Vec<ConstantLeaves>,
    /// Per tree joint, whether its row of M̄ is one of those constant leaves.
    pub constant_row: Vec<bool>,
}

/// A revolute joint whose child body spins about the joint axis without anything in the
/// right-hand side depending on the angle: the child has no children, is in no loop and is
/// attached to no spring, carries no shape of another contact's body, only spheres centred on
/// the axis, has its centre of mass on the axis and an inertia symmetric about it (a wheel, a
/// flywheel, a rotor). Its pose, spatial inertia and motion subspace are then those of the
/// joint frame, whatever the angle: the right-hand side skips the rotation by the angle (its
/// sine and cosine, two quaternion products, the rotated inertia) and takes the world inertia
/// as `I_t 1 + (I_a − I_t) h hᵀ` from the axis `h`. Decided at compilation
/// ([`Plan::of`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rotor {
    /// Moment of inertia about the axis and about any axis across it, at the centre of mass.
    pub axial: f64,
    pub transverse: f64,
    /// The child's constant rotation relative to the joint frame, as a matrix.
    pub rot0: Matrix3<f64>,
}

impl Rotor {
    /// The rotor of tree joint `j`, if it is one (see [`Rotor`]).
    fn of(
        j: &TreeJoint,
        b: &Body,
        is_attached: bool,
        contacts: &[ContactElement],
        groups: &Groups,
        child: usize,
    ) -> Option<Rotor> {
        if j.kind != JointType::Revolute || is_attached {
            return None;
        }
        let axis = j.axis.try_normalize(1e-300)?;
        let on_axis = |v: &Vector3<f64>, a: &Vector3<f64>| v.cross(a).norm() <= 1e-12 * v.norm().max(1e-9);
        // the axis in the body frame: R0ᵀ a (the spin about the axis leaves it)
        let a_body = j.rot0.inverse() * axis;
        if !on_axis(&j.offset, &axis) {
            return None;
        }
        for c in contacts {
            if c.body == Some(child) || (c.sphere_body == Some(child) && !on_axis(&c.center, &a_body)) {
                return None;
            }
        }
        // the contact groups' shapes on it, whatever pairs the broad phase will list: none may
        // be the other shape of a pair, and its spheres must be centred on the axis
        let ng = groups.ngroups;
        for (s, shape) in groups.shapes.iter().enumerate() {
            if shape.body != Some(child) {
                continue;
            }
            let g = shape.group;
            let touched = (0..ng).any(|a| groups.touch[a * ng + g].is_some());
            let touching = (0..ng).any(|o| groups.touch[g * ng + o].is_some());
            if touched || (touching && !on_axis(&groups.sphere_sides[s].center, &a_body)) {
                return None;
            }
        }
        let inertia = Matrix3::from_diagonal(&b.inertia);
        let axial = a_body.dot(&(inertia * a_body));
        let transverse = 0.5 * (inertia.trace() - axial);
        let symmetric =
            Matrix3::from_diagonal_element(transverse) + (a_body * (axial - transverse)) * a_body.transpose();
        if (inertia - symmetric).abs().max() > 1e-12 * inertia.abs().max() {
            return None;
        }
        Some(Rotor {
            axial,
            transverse,
            rot0: *j.rot0.to_rotation_matrix().matrix(),
        })
    }
}

/// Largest `|a × b|` of unit axes `a`, `b` taken as parallel by [`constant_rotor_row`]: the
/// rounding of the frames' rotations (a varying entry would vary by this fraction at most).
pub const PARALLEL_AXES: f64 = 64.0 * f64::EPSILON;

/// The row of M̄ of rotor joint `ji` ([`Rotor`]), when it is constant: per unit spin the
/// rotor's momentum is `(I_a h, 0)` (no linear momentum: its centre of mass is on the axis `h`;
/// its angular momentum about it is `I_a h`: `h` is a principal axis), so its row is `I_a` on the
/// diagonal and `I_a (ω_k · h)` at each ancestor dof k whose motion subspace has the angular
/// part `ω_k` (none for prismatic joints and a free joint's translations). `ω_k` is fixed in
/// the frame of joint k's child, `h` in the rotor's parent's; the product is constant when no
/// joint between the two turns `h` (prismatic and fixed ones, and revolute ones about an axis
/// parallel to it). Returns the pivot `I_a` and
/// the nonzero `ω_k · h` (the row over the pivot: the rotor's row of the `LᵀDL` factor) by
/// velocity index; None when an entry varies or `I_a` is not positive.
pub fn constant_rotor_row(
    joints: &[TreeJoint],
    bodies: &[Body],
    ji: usize,
    rotor: &Rotor,
) -> Option<(f64, Vec<(usize, f64)>)> {
    if rotor.axial.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let mut row = Vec::new();
    // the axis in the frame of the current body, from the rotor's parent up
    let mut h = joints[ji].axis;
    let mut rotated = false;
    let mut cur = joints[ji].parent;
    while let Some(c) = cur {
        let j = &joints[bodies[c].joint];
        // the angular parts of the joint's dofs in the child's frame
        let (axes, axis) = ([Vector3::x(), Vector3::y(), Vector3::z()], [j.rot0.inverse() * j.axis]);
        let (first, angular) = match j.kind {
            JointType::Prismatic | JointType::Fixed => (j.qvel, &axes[..0]),
            JointType::Revolute => (j.qvel, &axis[..]),
            JointType::Spherical => (j.qvel, &axes[..]),
            JointType::Free => (j.qvel + 3, &axes[..]),
        };
        if rotated && !angular.is_empty() {
            return None;
        }
        for (k, w) in angular.iter().enumerate() {
            let c = w.dot(&h);
            if c != 0.0 {
                row.push((first + k, c));
            }
        }
        // the axis in the parent's frame: the child's frame is the parent's turned by the
        // constant rot0, and a revolute joint's also by its angle, which leaves an axis
        // parallel to its own as it is
        let turned = j.rot0 * h;
        match j.kind {
            JointType::Prismatic | JointType::Fixed => h = turned,
            JointType::Revolute if turned.cross(&j.axis).norm() <= PARALLEL_AXES => h = turned,
            _ => rotated = true,
        }
        cur = j.parent;
    }
    Some((rotor.axial, row))
}

/// [`Plan::free_of`] of a body on the general path.
pub const NOT_FREE: usize = usize::MAX;

impl Plan {
    /// The free body `b` is, if it is one.
    #[inline]
    pub fn free_body(&self, b: usize) -> Option<&FreeBody> {
        self.free.get(*self.free_of.get(b)?)
    }
}

impl Plan {
    /// The plan of a model: every tree that is one free body with nothing attached by a loop
    /// goes to `free`.
    pub fn of(
        bodies: &[Body],
        joints: &[TreeJoint],
        loops: &[LoopConstraint],
        springs: &[SpringDamper],
        contacts: &[ContactElement],
        groups: &Groups,
        trees: &[(usize, usize)],
    ) -> Plan {
        let ntrees = trees.len();
        let mut tree_joints = vec![0usize; ntrees];
        for j in joints {
            tree_joints[j.tree] += 1;
        }
        let mut in_loop = vec![false; bodies.len()];
        for l in loops {
            if let Some(a) = l.body_a {
                in_loop[a] = true;
            }
            in_loop[l.body_b] = true;
        }
        // (A body without positive mass and inertia stays on the general path, whose
        // factorisation reports the singular mass matrix.)
        let is_free = |j: &TreeJoint| {
            let b = &bodies[j.child];
            j.kind == JointType::Free
                && j.parent.is_none()
                && tree_joints[j.tree] == 1
                && !in_loop[j.child]
                && b.mass > 0.0
                && b.inertia.iter().all(|&x| x > 0.0)
        };
        let mut plan = Plan {
            free_of: vec![NOT_FREE; bodies.len()],
            ..Plan::default()
        };
        let mut general_tree = vec![false; ntrees];
        for (ji, j) in joints.iter().enumerate() {
            if is_free(j) {
                let b = &bodies[j.child];
                plan.free_of[j.child] = plan.free.len();
                plan.free.push(FreeBody {
                    body: j.child,
                    qpos: j.qpos,
                    qvel: j.qvel,
                    inv_mass: 1.0 / b.mass,
                    inertia: b.inertia,
                    inv_inertia: b.inertia.map(|x| 1.0 / x),
                });
            } else {
                plan.general.joints.push(ji);
                plan.general.bodies.push(j.child);
                general_tree[j.tree] = true;
            }
        }
        plan.general.bodies.sort_unstable();
        plan.general.trees = (0..ntrees).filter(|&t| general_tree[t]).collect();
        // rotors: bodies that nothing but their joint, centred spheres and forces hold
        let mut attached = in_loop;
        for j in joints {
            if let Some(p) = j.parent {
                attached[p] = true;
            }
        }
        for s in springs {
            for b in [s.body_a, s.body_b].into_iter().flatten() {
                attached[b] = true;
            }
        }
        plan.rotors = joints
            .iter()
            .map(|j| Rotor::of(j, &bodies[j.child], attached[j.child], contacts, groups, j.child))
            .collect();
        // the rotors' constant rows of M̄, by tree (velocity indices local to its block)
        let mut leaves: Vec<Vec<LeafRow>> = vec![Vec::new(); ntrees];
        plan.constant_row = vec![false; joints.len()];
        for (ji, j) in joints.iter().enumerate() {
            let Some(rotor) = &plan.rotors[ji] else { continue };
            if let Some((pivot, row)) = constant_rotor_row(joints, bodies, ji, rotor) {
                let t0 = trees[j.tree].0;
                let row = row.into_iter().map(|(k, c)| (k - t0, c)).collect();
                leaves[j.tree].push((j.qvel - t0, pivot, row));
                plan.constant_row[ji] = true;
            }
        }
        plan.leaves = leaves
            .iter()
            .zip(trees)
            .map(|(l, &(_, n))| ConstantLeaves::new(n, l))
            .collect();
        plan
    }
}

/// The compiled, read-only model.
#[derive(Debug, Clone, Default)]
pub struct Model {
    /// Name.
    pub name: String,
    /// Gravity \[m/s^2\].
    pub gravity: Vector3<f64>,
    /// Bodies, in scene order.
    pub bodies: Vec<Body>,
    /// Tree joints, in processing order (parents before children).
    pub joints: Vec<TreeJoint>,
    /// For each scene joint: Ok(tree joint index) or Err(loop index).
    pub scene_joint: Vec<Result<usize, usize>>,
    /// Loop-closing constraints.
    pub loops: Vec<LoopConstraint>,
    /// Driven joints (`joint_motion` inputs), in scene order.
    pub drives: Vec<Drive>,
    /// Spring-dampers.
    pub springs: Vec<SpringDamper>,
    /// The contact elements at the initial configuration: the declared contacts (with their
    /// constraint rows after the fixed rows), then one per initial candidate pair of the
    /// contact groups. The data's list ([`crate::model::Data::contacts`]) starts as this one;
    /// the broad phase makes it anew there.
    pub initial_contacts: Vec<ContactElement>,
    /// Contact groups: the group shapes, their compiled sides and law constants, and the
    /// initial candidate pairs (`initial_contacts[groups.n_explicit..]`).
    pub groups: crate::model::groups::Groups,
    /// Inputs, in scene order.
    pub inputs: Vec<Input>,
    /// For each input, the index of its first value in `Data::inputs` (a `joint_motion` has
    /// three values, the others one).
    pub input_value: Vec<usize>,
    /// Start values of the input values.
    pub input_start: Vec<f64>,
    /// Number of position coordinates.
    pub nq: usize,
    /// Number of degrees of freedom.
    pub nv: usize,
    /// First position coordinate of each joint quaternion ([`TreeJoint::quaternion`]), in
    /// joint order.
    pub quaternions: Vec<usize>,
    /// For each tree: first velocity index and size (a dense block of the mass matrix).
    pub trees: Vec<(usize, usize)>,
    /// Offset of each tree's block in the packed mass-matrix storage.
    pub tree_block: Vec<usize>,
    /// For each velocity index, the tree joint it belongs to.
    pub dof_joint: Vec<usize>,
    /// For each velocity index, the previous one on its path to the ground, local to its
    /// tree's block ([`crate::linalg::NO_PARENT`] at a tree's root): the sparsity of M̄.
    pub dof_parent: Vec<usize>,
    /// How the right-hand side is evaluated (the lean path of the free bodies).
    pub plan: Plan,
    /// Solver settings.
    pub solver: crate::scene::SolverSection,
    /// Baumgarte stabilisation frequency for loop constraints \[1/s\].
    pub baumgarte: f64,
    /// Warnings produced during compilation (inconsistent initial velocities, ...).
    pub warnings: Vec<String>,
}

impl Model {
    /// Writes free body `fb`'s block of M̄ into `mass_blocks`: diag(m, m, m, I₁, I₂, I₃) in
    /// its body frame, its own `LᵀDL` factor. The lean right-hand side never assembles it; a
    /// solve over every block finds a valid factor there (see `forward::evaluate_rhs`).
    pub fn write_free_block(&self, fb: &FreeBody, mass_blocks: &mut [f64]) {
        let b = &self.bodies[fb.body];
        let off = self.tree_block[self.joints[b.joint].tree];
        let block = &mut mass_blocks[off..off + 36];
        block.fill(0.0);
        let diag = [b.mass, b.mass, b.mass, b.inertia[0], b.inertia[1], b.inertia[2]];
        for (k, x) in diag.into_iter().enumerate() {
            block[7 * k] = x;
        }
    }

    /// Size of the state vector: positions, velocities, dissipated energy, and with inputs the
    /// work they did (a scene without inputs integrates no zero, so that its steps are those
    /// of a state without it).
    pub fn nstate(&self) -> usize {
        self.nq + self.nv + 1 + usize::from(!self.inputs.is_empty())
    }
    /// The state's second-order structure: each joint's positions and velocities; the
    /// integrals (dissipated energy, input work) follow them. Written into `out` (its buffer
    /// kept).
    pub fn second_order_into(&self, out: &mut SecondOrder) {
        (out.nq, out.nv) = (self.nq, self.nv);
        out.blocks.clear();
        out.blocks
            .extend(self.joints.iter().filter(|j| j.nq() > 0).map(|j| Block {
                q0: j.qpos,
                nq: j.nq(),
                v0: j.qvel,
                nv: j.nv(),
            }));
    }
    /// Index of the dissipated-energy state.
    pub fn dissipated_index(&self) -> usize {
        self.nq + self.nv
    }
    /// Index of the state of the inputs' work on the system since initialisation (none
    /// without inputs).
    pub fn input_work_index(&self) -> Option<usize> {
        (!self.inputs.is_empty()).then_some(self.nq + self.nv + 1)
    }

    /// The inputs' work on the system since initialisation, from a state vector \[J\].
    pub fn input_work(&self, state: &[f64]) -> f64 {
        self.input_work_index().map_or(0.0, |i| state[i])
    }

    /// Adds `work` to the inputs' work in a state vector (nothing without inputs).
    pub fn add_input_work(&self, state: &mut [f64], work: f64) {
        if let Some(i) = self.input_work_index() {
            state[i] += work;
        }
    }
    /// The indices of input `i`'s values in `Data::inputs`.
    pub fn input_range(&self, i: usize) -> std::ops::Range<usize> {
        let end = self.input_value.get(i + 1).copied().unwrap_or(self.input_values());
        self.input_value[i]..end
    }
    /// Number of input values (`Data::inputs`).
    pub fn input_values(&self) -> usize {
        self.input_start.len()
    }
    /// Number of the constraint rows that are always on: the loops' rows, then one row per
    /// driven joint (the rows of resting contacts follow).
    pub fn fixed_rows(&self) -> usize {
        self.loop_rows() + self.drives.len()
    }
    /// Number of the loops' constraint rows (the first of the fixed rows). A drive's row holds
    /// by construction (the driven coordinate is prescribed), so without loops there is
    /// nothing to project and no position or velocity output needs the constrained solve.
    pub fn loop_rows(&self) -> usize {
        self.loops.last().map(|l| l.row + l.rows()).unwrap_or(0)
    }
}
