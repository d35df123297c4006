//! Scene files: the user's TOML description of a multibody system (see the README and
//! `docs/scene.md`). Parsing is done by serde; [`Scene::validate`] checks what serde cannot
//! (names that refer to each other, signs, ranges) and reports the file, the item and the field.
//!
//! Units are SI. Positions, axes and velocities are in the world frame at the initial
//! configuration.

use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};
use std::path::Path;

mod groups;
pub use groups::{shape_item, BroadPhaseMethod, BroadPhaseSection, ContactGroupSpec, ShapeSpec, ShapeType};

/// An error in a scene: names the file (origin), the item and the field.
#[derive(Debug, Clone, thiserror::Error, PartialEq)]
#[error("{origin}: {item}: {field}: {message}")]
pub struct SceneError {
    /// File name (or other origin) of the scene.
    pub origin: String,
    /// The item, e.g. `body "arm"` or `[model]`.
    pub item: String,
    /// The field inside the item, e.g. `mass`.
    pub field: String,
    /// What is wrong.
    pub message: String,
}

impl SceneError {
    /// Builds an error.
    pub fn new(origin: &str, item: impl Into<String>, field: &str, message: impl Into<String>) -> Self {
        SceneError {
            origin: origin.to_string(),
            item: item.into(),
            field: field.to_string(),
            message: message.into(),
        }
    }
}

/// The whole scene file.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// `[model]`: name, gravity, default experiment.
    pub model: ModelSection,
    /// `[solver]`: integrator and tolerances.
    #[serde(default)]
    pub solver: SolverSection,
    /// `[[material]]`
    #[serde(default)]
    pub material: Vec<MaterialSpec>,
    /// `[[body]]`
    #[serde(default)]
    pub body: Vec<BodySpec>,
    /// `[[joint]]`
    #[serde(default)]
    pub joint: Vec<JointSpec>,
    /// `[[spring_damper]]`
    #[serde(default)]
    pub spring_damper: Vec<SpringDamperSpec>,
    /// `[[contact]]`
    #[serde(default)]
    pub contact: Vec<ContactSpec>,
    /// `[[input]]`
    #[serde(default)]
    pub input: Vec<InputSpec>,
    /// `[[shape]]`: contact shapes declared once per body, each in a group.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shape: Vec<ShapeSpec>,
    /// `[[contact_group]]`: which groups touch which, with the law of their contacts.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub contact_group: Vec<ContactGroupSpec>,
    /// `[broad_phase]`: how the pairs of the contact groups that can touch are found.
    #[serde(default, skip_serializing_if = "BroadPhaseSection::is_default")]
    pub broad_phase: BroadPhaseSection,
}

/// `[model]`
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ModelSection {
    /// Model name: the FMU's modelIdentifier and file name.
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Gravity vector [m/s^2].
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 3],
    /// Default experiment stop time [s].
    #[serde(default = "default_stop_time")]
    pub stop_time: f64,
    /// Default communication step [s].
    #[serde(default = "default_interval")]
    pub interval: f64,
    /// Metadata of the FMU: `version` of the model description.
    #[serde(default = "default_version")]
    pub version: String,
    /// Metadata of the FMU: `author` of the model description.
    #[serde(default = "default_author")]
    pub author: String,
    /// Metadata of the FMU: `copyright` of the model description.
    #[serde(default = "default_copyright")]
    pub copyright: String,
    /// Metadata of the FMU: `license` of the model description.
    #[serde(default = "default_license")]
    pub license: String,
}

// The metadata defaults describe what contact-fmu puts into an FMU whose scene names no
// author: the bundled scenes use them; docs/scene.md asks authors of their own scenes to set them.
fn default_version() -> String {
    "1.0".into()
}
fn default_author() -> String {
    "contact-fmu".into()
}
fn default_copyright() -> String {
    "Copyright (c) contact-fmu contributors".into()
}
fn default_license() -> String {
    "MIT".into()
}

impl ModelSection {
    /// `[model]` named `name`, every other key at its scene-file default.
    pub fn new(name: &str) -> ModelSection {
        ModelSection {
            name: name.to_string(),
            description: String::new(),
            gravity: default_gravity(),
            stop_time: default_stop_time(),
            interval: default_interval(),
            version: default_version(),
            author: default_author(),
            copyright: default_copyright(),
            license: default_license(),
        }
    }
}

fn default_gravity() -> [f64; 3] {
    [0.0, 0.0, -9.81]
}
fn default_stop_time() -> f64 {
    1.0
}
fn default_interval() -> f64 {
    1e-3
}

/// Integration methods, by their scene-file name. The numbers are the FMU enumeration values
/// of `solver.method`.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Adaptive explicit Dormand-Prince 5(4) with dense output and event location.
    Dopri5 = 1,
    /// Adaptive implicit SDIRK4 (L-stable, order 4) for stiff problems.
    Sdirk = 2,
    /// Classical fixed-step Runge-Kutta 4 (step = `max_step`), a baseline.
    Rk4 = 3,
    /// Adaptive implicit Radau IIA of order 5 (stage order 3) for stiff problems with a smooth
    /// slow solution.
    Radau5 = 4,
    /// Dormand-Prince while the problem is not stiff, Radau IIA while it is, switched by a
    /// stiffness estimate (default).
    #[default]
    Auto = 5,
}

impl Method {
    /// All methods, in enumeration order.
    pub const ALL: [Method; 5] = [Method::Dopri5, Method::Sdirk, Method::Rk4, Method::Radau5, Method::Auto];
    /// Scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            Method::Dopri5 => "dopri5",
            Method::Sdirk => "sdirk",
            Method::Rk4 => "rk4",
            Method::Radau5 => "radau5",
            Method::Auto => "auto",
        }
    }
    /// From the FMU enumeration value.
    pub fn from_index(i: i64) -> Option<Method> {
        Method::ALL.iter().copied().find(|m| *m as i64 == i)
    }
}

/// `[solver]`: every key is also an FMU parameter `solver.<key>`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SolverSection {
    /// Integration method.
    #[serde(default)]
    pub method: Method,
    /// Relative tolerance.
    #[serde(default = "default_rtol")]
    pub rtol: f64,
    /// Absolute tolerance.
    #[serde(default = "default_atol")]
    pub atol: f64,
    /// Largest internal step [s] (the fixed step of `rk4`); 0 (the default): none, the steps
    /// of the adaptive methods are bounded only by their error control and by the time to
    /// contact of the approaching contacts.
    #[serde(default)]
    pub max_step: f64,
    /// Most integrator steps one communication step (`fmi2DoStep`, one `--interval`) may
    /// take; beyond them the step stops at the last time reached and is reported (the FMU
    /// returns `fmi2Discard`), so that no call runs unbounded.
    #[serde(default = "default_max_steps")]
    pub max_steps: u64,
    /// Continue the integrator across communication points (it may step past one; the
    /// outputs there come from its dense output) instead of restarting it at each (default).
    #[serde(default = "default_continuation")]
    pub continuation: bool,
    /// Advance independent islands (bodies coupled through joints, spring-dampers, inputs
    /// or contacts that can act) each with its own integrator, meeting at the communication
    /// points (default), instead of the whole scene with one integrator (scene key only).
    #[serde(default = "default_islands")]
    pub islands: bool,
}

