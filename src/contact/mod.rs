//! Contact: detection (geometry, [`geometry`]) apart from response (force laws, [`laws`]).
//!
//! Every element is a sphere on one body against a shape on another (either may be the
//! ground). Detection gives the penetration δ, its rate δ̇, the normal `n` (pointing from
//! the other shape toward the sphere: the force on the sphere is `+F n`), the contact point
//! and the margin by which the sphere centre's projection lies inside the shape's patch.
//!
//! The gap rate is `δ̇ = −(v_sphere(p) − v_other(p)) · n` for the material points at the
//! contact point `p`, so the same coefficient vectors give δ̇, the Jacobian row of the
//! normal gap (for impulses) and the generalised contact force.

//!
//! Modes: a continuous-law contact is *active* from touch to separation (its force law acts
//! and it remembers δ̇⁻). An impulse-law contact is normally inactive (impacts are velocity
//! jumps, [`impulse`]); when it is hit slower than `min_impact_velocity` it becomes *resting*
//! (`active`): a unilateral constraint row `J q̈ = −J̇ q̇` (with Baumgarte stabilisation of δ)
//! holds it until its normal force would become tensile, or the sphere leaves the patch.

pub mod geometry;
pub mod impulse;
pub mod laws;

use crate::dynamics::{self, add_jacobian_row};
use crate::model::{Data, Model};
use crate::scene::{ContactSpec, ContactType, ImpulseMethod, Law, Scene, SceneError, Side};
use crate::spatial::Spatial;
use nalgebra::Vector3;

pub use geometry::{Gap, Shape};

/// A compiled contact element.
#[derive(Debug, Clone)]
pub struct ContactElement {
    /// Name.
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
    /// Sphere radius [m].
    pub radius: f64,
    /// Body carrying the other shape (None = ground).
    pub body: Option<usize>,
    /// The other shape, in its body's frame.
    pub shape: Shape,
    /// Stiffness K [N/m^n].
    pub stiffness: f64,
    /// True when K was derived from the materials (a calculated parameter).
    pub stiffness_derived: bool,
    /// Exponent n.
    pub exponent: f64,
    /// Kelvin-Voigt damping c [N s/m].
    pub damping: f64,
    /// Largest admissible penetration [m].
    pub max_penetration: f64,
    /// Floor on δ̇⁻ [m/s]; for the impulse law, approach speeds below it come to rest.
    pub min_impact_velocity: f64,
    /// Radius of a bounding sphere of the other shape around its reference point (broad
    /// phase); infinite for unbounded shapes.
    pub bound_radius: f64,
    /// Impulse law: how the impulse of an impact is computed.
    pub impulse_method: ImpulseMethod,
    /// Impulse law: the row of the constraint system reserved for the resting contact (after
    /// the loop rows; zero while the contact does not rest).
    pub constraint_row: Option<usize>,
}

/// Per-contact memory carried from touch to separation (part of the state).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactMemory {
    /// In contact (the force law acts, or a resting impulse contact holds).
    pub active: bool,
    /// Penetration rate at the first instant of this contact, floored (δ̇⁻) [m/s].
    pub impact_velocity: f64,
    /// Impacts resolved so far (impulse law).
    pub impacts: u64,
}

/// Per-contact results of the last evaluation (outputs).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactOutput {
    /// Penetration (0 when apart) [m].
    pub delta: f64,
    /// Penetration rate [m/s].
    pub delta_dot: f64,
    /// Normal force [N].
    pub force: f64,
    /// Elastic energy stored [J].
    pub elastic_energy: f64,
}

/// Hertz stiffness (22), corrected: `K = 4/(3π(h_i+h_j)) · sqrt(R_i R_j/(R_i+R_j))`,
/// `h = (1−ν²)/(πE)`. `r_eff` is the effective radius `R_i R_j/(R_i+R_j)`.
pub fn hertz_stiffness(e1: f64, nu1: f64, e2: f64, nu2: f64, r_eff: f64) -> f64 {
    let h = |e: f64, nu: f64| (1.0 - nu * nu) / (std::f64::consts::PI * e);
    4.0 / (3.0 * std::f64::consts::PI * (h(e1, nu1) + h(e2, nu2))) * r_eff.sqrt()
}

