//! Friction (docs/friction.md): the tangential kinematics of a contact and the continuous
//! friction law.
//!
//! **Kinematics.** The slip velocity is the tangential part of the velocity of the sphere's
//! material point at the contact point `p` relative to the other body's material point there:
//! `u = (I − n nᵀ)(v_sphere(p) − v_other(p))`, `v(p) = v_O + ω × p` (in world Plücker
//! coordinates), so it includes the rotation of both bodies (the `ω × r` of each). The same
//! coefficient vectors give the Jacobian rows of the two tangent directions
//! ([`add_tangent_row`]), used by the impulse law.
//!
//! **Law.** The friction force on the sphere is `F = −F_n φ(|u|) u/|u|` with the coefficient
//!
//! ```text
//! φ(s) = μ_dry(s) r(s/v_s) + σ s,   μ_dry(s) = μ + (μ_s − μ) exp(−(s/v_st)²),
//! r(x) = x (2 − x) for x < 1, 1 beyond
//! ```
//!
//! (Stribeck curve `μ_dry`, viscous term `σ s`, regularisation `r`): exact Coulomb (with the
//! Stribeck curve) for slip speeds above the stiction velocity `v_s`; below it the force falls
//! to zero with the slip, continuously and with a continuous derivative at `v_s`. The dry
//! part is bounded by `μ_s F_n` (when `μ_s ≥ μ`). The dissipated power is `−F·u ≥ 0`.

use super::geometry::Gap;
use crate::kinematics::add_jacobian_row;
use crate::model::contact::{ContactElement, Friction};
use crate::model::Model;
use crate::spatial::{Frame, Spatial};
use nalgebra::Vector3;

/// Slip velocity at gap `g` (sphere on frame `fs`, the other shape on `fo`): the tangential
/// velocity of the sphere's material point at the contact point relative to the other body's
/// \[m/s\].
pub fn slip_velocity(fs: &Frame, fo: &Frame, g: &Gap) -> Vector3<f64> {
    let u = fs.vel.point_velocity(&g.point) - fo.vel.point_velocity(&g.point);
    u - g.normal * u.dot(&g.normal)
}

/// Two unit tangent directions completing the normal `n` to a right-handed orthonormal triad
/// `(n, t1, t2)`.
pub fn tangents(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let t = crate::spatial::triad(n);
    (t.column(1).into_owned(), t.column(2).into_owned())
}

/// Adds the Jacobian row of the relative tangential velocity along `t` at gap `g`
/// (`row · q̇ = (v_sphere(p) − v_other(p)) · t`) to `row` (`dof_s`: `Data::dof_s`).
pub fn add_tangent_row(m: &Model, dof_s: &[Spatial], c: &ContactElement, g: &Gap, t: &Vector3<f64>, row: &mut [f64]) {
    let s = Spatial::point_direction(&g.point, t);
    add_jacobian_row(m, dof_s, c.sphere_body, &s, 1.0, row);
    add_jacobian_row(m, dof_s, c.body, &s, -1.0, row);
}

/// Regularisation factor `r(x)`: `x (2 − x)` below 1, 1 beyond (continuous with its
/// derivative at 1; slope 2 at 0).
pub fn regularisation(x: f64) -> f64 {
    if x >= 1.0 {
        1.0
    } else {
        x * (2.0 - x)
    }
}

/// Dry friction coefficient at slip speed `s` (Stribeck curve): `μ + (μ_s − μ) exp(−(s/v_st)²)`.
pub fn dry_coefficient(f: &Friction, s: f64) -> f64 {
    if f.mu_static == f.mu {
        f.mu
    } else {
        let x = s / f.stribeck_velocity;
        f.mu + (f.mu_static - f.mu) * crate::math::exp(-x * x)
    }
}

/// The friction coefficient `φ(s)` of the continuous law at slip speed `s` ≥ 0 (force over
/// normal force).
pub fn coefficient(f: &Friction, s: f64) -> f64 {
    dry_coefficient(f, s) * regularisation(s / f.stiction_velocity) + f.viscous * s
}

/// Friction force on the sphere \[N\] for normal force `normal_force` ≥ 0 and slip velocity
/// `slip`; zero without slip.
pub fn force(f: &Friction, normal_force: f64, slip: &Vector3<f64>) -> Vector3<f64> {
    let s = slip.norm();
    if s == 0.0 || normal_force <= 0.0 {
        return Vector3::zeros();
    }
    slip * (-normal_force * coefficient(f, s) / s)
}

/// Event function of the regularisation: `|u| − v_s` (positive while the contact slides at
/// the full Coulomb value, negative in the regularised, sticking, range).
pub fn slip_function(f: &Friction, slip_speed: f64) -> f64 {
    slip_speed - f.stiction_velocity
}