fn default_rtol() -> f64 {
    1e-8
}
fn default_atol() -> f64 {
    1e-10
}
fn default_continuation() -> bool {
    true
}
fn default_islands() -> bool {
    true
}
fn default_max_steps() -> u64 {
    5_000
}

impl Default for SolverSection {
    fn default() -> Self {
        SolverSection {
            method: Method::default(),
            rtol: default_rtol(),
            atol: default_atol(),
            max_step: 0.0,
            max_steps: default_max_steps(),
            continuation: default_continuation(),
            islands: default_islands(),
        }
    }
}

/// `[[material]]`
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Name, referred to by contacts.
    pub name: String,
    /// Young's modulus E [Pa].
    pub youngs_modulus: f64,
    /// Poisson's ratio ν (0 ≤ ν < 0.5).
    pub poisson_ratio: f64,
}

/// `[[body]]`
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Name; "ground" is reserved for the fixed world.
    pub name: String,
    /// Mass [kg].
    pub mass: f64,
    /// Principal moments of inertia about the centre of mass [kg m^2].
    pub inertia: [f64; 3],
    /// Centre of mass, world frame [m].
    pub position: [f64; 3],
    /// Orientation quaternion (w, x, y, z) of the principal axes.
    #[serde(default = "identity_quaternion")]
    pub orientation: [f64; 4],
    /// Centre-of-mass velocity, world frame [m/s].
    #[serde(default)]
    pub velocity: [f64; 3],
    /// Angular velocity, world frame [rad/s].
    #[serde(default)]
    pub angular_velocity: [f64; 3],
}

impl BodySpec {
    /// A body with the scene-file defaults for what is not given: principal axes along the
    /// world axes, at rest.
    pub fn new(name: &str, mass: f64, inertia: [f64; 3], position: [f64; 3]) -> BodySpec {
        BodySpec {
            name: name.to_string(),
            mass,
            inertia,
            position,
            orientation: identity_quaternion(),
            velocity: [0.0; 3],
            angular_velocity: [0.0; 3],
        }
    }
}

fn identity_quaternion() -> [f64; 4] {
    [1.0, 0.0, 0.0, 0.0]
}

/// Joint types.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum JointType {
    /// One rotation about `axis` through `anchor`.
    Revolute,
    /// One translation along `axis`.
    Prismatic,
    /// Three rotations about `anchor` (quaternion).
    Spherical,
    /// No relative motion.
    Fixed,
    /// Six degrees of freedom.
    Free,
}

/// `[[joint]]`
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct JointSpec {
    /// Name.
    pub name: String,
    /// Type.
    #[serde(rename = "type")]
    pub kind: JointType,
    /// Parent body name ("ground" for the world).
    pub parent: String,
    /// Child body name.
    pub child: String,
    /// Joint point, world frame [m]. Default: the child's centre of mass.
    #[serde(default)]
    pub anchor: Option<[f64; 3]>,
    /// Joint axis, world frame (revolute and prismatic).
    #[serde(default)]
    pub axis: Option<[f64; 3]>,
}

/// `[[spring_damper]]`
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpringDamperSpec {
    /// Name.
    pub name: String,
    /// First body.
    pub body_a: String,
    /// Attachment point on body_a, world frame [m].
    pub point_a: [f64; 3],
    /// Second body.
    pub body_b: String,
    /// Attachment point on body_b, world frame [m].
    pub point_b: [f64; 3],
    /// Stiffness [N/m].
    pub stiffness: f64,
    /// Damping [N s/m].
    #[serde(default)]
    pub damping: f64,
    /// Free length [m]; default the initial distance.
    #[serde(default)]
    pub free_length: Option<f64>,
}

/// Contact element types.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ContactType {
    /// Sphere against sphere.
    SphereSphere,
    /// Sphere against a finite rectangle.
    SpherePlane,
    /// Sphere against a cylindrical surface patch.
    SphereCylinder,
}

/// Contact laws. The numbers are the FMU enumeration values of `<contact>.law`.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Law {
    /// F = K δ + c δ̇ (20)
    KelvinVoigt = 1,
    /// F = K δ^n (21)
    Hertz = 2,
    /// Hertz with Lankarani-Nikravesh hysteresis damping (24)-(26)
    HertzLn = 3,
    /// Hunt-Crossley: F = K δ^n (1 + α δ̇), α = 3(1-e)/(2 δ̇⁻)
    HuntCrossley = 4,
    /// Flores et al. (2011): F = K δ^n [1 + 8(1-e)/(5e) δ̇/δ̇⁻]
    Flores = 5,
    /// Piecewise analysis: instantaneous impact with restitution.
    Impulse = 6,
}

impl Law {
    /// All laws, in enumeration order.
    pub const ALL: [Law; 6] = [
        Law::KelvinVoigt,
        Law::Hertz,
        Law::HertzLn,
        Law::HuntCrossley,
        Law::Flores,
        Law::Impulse,
    ];
    /// Scene-file name.
    pub fn name(self) -> &'static str {
        match self {
            Law::KelvinVoigt => "kelvin_voigt",
            Law::Hertz => "hertz",
            Law::HertzLn => "hertz_ln",
            Law::HuntCrossley => "hunt_crossley",
            Law::Flores => "flores",
            Law::Impulse => "impulse",
        }
    }
    /// From the FMU enumeration value.
    pub fn from_index(i: i64) -> Option<Law> {
        Law::ALL.iter().copied().find(|m| *m as i64 == i)
    }
}

/// Which side of a cylindrical surface the sphere is on.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// Convex: the sphere outside the cylinder (rail head, cam).
    #[default]
    Outside,
    /// Concave: the sphere inside (groove, bearing shell).
    Inside,
}

/// How the impulse law computes the normal impulse of an impact.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum ImpulseMethod {
    /// Generalised impulse-momentum balance in joint coordinates with the loops closed
    /// (docs/physics.md §3.1): Newton's law `J q̇⁺ = −e J q̇⁻` holds exactly.
    #[default]
    Exact,
    /// The paper's effective masses (17) and velocity formulas (18)-(19) (with the corrected
    /// (19)); an approximation kept for comparison.
    EffectiveMass,
}

