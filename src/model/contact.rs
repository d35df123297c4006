//! The compiled contact element (a sphere and the [`Shape`] it can touch) and its per-contact
//! records: what the model holds of a
//! contact ([`ContactElement`]), what the state remembers of it ([`ContactMemory`]) and what
//! an evaluation reports ([`ContactOutput`]).

use crate::scene::{ContactType, ImpulseMethod, Law};
use nalgebra::Vector3;

/// The shape a sphere can touch, in its body's frame.
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// Another sphere.
    Sphere {
        /// Centre.
        center: Vector3<f64>,
        /// Radius \[m\].
        radius: f64,
    },
    /// A finite rectangle: centre, outward normal, in-plane axes u and v, half side lengths.
    Plane {
        /// Centre of the rectangle.
        origin: Vector3<f64>,
        /// Unit outward normal (the side the sphere may touch).
        normal: Vector3<f64>,
        /// First in-plane axis.
        u: Vector3<f64>,
        /// Second in-plane axis (normal × u).
        v: Vector3<f64>,
        /// Half side lengths along u and v \[m\].
        half: [f64; 2],
    },
    /// A cylindrical surface patch.
    Cylinder {
        /// Point on the axis at the middle of the patch's length.
        point: Vector3<f64>,
        /// Unit axis.
        axis: Vector3<f64>,
        /// Unit direction perpendicular to the axis where θ = 0.
        reference: Vector3<f64>,
        /// Cylinder radius ρ \[m\].
        radius: f64,
        /// Half length along the axis \[m\].
        half_length: f64,
        /// Angular range [min, max] \[rad\] (None: the whole circumference).
        theta_range: Option<[f64; 2]>,
        /// Sphere inside (concave) rather than outside (convex).
        inside: bool,
    },
}

/// The sphere of a contact, compiled: what an element takes from its sphere shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereSide {
    /// Body carrying the sphere (None = ground).
    pub body: Option<usize>,
    /// Centre in that body's frame.
    pub center: Vector3<f64>,
    /// Radius \[m\].
    pub radius: f64,
    /// Young's modulus and Poisson's ratio of its material (None: no material).
    pub material: Option<[f64; 2]>,
}

/// The shape a sphere touches, compiled: what an element takes from its other shape.
#[derive(Debug, Clone, PartialEq)]
pub struct OtherSide {
    /// Body carrying the shape (None = ground).
    pub body: Option<usize>,
    /// Element type (from the shape's type).
    pub kind: ContactType,
    /// The shape in its body's frame.
    pub shape: Shape,
    /// Radius of a bounding sphere around its reference point (infinite: unbounded).
    pub bound_radius: f64,
    /// Young's modulus and Poisson's ratio of its material (None: no material).
    pub material: Option<[f64; 2]>,
}

/// The law constants of a contact: a declared contact's, or a contact group pair's (the same
/// for all its candidate pairs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LawConstants {
    /// Force law.
    pub law: Law,
    /// Coefficient of restitution.
    pub restitution: f64,
    /// Exponent n.
    pub exponent: f64,
    /// Kelvin-Voigt damping c \[N s/m\].
    pub damping: f64,
    /// Largest admissible penetration \[m\] (None: the sphere's radius).
    pub max_penetration: Option<f64>,
    /// Floor on δ̇⁻ \[m/s\].
    pub min_impact_velocity: f64,
    /// Stiffness K (None: Hertz's, from the materials).
    pub stiffness: Option<f64>,
    /// Friction constants.
    pub friction: Friction,
    /// Impulse law: how the impulse of an impact is computed.
    pub impulse_method: ImpulseMethod,
}

