//! The law constants as FMU parameters, alike for a declared contact (`<contact>.<key>`) and a
//! contact group pair (`<pair>.<key>`): each key declared once (its unit, range, whether a host
//! may change it after initialisation, its description), read from the law constants and
//! written into them.

use super::*;

/// The keys of the friction law, in the order of their variables.
pub(super) const FRICTION_KEYS: [LawKey; 5] = [
    LawKey::Friction,
    LawKey::StaticFriction,
    LawKey::StribeckVelocity,
    LawKey::ViscousFriction,
    LawKey::StictionVelocity,
];

/// The variable of the law constant `key` (a number, not `law`) of the item `item` (a
/// contact's or a group pair's name) at `value`, referring to `target`; `scope` follows its
/// description (what it acts on, when that is more than the item).
pub(super) fn law_variable(item: &str, key: LawKey, value: f64, target: VarRef, scope: &str) -> Variable {
    let pos = Range::open_above(0.0, true);
    let nonneg = Range::open_above(0.0, false);
    let (name, unit, range, is_tunable, description) = match key {
        LawKey::Law => unreachable!("the law is an enumeration parameter (enum_param)"),
        LawKey::Restitution => (
            "restitution",
            None,
            Range::closed([0.0, 1.0]),
            true,
            "coefficient of restitution e",
        ),
        LawKey::Exponent => (
            "exponent",
            None,
            Range::open_above(1.0, false),
            true,
            "force exponent n of the penetration (1.5 for Hertz)",
        ),
        LawKey::Damping => ("damping", Some("N.s/m"), nonneg, true, "Kelvin-Voigt damping coefficient"),
        LawKey::MaxPenetration => (
            "max_penetration",
            Some("m"),
            Range::open_above(MIN_MAX_PENETRATION, false),
            false,
            "largest admissible penetration (a deeper one fails the step)",
        ),
        LawKey::MinImpactVelocity => (
            "min_impact_velocity",
            Some("m/s"),
            nonneg,
            false,
            "floor on the remembered impact velocity; impulse law: approach speeds below it rest instead of bouncing",
        ),
        LawKey::Stiffness => (
            "stiffness",
            None,
            pos,
            true,
            // N/m^n: the unit depends on the exponent n, so it is stated in the description
            "contact stiffness K of F = K delta^n [N/m^n]",
        ),
        LawKey::Friction => (
            "friction",
            None,
            nonneg,
            true,
            "Coulomb (sliding) friction coefficient mu (0: frictionless)",
        ),
        LawKey::StaticFriction => (
            "static_friction",
            None,
            nonneg,
            true,
            "static friction coefficient mu_s, the peak of the Stribeck curve at zero slip",
        ),
        LawKey::StribeckVelocity => (
            "stribeck_velocity",
            Some("m/s"),
            pos,
            true,
            "Stribeck velocity: the coefficient falls from mu_s to mu as exp(-(slip/v_st)^2)",
        ),
        LawKey::ViscousFriction => (
            "viscous_friction",
            Some("s/m"),
            nonneg,
            true,
            "viscous friction: the coefficient grows by viscous_friction * slip speed",
        ),
        LawKey::StictionVelocity => (
            "stiction_velocity",
            Some("m/s"),
            pos,
            true,
            "regularisation velocity of the continuous friction law: full friction above it, proportional below (creep)",
        ),
    };
    let var = param(
        format!("{item}.{name}"),
        value,
        unit,
        range,
        target,
        &format!("{description}{scope}"),
    );
    if is_tunable {
        tunable(var)
    } else {
        var
    }
}

/// The value of the law constant `key` in `law`: None for the law itself (an enumeration) and
/// for a `max_penetration` or `stiffness` the scene does not give.
pub(super) fn law_value(law: &LawConstants, key: LawKey) -> Option<f64> {
    let f = &law.friction;
    match key {
        LawKey::Law => None,
        LawKey::Restitution => Some(law.restitution),
        LawKey::Exponent => Some(law.exponent),
        LawKey::Damping => Some(law.damping),
        LawKey::MaxPenetration => law.max_penetration,
        LawKey::MinImpactVelocity => Some(law.min_impact_velocity),
        LawKey::Stiffness => law.stiffness,
        LawKey::Friction => Some(f.mu),
        LawKey::StaticFriction => Some(f.mu_static),
        LawKey::StribeckVelocity => Some(f.stribeck_velocity),
        LawKey::ViscousFriction => Some(f.viscous),
        LawKey::StictionVelocity => Some(f.stiction_velocity),
    }
}

/// Writes the value `x` of the law constant `key` into `law` (a contact's or a group pair's). A
/// law value that is no item (0, the start of the Integer twin `law_index`) changes nothing.
pub(super) fn set_law_value(law: &mut LawConstants, key: LawKey, x: f64) {
    match key {
        LawKey::Law => {
            if let Some(l) = Law::from_value(x as i64) {
                law.law = l;
            }
        }
        LawKey::Restitution => law.restitution = x,
        LawKey::Exponent => law.exponent = x,
        LawKey::Damping => law.damping = x,
        LawKey::MaxPenetration => law.max_penetration = Some(x),
        LawKey::MinImpactVelocity => law.min_impact_velocity = x,
        LawKey::Stiffness => law.stiffness = Some(x),
        LawKey::Friction => law.friction.mu = x,
        LawKey::StaticFriction => law.friction.mu_static = x,
        LawKey::StribeckVelocity => law.friction.stribeck_velocity = x,
        LawKey::ViscousFriction => law.friction.viscous = x,
        LawKey::StictionVelocity => law.friction.stiction_velocity = x,
    }
}