/// `[[contact]]`
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// Name.
    pub name: String,
    /// Element type.
    #[serde(rename = "type")]
    pub kind: ContactType,
    /// Force law.
    pub law: Law,
    /// Coefficient of restitution e (0..=1).
    #[serde(default = "default_restitution")]
    pub restitution: f64,
    /// Body that carries the sphere.
    pub sphere_body: String,
    /// Sphere centre, world frame [m].
    pub center: [f64; 3],
    /// Sphere radius [m].
    pub radius: f64,
    /// Sphere material.
    #[serde(default)]
    pub sphere_material: Option<String>,
    /// Body that carries the other shape.
    pub body: String,
    /// Material of the other shape.
    #[serde(default)]
    pub material: Option<String>,
    /// sphere_sphere: centre of the other sphere, world frame [m].
    #[serde(default)]
    pub other_center: Option<[f64; 3]>,
    /// sphere_sphere: radius of the other sphere [m].
    #[serde(default)]
    pub other_radius: Option<f64>,
    /// sphere_plane: centre of the rectangle [m].
    #[serde(default)]
    pub origin: Option<[f64; 3]>,
    /// sphere_plane: outward normal.
    #[serde(default)]
    pub normal: Option<[f64; 3]>,
    /// sphere_plane: first in-plane axis.
    #[serde(default)]
    pub u_axis: Option<[f64; 3]>,
    /// sphere_plane: side lengths [lu, lv] [m].
    #[serde(default)]
    pub size: Option<[f64; 2]>,
    /// sphere_cylinder: a point on the axis (the middle of the patch's length) [m].
    #[serde(default)]
    pub axis_point: Option<[f64; 3]>,
    /// sphere_cylinder: axis direction.
    #[serde(default)]
    pub axis: Option<[f64; 3]>,
    /// sphere_cylinder: cylinder radius [m].
    #[serde(default)]
    pub cylinder_radius: Option<f64>,
    /// sphere_cylinder: length along the axis [m].
    #[serde(default)]
    pub length: Option<f64>,
    /// sphere_cylinder: angular range [min, max] from `ref_axis` [rad].
    #[serde(default)]
    pub theta_range: Option<[f64; 2]>,
    /// sphere_cylinder: direction (perpendicular to the axis) where θ = 0.
    #[serde(default)]
    pub ref_axis: Option<[f64; 3]>,
    /// sphere_cylinder: outside (convex) or inside (concave).
    #[serde(default)]
    pub side: Side,
    /// Contact stiffness K [N/m^n]; derived for the Hertz family when absent.
    #[serde(default)]
    pub stiffness: Option<f64>,
    /// Kelvin-Voigt damping c [N s/m].
    #[serde(default)]
    pub damping: Option<f64>,
    /// Exponent n (default 1.5).
    #[serde(default)]
    pub exponent: Option<f64>,
    /// Largest admissible penetration [m].
    #[serde(default)]
    pub max_penetration: Option<f64>,
    /// Floor on the remembered impact velocity δ̇⁻ [m/s]; for the impulse law, approach
    /// speeds below it end in a resting contact.
    #[serde(default)]
    pub min_impact_velocity: Option<f64>,
    /// Impulse law only: `exact` (default) or `effective_mass` (paper (17)-(19)).
    #[serde(default)]
    pub impulse_method: ImpulseMethod,
    /// Coulomb (sliding) friction coefficient μ (default 0: no friction).
    #[serde(default)]
    pub friction: Option<f64>,
    /// Static friction coefficient μ_s, the peak of the Stribeck curve (default μ).
    #[serde(default)]
    pub static_friction: Option<f64>,
    /// Stribeck velocity [m/s]: how fast μ_s decays to μ with the slip speed.
    #[serde(default)]
    pub stribeck_velocity: Option<f64>,
    /// Viscous friction coefficient σ [s/m] (friction coefficient grows by σ·|slip|).
    #[serde(default)]
    pub viscous_friction: Option<f64>,
    /// Regularisation velocity v_s [m/s] of the continuous friction law.
    #[serde(default)]
    pub stiction_velocity: Option<f64>,
}

impl ContactSpec {
    /// A contact between the sphere (`center`, `radius`) on `sphere_body` and a shape on
    /// `body`, every optional key at its scene-file default (the shape's keys unset).
    pub fn new(
        name: &str,
        kind: ContactType,
        law: Law,
        sphere_body: &str,
        center: [f64; 3],
        radius: f64,
        body: &str,
    ) -> ContactSpec {
        ContactSpec {
            name: name.to_string(),
            kind,
            law,
            restitution: default_restitution(),
            sphere_body: sphere_body.to_string(),
            center,
            radius,
            sphere_material: None,
            body: body.to_string(),
            material: None,
            other_center: None,
            other_radius: None,
            origin: None,
            normal: None,
            u_axis: None,
            size: None,
            axis_point: None,
            axis: None,
            cylinder_radius: None,
            length: None,
            theta_range: None,
            ref_axis: None,
            side: Side::default(),
            stiffness: None,
            damping: None,
            exponent: None,
            max_penetration: None,
            min_impact_velocity: None,
            impulse_method: ImpulseMethod::default(),
            friction: None,
            static_friction: None,
            stribeck_velocity: None,
            viscous_friction: None,
            stiction_velocity: None,
        }
    }
}

fn default_restitution() -> f64 {
    1.0
}

/// Input types.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum InputType {
    /// Force on a body's centre of mass along a world direction [N].
    Force,
    /// Torque on a body about a world direction [N m].
    Torque,
    /// Generalised force on a 1-DOF joint [N or N m].
    JointForce,
    /// Prescribed motion of a 1-DOF tree joint: three inputs `<name>.q`, `<name>.qd`,
    /// `<name>.qdd` (coordinate, rate and acceleration at the start of the communication step;
    /// between communication points the joint follows `q + qd τ + qdd τ²/2`) and one output
    /// `<name>.force`, the generalised force the drive exerts.
    JointMotion,
}

impl InputSpec {
    /// How many input values this input takes: three for a `joint_motion` (coordinate, rate,
    /// acceleration), one otherwise.
    pub fn values(&self) -> usize {
        match self.kind {
            InputType::JointMotion => 3,
            _ => 1,
        }
    }
}

impl Scene {
    /// The rate of a 1-DOF joint that the scene's body velocities give it at the initial
    /// configuration (rad/s about, or m/s along, its axis): the child's angular velocity
    /// relative to the parent's (revolute), or the child's centre-of-mass velocity relative to
    /// the parent's frame (prismatic), on the axis. 0 for other joints.
    pub fn joint_rate(&self, joint: &JointSpec) -> f64 {
        let v3 = |a: [f64; 3]| nalgebra::Vector3::new(a[0], a[1], a[2]);
        let motion = |name: &str| {
            self.body.iter().find(|b| b.name == name).map_or(
                (
                    nalgebra::Vector3::zeros(),
                    nalgebra::Vector3::zeros(),
                    nalgebra::Vector3::zeros(),
                ),
                |b| (v3(b.position), v3(b.velocity), v3(b.angular_velocity)),
            )
        };
        let axis = v3(joint.axis.unwrap_or([0.0, 0.0, 1.0]));
        let axis = if axis.norm() > 0.0 { axis.normalize() } else { axis };
        let (rp, vp, wp) = motion(&joint.parent);
        let (rc, vc, wc) = motion(&joint.child);
        match joint.kind {
            JointType::Revolute => (wc - wp).dot(&axis),
            JointType::Prismatic => (vc - vp - wp.cross(&(rc - rp))).dot(&axis),
            _ => 0.0,
        }
    }

