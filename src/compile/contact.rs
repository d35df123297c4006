//! What a shape brings to a contact element, and a declared contact compiled as a group pair.
//!
//! A `[[contact]]` is a pair of two one-shape groups with the contact's law: its sphere and its
//! other shape are written as two `[[shape]]`s ([`contact_shapes`]), placed by the functions
//! that place every group shape ([`sphere_side`], [`other_side`]), and the element is made from
//! the first's sphere side, the second's other side and the law by [`element`], as a group
//! pair's candidate is ([`crate::contact::elements::candidate_element`]). So the two scene
//! forms become the same element by the same arithmetic.

use super::parameters::{ContactValues, MaterialValues};
use crate::contact::elements::element;
use crate::model::contact::{ContactElement, OtherSide, Shape, SphereSide};
use crate::scene::keys::Surface;
use crate::scene::{item_name, ContactSpec, ContactType, SceneError, ShapeSpec, ShapeType, Side};
use crate::spatial::triad;
use nalgebra::{UnitQuaternion, Vector3};

/// What the compiler places shapes (and springs' points) by: the bodies by name, their initial
/// poses and the materials' values.
pub(super) struct Placing<'a> {
    /// A body's index by name (None = ground).
    pub body_of: &'a dyn Fn(&str) -> Option<usize>,
    /// A body's initial pose (position, orientation; None = ground).
    pub pose0: &'a dyn Fn(Option<usize>) -> (Vector3<f64>, UnitQuaternion<f64>),
    /// A material's index by name.
    pub material_of: &'a dyn Fn(&str) -> Option<usize>,
    /// The materials' values, in scene order.
    pub materials: &'a [MaterialValues],
}

impl Placing<'_> {
    /// A world point in the initial frame of body `b`.
    pub fn local_point(&self, b: Option<usize>, p: Vector3<f64>) -> Vector3<f64> {
        let (r, q) = (self.pose0)(b);
        q.inverse() * (p - r)
    }

    /// A world direction in the initial frame of body `b`.
    pub fn local_dir(&self, b: Option<usize>, v: Vector3<f64>) -> Vector3<f64> {
        let (_, q) = (self.pose0)(b);
        q.inverse() * v
    }

    /// Young's modulus and Poisson's ratio of the material named (None: none named).
    fn material(&self, name: &Option<String>) -> Option<[f64; 2]> {
        name.as_ref()
            .and_then(|n| (self.material_of)(n))
            .map(|i| [self.materials[i].youngs_modulus, self.materials[i].poisson_ratio])
    }
}

/// The two one-shape groups a declared contact stands for, with its parameter values `p` (the
/// sizes a host may set): its sphere, and the shape it touches. It undoes
/// [`crate::scene::Scene::group_pair_contact`] up to the element they give (it sets every size,
/// used or not); the groups are unnamed (nothing looks them up).
pub(super) fn contact_shapes(c: &ContactSpec, p: &ContactValues) -> [ShapeSpec; 2] {
    let sphere = ShapeSpec {
        material: c.sphere_material.clone(),
        ..ShapeSpec::sphere("", &c.sphere_body, c.center, p.radius)
    };
    let kind = match c.kind {
        ContactType::SphereSphere => ShapeType::Sphere,
        ContactType::SpherePlane => ShapeType::Plane,
        ContactType::SphereCylinder => ShapeType::Cylinder,
    };
    let surface = c.surface();
    let other = ShapeSpec {
        material: c.material.clone(),
        center: Some(c.other_center.unwrap_or_default()),
        radius: Some(p.other_radius),
        origin: surface.origin,
        normal: surface.normal,
        u_axis: surface.u_axis,
        size: Some(p.size),
        axis_point: surface.axis_point,
        axis: surface.axis,
        cylinder_radius: Some(p.cylinder_radius),
        length: Some(p.length),
        theta_range: surface.theta_range,
        ref_axis: surface.ref_axis,
        side: surface.side,
        ..ShapeSpec::new("", kind, &c.body)
    };
    [sphere, other]
}

