//! One contact element from its scene entry and parameter values: the shape in its body's
//! frame (radii and sizes from the parameters), the stiffness (given, or Hertz's from the
//! materials and the radii), the law constants.

use super::parameters::{ContactValues, MaterialValues};
use crate::contact::elements::element;
use crate::model::contact::{ContactElement, OtherSide, Shape, SphereSide};
use crate::scene::keys::Surface;
use crate::scene::{item_name, ContactSpec, ContactType, SceneError, Side};
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
    let material = |name: &Option<String>| {
        name.as_ref()
            .and_then(|n| material_of(n))
            .map(|i| [materials[i].youngs_modulus, materials[i].poisson_ratio])
    };
    let sphere_body = body_of(&c.sphere_body);
    let sphere = SphereSide {
        body: sphere_body,
        center: local_point(sphere_body, to_v(c.center)),
        radius: p.radius,
        material: material(&c.sphere_material),
    };
    let body = body_of(&c.body);
    let dims = Dimensions {
        other_radius: p.other_radius,
        size: p.size,
        cylinder_radius: p.cylinder_radius,
        length: p.length,
    };
    let (shape, bound_radius) = other_shape(
        c.kind,
        c.other_center,
        &c.surface(),
        &dims,
        body,
        local_point,
        local_dir,
    );
    let other = OtherSide {
        body,
        kind: c.kind,
        shape,
        bound_radius,
        material: material(&c.material),
    };
    element(c.name.clone(), &sphere, &other, &p.law)
        .map_err(|message| SceneError::new(origin, item_name("contact", &c.name), "stiffness", message))
}

fn to_v(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

/// The sizes of the other shape (parameters a host may set).
pub(super) struct Dimensions {
    /// sphere_sphere: radius of the other sphere \[m\].
    pub other_radius: f64,
    /// sphere_plane: side lengths of the rectangle \[m\].
    pub size: [f64; 2],
    /// sphere_cylinder: cylinder radius \[m\].
    pub cylinder_radius: f64,
    /// sphere_cylinder: length of the patch \[m\].
    pub length: f64,
}

/// The shape a sphere touches, in the frame of `body`, and the radius of a bounding sphere
/// around its reference point: a sphere centred at `center` (world), or the plane or cylinder
/// `surface` with the sizes `dims`.
pub(super) fn other_shape(
    kind: ContactType,
    center: Option<[f64; 3]>,
    surface: &Surface,
    dims: &Dimensions,
    body: Option<usize>,
    local_point: &dyn Fn(Option<usize>, Vector3<f64>) -> Vector3<f64>,
    local_dir: &dyn Fn(Option<usize>, Vector3<f64>) -> Vector3<f64>,
) -> (Shape, f64) {
    match kind {
        ContactType::SphereSphere => {
            let r2 = dims.other_radius;
            (
                Shape::Sphere {
                    center: local_point(body, to_v(center.unwrap_or_default())),
                    radius: r2,
                },
                r2,
            )
        }
        ContactType::SpherePlane => {
            let n = to_v(surface.normal.unwrap_or([0.0, 0.0, 1.0])).normalize();
            let u = to_v(surface.u_axis.unwrap_or([1.0, 0.0, 0.0])).normalize();
            let w = n.cross(&u);
            let [lu, lv] = dims.size;
            (
                Shape::Plane {
                    origin: local_point(body, to_v(surface.origin.unwrap_or_default())),
                    normal: local_dir(body, n),
                    u: local_dir(body, u),
                    v: local_dir(body, w),
                    half: [lu / 2.0, lv / 2.0],
                },
                0.5 * (lu * lu + lv * lv).sqrt(),
            )
        }
        ContactType::SphereCylinder => {
            let k = to_v(surface.axis.unwrap_or([0.0, 0.0, 1.0])).normalize();
            let (rho, len) = (dims.cylinder_radius, dims.length);
            let reference = match surface.ref_axis {
                Some(r) => to_v(r).normalize(),
                None => triad(&k).column(1).into_owned(),
            };
            (
                Shape::Cylinder {
                    point: local_point(body, to_v(surface.axis_point.unwrap_or_default())),
                    axis: local_dir(body, k),
                    reference: local_dir(body, reference),
                    radius: rho,
                    half_length: len / 2.0,
                    theta_range: surface.theta_range,
                    inside: surface.side == Side::Inside,
                },
                (rho * rho + len * len / 4.0).sqrt(),
            )
        }
    }
}