    /// The start values of all inputs' values, in order: a `joint_motion`'s coordinate 0 (the
    /// scene's configuration), its joint's rate ([`Scene::joint_rate`]) and acceleration 0; the
    /// `start` of every other input.
    pub fn input_start_values(&self) -> Vec<f64> {
        let mut out = Vec::new();
        for i in &self.input {
            match i.kind {
                InputType::JointMotion => {
                    let rate = i
                        .joint
                        .as_deref()
                        .and_then(|n| self.joint.iter().find(|j| j.name == n))
                        .map_or(0.0, |j| self.joint_rate(j));
                    out.extend([0.0, rate, 0.0]);
                }
                _ => out.push(i.start),
            }
        }
        out
    }

    /// The index of each input's first value among all inputs' values (in scene order; a
    /// `joint_motion` takes three, [`InputSpec::values`]), and the number of values.
    pub fn input_values(&self) -> (Vec<usize>, usize) {
        let mut first = Vec::with_capacity(self.input.len());
        let mut n = 0;
        for i in &self.input {
            first.push(n);
            n += i.values();
        }
        (first, n)
    }
}

/// `[[input]]`
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct InputSpec {
    /// Name: the FMU input variable.
    pub name: String,
    /// Type.
    #[serde(rename = "type")]
    pub kind: InputType,
    /// Body (force, torque).
    #[serde(default)]
    pub body: Option<String>,
    /// Joint (joint_force).
    #[serde(default)]
    pub joint: Option<String>,
    /// Several joints (joint_force): the same generalised force on each (e.g. a brake torque
    /// on every wheel).
    #[serde(default)]
    pub joints: Option<Vec<String>>,
    /// World direction (force, torque).
    #[serde(default)]
    pub direction: Option<[f64; 3]>,
    /// Start value.
    #[serde(default)]
    pub start: f64,
}

/// True when positive principal moments of inertia satisfy the triangle inequality
/// (I1 + I2 ≥ I3 and its permutations, to a relative 1e-9): the moments of a physical body.
pub fn inertia_is_physical([a, b, c]: [f64; 3]) -> bool {
    let tol = 1e-9 * (a + b + c);
    a + b >= c - tol && b + c >= a - tol && a + c >= b - tol
}

/// The reserved name of the fixed world.
pub const GROUND: &str = "ground";

/// What a contact law needs of the other constants: Kelvin-Voigt a given stiffness, Flores
/// e > 0, the Hertz family a stiffness or two materials to derive it from. The error names
/// the field and says why.
pub fn check_law(
    law: Law,
    restitution: f64,
    has_stiffness: bool,
    has_materials: bool,
) -> Result<(), (&'static str, String)> {
    if law == Law::Flores && restitution <= 0.0 {
        return Err(("restitution", "the flores law needs e > 0".into()));
    }
    match law {
        Law::KelvinVoigt if !has_stiffness => Err(("stiffness", "required for the kelvin_voigt law".into())),
        Law::KelvinVoigt | Law::Impulse => Ok(()),
        _ if !has_stiffness && !has_materials => Err((
            "stiffness",
            "give stiffness, or both sphere_material and material to derive it".into(),
        )),
        _ => Ok(()),
    }
}

/// Default floor on the remembered impact velocity [m/s] (`min_impact_velocity`).
pub const DEFAULT_MIN_IMPACT_VELOCITY: f64 = 1e-3;

/// Default Stribeck velocity [m/s] (`stribeck_velocity`).
pub const DEFAULT_STRIBECK_VELOCITY: f64 = 1e-2;

/// Default regularisation velocity of the continuous friction law [m/s]
/// (`stiction_velocity`; docs/friction.md gives the measurements behind it).
pub const DEFAULT_STICTION_VELOCITY: f64 = 1e-4;

impl SpringDamperSpec {
    /// `free_length`, by default the initial distance of the two points.
    pub fn free_length_or_default(&self) -> f64 {
        let v = |a: [f64; 3]| nalgebra::Vector3::new(a[0], a[1], a[2]);
        self.free_length
            .unwrap_or_else(|| (v(self.point_b) - v(self.point_a)).norm())
    }
}

impl ContactSpec {
    /// `max_penetration`, by default the sphere radius (a deeper overlap is not a contact the
    /// model can describe).
    pub fn max_penetration_or_default(&self) -> f64 {
        self.max_penetration.unwrap_or(self.radius)
    }

    /// `min_impact_velocity`, by default [`DEFAULT_MIN_IMPACT_VELOCITY`].
    pub fn min_impact_velocity_or_default(&self) -> f64 {
        self.min_impact_velocity.unwrap_or(DEFAULT_MIN_IMPACT_VELOCITY)
    }

    /// The friction constants with their defaults: μ = 0, μ_s = μ, Stribeck velocity
    /// [`DEFAULT_STRIBECK_VELOCITY`], σ = 0, v_s = [`DEFAULT_STICTION_VELOCITY`].
    pub fn friction_or_default(&self) -> [f64; 5] {
        let mu = self.friction.unwrap_or(0.0);
        [
            mu,
            self.static_friction.unwrap_or(mu),
            self.stribeck_velocity.unwrap_or(DEFAULT_STRIBECK_VELOCITY),
            self.viscous_friction.unwrap_or(0.0),
            self.stiction_velocity.unwrap_or(DEFAULT_STICTION_VELOCITY),
        ]
    }
}

impl Scene {
    /// Parses a scene from TOML text; `origin` names the file in messages. Also validates.
    pub fn from_str(text: &str, origin: &str) -> Result<Scene, SceneError> {
        let scene: Scene = toml::from_str(text).map_err(|e| {
            let (line, col) = e.span().map(|s| line_col(text, s.start)).unwrap_or((0, 0));
            SceneError::new(
                origin,
                format!("line {line}, column {col}"),
                "toml",
                // one line: the parser's message may span several
                e.message()
                    .lines()
                    .map(str::trim)
                    .filter(|l| !l.is_empty())
                    .collect::<Vec<_>>()
                    .join("; "),
            )
        })?;
        scene.validate(origin)?;
        Ok(scene)
    }

