//! Scene files: the user's TOML description of a multibody system (see the README and
//! `docs/scene.md`). Parsing is done by serde; [`Scene::validate`] checks what serde cannot
//! (names that refer to each other, signs, ranges) and reports the file, the item and the field.
//!
//! Units are SI. Positions, axes and velocities are in the world frame at the initial
//! configuration.

use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};
use std::path::Path;

#[macro_use]
pub(crate) mod keys;
pub(crate) mod exact;
mod groups;
mod inputs;
mod rules;
mod validate;
pub use groups::{shape_item, BroadPhaseMethod, BroadPhaseSection, ContactGroupSpec, ShapeSpec, ShapeType};
pub use inputs::{InputSpec, InputType};
pub use rules::{
    check_max_step, item_name, quote, short, Num, ATOL_RANGE, MAX_COMMUNICATION_POINTS, MAX_MAGNITUDE, MAX_MODEL_NAME,
    MAX_STEPS_LIMIT, MIN_MAX_PENETRATION, MIN_MAX_STEP, RK4_DEFAULT_STEP, RTOL_RANGE, RUNAWAY_SPEED,
};
use rules::{check_name, length, magnitude, vector};
use validate::validate_law_keys;

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
    /// Gravity vector \[m/s^2\].
    #[serde(default = "default_gravity")]
    #[serde(deserialize_with = "crate::scene::exact::array")]
    pub gravity: [f64; 3],
    /// Default experiment stop time \[s\].
    #[serde(default = "default_stop_time")]
    pub stop_time: f64,
    /// Default communication step \[s\].
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

named_enum! {
    /// Integration methods, by their scene-file name. The numbers are the FMU enumeration values
    /// of `solver.method`.
    #[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
    #[serde(rename_all = "snake_case")]
    pub enum Method {
        /// Adaptive explicit Dormand-Prince 5(4) with dense output and event location.
        Dopri5 = 1 => "dopri5",
        /// Adaptive implicit SDIRK4 (L-stable, order 4) for stiff problems.
        Sdirk = 2 => "sdirk",
        /// Classical fixed-step Runge-Kutta 4 (step = `max_step`), a baseline.
        Rk4 = 3 => "rk4",
        /// Adaptive implicit Radau IIA of order 5 (stage order 3) for stiff problems with a smooth
        /// slow solution.
        Radau5 = 4 => "radau5",
        /// Dormand-Prince while the problem is not stiff, Radau IIA while it is, switched by a
        /// stiffness estimate (default).
        #[default]
        Auto = 5 => "auto",
    }
}

/// `[solver]`: every key but `continuation`, `islands` and `threads` (scene keys only) is also
/// an FMU parameter `solver.<key>`.
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
    /// Largest internal step \[s\] (the fixed step of `rk4`); 0 (the default): none, the steps
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
    /// Threads that advance the islands of a round side by side (scene key only): 1 (the
    /// default) advances them one after the other, 0 takes as many as the machine has. The
    /// islands are independent within a round, so the results do not depend on it.
    #[serde(default = "default_threads", skip_serializing_if = "is_default_threads")]
    pub threads: usize,
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
fn default_threads() -> usize {
    1
}
fn is_default_threads(n: &usize) -> bool {
    *n == default_threads()
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
            threads: default_threads(),
        }
    }
}

/// `[[material]]`
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Name, referred to by contacts.
    pub name: String,
    /// Young's modulus E \[Pa\].
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
    /// Mass \[kg\].
    pub mass: f64,
    /// Principal moments of inertia about the centre of mass \[kg m^2\].
    #[serde(deserialize_with = "crate::scene::exact::array")]
    pub inertia: [f64; 3],
    /// Centre of mass, world frame \[m\].
    #[serde(deserialize_with = "crate::scene::exact::array")]
    pub position: [f64; 3],
    /// Orientation quaternion (w, x, y, z) of the principal axes.
    #[serde(default = "identity_quaternion")]
    #[serde(deserialize_with = "crate::scene::exact::array")]
    pub orientation: [f64; 4],
    /// Centre-of-mass velocity, world frame \[m/s\].
    #[serde(default)]
    #[serde(deserialize_with = "crate::scene::exact::array")]
    pub velocity: [f64; 3],
    /// Angular velocity, world frame \[rad/s\].
    #[serde(default)]
    #[serde(deserialize_with = "crate::scene::exact::array")]
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
    /// Joint point, world frame \[m\]. Default: the child's centre of mass.
    #[serde(default, deserialize_with = "crate::scene::exact::option_array")]
    pub anchor: Option<[f64; 3]>,
    /// Joint axis, world frame (revolute and prismatic).
    #[serde(default, deserialize_with = "crate::scene::exact::option_array")]
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
    /// Attachment point on body_a, world frame \[m\].
    #[serde(deserialize_with = "crate::scene::exact::array")]
    pub point_a: [f64; 3],
    /// Second body.
    pub body_b: String,
    /// Attachment point on body_b, world frame \[m\].
    #[serde(deserialize_with = "crate::scene::exact::array")]
    pub point_b: [f64; 3],
    /// Stiffness \[N/m\].
    pub stiffness: f64,
    /// Damping \[N s/m\].
    #[serde(default)]
    pub damping: f64,
    /// Free length \[m\]; default the initial distance.
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

