//! One contact element from its scene entry and parameter values: the shape in its body's
//! frame (radii and sizes from the parameters), the stiffness (given, or Hertz's from the
//! materials and the radii), the law constants.

use super::parameters::{ContactValues, MaterialValues};
use crate::contact::laws::{hertz_stiffness, hysteresis_factor};
use crate::model::contact::{ContactElement, Shape};
use crate::scene::{item_name, ContactSpec, ContactType, Law, SceneError, Side};
use crate::spatial::triad;
use nalgebra::Vector3;

/// Compiles one contact with its parameter values `p` (materials: `materials`, in scene
/// order; `material_of` maps their names to indices). `body_of` maps names to body indices
/// (None = ground), `local_point` and `local_dir` express world points and directions in a
/// body's initial frame.
#[allow(clippy::too_many_arguments)]
pub(super) fn compile_contact(
    c: &ContactSpec,
    p: &ContactValues,
    materials: &[MaterialValues],
    material_of: &dyn Fn(&str) -> Option<usize>,
    origin: &str,
    body_of: &dyn Fn(&str) -> Option<usize>,
    local_point: &dyn Fn(Option<usize>, Vector3<f64>) -> Vector3<f64>,
    local_dir: &dyn Fn(Option<usize>, Vector3<f64>) -> Vector3<f64>,
) -> Result<ContactElement, SceneError> {
    let item = item_name("contact", &c.name);
    let v = |a: [f64; 3]| Vector3::new(a[0], a[1], a[2]);
    let sphere_body = body_of(&c.sphere_body);
    let body = body_of(&c.body);
    let radius = p.radius;
    let (shape, r_eff, bound_radius) = match c.kind {
        ContactType::SphereSphere => {
            let r2 = p.other_radius;
            (
                Shape::Sphere {
                    center: local_point(body, v(c.other_center.unwrap_or_default())),
                    radius: r2,
                },
                radius * r2 / (radius + r2),
                r2,
            )
        }
        ContactType::SpherePlane => {
            let n = v(c.normal.unwrap_or([0.0, 0.0, 1.0])).normalize();
            let u = v(c.u_axis.unwrap_or([1.0, 0.0, 0.0])).normalize();
            let w = n.cross(&u);
            let [lu, lv] = p.size;
            (
                Shape::Plane {
                    origin: local_point(body, v(c.origin.unwrap_or_default())),
                    normal: local_dir(body, n),
                    u: local_dir(body, u),
                    v: local_dir(body, w),
                    half: [lu / 2.0, lv / 2.0],
                },
                radius,
                0.5 * (lu * lu + lv * lv).sqrt(),
            )
        }
        ContactType::SphereCylinder => {
            let k = v(c.axis.unwrap_or([0.0, 0.0, 1.0])).normalize();
            let (rho, len) = (p.cylinder_radius, p.length);
            let reference = match c.ref_axis {
                Some(r) => v(r).normalize(),
                None => triad(&k).column(1).into_owned(),
            };
            let inside = c.side == Side::Inside;
            // Effective radius of the elliptical contact: geometric mean of the principal
            // relative radii (axial: R; circumferential: 1/(1/R ± 1/ρ)).
            let circ = if inside {
                1.0 / (1.0 / radius - 1.0 / rho)
            } else {
                1.0 / (1.0 / radius + 1.0 / rho)
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
                (radius * circ).sqrt(),
                (rho * rho + len * len / 4.0).sqrt(),
            )
        }
    };
    let material = |name: &Option<String>| name.as_ref().and_then(|n| material_of(n)).map(|i| materials[i]);
    let (stiffness, derived) = match p.stiffness {
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
            _ if p.law == Law::Impulse => (0.0, true),
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
        law: p.law,
        restitution: p.restitution,
        sphere_body,
        center: local_point(sphere_body, v(c.center)),
        radius,
        body,
        shape,
        stiffness,
        stiffness_derived: derived,
        exponent: p.exponent,
        damping: p.damping,
        max_penetration: p.max_penetration,
        min_impact_velocity: p.min_impact_velocity,
        bound_radius,
        impulse_method: c.impulse_method,
        constraint_row: None,
        hysteresis: hysteresis_factor(p.law, p.restitution),
        friction: p.friction,
    })
}

/// Reserves one constraint row per impulse-law contact after the `nc` loop rows (for its
/// resting mode) and returns the new total.
pub(crate) fn reserve_constraint_rows(contacts: &mut [ContactElement], nc: usize) -> usize {
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