    /// Reads and parses a scene file.
    pub fn from_file(path: &Path) -> Result<Scene, SceneError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| SceneError::new(&origin, "file", "-", format!("cannot read: {e}")))?;
        Scene::from_str(&text, &origin)
    }

    /// Checks names, references, signs, ranges and magnitudes (the rules of docs/scene.md,
    /// "Rules for names and numbers"). Geometry-level checks that need the compiled tree
    /// (cycles, loops) are done by the model compiler.
    pub fn validate(&self, origin: &str) -> Result<(), SceneError> {
        let err = |item: String, field: &str, msg: String| SceneError::new(origin, item, field, msg);
        let m = &self.model;
        check_model_name(origin, &m.name)?;
        check_text(origin, "[model]", "description", &m.description)?;
        vector(origin, "[model]", "gravity", &m.gravity)?;
        positive(origin, "[model]", "stop_time", m.stop_time)?;
        positive(origin, "[model]", "interval", m.interval)?;
        let points = m.stop_time / m.interval;
        if points > MAX_COMMUNICATION_POINTS {
            return Err(err(
                "[model]".into(),
                "interval",
                format!(
                    "{} gives {points:.3e} communication points up to stop_time = {}; at most {MAX_COMMUNICATION_POINTS:e}",
                    m.interval, m.stop_time
                ),
            ));
        }
        let s = &self.solver;
        for (f, v, [lo, hi], why) in [
            (
                "rtol",
                s.rtol,
                RTOL_RANGE,
                "a looser tolerance gives results without meaning (the energy drifts), a tighter one \
                 lies below the rounding error",
            ),
            (
                "atol",
                s.atol,
                ATOL_RANGE,
                "a looser tolerance gives results without meaning, a much tighter one makes steps \
                 fail on components near zero",
            ),
        ] {
            if !(v >= lo && v <= hi) {
                return Err(err(
                    "[solver]".into(),
                    f,
                    format!("must be in [{}, {}] (got {}): {why}", short(lo), short(hi), short(v)),
                ));
            }
        }
        if let Err((field, msg)) = check_max_step(s) {
            return Err(err("[solver]".into(), field, msg));
        }
        // every name is valid and unique across the scene
        let mut names: HashSet<&str> = HashSet::new();
        let mut unique = |item: &str, name| -> Result<(), SceneError> {
            check_name(origin, item, name)?;
            if !names.insert(name) {
                return Err(SceneError::new(
                    origin,
                    item,
                    "name",
                    format!("duplicate name {}", quote(name)),
                ));
            }
            Ok(())
        };
        let mut materials = HashSet::new();
        for mat in &self.material {
            let item = item_name("material", &mat.name);
            unique(&item, &mat.name)?;
            materials.insert(mat.name.as_str());
            positive(origin, &item, "youngs_modulus", mat.youngs_modulus)?;
            if !(mat.poisson_ratio >= 0.0 && mat.poisson_ratio < 0.5) {
                return Err(err(
                    item,
                    "poisson_ratio",
                    format!("must be in [0, 0.5) (got {})", mat.poisson_ratio),
                ));
            }
        }
        let mut bodies = HashSet::new();
        for b in &self.body {
            let item = item_name("body", &b.name);
            if b.name == GROUND {
                return Err(err(item, "name", "\"ground\" is reserved for the fixed world".into()));
            }
            unique(&item, &b.name)?;
            bodies.insert(b.name.as_str());
            positive(origin, &item, "mass", b.mass)?;
            let [a, bb, c] = b.inertia;
            if !(a > 0.0 && bb > 0.0 && c > 0.0 && a.is_finite() && bb.is_finite() && c.is_finite()) {
                return Err(err(
                    item,
                    "inertia",
                    "principal moments must be > 0 (positive definite)".into(),
                ));
            }
            if !inertia_is_physical(b.inertia) {
                return Err(err(
                    item,
                    "inertia",
                    "violates the triangle inequality (no physical body has these moments)".into(),
                ));
            }
            vector(origin, &item, "position", &b.position)?;
            vector(origin, &item, "velocity", &b.velocity)?;
            vector(origin, &item, "angular_velocity", &b.angular_velocity)?;
            let q = b.orientation;
            let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
            if !(n.is_finite() && (n - 1.0).abs() < 1e-6) {
                return Err(err(
                    item,
                    "orientation",
                    format!("must be a unit quaternion (norm {n})"),
                ));
            }
        }
        let is_body = |n: &str| n == GROUND || bodies.contains(n);
        let mut joints = HashMap::new();
        for j in &self.joint {
            let item = item_name("joint", &j.name);
            unique(&item, &j.name)?;
            joints.insert(j.name.as_str(), j);
            if !is_body(&j.parent) {
                return Err(err(item, "parent", format!("unknown body {}", quote(&j.parent))));
            }
            if !bodies.contains(j.child.as_str()) {
                return Err(err(
                    item,
                    "child",
                    format!("unknown body {} (the ground cannot be a child)", quote(&j.child)),
                ));
            }
            if j.parent == j.child {
                return Err(err(item, "child", "a body cannot be joined to itself".into()));
            }
            if let Some(a) = j.anchor {
                vector(origin, &item, "anchor", &a)?;
            }
            match (j.kind, j.axis) {
                // a fixed or spherical joint that closes a loop uses a given axis too
                (_, Some(ax)) => direction(origin, &item, "axis", ax)?,
                (JointType::Revolute | JointType::Prismatic, None) => {
                    return Err(err(item, "axis", "required for revolute and prismatic joints".into()));
                }
                _ => {}
            }
        }
        for s in &self.spring_damper {
            let item = item_name("spring_damper", &s.name);
            unique(&item, &s.name)?;
            if !is_body(&s.body_a) {
                return Err(err(item, "body_a", format!("unknown body {}", quote(&s.body_a))));
            }
            if !is_body(&s.body_b) {
                return Err(err(item, "body_b", format!("unknown body {}", quote(&s.body_b))));
            }
            if s.body_a == s.body_b {
                return Err(err(item, "body_b", "must differ from body_a".into()));
            }
            vector(origin, &item, "point_a", &s.point_a)?;
            vector(origin, &item, "point_b", &s.point_b)?;
            nonnegative(origin, &item, "stiffness", s.stiffness)?;
            nonnegative(origin, &item, "damping", s.damping)?;
            if let Some(l) = s.free_length {
                nonnegative(origin, &item, "free_length", l)?;
                magnitude(origin, &item, "free_length", l)?;
            }
        }
        for c in &self.contact {
            let item = item_name("contact", &c.name);
            unique(&item, &c.name)?;
            self.validate_contact(origin, &item, c, &bodies, &materials)?;
        }
        for g in &self.contact_group {
            unique(&item_name("contact_group", &g.name), &g.name)?;
        }
        self.validate_groups(origin, &bodies, &materials)?;
        for i in &self.input {
            let item = item_name("input", &i.name);
            unique(&item, &i.name)?;
            if let Some(d) = i.direction {
                direction(origin, &item, "direction", d)?;
            }
            match i.kind {
                InputType::Force | InputType::Torque => {
                    let Some(b) = &i.body else {
                        return Err(err(item, "body", "required for force and torque inputs".into()));
                    };
                    if !bodies.contains(b.as_str()) {
                        return Err(err(item, "body", format!("unknown body {}", quote(b))));
                    }
                    if i.direction.is_none() {
                        return Err(err(item, "direction", "required for force and torque inputs".into()));
                    }
                }
                InputType::JointMotion => {
                    if i.joints.is_some() {
                        return Err(err(
                            item,
                            "joints",
                            "a joint_motion drives one joint: give joint".into(),
                        ));
                    }
                    let Some(jn) = &i.joint else {
                        return Err(err(item, "joint", "required for joint_motion inputs".into()));
                    };
                    let Some(j) = joints.get(jn.as_str()) else {
                        return Err(err(item, "joint", format!("unknown joint {}", quote(jn))));
                    };
                    if !matches!(j.kind, JointType::Revolute | JointType::Prismatic) {
                        return Err(err(
                            item,
                            "joint",
                            format!(
                                "joint {} is not a 1-DOF joint (a joint_motion drives a revolute or prismatic joint)",
                                quote(jn)
                            ),
                        ));
                    }
                    if let Some(other) = self
                        .input
                        .iter()
                        .take_while(|o| !std::ptr::eq(*o, i))
                        .find(|o| o.kind == InputType::JointMotion && o.joint.as_deref() == Some(jn.as_str()))
                    {
                        return Err(err(
                            item,
                            "joint",
                            format!("joint {} is already driven by input {}", quote(jn), quote(&other.name)),
                        ));
                    }
                    if i.body.is_some() || i.direction.is_some() {
                        let field = if i.body.is_some() { "body" } else { "direction" };
                        return Err(err(
                            item,
                            field,
                            "not used by a joint_motion input (it drives its joint)".into(),
                        ));
                    }
                    if i.start != 0.0 {
                        return Err(err(
                            item,
                            "start",
                            "a joint_motion starts at the joint's initial coordinate and rate (set <input>.q and \
                             <input>.qd to change them)"
                                .into(),
                        ));
                    }
                }
                InputType::JointForce => {
                    let names: Vec<&String> = match (&i.joint, &i.joints) {
                        (Some(j), None) => vec![j],
                        (None, Some(js)) if !js.is_empty() => js.iter().collect(),
                        (Some(_), Some(_)) => {
                            return Err(err(item, "joints", "give joint or joints, not both".into()));
                        }
                        _ => return Err(err(item, "joint", "required for joint_force inputs (or joints)".into())),
                    };
                    let field = if i.joint.is_some() { "joint" } else { "joints" };
                    let mut kinds = names.iter().filter_map(|n| joints.get(n.as_str()).map(|j| j.kind));
                    if let Some(first) = kinds.next() {
                        if kinds.any(|k| k != first) {
                            return Err(err(
                                item,
                                field,
                                "mixes revolute and prismatic joints (a torque and a force in one input)".into(),
                            ));
                        }
                    }
                    for jn in names {
                        let Some(j) = joints.get(jn.as_str()) else {
                            return Err(err(item, field, format!("unknown joint {}", quote(jn))));
                        };
                        if !matches!(j.kind, JointType::Revolute | JointType::Prismatic) {
                            return Err(err(item, field, format!("joint {} is not a 1-DOF joint", quote(jn))));
                        }
                    }
                }
            }
            if !i.start.is_finite() {
                return Err(err(item, "start", format!("must be finite (got {})", i.start)));
            }
        }
        Ok(())
    }

    fn validate_contact(
        &self,
        origin: &str,
        item: &str,
        c: &ContactSpec,
        bodies: &HashSet<&str>,
        materials: &HashSet<&str>,
    ) -> Result<(), SceneError> {
        let err = |field: &str, msg: String| SceneError::new(origin, item, field, msg);
        let is_body = |n: &str| n == GROUND || bodies.contains(n);
        if !is_body(&c.sphere_body) {
            return Err(err("sphere_body", format!("unknown body {}", quote(&c.sphere_body))));
        }
        if !is_body(&c.body) {
            return Err(err("body", format!("unknown body {}", quote(&c.body))));
        }
        if c.sphere_body == GROUND && c.body == GROUND {
            return Err(err(
                "body",
                "both shapes are on the ground: this contact can never act".into(),
            ));
        }
        if c.sphere_body == c.body {
            return Err(err("body", "both shapes are on the same body".into()));
        }
        if !(0.0..=1.0).contains(&c.restitution) {
            return Err(err("restitution", format!("must be in [0, 1] (got {})", c.restitution)));
        }
        length(origin, item, "radius", c.radius)?;
        vector(origin, item, "center", &c.center)?;
        for (f, m) in [("sphere_material", &c.sphere_material), ("material", &c.material)] {
            if let Some(m) = m {
                if !materials.contains(m.as_str()) {
                    return Err(err(f, format!("unknown material {}", quote(m))));
                }
            }
        }
        // Every number given is checked, whether or not this type of contact uses it.
        for (f, v) in [
            ("other_center", c.other_center),
            ("origin", c.origin),
            ("axis_point", c.axis_point),
        ] {
            if let Some(v) = v {
                vector(origin, item, f, &v)?;
            }
        }
        for (f, v) in [
            ("normal", c.normal),
            ("u_axis", c.u_axis),
            ("axis", c.axis),
            ("ref_axis", c.ref_axis),
        ] {
            if let Some(v) = v {
                direction(origin, item, f, v)?;
            }
        }
        for (f, v) in [
            ("other_radius", c.other_radius),
            ("cylinder_radius", c.cylinder_radius),
            ("length", c.length),
        ] {
            if let Some(v) = v {
                length(origin, item, f, v)?;
            }
        }
        if let Some([a, b]) = c.size {
            if !(a > 0.0 && b > 0.0 && a.is_finite() && b.is_finite()) {
                return Err(err(
                    "size",
                    format!("both side lengths must be finite and > 0 (got [{a}, {b}])"),
                ));
            }
            magnitude(origin, item, "size", a.max(b))?;
        }
        if let Some([a, b]) = c.theta_range {
            if !(a.is_finite() && b.is_finite()) || a >= b {
                return Err(err("theta_range", "needs finite min < max".into()));
            }
            magnitude(origin, item, "theta_range", a.abs().max(b.abs()))?;
        }
        let need = |f: &str, present: bool| -> Result<(), SceneError> {
            if present {
                Ok(())
            } else {
                Err(err(f, format!("required for a {} contact", kind_name(c.kind))))
            }
        };
        match c.kind {
            ContactType::SphereSphere => {
                need("other_center", c.other_center.is_some())?;
                need("other_radius", c.other_radius.is_some())?;
            }
            ContactType::SpherePlane => {
                need("origin", c.origin.is_some())?;
                need("normal", c.normal.is_some())?;
                need("u_axis", c.u_axis.is_some())?;
                need("size", c.size.is_some())?;
                let n = unit(c.normal.unwrap_or_default());
                let u = unit(c.u_axis.unwrap_or_default());
                if (n[0] * u[0] + n[1] * u[1] + n[2] * u[2]).abs() > 1e-6 {
                    return Err(err("u_axis", "must be perpendicular to normal".into()));
                }
            }
            ContactType::SphereCylinder => {
                need("axis_point", c.axis_point.is_some())?;
                need("axis", c.axis.is_some())?;
                need("cylinder_radius", c.cylinder_radius.is_some())?;
                need("length", c.length.is_some())?;
                let rho = c.cylinder_radius.unwrap_or(0.0);
                if c.side == Side::Inside && rho <= c.radius {
                    return Err(err(
                        "cylinder_radius",
                        "must exceed the sphere radius for an inside contact".into(),
                    ));
                }
                if c.theta_range.is_some() && c.ref_axis.is_none() {
                    return Err(err("ref_axis", "required with theta_range".into()));
                }
                if let Some(r) = c.ref_axis {
                    let a = unit(c.axis.unwrap_or_default());
                    let r = unit(r);
                    if (a[0] * r[0] + a[1] * r[1] + a[2] * r[2]).abs() > 1e-6 {
                        return Err(err("ref_axis", "must be perpendicular to axis".into()));
                    }
                }
            }
        }
        let materials = c.sphere_material.is_some() && c.material.is_some();
        validate_law_keys(origin, item, c, materials)
    }
}

