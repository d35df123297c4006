//! The contact list: a contact element from its compiled sides and law constants (a declared
//! contact's at compilation, a candidate pair's whenever the broad phase lists it), and the
//! data's list made for a list of candidate pairs ([`set_candidates`]: the broad phase's
//! stage; the model does not change), each pair's place in the former list
//! ([`former_indices`]) and the check of the pairs new to it ([`check_new_pairs`]).

use crate::contact::laws::{hertz_stiffness, hysteresis_factor};
use crate::model::contact::{ContactElement, ContactMemory, LawConstants, OtherSide, Shape, SphereSide};
use crate::model::groups::{Candidate, Groups};
use crate::model::{Data, Model};
use crate::scene::Law;
use std::borrow::Cow;

/// The contact element `name` of a sphere and the shape it touches, with the law constants
/// `law`: the stiffness given, or Hertz's from the two materials and the effective radius;
/// the hysteresis factor. Errs (with the message) when neither stiffness nor both materials
/// are given for a law that needs a stiffness.
pub fn element(
    name: String,
    sphere: &SphereSide,
    other: &OtherSide,
    law: &LawConstants,
) -> Result<ContactElement, &'static str> {
    let radius = sphere.radius;
    let r_eff = match other.shape {
        Shape::Sphere { radius: r2, .. } => radius * r2 / (radius + r2),
        Shape::Plane { .. } => radius,
        Shape::Cylinder {
            radius: rho, inside, ..
        } => {
            // Effective radius of the elliptical contact: geometric mean of the principal
            // relative radii (axial: R; circumferential: 1/(1/R ± 1/ρ)).
            let circ = if inside {
                1.0 / (1.0 / radius - 1.0 / rho)
            } else {
                1.0 / (1.0 / radius + 1.0 / rho)
            };
            (radius * circ).sqrt()
        }
    };
    let (stiffness, derived) = match law.stiffness {
        Some(k) => (k, false),
        None => match (sphere.material, other.material) {
            (Some([ea, nua]), Some([eb, nub])) => (hertz_stiffness(ea, nua, eb, nub, r_eff), true),
            _ if law.law == Law::Impulse => (0.0, true),
            _ => return Err("give stiffness, or both sphere_material and material"),
        },
    };
    Ok(ContactElement {
        name,
        kind: other.kind,
        law: law.law,
        restitution: law.restitution,
        sphere_body: sphere.body,
        center: sphere.center,
        radius,
        body: other.body,
        shape: other.shape.clone(),
        stiffness,
        stiffness_derived: derived,
        exponent: law.exponent,
        damping: law.damping,
        max_penetration: law.max_penetration.unwrap_or(radius),
        min_impact_velocity: law.min_impact_velocity,
        bound_radius: other.bound_radius,
        impulse_method: law.impulse_method,
        constraint_row: None,
        hysteresis: hysteresis_factor(law.law, law.restitution),
        friction: law.friction,
    })
}

/// Reserves one constraint row per impulse-law contact after the `nc` loop rows (for its
/// resting mode) and returns the new total.
pub fn reserve_constraint_rows(contacts: &mut [ContactElement], nc: usize) -> usize {
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

/// The contact element of candidate pair `c`, named `name`, from the sides and law constants
/// compiled in `groups` (Err: the message of [`element`]).
pub fn candidate_element(groups: &Groups, c: &Candidate, name: String) -> Result<ContactElement, &'static str> {
    element(
        name,
        &groups.sphere_sides[c.sphere],
        &groups.other_sides[c.other],
        &groups.laws[c.pair],
    )
}

/// [`former_indices`]: a candidate pair not in the former list.
pub const NOT_LISTED: usize = usize::MAX;

/// Per candidate pair of the list `new`, its index in the list `old` ([`NOT_LISTED`]: none),
/// into `out`: by one walk through both when both are sorted (the broad phase's lists are),
/// by a map of `old` otherwise (a pair listed twice: its last index).
pub fn former_indices(old: &[Candidate], new: &[Candidate], out: &mut Vec<usize>) {
    out.clear();
    let sorted = |l: &[Candidate]| l.windows(2).all(|w| w[0] < w[1]);
    if sorted(old) && sorted(new) {
        let mut i = 0;
        for c in new {
            while i < old.len() && old[i] < *c {
                i += 1;
            }
            out.push(if old.get(i) == Some(c) { i } else { NOT_LISTED });
        }
    } else {
        let index: rustc_hash::FxHashMap<Candidate, usize> = old.iter().enumerate().map(|(i, c)| (*c, i)).collect();
        out.extend(new.iter().map(|c| index.get(c).copied().unwrap_or(NOT_LISTED)));
    }
}

/// Checks the candidate pairs of `found` new to the list (those whose index in the former list,
/// `former` of [`former_indices`], is [`NOT_LISTED`]): that their contact elements can be made,
/// and that none touches at the kinematics in `d` (such a pair was found too late, after a body
/// moved more than half the broad-phase margin within one step, which the step's bounds allow
/// only to a body accelerated far beyond gravity). Err: the message. (Checked before a list
/// changes, so that making it cannot fail halfway.)
pub fn check_new_pairs(m: &Model, d: &Data, found: &[Candidate], former: &[usize]) -> Result<(), String> {
    for (c, _) in found.iter().zip(former).filter(|&(_, &i)| i == NOT_LISTED) {
        let e = candidate_element(&m.groups, c, String::new())
            .map_err(|message| format!("contact {:?}: {message}", m.groups.element_name(c)))?;
        if crate::contact::event_function(&e, &crate::contact::gap_of(&e, d)) > 0.0 {
            return Err(format!(
                "contact {:?} touched before the broad phase listed it: a body moved more than half the \
                 broad-phase margin ({} m) within one step; raise [broad_phase] margin",
                m.groups.element_name(c),
                m.groups.margin
            ));
        }
    }
    Ok(())
}

