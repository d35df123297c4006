//! Contact detection for the three elements of the paper: sphere-sphere (1)-(3),
//! sphere-finite plane (4)-(12) and sphere-cylindrical surface (13).

use crate::model::contact::{ContactElement, Shape};
use crate::spatial::{Frame, Placement};
use nalgebra::Vector3;

/// Result of detection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gap {
    /// Penetration δ (negative when apart) \[m\].
    pub delta: f64,
    /// Penetration rate δ̇ \[m/s\].
    pub delta_dot: f64,
    /// Unit normal from the other shape toward the sphere.
    pub normal: Vector3<f64>,
    /// Contact point (world) \[m\].
    pub point: Vector3<f64>,
    /// Signed distance of the sphere centre's projection inside the patch (positive
    /// inside; infinite for shapes without edges) \[m\].
    pub margin: f64,
}

/// Detects contact between the sphere of `c` (on frame `fs`) and its other shape (on `fo`).
pub fn detect(c: &ContactElement, fs: &Frame, fo: &Frame) -> Gap {
    detect_placed(c, Some(Placement::of(fs)), Some(Placement::of(fo)))
}

/// [`detect`] on the bodies' placements (`None`: the ground): the same numbers, up to the
/// sign of a zero, without the products with the ground's identity rotation and zero
/// velocity, nor the rotation of a sphere centred on its body's centre of mass.
pub fn detect_placed(c: &ContactElement, fs: Option<Placement>, fo: Option<Placement>) -> Gap {
    let center = Placement::point(fs, &c.center);
    let r = c.radius;
    let (delta, normal, point, margin) = match &c.shape {
        Shape::Sphere { center: oc, radius } => {
            let other = Placement::point(fo, oc);
            let d = center - other;
            let dist = d.norm();
            let n = if dist > 0.0 { d / dist } else { Vector3::z() };
            let delta = r + radius - dist;
            (delta, n, other + n * (radius - 0.5 * delta), f64::INFINITY)
        }
        Shape::Plane {
            origin,
            normal,
            u,
            v,
            half,
        } => {
            let o = Placement::point(fo, origin);
            let n = Placement::direction(fo, normal);
            let d = center - o;
            let h = d.dot(&n);
            let su = d.dot(&Placement::direction(fo, u));
            let sv = d.dot(&Placement::direction(fo, v));
            let margin = (half[0] - su.abs()).min(half[1] - sv.abs());
            (r - h, n, center - n * h, margin)
        }
        Shape::Cylinder {
            point,
            axis,
            reference,
            radius,
            half_length,
            theta_range,
            inside,
        } => {
            let a0 = Placement::point(fo, point);
            let k = Placement::direction(fo, axis);
            let d = center - a0;
            let s = d.dot(&k);
            let radial = d - k * s;
            let dist = radial.norm();
            let er = if dist > 0.0 {
                radial / dist
            } else {
                Placement::direction(fo, reference)
            };
            let mut margin = half_length - s.abs();
            if let Some(range) = theta_range {
                let refw = Placement::direction(fo, reference);
                let theta = crate::math::atan2(er.dot(&k.cross(&refw)), er.dot(&refw));
                margin = margin.min(radius * angular_margin(theta, *range));
            }
            let surface = a0 + k * s + er * *radius;
            if *inside {
                (dist - (radius - r), -er, surface, margin)
            } else {
                (radius + r - dist, er, surface, margin)
            }
        }
    };
    let vs = Placement::point_velocity(fs, &point);
    let vo = Placement::point_velocity(fo, &point);
    Gap {
        delta,
        delta_dot: -(vs - vo).dot(&normal),
        normal,
        point,
        margin,
    }
}

/// Signed angular margin \[rad\] of the angle `theta` inside the arc `[lo, hi]` (measured
/// counter-clockwise about the axis): half the arc minus the angular distance from its middle,
/// wrapped to `[0, π]`. Continuous in θ everywhere (no jump at ±π), positive strictly inside.
/// An arc of 2π or more has no edge (infinite margin).
pub fn angular_margin(theta: f64, [lo, hi]: [f64; 2]) -> f64 {
    let half = 0.5 * (hi - lo);
    if half >= std::f64::consts::PI {
        return f64::INFINITY;
    }
    let mid = 0.5 * (hi + lo);
    let off = (theta - mid).rem_euclid(std::f64::consts::TAU);
    let dist = if off > std::f64::consts::PI {
        std::f64::consts::TAU - off
    } else {
        off
    };
    half - dist
}

/// Centre of the other shape's bounding sphere, in its body frame (see
/// [`ContactElement::bound_radius`]).
pub fn bound_center(shape: &Shape) -> Vector3<f64> {
    match shape {
        Shape::Sphere { center, .. } => *center,
        Shape::Plane { origin, .. } => *origin,
        Shape::Cylinder { point, .. } => *point,
    }
}

/// Second time derivative of the separation `s = −δ` at zero joint accelerations (the
/// velocity-product part `J̇ q̇` of `s̈ = J q̈ + J̇ q̇`), for the resting-contact constraint.
///
/// With `u = v_sphere(c) − v_other(c)` the velocity of the sphere centre `c` relative to the
/// other body's material point at `c`, and `H` the Hessian of the distance function of the
/// shape (zero for a plane; `(I − n nᵀ)/d` for a sphere; `±(I − k kᵀ − n nᵀ)/d` for a
/// cylinder, `d` the distance to the centre or axis):
/// `s̈₀ = n · (a_c − a_other(c) − 2 ω_other × u) + uᵀ H u`.
pub fn separation_acceleration_bias(c: &ContactElement, fs: &Frame, fo: &Frame, g: &Gap) -> f64 {
    use crate::spatial::point_acceleration;
    let center = fs.pos + fs.rot * c.center;
    let u = fs.vel.point_velocity(&center) - fo.vel.point_velocity(&center);
    let a_rel = point_acceleration(&fs.acc, &fs.vel, &center) - point_acceleration(&fo.acc, &fo.vel, &center);
    let n = g.normal;
    let un = u.dot(&n);
    let curvature = match &c.shape {
        Shape::Plane { .. } => 0.0,
        Shape::Sphere { center: oc, .. } => {
            let dist = (center - (fo.pos + fo.rot * oc)).norm();
            if dist > 0.0 {
                (u.norm_squared() - un * un) / dist
            } else {
                0.0
            }
        }
        Shape::Cylinder {
            point, axis, inside, ..
        } => {
            let k = fo.rot * axis;
            let d = center - (fo.pos + fo.rot * point);
            let dist = (d - k * d.dot(&k)).norm();
            let uk = u.dot(&k);
            let t = if dist > 0.0 {
                (u.norm_squared() - uk * uk - un * un) / dist
            } else {
                0.0
            };
            if *inside {
                -t
            } else {
                t
            }
        }
    };
    n.dot(&(a_rel - 2.0 * fo.vel.ang.cross(&u))) + curvature
}