/// The law constants of a contact (or of a contact group's template contact): what
/// [`check_law`] asks, signs and ranges of the optional keys.
fn validate_law_keys(origin: &str, item: &str, c: &ContactSpec, materials: bool) -> Result<(), SceneError> {
    let err = |field: &str, msg: String| SceneError::new(origin, item, field, msg);
    {
        if !(0.0..=1.0).contains(&c.restitution) {
            return Err(err("restitution", format!("must be in [0, 1] (got {})", c.restitution)));
        }
        check_law(c.law, c.restitution, c.stiffness.is_some(), materials).map_err(|(f, m)| err(f, m))?;
        if let Some(k) = c.stiffness {
            positive(origin, item, "stiffness", k)?;
        }
        if let Some(v) = c.max_penetration {
            if !(v > 0.0 && v.is_finite()) {
                return Err(err(
                    "max_penetration",
                    format!("must be > 0 (got {v}): no penetration could be admitted"),
                ));
            }
            magnitude(origin, item, "max_penetration", v)?;
        }
        for (f, v) in [
            ("damping", c.damping),
            ("min_impact_velocity", c.min_impact_velocity),
            ("friction", c.friction),
            ("static_friction", c.static_friction),
            ("viscous_friction", c.viscous_friction),
        ] {
            if let Some(v) = v {
                nonnegative(origin, item, f, v)?;
            }
        }
        for (f, v) in [
            ("stribeck_velocity", c.stribeck_velocity),
            ("stiction_velocity", c.stiction_velocity),
        ] {
            if let Some(v) = v {
                positive(origin, item, f, v)?;
                magnitude(origin, item, f, v)?;
            }
        }
        if let Some(n) = c.exponent {
            if !(n >= 1.0 && n.is_finite()) {
                return Err(err("exponent", format!("must be >= 1 (got {n})")));
            }
        }
        Ok(())
    }
}

