//! A typed builder for [`Scene`]s: tests, benchmarks and examples write a scene as Rust values
//! instead of TOML text, in the vocabulary of the scene file (`[[body]]` is [`BodySpec`],
//! `restitution = 0.8` is `.restitution(0.8)`), and get the TOML text from
//! [`Scene::to_toml`] where they need a file.
//!
//! Whatever a builder does not set keeps the scene file's default, so a scene built here
//! equals the one parsed from TOML that leaves the same keys out. Nothing is validated while
//! building: [`Scene::validate`] (or parsing the text) reports mistakes as for a file.
//!
//! ```
//! use contact_fmu::scene::{BodySpec, ContactSpec, Law, GROUND};
//! use contact_fmu::scene_builder::{Plane, SceneBuilder, Sphere};
//!
//! // A steel ball dropped from 0.1 m onto the floor.
//! let ball = BodySpec::sphere("ball", 0.0329, 0.01, [0.0, 0.0, 0.11]);
//! let floor = Plane::horizontal([0.0; 3], [1.0, 1.0]);
//! let scene = SceneBuilder::new("bouncing_ball")
//!     .steel()
//!     .body(ball.clone())
//!     .contact(
//!         ContactSpec::sphere_plane("floor", Law::HertzLn, Sphere::of(&ball, 0.01), GROUND, floor)
//!             .materials("steel", "steel")
//!             .restitution(0.8),
//!     )
//!     .build();
//! scene.validate("example").unwrap();
//! assert!(scene.to_toml().contains("law = \"hertz_ln\""));
//! ```

use crate::scene::{
    BodySpec, ContactGroupSpec, ContactSpec, ContactType, ImpulseMethod, InputSpec, InputType, JointSpec, JointType,
    Law, MaterialSpec, Method, ModelSection, Scene, ShapeSpec, ShapeType, Side, SolverSection, SpringDamperSpec,
};
use nalgebra::UnitQuaternion;

/// For each table `key / keys: Type` of a scene: the [`SceneBuilder`] methods `key`, which adds
/// one `[[key]]`, and `keys`, which adds several.
macro_rules! add_tables {
    ($($key:ident / $keys:ident: $t:ty),* $(,)?) => {
        $(
            #[doc = concat!("Adds a `[[", stringify!($key), "]]`.")]
            pub fn $key(mut self, table: $t) -> SceneBuilder {
                self.scene.$key.push(table);
                self
            }

            #[doc = concat!("Adds several `[[", stringify!($key), "]]` tables.")]
            pub fn $keys(mut self, tables: impl IntoIterator<Item = $t>) -> SceneBuilder {
                self.scene.$key.extend(tables);
                self
            }
        )*
    };
}