/// Compiles one declared contact with its parameter values `p`: the element of its two shapes
/// ([`contact_shapes`]) and its law.
pub(super) fn compile_contact(
    c: &ContactSpec,
    p: &ContactValues,
    placing: &Placing,
    origin: &str,
) -> Result<ContactElement, SceneError> {
    let [sphere, other] = contact_shapes(c, p);
    element(
        c.name.clone(),
        &sphere_side(&sphere, placing),
        &other_side(&other, placing),
        &p.law,
    )
    .map_err(|message| SceneError::new(origin, item_name("contact", &c.name), "stiffness", message))
}

fn to_v(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

/// A sphere's centre, world frame: given, or its body's initial position.
fn sphere_center(s: &ShapeSpec, body: Option<usize>, placing: &Placing) -> [f64; 3] {
    s.center.unwrap_or_else(|| (placing.pose0)(body).0.into())
}

/// What shape `s` brings to a contact element as the sphere of a pair (unset sizes are 1 m,
/// which a checked scene never leaves unset where they are used; likewise below).
pub(super) fn sphere_side(s: &ShapeSpec, placing: &Placing) -> SphereSide {
    let body = (placing.body_of)(&s.body);
    SphereSide {
        body,
        center: placing.local_point(body, to_v(sphere_center(s, body, placing))),
        radius: s.radius.unwrap_or(1.0),
        material: placing.material(&s.material),
    }
}

/// What shape `s` brings to a contact element as the shape a sphere touches.
pub(super) fn other_side(s: &ShapeSpec, placing: &Placing) -> OtherSide {
    let body = (placing.body_of)(&s.body);
    let kind = match s.kind {
        ShapeType::Sphere => ContactType::SphereSphere,
        ShapeType::Plane => ContactType::SpherePlane,
        ShapeType::Cylinder => ContactType::SphereCylinder,
    };
    let dims = Dimensions {
        other_radius: s.radius.unwrap_or(1.0),
        size: s.size.unwrap_or([1.0, 1.0]),
        cylinder_radius: s.cylinder_radius.unwrap_or(1.0),
        length: s.length.unwrap_or(1.0),
    };
    let center = sphere_center(s, body, placing);
    let (shape, bound_radius) = other_shape(kind, center, &s.surface(), &dims, body, placing);
    OtherSide {
        body,
        kind,
        shape,
        bound_radius,
        material: placing.material(&s.material),
    }
}

/// The sizes of the shape a sphere touches.
struct Dimensions {
    /// sphere_sphere: radius of the other sphere \[m\].
    other_radius: f64,
    /// sphere_plane: side lengths of the rectangle \[m\].
    size: [f64; 2],
    /// sphere_cylinder: cylinder radius \[m\].
    cylinder_radius: f64,
    /// sphere_cylinder: length of the patch \[m\].
    length: f64,
}

/// The shape a sphere touches, in the frame of `body`, and the radius of a bounding sphere
/// around its reference point: a sphere centred at `center` (world), or the plane or cylinder
/// `surface` with the sizes `dims`.
fn other_shape(
    kind: ContactType,
    center: [f64; 3],
    surface: &Surface,
    dims: &Dimensions,
    body: Option<usize>,
    placing: &Placing,
) -> (Shape, f64) {
    match kind {
        ContactType::SphereSphere => {
            let r2 = dims.other_radius;
            (
                Shape::Sphere {
                    center: placing.local_point(body, to_v(center)),
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
                    origin: placing.local_point(body, to_v(surface.origin.unwrap_or_default())),
                    normal: placing.local_dir(body, n),
                    u: placing.local_dir(body, u),
                    v: placing.local_dir(body, w),
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
                    point: placing.local_point(body, to_v(surface.axis_point.unwrap_or_default())),
                    axis: placing.local_dir(body, k),
                    reference: placing.local_dir(body, reference),
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
