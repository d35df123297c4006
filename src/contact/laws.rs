//! Contact force laws (paper (20)-(26) and the modern Hunt-Crossley and Flores laws).
//!
//! Every law returns the total normal force, its elastic part `K δ^n` and the elastic energy
//! `K δ^(n+1)/(n+1)` (Kelvin-Voigt: `K δ²/2`). The force never pulls: a damping term that
//! would make the total negative (a tensile force near separation, which Kelvin-Voigt always
//! produces and the hysteresis laws produce when the exit rate exceeds what their damping
//! factor assumes) is cut at zero, and the energy balance counts the difference
//! `(F − F_elastic) δ̇` as dissipated power. The unclamped value is returned as well, so the
//! engine can locate the instant the cut starts.

use crate::model::contact::ContactElement;
use crate::scene::Law;

/// Force at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Force {
    /// Total normal force, ≥ 0 \[N\].
    pub total: f64,
    /// The law's value before the cut at zero (negative: the law would pull) \[N\].
    pub unclamped: f64,
    /// Elastic part \[N\].
    pub elastic: f64,
    /// Elastic energy stored \[J\].
    pub energy: f64,
}

/// Hertz stiffness (22), corrected: `K = 4/(3π(h_i+h_j)) · sqrt(R_i R_j/(R_i+R_j))`,
/// `h = (1−ν²)/(πE)`. `r_eff` is the effective radius `R_i R_j/(R_i+R_j)`.
pub fn hertz_stiffness(e1: f64, nu1: f64, e2: f64, nu2: f64, r_eff: f64) -> f64 {
    let h = |e: f64, nu: f64| (1.0 - nu * nu) / (std::f64::consts::PI * e);
    4.0 / (3.0 * std::f64::consts::PI * (h(e1, nu1) + h(e2, nu2))) * r_eff.sqrt()
}

/// Damping factor `d` of the hysteresis laws, `F = K δ^n (1 + d δ̇/δ̇⁻)`:
/// Lankarani-Nikravesh (26) `3(1 − e²)/4`, Hunt-Crossley `3(1 − e)/2`, Flores `8(1 − e)/(5e)`.
/// Zero for the other laws.
pub fn hysteresis_factor(law: Law, e: f64) -> f64 {
    match law {
        Law::HertzLn => 0.75 * (1.0 - e * e),
        Law::HuntCrossley => 1.5 * (1.0 - e),
        Law::Flores => 1.6 * (1.0 - e) / e,
        _ => 0.0,
    }
}

/// Normal force of contact `c` at penetration `delta` \[m\], rate `delta_dot` \[m/s\] and
/// remembered impact velocity `impact_velocity` (δ̇⁻, already floored) \[m/s\]. A negative
/// `delta` (an active contact evaluated past its separation, inside the step that crosses
/// it): Kelvin-Voigt's elastic part continues linearly through δ = 0 (its total force is cut
/// to zero there already), so that the right-hand side stays smooth up to the separation
/// event and the dense output that locates it is accurate; the Hertz family is floored at
/// δ = 0 (`δ^n` is C¹ there).
pub fn force(c: &ContactElement, delta: f64, delta_dot: f64, impact_velocity: f64) -> Force {
    let (k, n) = (c.stiffness, c.exponent);
    let (elastic, energy) = match c.law {
        Law::KelvinVoigt => (k * delta, 0.5 * k * delta * delta),
        _ => {
            let delta = delta.max(0.0);
            // δ·√δ for the Hertz exponent: exact and several times cheaper than powf
            let p = if n == 1.5 {
                delta * delta.sqrt()
            } else {
                crate::math::powf(delta, n)
            };
            (k * p, k * p * delta / (n + 1.0))
        }
    };
    let unclamped = match c.law {
        Law::KelvinVoigt => elastic + c.damping * delta_dot,
        Law::Hertz | Law::Impulse => elastic,
        Law::HertzLn | Law::HuntCrossley | Law::Flores => elastic * (1.0 + c.hysteresis * delta_dot / impact_velocity),
    };
    Force {
        total: unclamped.max(0.0),
        unclamped,
        elastic,
        energy,
    }
}

/// True for the laws whose force can be cut at zero before δ returns to zero (they have a
/// damping term).
pub fn can_clamp(c: &ContactElement) -> bool {
    match c.law {
        Law::KelvinVoigt => c.damping > 0.0,
        Law::HertzLn | Law::HuntCrossley | Law::Flores => c.hysteresis > 0.0,
        Law::Hertz | Law::Impulse => false,
    }
}

/// A function whose sign tells whether the law is cut at zero at this instant (negative: the
/// unclamped law would pull): `K δ + c δ̇` for Kelvin-Voigt, the hysteresis bracket
/// `1 + d δ̇/δ̇⁻` for the Hertz family (its sign is the force's for δ > 0, and it does not
/// vanish together with δ at separation), 1 for laws without damping.
pub fn clamp_function(c: &ContactElement, delta: f64, delta_dot: f64, impact_velocity: f64) -> f64 {
    match c.law {
        Law::KelvinVoigt => c.stiffness * delta + c.damping * delta_dot,
        Law::HertzLn | Law::HuntCrossley | Law::Flores => 1.0 + c.hysteresis * delta_dot / impact_velocity,
        Law::Hertz | Law::Impulse => 1.0,
    }
}