/// Chainable setters `key(self, value) -> Self` that give optional keys (`Option` fields) of a
/// scene table a value.
macro_rules! optional_keys {
    ($($(#[$doc:meta])* $key:ident: $t:ty),* $(,)?) => {
        $(
            $(#[$doc])*
            pub fn $key(mut self, value: $t) -> Self {
                self.$key = Some(value);
                self
            }
        )*
    };
}

/// Constructors `kind(name, parent, child, anchor, axis)` of [`JointSpec`]s of the joint types
/// that have an axis.
macro_rules! axis_joints {
    ($($(#[$doc:meta])* $kind:ident: $joint_type:expr),* $(,)?) => {
        $(
            $(#[$doc])*
            pub fn $kind(
                name: &str,
                parent: &str,
                child: &str,
                anchor: impl Into<[f64; 3]>,
                axis: impl Into<[f64; 3]>,
            ) -> JointSpec {
                JointSpec::new(name, $joint_type, parent, child).anchor(anchor).axis(axis)
            }
        )*
    };
}

/// Builds a [`Scene`] table by table; tables keep the order in which they are added.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneBuilder {
    scene: Scene,
}

impl SceneBuilder {
    /// An empty scene named `name` (the FMU's model identifier), with the default `[model]`
    /// and `[solver]`.
    pub fn new(name: &str) -> SceneBuilder {
        SceneBuilder {
            scene: Scene {
                model: ModelSection::new(name),
                solver: SolverSection::default(),
                material: Vec::new(),
                body: Vec::new(),
                joint: Vec::new(),
                spring_damper: Vec::new(),
                contact: Vec::new(),
                input: Vec::new(),
                shape: Vec::new(),
                contact_group: Vec::new(),
                broad_phase: Default::default(),
            },
        }
    }

    /// `model.description`.
    pub fn description(mut self, text: &str) -> SceneBuilder {
        self.scene.model.description = text.to_string();
        self
    }

    /// `model.gravity` \[m/s^2\].
    pub fn gravity(mut self, g: impl Into<[f64; 3]>) -> SceneBuilder {
        self.scene.model.gravity = g.into();
        self
    }

    /// The default experiment: `model.stop_time` and `model.interval` \[s\].
    pub fn experiment(mut self, stop_time: f64, interval: f64) -> SceneBuilder {
        self.scene.model.stop_time = stop_time;
        self.scene.model.interval = interval;
        self
    }

    /// The whole `[solver]` section.
    pub fn solver(self, method: Method, rtol: f64, atol: f64, max_step: f64) -> SceneBuilder {
        self.method(method).tolerances(rtol, atol).max_step(max_step)
    }

    /// `solver.method`.
    pub fn method(mut self, method: Method) -> SceneBuilder {
        self.scene.solver.method = method;
        self
    }

    /// `solver.rtol` and `solver.atol`.
    pub fn tolerances(mut self, rtol: f64, atol: f64) -> SceneBuilder {
        self.scene.solver.rtol = rtol;
        self.scene.solver.atol = atol;
        self
    }

    /// `solver.max_step` \[s\].
    pub fn max_step(mut self, max_step: f64) -> SceneBuilder {
        self.scene.solver.max_step = max_step;
        self
    }

    add_tables! {
        material / materials: MaterialSpec,
        body / bodies: BodySpec,
        joint / joints: JointSpec,
        spring_damper / spring_dampers: SpringDamperSpec,
        contact / contacts: ContactSpec,
        input / inputs: InputSpec,
        shape / shapes: ShapeSpec,
        contact_group / contact_groups: ContactGroupSpec,
    }

    /// Adds [`MaterialSpec::steel`].
    pub fn steel(self) -> SceneBuilder {
        self.material(MaterialSpec::steel())
    }

    /// The scene (not validated).
    pub fn build(self) -> Scene {
        self.scene
    }
}

impl From<SceneBuilder> for Scene {
    fn from(b: SceneBuilder) -> Scene {
        b.build()
    }
}

impl Scene {
    /// The scene as TOML text, which [`Scene::from_str`] parses back to an equal scene.
    pub fn to_toml(&self) -> String {
        // Every field of a scene is a string, number, array or table: serialisation cannot
        // fail.
        toml::to_string(self).expect("a scene serialises to TOML")
    }
}

impl MaterialSpec {
    /// A `[[material]]`: Young's modulus \[Pa\] and Poisson's ratio.
    pub fn new(name: &str, youngs_modulus: f64, poisson_ratio: f64) -> MaterialSpec {
        MaterialSpec {
            name: name.to_string(),
            youngs_modulus,
            poisson_ratio,
        }
    }

    /// "steel": E = 210 GPa, ν = 0.3.
    pub fn steel() -> MaterialSpec {
        MaterialSpec::new("steel", 210e9, 0.3)
    }
}

impl BodySpec {
    /// A solid sphere of uniform density: every principal moment 2/5 m r².
    pub fn sphere(name: &str, mass: f64, radius: f64, position: impl Into<[f64; 3]>) -> BodySpec {
        let i = 0.4 * mass * radius * radius;
        BodySpec::new(name, mass, [i, i, i], position.into())
    }

    /// `orientation`: the rotation from the world axes to the principal axes.
    pub fn orientation(mut self, q: UnitQuaternion<f64>) -> BodySpec {
        self.orientation = [q.w, q.i, q.j, q.k];
        self
    }

    /// `velocity` of the centre of mass \[m/s\].
    pub fn velocity(mut self, v: impl Into<[f64; 3]>) -> BodySpec {
        self.velocity = v.into();
        self
    }

    /// `angular_velocity` \[rad/s\].
    pub fn angular_velocity(mut self, w: impl Into<[f64; 3]>) -> BodySpec {
        self.angular_velocity = w.into();
        self
    }
}

impl JointSpec {
    /// A joint of `kind` from `parent` to `child`, anchored at the child's centre of mass,
    /// without an axis.
    pub fn new(name: &str, kind: JointType, parent: &str, child: &str) -> JointSpec {
        JointSpec {
            name: name.to_string(),
            kind,
            parent: parent.to_string(),
            child: child.to_string(),
            anchor: None,
            axis: None,
        }
    }

    axis_joints! {
        /// A revolute joint about `axis` through `anchor`.
        revolute: JointType::Revolute,
        /// A prismatic joint along `axis` through `anchor`.
        prismatic: JointType::Prismatic,
    }

    /// A spherical joint about `anchor`.
    pub fn spherical(name: &str, parent: &str, child: &str, anchor: impl Into<[f64; 3]>) -> JointSpec {
        JointSpec::new(name, JointType::Spherical, parent, child).anchor(anchor)
    }

    /// `anchor` \[m\].
    pub fn anchor(mut self, anchor: impl Into<[f64; 3]>) -> JointSpec {
        self.anchor = Some(anchor.into());
        self
    }

    /// `axis`.
    pub fn axis(mut self, axis: impl Into<[f64; 3]>) -> JointSpec {
        self.axis = Some(axis.into());
        self
    }
}

impl SpringDamperSpec {
    /// An undamped spring-damper from `point_a` on `body_a` to `point_b` on `body_b`, its free
    /// length the initial distance.
    pub fn new(
        name: &str,
        body_a: &str,
        point_a: impl Into<[f64; 3]>,
        body_b: &str,
        point_b: impl Into<[f64; 3]>,
        stiffness: f64,
    ) -> SpringDamperSpec {
        SpringDamperSpec {
            name: name.to_string(),
            body_a: body_a.to_string(),
            point_a: point_a.into(),
            body_b: body_b.to_string(),
            point_b: point_b.into(),
            stiffness,
            damping: 0.0,
            free_length: None,
        }
    }

    /// `damping` \[N s/m\].
    pub fn damping(mut self, c: f64) -> SpringDamperSpec {
        self.damping = c;
        self
    }

    /// `free_length` \[m\].
    pub fn free_length(mut self, l: f64) -> SpringDamperSpec {
        self.free_length = Some(l);
        self
    }
}

/// A sphere on a body: the sphere of a contact, or the other sphere of a sphere-sphere one.
#[derive(Debug, Clone, PartialEq)]
pub struct Sphere {
    /// The body that carries it.
    pub body: String,
    /// Centre, world frame \[m\].
    pub center: [f64; 3],
    /// Radius \[m\].
    pub radius: f64,
}

impl Sphere {
    /// A sphere of `radius` centred at `center` on `body`.
    pub fn new(body: &str, center: impl Into<[f64; 3]>, radius: f64) -> Sphere {
        Sphere {
            body: body.to_string(),
            center: center.into(),
            radius,
        }
    }

    /// A sphere of `radius` centred at the centre of mass of `body`.
    pub fn of(body: &BodySpec, radius: f64) -> Sphere {
        Sphere::new(&body.name, body.position, radius)
    }
}

/// The rectangle of a sphere-plane contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// Centre of the rectangle \[m\].
    pub origin: [f64; 3],
    /// Outward normal.
    pub normal: [f64; 3],
    /// First in-plane axis.
    pub u_axis: [f64; 3],
    /// Side lengths along `u_axis` and along `normal × u_axis` \[m\].
    pub size: [f64; 2],
}

impl Plane {
    /// A rectangle centred at `origin`.
    pub fn new(
        origin: impl Into<[f64; 3]>,
        normal: impl Into<[f64; 3]>,
        u_axis: impl Into<[f64; 3]>,
        size: [f64; 2],
    ) -> Plane {
        Plane {
            origin: origin.into(),
            normal: normal.into(),
            u_axis: u_axis.into(),
            size,
        }
    }

    /// A floor: normal +z, sides along x and y.
    pub fn horizontal(origin: impl Into<[f64; 3]>, size: [f64; 2]) -> Plane {
        Plane::new(origin, [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], size)
    }
}

/// The cylindrical surface patch of a sphere-cylinder contact (the sphere outside it unless
/// [`ContactSpec::side`] says otherwise).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cylinder {
    /// A point on the axis, the middle of the patch's length \[m\].
    pub axis_point: [f64; 3],
    /// Axis direction.
    pub axis: [f64; 3],
    /// Cylinder radius \[m\].
    pub radius: f64,
    /// Length along the axis \[m\].
    pub length: f64,
}

impl Cylinder {
    /// A cylinder of `radius` and `length` about `axis` through `axis_point`.
    pub fn new(axis_point: impl Into<[f64; 3]>, axis: impl Into<[f64; 3]>, radius: f64, length: f64) -> Cylinder {
        Cylinder {
            axis_point: axis_point.into(),
            axis: axis.into(),
            radius,
            length,
        }
    }
}

impl ContactSpec {
    fn with_sphere(name: &str, kind: ContactType, law: Law, s: Sphere, body: &str) -> ContactSpec {
        ContactSpec::new(name, kind, law, &s.body, s.center, s.radius, body)
    }

    /// Sphere `a` against sphere `b`.
    pub fn sphere_sphere(name: &str, law: Law, a: Sphere, b: Sphere) -> ContactSpec {
        ContactSpec {
            other_center: Some(b.center),
            other_radius: Some(b.radius),
            ..ContactSpec::with_sphere(name, ContactType::SphereSphere, law, a, &b.body)
        }
    }

    /// Sphere `s` against the rectangle `p` on `body`.
    pub fn sphere_plane(name: &str, law: Law, s: Sphere, body: &str, p: Plane) -> ContactSpec {
        ContactSpec::with_sphere(name, ContactType::SpherePlane, law, s, body).plane_keys(p)
    }

    /// Sphere `s` against the cylinder `cyl` on `body`.
    pub fn sphere_cylinder(name: &str, law: Law, s: Sphere, body: &str, cyl: Cylinder) -> ContactSpec {
        ContactSpec::with_sphere(name, ContactType::SphereCylinder, law, s, body).cylinder_keys(cyl)
    }

    /// `sphere_material` and `material` (of the other shape).
    pub fn materials(mut self, sphere: &str, other: &str) -> ContactSpec {
        self.sphere_material = Some(sphere.to_string());
        self.material = Some(other.to_string());
        self
    }

    /// `side` of a cylinder the sphere is on.
    pub fn side(mut self, side: Side) -> ContactSpec {
        self.side = side;
        self
    }

    /// `theta_range` \[rad\] of a cylinder patch, measured from `ref_axis`.
    pub fn theta_range(mut self, range: [f64; 2], ref_axis: impl Into<[f64; 3]>) -> ContactSpec {
        self.theta_range = Some(range);
        self.ref_axis = Some(ref_axis.into());
        self
    }
}

/// Group shapes of a rectangle or a cylinder, their surface keys set by the setters below.
impl ShapeSpec {
    /// The rectangle `p` on `body`, in `group` (see `[[contact]]`'s sphere_plane keys).
    pub fn plane(group: &str, body: &str, p: Plane) -> ShapeSpec {
        ShapeSpec::new(group, ShapeType::Plane, body).plane_keys(p)
    }

    /// The whole cylindrical surface `cyl` (outside) on `body`, in `group`.
    pub fn cylinder(group: &str, body: &str, cyl: Cylinder) -> ShapeSpec {
        ShapeSpec::new(group, ShapeType::Cylinder, body).cylinder_keys(cyl)
    }
}

/// The chainable setters of the surface keys of a `[[contact]]` and a `[[shape]]`: those of a
/// rectangle and those of a cylinder.
macro_rules! surface_key_setters {
    ($spec:ty) => {
        impl $spec {
            /// The plane keys (`origin`, `normal`, `u_axis`, `size`) of the rectangle `p`.
            pub fn plane_keys(self, p: Plane) -> Self {
                Self {
                    origin: Some(p.origin),
                    normal: Some(p.normal),
                    u_axis: Some(p.u_axis),
                    size: Some(p.size),
                    ..self
                }
            }

            /// The cylinder keys (`axis_point`, `axis`, `cylinder_radius`, `length`) of `cyl`.
            pub fn cylinder_keys(self, cyl: Cylinder) -> Self {
                Self {
                    axis_point: Some(cyl.axis_point),
                    axis: Some(cyl.axis),
                    cylinder_radius: Some(cyl.radius),
                    length: Some(cyl.length),
                    ..self
                }
            }
        }
    };
}

surface_key_setters!(ContactSpec);
surface_key_setters!(ShapeSpec);

/// The chainable setters of the contact-law keys (`restitution`, the optional constants,
/// `impulse_method`) of a `[[contact]]` and a `[[contact_group]]`.
macro_rules! law_key_setters {
    ($spec:ty) => {
        impl $spec {
            /// `restitution` e.
            pub fn restitution(mut self, e: f64) -> Self {
                self.restitution = e;
                self
            }

            optional_keys! {
                /// `stiffness` K \[N/m^n\].
                stiffness: f64,
                /// `damping` c \[N s/m\] (Kelvin-Voigt).
                damping: f64,
                /// `exponent` n of the force law.
                exponent: f64,
                /// `max_penetration` \[m\].
                max_penetration: f64,
                /// `min_impact_velocity` \[m/s\].
                min_impact_velocity: f64,
                /// `friction`: Coulomb coefficient μ.
                friction: f64,
                /// `static_friction` μ_s.
                static_friction: f64,
                /// `stribeck_velocity` \[m/s\].
                stribeck_velocity: f64,
                /// `viscous_friction` σ \[s/m\].
                viscous_friction: f64,
                /// `stiction_velocity` v_s \[m/s\] (regularisation).
                stiction_velocity: f64,
            }

            /// `impulse_method` (impulse law).
            pub fn impulse_method(mut self, m: ImpulseMethod) -> Self {
                self.impulse_method = m;
                self
            }
        }
    };
}

law_key_setters!(ContactSpec);
law_key_setters!(ContactGroupSpec);

impl InputSpec {
    fn on(
        name: &str,
        kind: InputType,
        body: Option<&str>,
        joint: Option<&str>,
        direction: Option<[f64; 3]>,
    ) -> InputSpec {
        InputSpec {
            name: name.to_string(),
            kind,
            body: body.map(str::to_string),
            joint: joint.map(str::to_string),
            joints: None,
            direction,
            start: 0.0,
        }
    }

    /// A force on the centre of mass of `body` along `direction` \[N\].
    pub fn force(name: &str, body: &str, direction: impl Into<[f64; 3]>) -> InputSpec {
        InputSpec::on(name, InputType::Force, Some(body), None, Some(direction.into()))
    }

    /// A torque on `body` about `direction` \[N m\].
    pub fn torque(name: &str, body: &str, direction: impl Into<[f64; 3]>) -> InputSpec {
        InputSpec::on(name, InputType::Torque, Some(body), None, Some(direction.into()))
    }

    /// A generalised force on the 1-DOF `joint` \[N or N m\].
    pub fn joint_force(name: &str, joint: &str) -> InputSpec {
        InputSpec::on(name, InputType::JointForce, None, Some(joint), None)
    }

    /// A prescribed motion of the 1-DOF `joint` (its coordinate, rate and acceleration).
    pub fn joint_motion(name: &str, joint: &str) -> InputSpec {
        InputSpec::on(name, InputType::JointMotion, None, Some(joint), None)
    }

    /// The same generalised force on each of the 1-DOF `joints` \[N or N m\].
    pub fn joint_forces(name: &str, joints: &[&str]) -> InputSpec {
        InputSpec {
            joints: Some(joints.iter().map(|j| j.to_string()).collect()),
            ..InputSpec::on(name, InputType::JointForce, None, None, None)
        }
    }

    /// `start` value.
    pub fn start(mut self, value: f64) -> InputSpec {
        self.start = value;
        self
    }
}