/// `solver.rtol` must lie in this range (closed): looser tolerances give results without
/// meaning (at 3e-2 the bundled bouncing ball gains 19× its energy, at 0.5 5.5×), tighter
/// ones lie below the rounding error of f64. The FMU parameter has the same range.
pub const RTOL_RANGE: [f64; 2] = [1e-14, 1e-2];

/// `solver.atol` must lie in this range (closed): it is absolute, in the units of the state
/// (m, rad, m/s, rad/s, J), so above 1e-2 the error control stops seeing the motion; small
/// motions need small values (1e-17 for oscillations of 1e-4 rad), but far below 1e-20 steps
/// fail on components that stay near zero (at 1e-30 the bundled slider-crank fails). The FMU
/// parameter has the same range.
pub const ATOL_RANGE: [f64; 2] = [1e-20, 1e-2];

/// `solver.max_step`: 0 (none; `rk4` then steps by [`RK4_DEFAULT_STEP`]) or at least
/// [`MIN_MAX_STEP`], finite. Returns the field and the message.
pub fn check_max_step(s: &SolverSection) -> Result<(), (&'static str, String)> {
    let h = s.max_step;
    if !(h == 0.0 || (h >= MIN_MAX_STEP && h.is_finite())) {
        return Err((
            "max_step",
            format!(
                "must be 0 (none) or finite and >= {MIN_MAX_STEP:e} s (got {}): a smaller step never ends a simulation",
                short(h)
            ),
        ));
    }
    Ok(())
}

/// The fixed step of `rk4` [s] when `solver.max_step` is 0 (none).
pub const RK4_DEFAULT_STEP: f64 = 1e-3;

/// Smallest `solver.max_step` [s]: the step of `rk4`, and a cap on every method's step;
/// a smaller one makes any simulation practically endless (and below the rounding of the
/// time, truly endless). The FMU parameter has the same lower bound.
pub const MIN_MAX_STEP: f64 = 1e-9;

/// Largest magnitude of a coordinate [m], a length [m], a vector component (directions,
/// velocities, gravity) or an angle [rad] in a scene: the model forms squares and products
/// of them, which overflow or lose all precision beyond this.
pub const MAX_MAGNITUDE: f64 = 1e12;

/// Most communication points of the default experiment (`stop_time / interval`).
pub const MAX_COMMUNICATION_POINTS: f64 = 1e9;

/// Longest model name: the FMU's file name (`<name>.fmu`, `<name>.so`) and
/// `modelIdentifier`, with room for suffixes within the 255 bytes of a file name.
pub const MAX_MODEL_NAME: usize = 200;

/// Names that Windows reserves for devices, refused as model names (`NUL.fmu` cannot be a
/// file there), compared without case.
const DEVICE_NAMES: [&str; 22] = [
    "con", "prn", "aux", "nul", "com1", "com2", "com3", "com4", "com5", "com6", "com7", "com8", "com9", "lpt1", "lpt2",
    "lpt3", "lpt4", "lpt5", "lpt6", "lpt7", "lpt8", "lpt9",
];

/// A number as messages show it: the shorter of plain and scientific notation (`0.5`, `1e-15`).
fn short(x: f64) -> String {
    let (plain, sci) = (format!("{x}"), format!("{x:e}"));
    if sci.len() < plain.len() {
        sci
    } else {
        plain
    }
}

/// A name as messages show it: quoted and escaped (`"arm"`, `"a\tb"`), a long one cut to its
/// first 40 characters.
pub fn quote(name: &str) -> String {
    const SHOWN: usize = 40;
    let n = name.chars().count();
    if n <= SHOWN {
        format!("{name:?}")
    } else {
        let head: String = name.chars().take(SHOWN).collect();
        format!("{head:?}… ({n} characters)")
    }
}

/// An item as messages name it: its kind and its quoted name, e.g. `body "arm"`.
pub fn item_name(kind: &str, name: &str) -> String {
    format!("{kind} {}", quote(name))
}

