//! The variables of the contact groups: per group pair its law constants, per body its total
//! contact force and torque, per group pair its outputs.

use super::table::{enum_param, param, tunable};
use super::*;

/// The variables of the contact groups, after every other (so that no value reference of a
/// scene without groups moves): per group pair its law constants, then per body its total
/// contact force and torque, then per group pair its active count and largest penetration.
pub(super) fn group_variables(scene: &Scene, v: &mut Vec<Variable>) {
    if scene.contact_group.is_empty() {
        return;
    }
    // (a group pair's law constant: `table::param` described for every contact of the pair)
    let group_param = |name: String, start: f64, unit, range: Range, target, is_tunable: bool, description: &str| {
        let var = param(
            name,
            start,
            unit,
            range,
            target,
            &format!("{description} (every contact of the group pair)"),
        );
        if is_tunable {
            tunable(var)
        } else {
            var
        }
    };
    let pos = Range::open_above(0.0, true);
    let nonneg = Range::open_above(0.0, false);
    let unit_interval = Range::closed([0.0, 1.0]);
    for (p, g) in scene.contact_group.iter().enumerate() {
        let t = |key| VarRef::Group(p, key);
        v.push(enum_param(
            format!("{}.law", g.name),
            EnumType::ContactLaw,
            g.law as i64,
            t(LawKey::Law),
            "contact force law of every contact of the group pair".into(),
        ));
        v.push(integer_twin(
            format!("{}.law_index", g.name),
            EnumType::ContactLaw,
            &format!("{}.law", g.name),
            t(LawKey::Law),
        ));
        let template = scene.group_pair_contact(g, &g.name, &scene.shape[0], &scene.shape[0]);
        let [mu, mu_s, v_st, sigma, v_s] = template.friction_or_default();
        for (key, value, unit, range, target, tunable, description) in [
            (
                "restitution",
                g.restitution,
                None,
                unit_interval,
                LawKey::Restitution,
                true,
                "coefficient of restitution e",
            ),
            (
                "exponent",
                g.exponent.unwrap_or(1.5),
                None,
                Range::open_above(1.0, false),
                LawKey::Exponent,
                true,
                "force exponent n of the penetration",
            ),
            (
                "damping",
                g.damping.unwrap_or(0.0),
                Some("N.s/m"),
                nonneg,
                LawKey::Damping,
                true,
                "Kelvin-Voigt damping coefficient",
            ),
            (
                "min_impact_velocity",
                template.min_impact_velocity_or_default(),
                Some("m/s"),
                nonneg,
                LawKey::MinImpactVelocity,
                false,
                "floor on the remembered impact velocity",
            ),
            (
                "friction",
                mu,
                None,
                nonneg,
                LawKey::Friction,
                true,
                "Coulomb (sliding) friction coefficient mu",
            ),
            (
                "static_friction",
                mu_s,
                None,
                nonneg,
                LawKey::StaticFriction,
                true,
                "static friction coefficient mu_s",
            ),
            (
                "stribeck_velocity",
                v_st,
                Some("m/s"),
                pos,
                LawKey::StribeckVelocity,
                true,
                "Stribeck velocity",
            ),
            (
                "viscous_friction",
                sigma,
                Some("s/m"),
                nonneg,
                LawKey::ViscousFriction,
                true,
                "viscous friction coefficient",
            ),
            (
                "stiction_velocity",
                v_s,
                Some("m/s"),
                pos,
                LawKey::StictionVelocity,
                true,
                "regularisation velocity of the continuous friction law",
            ),
        ] {
            v.push(group_param(
                format!("{}.{key}", g.name),
                value,
                unit,
                range,
                t(target),
                tunable,
                description,
            ));
        }
        if let Some(d) = g.max_penetration {
            v.push(group_param(
                format!("{}.max_penetration", g.name),
                d,
                Some("m"),
                Range::open_above(MIN_MAX_PENETRATION, false),
                t(LawKey::MaxPenetration),
                false,
                "largest admissible penetration",
            ));
        }
        if let Some(k) = g.stiffness {
            v.push(group_param(
                format!("{}.stiffness", g.name),
                k,
                None,
                pos,
                t(LawKey::Stiffness),
                true,
                "contact stiffness K of F = K delta^n [N/m^n]",
            ));
        }
    }
    let depends_on_inputs = !scene.input.is_empty();
    let out = |name, vtype, unit, target, description| {
        output_variable(name, vtype, unit, target, description, depends_on_inputs)
    };
    for (b, body) in scene.body.iter().enumerate() {
        let vectors: [(_, _, ComponentRef, _); 2] = [
            (
                "contact_force",
                "N",
                VarRef::BodyContactForce,
                "total contact force on the body (normal and friction, every contact)",
            ),
            (
                "contact_torque",
                "N.m",
                VarRef::BodyContactTorque,
                "total contact torque on the body about its centre of mass",
            ),
        ];
        for (key, unit, target, what) in vectors {
            v.extend(world_vector(
                &body.name,
                key,
                unit,
                |k| target(b, k),
                what,
                depends_on_inputs,
            ));
        }
    }
    for (p, g) in scene.contact_group.iter().enumerate() {
        v.push(out(
            format!("{}.active_contacts", g.name),
            VarType::Integer,
            None,
            VarRef::GroupActive(p),
            "number of contacts of the group pair in contact".into(),
        ));
        v.push(out(
            format!("{}.largest_penetration", g.name),
            VarType::Real,
            Some("m"),
            VarRef::GroupLargestPenetration(p),
            "largest penetration among the contacts of the group pair (0: none in contact)".into(),
        ));
    }
}
