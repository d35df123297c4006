//! The variables of the contact groups: per group pair its law constants, per body its total
//! contact force and torque, per group pair its outputs.

use super::law::{law_value, law_variable, FRICTION_KEYS};
use super::*;

/// The variables of the contact groups, after every other (so that no value reference of a
/// scene without groups moves): per group pair its law constants, then per body its total
/// contact force and torque, then per group pair its active count and largest penetration.
pub(super) fn group_variables(scene: &Scene, v: &mut Vec<Variable>) {
    if scene.contact_group.is_empty() {
        return;
    }
    // (a group pair's law constants act on every contact of the pair)
    let scope = "; for every contact of the group pair";
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
        let law = crate::compile::group_law_constants(scene, g);
        let keys = [
            LawKey::Restitution,
            LawKey::Exponent,
            LawKey::Damping,
            LawKey::MinImpactVelocity,
        ];
        // (max_penetration and stiffness only where the scene gives them)
        let given = [LawKey::MaxPenetration, LawKey::Stiffness];
        for key in keys.into_iter().chain(FRICTION_KEYS).chain(given) {
            if let Some(value) = law_value(&law, key) {
                v.push(law_variable(&g.name, key, value, t(key), scope));
            }
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