/// The name of contact `i` of the data's list: a declared contact's own, or for a candidate pair
/// of the contact groups `<group pair>[<sphere>:<other>]` (1-based shape numbers; its element
/// holds no name, so that listing it allocates none).
pub fn contact_name<'a>(m: &Model, d: &'a Data, i: usize) -> Cow<'a, str> {
    match i.checked_sub(m.groups.n_explicit).and_then(|k| d.candidates.get(k)) {
        Some(c) => Cow::Owned(m.groups.element_name(c)),
        None => Cow::Borrowed(&d.contacts[i].name),
    }
}

/// The contact list of the candidate pairs `found`: the data's declared contacts, then one
/// element per pair (Err: a pair whose law needs a stiffness that neither it nor the
/// materials give). The data is not changed; [`set_contact_list`] makes it the data's.
pub fn contact_list(m: &Model, d: &Data, found: &[Candidate]) -> Result<Vec<ContactElement>, String> {
    let n = m.groups.n_explicit;
    let mut contacts = Vec::with_capacity(n + found.len());
    contacts.extend_from_slice(&d.contacts[..n]);
    for c in found {
        let e = candidate_element(&m.groups, c, String::new())
            .map_err(|message| format!("contact {:?}: {message}", m.groups.element_name(c)))?;
        contacts.push(e);
    }
    Ok(contacts)
}

/// The contact memory of each candidate pair of a new list, from the data's: by the pair's
/// index in the data's list (`former`, of [`former_indices`]); a pair new to the list starts
/// apart.
pub fn kept_memory<'a>(m: &Model, d: &'a Data, former: &'a [usize]) -> impl Iterator<Item = ContactMemory> + 'a {
    let n = m.groups.n_explicit;
    former.iter().map(move |&i| match i {
        NOT_LISTED => ContactMemory::default(),
        i => d.contact_memory.get(n + i).copied().unwrap_or_default(),
    })
}

/// Makes `contacts`, the [`contact_list`] of the candidate pairs `found`, the data's: their
/// constraint rows, step powers and work buffers. A pair that was listed before (`former`: each
/// pair's index in the data's list, of [`former_indices`]) keeps its contact memory; a new one
/// starts apart.
pub fn set_contact_list(
    m: &Model,
    d: &mut Data,
    found: &[Candidate],
    former: &[usize],
    mut contacts: Vec<ContactElement>,
) {
    let n = m.groups.n_explicit;
    let nc = reserve_constraint_rows(&mut contacts, m.fixed_rows());
    let kept: Vec<ContactMemory> = kept_memory(m, d, former).collect();
    d.contact_memory.truncate(n);
    d.contact_memory.extend(kept);
    crate::model::step_rtol_powers(&contacts, m.solver.rtol, &mut d.step_rtol_powers);
    d.contacts = contacts;
    d.candidates = found.to_vec();
    d.nc = nc;
    d.fit_contact_work(m);
    // (the kinematics stay, but no contact forces were evaluated for this list)
    d.planned_kinematics = false;
    // (the contact outputs were zeroed with the work: they are evaluated again when read)
    d.outputs_valid = false;
}

/// Makes the data's contact list that of the candidate pairs `found` ([`contact_list`], then
/// [`set_contact_list`]); on an error the data is unchanged.
pub fn set_candidates(m: &Model, d: &mut Data, found: &[Candidate]) -> Result<(), String> {
    let contacts = contact_list(m, d, found)?;
    let mut former = Vec::new();
    former_indices(&d.candidates, found, &mut former);
    set_contact_list(m, d, found, &former, contacts);
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::model::step_rtol_powers;
    use crate::scene::{Law, Scene};

    /// The powers of rtol of a contact list, reused for contacts of the same law and exponent,
    /// are those taken for each contact afresh, bit for bit: over a list of more laws and
    /// exponents than the powers kept at once, in an order that comes back to each.
    #[test]
    fn reused_powers_of_rtol_are_those_taken_afresh() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/two_spheres/scene.toml");
        let scene = Scene::from_file(&path).unwrap();
        let (m, _) = crate::compile::compile(&scene, "two_spheres").unwrap();
        let first = m.initial_contacts[0].clone();
        let kinds = [
            (Law::Hertz, 1.5),
            (Law::KelvinVoigt, 1.0),
            (Law::Hertz, 2.2),
            (Law::HertzLn, 1.5),
            (Law::Hertz, 1.0),
            (Law::Hertz, 3.1),
            (Law::Hertz, 0.7),
            // (the same touch power as Kelvin-Voigt's, another separation power)
            (Law::Hertz, 2.0),
            (Law::KelvinVoigt, 3.0),
        ];
        let contacts: Vec<_> = (0..60)
            .map(|k| {
                let (law, exponent) = kinds[(k * 5 + k / 9) % kinds.len()];
                let mut c = first.clone();
                c.law = law;
                c.exponent = exponent;
                c
            })
            .collect();
        let rtol = 3.7e-7;
        let afresh: Vec<[f64; 2]> = contacts
            .iter()
            .map(|c| [c.touch_power(), c.separation_power()].map(|p| crate::math::powf(rtol, p)))
            .collect();
        let mut reused = Vec::new();
        step_rtol_powers(&contacts, rtol, &mut reused);
        assert_eq!(reused.len(), afresh.len());
        for (k, (a, b)) in reused.iter().zip(&afresh).enumerate() {
            assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "contact {k}");
        }
    }
}