/// Compiles one contact. `body_of` maps names to body indices (None = ground), `local_point`
/// and `local_dir` express world points and directions in a body's initial frame.
pub fn compile_contact(
    scene: &Scene,
    c: &ContactSpec,
    origin: &str,
    body_of: &dyn Fn(&str) -> Option<usize>,
    local_point: &dyn Fn(Option<usize>, Vector3<f64>) -> Vector3<f64>,
    local_dir: &dyn Fn(Option<usize>, Vector3<f64>) -> Vector3<f64>,
) -> Result<ContactElement, SceneError> {
    let item = format!("contact {:?}", c.name);
    let v = |a: [f64; 3]| Vector3::new(a[0], a[1], a[2]);
    let sphere_body = body_of(&c.sphere_body);
    let body = body_of(&c.body);
    let (shape, r_eff, bound_radius) = match c.kind {
        ContactType::SphereSphere => {
            let r2 = c.other_radius.unwrap_or(1.0);
            (
                Shape::Sphere {
                    center: local_point(body, v(c.other_center.unwrap_or_default())),
                    radius: r2,
                },
                c.radius * r2 / (c.radius + r2),
                r2,
            )
        }
        ContactType::SpherePlane => {
            let n = v(c.normal.unwrap_or([0.0, 0.0, 1.0])).normalize();
            let u = v(c.u_axis.unwrap_or([1.0, 0.0, 0.0])).normalize();
            let w = n.cross(&u);
            let [lu, lv] = c.size.unwrap_or([1.0, 1.0]);
            (
                Shape::Plane {
                    origin: local_point(body, v(c.origin.unwrap_or_default())),
                    normal: local_dir(body, n),
                    u: local_dir(body, u),
                    v: local_dir(body, w),
                    half: [lu / 2.0, lv / 2.0],
                },
                c.radius,
                0.5 * (lu * lu + lv * lv).sqrt(),
            )
        }
        ContactType::SphereCylinder => {
            let k = v(c.axis.unwrap_or([0.0, 0.0, 1.0])).normalize();
            let rho = c.cylinder_radius.unwrap_or(1.0);
            let len = c.length.unwrap_or(1.0);
            let reference = match c.ref_axis {
                Some(r) => v(r).normalize(),
                None => crate::model::triad(&k).column(1).into_owned(),
            };
            let inside = c.side == Side::Inside;
            // Effective radius of the elliptical contact: geometric mean of the principal
            // relative radii (axial: R; circumferential: 1/(1/R ± 1/ρ)).
            let circ = if inside {
                1.0 / (1.0 / c.radius - 1.0 / rho)
            } else {
                1.0 / (1.0 / c.radius + 1.0 / rho)
            };
            (
                Shape::Cylinder {
                    point: local_point(body, v(c.axis_point.unwrap_or_default())),
                    axis: local_dir(body, k),
                    reference: local_dir(body, reference),
                    radius: rho,
                    half_length: len / 2.0,
                    theta_range: c.theta_range,
                    inside,
                },
                (c.radius * circ).sqrt(),
                (rho * rho + len * len / 4.0).sqrt(),
            )
        }
    };
    let material = |name: &Option<String>| name.as_ref().and_then(|n| scene.material.iter().find(|m| &m.name == n));
    let (stiffness, derived) = match c.stiffness {
        Some(k) => (k, false),
        None => match (material(&c.sphere_material), material(&c.material)) {
            (Some(a), Some(b)) => (
                hertz_stiffness(
                    a.youngs_modulus,
                    a.poisson_ratio,
                    b.youngs_modulus,
                    b.poisson_ratio,
                    r_eff,
                ),
                true,
            ),
            _ if c.law == Law::Impulse => (0.0, true),
            _ => {
                return Err(SceneError::new(
                    origin,
                    item,
                    "stiffness",
                    "give stiffness, or both sphere_material and material",
                ))
            }
        },
    };
    Ok(ContactElement {
        name: c.name.clone(),
        kind: c.kind,
        law: c.law,
        restitution: c.restitution,
        sphere_body,
        center: local_point(sphere_body, v(c.center)),
        radius: c.radius,
        body,
        shape,
        stiffness,
        stiffness_derived: derived,
        exponent: c.exponent.unwrap_or(1.5),
        damping: c.damping.unwrap_or(0.0),
        max_penetration: crate::variables::default_max_penetration(c),
        min_impact_velocity: c
            .min_impact_velocity
            .unwrap_or(crate::variables::DEFAULT_MIN_IMPACT_VELOCITY),
        bound_radius,
        impulse_method: c.impulse_method,
        constraint_row: None,
    })
}