/// A compiled contact element.
#[derive(Debug, Clone)]
pub struct ContactElement {
    /// Name of a declared contact (empty for a contact group's candidate pair, whose name
    /// `crate::contact::elements::contact_name` makes when it is needed).
    pub name: String,
    /// Element type.
    pub kind: ContactType,
    /// Force law.
    pub law: Law,
    /// Coefficient of restitution.
    pub restitution: f64,
    /// Body carrying the sphere (None = ground).
    pub sphere_body: Option<usize>,
    /// Sphere centre in that body's frame.
    pub center: Vector3<f64>,
    /// Sphere radius \[m\].
    pub radius: f64,
    /// Body carrying the other shape (None = ground).
    pub body: Option<usize>,
    /// The other shape, in its body's frame.
    pub shape: Shape,
    /// Stiffness K \[N/m^n\].
    pub stiffness: f64,
    /// True when K was derived from the materials (a calculated parameter).
    pub stiffness_derived: bool,
    /// Exponent n.
    pub exponent: f64,
    /// Kelvin-Voigt damping c \[N s/m\].
    pub damping: f64,
    /// Largest admissible penetration \[m\].
    pub max_penetration: f64,
    /// Floor on δ̇⁻ \[m/s\]; for the impulse law, approach speeds below it come to rest.
    pub min_impact_velocity: f64,
    /// Radius of a bounding sphere of the other shape around its reference point (broad
    /// phase); infinite for unbounded shapes.
    pub bound_radius: f64,
    /// Impulse law: how the impulse of an impact is computed.
    pub impulse_method: ImpulseMethod,
    /// Impulse law: the row of the constraint system reserved for the resting contact (after
    /// the loop rows; zero while the contact does not rest).
    pub constraint_row: Option<usize>,
    /// Damping factor of the hysteresis laws from the restitution
    /// (the contact laws' hysteresis factor), computed once at compilation.
    pub hysteresis: f64,
    /// Friction constants (all zero: frictionless).
    pub friction: Friction,
}

impl ContactElement {
    /// The power of `rtol` in the first step after a touch (`engine::events::first_contact_step`):
    /// `1/5` where the force is smooth from the touch on (Kelvin-Voigt's `K δ + c δ̇`, an
    /// integer exponent: a polynomial in the state) and the steps of the order-5 method scale
    /// as `rtol^{1/5}`; else (`K δⁿ` with a fractional `n`, whose derivatives are unbounded at
    /// `δ = 0`) the larger of `1/5` and `1/(n + 1)`, so that the first step's error, which
    /// grows as its length to the power `n + 1`, stays in proportion to rtol.
    pub fn touch_power(&self) -> f64 {
        let n = self.exponent;
        if self.law == Law::KelvinVoigt || n.fract() == 0.0 {
            0.2
        } else {
            (1.0 / (n + 1.0)).max(0.2)
        }
    }

    /// The power `1/(n + 1)` of `rtol` in the floor of the steps toward a separation
    /// (`engine::events::time_to_contact`).
    pub fn separation_power(&self) -> f64 {
        1.0 / (self.exponent + 1.0)
    }
}

/// The friction constants of a contact (docs/friction.md).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Friction {
    /// Coulomb (sliding) coefficient μ.
    pub mu: f64,
    /// Static coefficient μ_s (peak of the Stribeck curve at zero slip).
    pub mu_static: f64,
    /// Stribeck velocity \[m/s\].
    pub stribeck_velocity: f64,
    /// Viscous coefficient σ \[s/m\]: the coefficient grows by σ·|slip|.
    pub viscous: f64,
    /// Regularisation (stiction) velocity v_s \[m/s\] of the continuous law.
    pub stiction_velocity: f64,
}

impl Friction {
    /// From the scene's (or a host's) values `[μ, μ_s, Stribeck velocity, σ, v_s]`.
    pub fn from_values([mu, mu_static, stribeck_velocity, viscous, stiction_velocity]: [f64; 5]) -> Friction {
        Friction {
            mu,
            mu_static,
            stribeck_velocity,
            viscous,
            stiction_velocity,
        }
    }

    /// True when the contact has any friction (otherwise it is skipped entirely, so a
    /// frictionless contact computes exactly what it did before friction existed).
    pub fn is_on(&self) -> bool {
        self.mu > 0.0 || self.mu_static > 0.0 || self.viscous > 0.0
    }
}

/// Per-contact memory carried from touch to separation (part of the state).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactMemory {
    /// In contact (the force law acts, or a resting impulse contact holds).
    pub active: bool,
    /// Penetration rate at the first instant of this contact, floored (δ̇⁻) \[m/s\].
    pub impact_velocity: f64,
    /// Impacts resolved so far (impulse law).
    pub impacts: u64,
}

/// Per-contact results of the last evaluation (outputs).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactOutput {
    /// Penetration (0 when apart) \[m\].
    pub delta: f64,
    /// Penetration rate \[m/s\].
    pub delta_dot: f64,
    /// Normal force \[N\].
    pub force: f64,
    /// Elastic energy stored \[J\].
    pub elastic_energy: f64,
    /// Friction force on the sphere, world frame \[N\].
    pub friction_force: Vector3<f64>,
    /// Slip speed at the contact point (tangential relative velocity magnitude) \[m/s\].
    pub slip_speed: f64,
}