named_enum! {
    /// Contact laws, by their scene-file name. The numbers are the FMU enumeration values of
    /// `<contact>.law`.
    #[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
    #[serde(rename_all = "snake_case")]
    pub enum Law {
        /// F = K δ + c δ̇ (20)
        KelvinVoigt = 1 => "kelvin_voigt",
        /// F = K δ^n (21)
        Hertz = 2 => "hertz",
        /// Hertz with Lankarani-Nikravesh hysteresis damping (24)-(26)
        HertzLn = 3 => "hertz_ln",
        /// Hunt-Crossley: F = K δ^n (1 + α δ̇), α = 3(1-e)/(2 δ̇⁻)
        HuntCrossley = 4 => "hunt_crossley",
        /// Flores et al. (2011): F = K δ^n [1 + 8(1-e)/(5e) δ̇/δ̇⁻]
        Flores = 5 => "flores",
        /// Piecewise analysis: instantaneous impact with restitution.
        Impulse = 6 => "impulse",
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

scene_item! {
    [surface_keys, law_keys]
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
        /// Sphere centre, world frame \[m\].
        #[serde(deserialize_with = "crate::scene::exact::array")]
        pub center: [f64; 3],
        /// Sphere radius \[m\].
        pub radius: f64,
        /// Sphere material.
        pub sphere_material: Option<String>,
        /// Body that carries the other shape.
        pub body: String,
        /// Material of the other shape.
        pub material: Option<String>,
        /// sphere_sphere: centre of the other sphere, world frame \[m\].
        #[serde(default, deserialize_with = "crate::scene::exact::option_array")]
        pub other_center: Option<[f64; 3]>,
        /// sphere_sphere: radius of the other sphere \[m\].
        pub other_radius: Option<f64>,
    }
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

/// True when positive principal moments of inertia satisfy the triangle inequality
/// (I1 + I2 ≥ I3 and its permutations, to a relative 1e-9): the moments of a physical body.
pub fn inertia_is_physical([a, b, c]: [f64; 3]) -> bool {
    // (compared relative to the largest, so that no sum overflows: with moments near f64::MAX
    // the tolerance became infinite and any three moments passed)
    let s = a.max(b).max(c);
    let (a, b, c) = (a / s, b / s, c / s);
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

/// Default floor on the remembered impact velocity \[m/s\] (`min_impact_velocity`).
pub const DEFAULT_MIN_IMPACT_VELOCITY: f64 = 1e-3;

/// Default Stribeck velocity \[m/s\] (`stribeck_velocity`).
pub const DEFAULT_STRIBECK_VELOCITY: f64 = 1e-2;

/// Default regularisation velocity of the continuous friction law \[m/s\]
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

/// Each name's index in `names` (validation keeps names unique).
fn index_by_name<'a>(names: impl Iterator<Item = &'a String>) -> HashMap<&'a str, usize> {
    names.enumerate().map(|(i, n)| (n.as_str(), i)).collect()
}

impl Scene {
    /// Each body's index by its name.
    pub(crate) fn body_index(&self) -> HashMap<&str, usize> {
        index_by_name(self.body.iter().map(|b| &b.name))
    }

    /// Each joint's index by its name.
    pub(crate) fn joint_index(&self) -> HashMap<&str, usize> {
        index_by_name(self.joint.iter().map(|j| &j.name))
    }

    /// Each material's index by its name.
    pub(crate) fn material_index(&self) -> HashMap<&str, usize> {
        index_by_name(self.material.iter().map(|m| &m.name))
    }
}