/// Reserves one constraint row per impulse-law contact after the `nc` loop rows (for its
/// resting mode) and returns the new total.
pub fn reserve_constraint_rows(contacts: &mut [ContactElement], nc: usize) -> usize {
    let mut n = nc;
    for c in contacts.iter_mut() {
        c.constraint_row = if c.law == Law::Impulse {
            n += 1;
            Some(n - 1)
        } else {
            None
        };
    }
    n
}

/// Number of loop-constraint rows (the contact rows follow them).
pub fn loop_rows(m: &Model) -> usize {
    m.loops.last().map(|l| l.row + l.rows()).unwrap_or(0)
}

/// Evaluates the geometry of contact `i` at the current kinematics.
pub fn gap(m: &Model, d: &Data, i: usize) -> Gap {
    let c = &m.contacts[i];
    let fs = crate::dynamics::frame(d, c.sphere_body);
    let fo = crate::dynamics::frame(d, c.body);
    geometry::detect(c, &fs, &fo)
}

/// Event function of contact `i`: positive exactly when the sphere is inside the shape's
/// patch with `0 < δ < δ_max`; continuous across every boundary.
pub fn event_function(c: &ContactElement, g: &Gap) -> f64 {
    g.delta.min(g.margin).min(c.max_penetration - g.delta)
}

/// Broad phase: when the sphere centre is farther from the other shape's bounding sphere than
/// `radius + max_penetration`, no part of the admissible region can be reached (δ < 0, or the
/// projection is off the patch, or δ > δ_max) and the exact detection is skipped. Returns
/// then a negative stand-in for the event function (minus the clearance [m]); `None` when
/// the exact detection is needed.
pub fn broad_phase(c: &ContactElement, d: &Data) -> Option<f64> {
    if !c.bound_radius.is_finite() {
        return None;
    }
    let fs = dynamics::frame(d, c.sphere_body);
    let fo = dynamics::frame(d, c.body);
    let center = fs.pos + fs.rot * c.center;
    let other = fo.pos + fo.rot * geometry::bound_center(&c.shape);
    let clearance = (center - other).norm() - (c.bound_radius + c.radius + c.max_penetration);
    if clearance > 0.0 {
        Some(-clearance)
    } else {
        None
    }
}

/// The geometric event function of contact `i` at the current kinematics, with the broad
/// phase: the same sign as [`event_function`] of the exact gap.
pub fn gap_event(m: &Model, d: &Data, i: usize) -> f64 {
    let c = &m.contacts[i];
    match broad_phase(c, d) {
        Some(v) => v,
        None => event_function(c, &gap(m, d, i)),
    }
}

/// Adds the Jacobian row of the separation rate `−δ̇` of gap `g` of contact `c` to `row`.
pub fn add_separation_row(m: &Model, d: &Data, c: &ContactElement, g: &Gap, row: &mut [f64]) {
    let (cs, co) = separation_coefficients(g);
    add_jacobian_row(m, d, c.sphere_body, &cs, 1.0, row);
    add_jacobian_row(m, d, c.body, &co, 1.0, row);
}

