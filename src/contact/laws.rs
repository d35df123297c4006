//! Contact force laws (paper (20)-(26) and the modern Hunt-Crossley and Flores laws).
//!
//! Every law returns the total normal force, its elastic part `K δ^n` and the elastic energy
//! `K δ^(n+1)/(n+1)`. The force never pulls: a damping term that would make the total
//! negative (a tensile force near separation) is cut at zero, and the energy balance counts
//! the difference `(F − F_elastic) δ̇` as dissipated power.

use super::ContactElement;
use crate::scene::Law;

/// Force at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Force {
    /// Total normal force, ≥ 0 [N].
    pub total: f64,
    /// Elastic part [N].
    pub elastic: f64,
    /// Elastic energy stored [J].
    pub energy: f64,
}

/// Normal force of contact `c` at penetration `delta` ≥ 0, rate `delta_dot` and remembered
/// impact velocity `impact_velocity` (δ̇⁻, already floored).
pub fn force(c: &ContactElement, delta: f64, delta_dot: f64, impact_velocity: f64) -> Force {
    let (k, n, e) = (c.stiffness, c.exponent, c.restitution);
    let (elastic, energy) = match c.law {
        Law::KelvinVoigt => (k * delta, 0.5 * k * delta * delta),
        _ => {
            let p = delta.powf(n);
            (k * p, k * p * delta / (n + 1.0))
        }
    };
    let v = impact_velocity;
    let total = match c.law {
        Law::KelvinVoigt => elastic + c.damping * delta_dot,
        Law::Hertz | Law::Impulse => elastic,
        Law::HertzLn => elastic * (1.0 + 0.75 * (1.0 - e * e) * delta_dot / v),
        Law::HuntCrossley => elastic * (1.0 + 1.5 * (1.0 - e) * delta_dot / v),
        Law::Flores => elastic * (1.0 + 1.6 * (1.0 - e) / e * delta_dot / v),
    };
    Force {
        total: total.max(0.0),
        elastic,
        energy,
    }
}