/// A character that XML 1.0 cannot carry (U+FFFE, U+FFFF) or a control character (C0,
/// DEL, C1; tab and line breaks included: an XML attribute would turn them into spaces).
fn is_forbidden_char(c: char) -> bool {
    c.is_control() || c == '\u{FFFE}' || c == '\u{FFFF}'
}

/// A character in words, for messages: `a tab (U+0009)`, `'%' (U+0025)`.
fn describe_char(c: char) -> String {
    let code = format!("U+{:04X}", c as u32);
    match c {
        '\t' => format!("a tab ({code})"),
        '\n' => format!("a line feed ({code})"),
        '\r' => format!("a carriage return ({code})"),
        ' ' => format!("a space ({code})"),
        '\u{FFFE}' | '\u{FFFF}' => format!("the non-character {code} (XML cannot carry it)"),
        c if c.is_control() => format!("the control character {code}"),
        c => format!("{c:?} ({code})"),
    }
}

/// A name of a material, body, joint, spring-damper, contact or input: it becomes (the first
/// part of) FMU variable names, whose structured form (`arm.mass`, `arm.r[1]`) allows, unquoted,
/// only a letter or `_` followed by letters, digits and `_` (the FMI 2.0 grammar that fmpy
/// checks).
fn check_name(origin: &str, item: &str, name: &str) -> Result<(), SceneError> {
    let rule = "a name is a letter or '_' followed by letters, digits and '_' \
                (it becomes part of FMU variable names such as \"arm.mass\")";
    let bad = |what: String| SceneError::new(origin, item, "name", format!("{} {what}; {rule}", quote(name)));
    if name.is_empty() {
        return Err(SceneError::new(
            origin,
            item,
            "name",
            format!("must not be empty; {rule}"),
        ));
    }
    if let Some(c) = name.chars().find(|c| !(c.is_ascii_alphanumeric() || *c == '_')) {
        return Err(bad(format!("contains {}", describe_char(c))));
    }
    if name.starts_with(|c: char| c.is_ascii_digit()) {
        return Err(bad("starts with a digit".into()));
    }
    Ok(())
}

/// The model name: a C identifier (the FMU's `modelIdentifier`), at most [`MAX_MODEL_NAME`]
/// characters, not a device name (it is also the FMU's file name).
fn check_model_name(origin: &str, name: &str) -> Result<(), SceneError> {
    let item = "[model]";
    let rule = "the model name is a C identifier (letters, digits, _; not starting with a digit), \
                the FMU's modelIdentifier and file name";
    let bad = |what: String| SceneError::new(origin, item, "name", format!("{what}; {rule}"));
    if name.is_empty() {
        return Err(bad("must not be empty".into()));
    }
    let n = name.chars().count();
    if n > MAX_MODEL_NAME {
        return Err(bad(format!(
            "{} is {n} characters long, at most {MAX_MODEL_NAME} are allowed",
            quote(name)
        )));
    }
    if let Some(c) = name.chars().find(|c| !(c.is_ascii_alphanumeric() || *c == '_')) {
        return Err(bad(format!("{} contains {}", quote(name), describe_char(c))));
    }
    if name.starts_with(|c: char| c.is_ascii_digit()) {
        return Err(bad(format!("{} starts with a digit", quote(name))));
    }
    if DEVICE_NAMES.iter().any(|d| d.eq_ignore_ascii_case(name)) {
        return Err(bad(format!(
            "{} is a device name on Windows and cannot be a file name there",
            quote(name)
        )));
    }
    Ok(())
}

/// Free text that goes into an XML attribute: no control characters.
fn check_text(origin: &str, item: &str, field: &str, text: &str) -> Result<(), SceneError> {
    match text.chars().enumerate().find(|(_, c)| is_forbidden_char(*c)) {
        Some((i, c)) => Err(SceneError::new(
            origin,
            item,
            field,
            format!(
                "character {} is {}; it must be one line of text without control characters",
                i + 1,
                describe_char(c)
            ),
        )),
        None => Ok(()),
    }
}

fn kind_name(k: ContactType) -> &'static str {
    match k {
        ContactType::SphereSphere => "sphere_sphere",
        ContactType::SpherePlane => "sphere_plane",
        ContactType::SphereCylinder => "sphere_cylinder",
    }
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

/// `|x| <= MAX_MAGNITUDE` (for a finite `x`).
fn magnitude(origin: &str, item: &str, field: &str, x: f64) -> Result<(), SceneError> {
    if x.abs() <= MAX_MAGNITUDE {
        Ok(())
    } else {
        Err(SceneError::new(
            origin,
            item,
            field,
            format!(
                "{x:e} is too large: at most {MAX_MAGNITUDE:e} in magnitude (beyond, the model's squares and \
                 products overflow or lose all precision)"
            ),
        ))
    }
}

/// A vector (point, velocity, gravity): finite components of magnitude at most
/// [`MAX_MAGNITUDE`].
fn vector(origin: &str, item: &str, field: &str, v: &[f64]) -> Result<(), SceneError> {
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        return Err(SceneError::new(
            origin,
            item,
            field,
            format!("must be finite (got a component {x})"),
        ));
    }
    match v.iter().find(|x| x.abs() > MAX_MAGNITUDE) {
        Some(&x) => magnitude(origin, item, field, x),
        None => Ok(()),
    }
}

/// A direction: a [`vector`] of length > 1e-12 (it is normalised).
fn direction(origin: &str, item: &str, field: &str, v: [f64; 3]) -> Result<(), SceneError> {
    vector(origin, item, field, &v)?;
    if v.iter().map(|x| x * x).sum::<f64>() > 1e-24 {
        Ok(())
    } else {
        Err(SceneError::new(origin, item, field, "must not be the zero vector"))
    }
}

/// A finite `x > 0`.
fn positive(origin: &str, item: &str, field: &str, x: f64) -> Result<(), SceneError> {
    let msg = if !x.is_finite() {
        format!("must be finite (got {x})")
    } else if x > 0.0 {
        return Ok(());
    } else {
        format!("must be > 0 (got {})", short(x))
    };
    Err(SceneError::new(origin, item, field, msg))
}

/// A finite `x >= 0`.
fn nonnegative(origin: &str, item: &str, field: &str, x: f64) -> Result<(), SceneError> {
    let msg = if !x.is_finite() {
        format!("must be finite (got {x})")
    } else if x >= 0.0 {
        return Ok(());
    } else {
        format!("must be >= 0 (got {})", short(x))
    };
    Err(SceneError::new(origin, item, field, msg))
}

/// A length [m]: finite, > 0, at most [`MAX_MAGNITUDE`].
fn length(origin: &str, item: &str, field: &str, x: f64) -> Result<(), SceneError> {
    positive(origin, item, field, x)?;
    magnitude(origin, item, field, x)
}

fn line_col(text: &str, byte: usize) -> (usize, usize) {
    let before = &text[..byte.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.len() - before.rfind('\n').map(|i| i + 1).unwrap_or(0) + 1;
    (line, col)
}