/// Fills the constraint rows of the resting impulse contacts (called by
/// [`crate::dynamics::constraints`] after the loop rows, before stabilisation): the row is the
/// separation-rate Jacobian `J`, the value `Φ = −δ`, and `γ = −J̇ q̇` (see
/// [`geometry::separation_acceleration_bias`]). Rows of contacts that do not rest are zero
/// (the pivoted factorisation drops them).
pub fn resting_rows(m: &Model, d: &Data, phi_q: &mut [f64], phi: &mut [f64], gamma: &mut [f64]) {
    let nv = m.nv;
    for (i, c) in m.contacts.iter().enumerate() {
        let Some(r) = c.constraint_row else { continue };
        phi[r] = 0.0;
        gamma[r] = 0.0;
        if !d.contact_memory[i].active {
            continue;
        }
        let fs = dynamics::frame(d, c.sphere_body);
        let fo = dynamics::frame(d, c.body);
        let g = geometry::detect(c, &fs, &fo);
        add_separation_row(m, d, c, &g, &mut phi_q[r * nv..(r + 1) * nv]);
        phi[r] = -g.delta;
        gamma[r] = -geometry::separation_acceleration_bias(c, &fs, &fo, &g);
    }
}

/// Normal force [N] carried by resting contact `i` after a constrained solve (the multiplier
/// of its row with the sign of a push); 0 when it does not rest.
pub fn resting_force(m: &Model, d: &Data, i: usize) -> f64 {
    match m.contacts[i].constraint_row {
        Some(r) if d.contact_memory[i].active => -d.lambda[r],
        _ => 0.0,
    }
}

/// Writes the outputs of the resting impulse contacts after a constrained solve.
pub fn resting_outputs(m: &Model, d: &mut Data) {
    for i in 0..m.contacts.len() {
        if m.contacts[i].constraint_row.is_some() && d.contact_memory[i].active {
            let g = gap(m, d, i);
            d.contact_out[i] = ContactOutput {
                delta: g.delta.max(0.0),
                delta_dot: g.delta_dot,
                force: resting_force(m, d, i),
                elastic_energy: 0.0,
            };
        }
    }
}

/// Adds the forces of the active continuous contacts to the bodies, updates the contact
/// outputs and returns the dissipated power [W].
pub fn apply_forces(m: &Model, d: &mut Data) -> f64 {
    let mut power = 0.0;
    for i in 0..m.contacts.len() {
        let c = &m.contacts[i];
        let mem = d.contact_memory[i];
        if !mem.active || c.law == Law::Impulse {
            d.contact_out[i] = ContactOutput::default();
            continue;
        }
        let g = gap(m, d, i);
        let delta = g.delta.max(0.0);
        let f = laws::force(c, delta, g.delta_dot, mem.impact_velocity);
        power += (f.total - f.elastic) * g.delta_dot;
        let force = g.normal * f.total;
        if let Some(b) = c.sphere_body {
            d.body_force[b] = d.body_force[b].add(&Spatial::force_at(&force, &g.point));
        }
        if let Some(b) = c.body {
            d.body_force[b] = d.body_force[b].add(&Spatial::force_at(&(-force), &g.point));
        }
        d.contact_out[i] = ContactOutput {
            delta,
            delta_dot: g.delta_dot,
            force: f.total,
            elastic_energy: f.energy,
        };
    }
    power
}

/// Coefficient vectors (sphere body, other body) whose pairing with the bodies' spatial
/// velocities gives the separation rate `−δ̇` at gap `g`.
pub fn separation_coefficients(g: &Gap) -> (Spatial, Spatial) {
    let s = Spatial::point_direction(&g.point, &g.normal);
    (s, s.scale(-1.0))
}
