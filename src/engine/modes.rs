//! Contact modes: which contacts are active, and how that changes at a located event.
//!
//! - Each contact has a *mode function* whose sign changes exactly when its mode must change
//!   (touch and separation of a continuous-law contact, release of a resting impulse-law
//!   contact, an impulse-law contact reaching the surface) and, for the damped laws, a *clamp
//!   function* whose sign tells whether the force is cut at zero ([`contact_event_values`]).
//! - At an event the driver calls [`handle_events`]: continuous contacts touch or separate;
//!   impulse-law contacts are settled by [`settle_impulse_contacts`] (rounds of impacts, then
//!   the resting set).

use crate::contact::elements::contact_name;
use crate::contact::{
    broad_phase, event_function, friction, gap, geometry, impulse, laws, resting_force, ContactElement, ContactMemory,
    Gap,
};
use crate::forward::{evaluate, evaluate_current};
use crate::kinematics::frame;
use crate::model::{ContactEventKind, Data, Model};
use crate::scene::Law;
use nalgebra::Vector3;

/// Mode function, clamp function and (δ, δ̇) of contact `i` at the evaluated kinematics
/// (`clamp`: evaluate the clamp function, else 1).
pub fn contact_event_values(d: &Data, i: usize, clamp: bool) -> (f64, f64, (f64, f64)) {
    let c = &d.contacts[i];
    let mem = d.contact_memory[i];
    if c.law == Law::Impulse && mem.active {
        // Resting: holds while the normal force pushes and the sphere stays on the patch.
        let g = gap(d, i);
        return (resting_force(d, i).min(g.margin), 1.0, (g.delta, g.delta_dot));
    }
    if let Some((v, closing)) = broad_phase(c, d) {
        return (v, 1.0, (v, closing));
    }
    gap_event_values(c, mem, &gap(d, i), clamp)
}

/// [`contact_event_values`] of a continuous-law contact that is active (in contact) from its
/// exact gap as the right-hand side's evaluation at the same kinematics computed it
/// (`d.events.stage_gaps`: the same numbers as [`gap`], not computed again).
pub fn stage_event_values(d: &Data, i: usize, clamp: bool) -> (f64, f64, (f64, f64)) {
    let c = &d.contacts[i];
    if let Some((v, closing)) = broad_phase(c, d) {
        return (v, 1.0, (v, closing));
    }
    let (delta, delta_dot, margin) = d.events.stage_gaps[i];
    let g = Gap {
        delta,
        delta_dot,
        margin,
        normal: Vector3::zeros(),
        point: Vector3::zeros(),
    };
    gap_event_values(c, d.contact_memory[i], &g, clamp)
}

/// Mode function, clamp function and (δ, δ̇) of contact `c` (memory `mem`) at its exact gap
/// `g` (its δ, δ̇ and margin).
fn gap_event_values(c: &ContactElement, mem: ContactMemory, g: &Gap, clamp: bool) -> (f64, f64, (f64, f64)) {
    let clamp_value = if clamp && mem.active && c.law != Law::Impulse && laws::can_clamp(c) {
        laws::clamp_function(c, g.delta.max(0.0), g.delta_dot, mem.impact_velocity)
    } else {
        1.0
    };
    let mut mode = event_function(c, g);
    if c.law == Law::Impulse && g.delta_dot < 0.0 {
        // An impulse contact that separates is apart whatever its (tiny) overlap: the
        // state right after an impact (located a hair past δ = 0) must not count as in
        // contact, or a bounce shorter than one step would go unseen.
        mode = mode.min(0.0);
    }
    (mode, clamp_value, (g.delta, g.delta_dot))
}

/// The friction event function of contact `i` at the evaluated kinematics: slip speed minus
/// stiction velocity for an active contact with friction (continuous law in contact, or
/// impulse law resting) (its sign change is
/// a stick or slip transition, where the regularised law changes its formula), else 1.
#[inline]
pub fn slip_event_value(d: &Data, i: usize) -> f64 {
    let c = &d.contacts[i];
    // active: in contact under a continuous law, resting under the impulse law
    if !c.friction.is_on() || !d.contact_memory[i].active {
        return 1.0;
    }
    slip_function_value(d, c)
}

/// [`slip_event_value`] of a continuous-law contact that is active, from the slip speed the
/// right-hand side's evaluation at the same kinematics computed (`ContactOutput::slip_speed`,
/// as [`stage_event_values`] takes its gap: the same numbers, not computed again).
pub fn stage_slip_event_value(d: &Data, i: usize) -> f64 {
    let c = &d.contacts[i];
    if c.friction.is_on() {
        friction::slip_function(&c.friction, d.contact_out[i].slip_speed)
    } else {
        1.0
    }
}

/// [`slip_event_value`] of an active contact `c` with friction.
fn slip_function_value(d: &Data, c: &ContactElement) -> f64 {
    let fs = frame(d, c.sphere_body);
    let fo = frame(d, c.body);
    let g = geometry::detect(c, &fs, &fo);
    friction::slip_function(&c.friction, friction::slip_velocity(&fs, &fo, &g).norm())
}

/// The band around a damped law's cut (relative to `clamp_scale`) inside which a crossing
/// of its clamp function is not located. The force is continuous across the cut (zero on
/// both sides), so the integrator's error control covers a crossing it steps over; where the
/// contact's state slides along the cut (a ball in a rattling pile whose damping holds its
/// force at zero), locating every crossing would cut every step short at the next one.
pub const CLAMP_BAND: f64 = 1e-6;

/// The scale of contact `c`'s clamp function ([`crate::contact::laws::clamp_function`]): 1 for
/// the hysteresis laws (`1 + D δ̇/δ̇⁻`), the damping force at the touch `c δ̇⁻` for
/// Kelvin-Voigt's `K δ + c δ̇`.
fn clamp_scale(c: &ContactElement, impact_velocity: f64) -> f64 {
    match c.law {
        Law::KelvinVoigt => c.damping * impact_velocity,
        _ => 1.0,
    }
}

/// True when the crossing of event function `k` (mode functions first, then clamp functions,
/// then friction functions)
/// from `g0` to `g1` needs handling (an impulse contact leaving its zone after an impact does
/// not; a cut of the force only matters while the contact is active).
pub fn relevant_crossing(d: &Data, k: usize, g0: f64, g1: f64, delta1: f64) -> bool {
    if !crossed(g0, g1) {
        return false;
    }
    let n_contacts = d.contacts.len();
    if k >= 2 * n_contacts {
        let i = k - 2 * n_contacts;
        return d.contact_memory[i].active && d.contacts[i].friction.is_on();
    }
    if k >= n_contacts {
        let i = k - n_contacts;
        let mem = &d.contact_memory[i];
        // (a crossing that stays within the band around the cut is the force sliding along
        // it, zero on both sides: locating each would stop every step; see CLAMP_BAND)
        return mem.active && g0.abs().max(g1.abs()) > CLAMP_BAND * clamp_scale(&d.contacts[i], mem.impact_velocity);
    }
    let c = &d.contacts[k];
    if c.law == Law::Impulse && !d.contact_memory[k].active && g1 <= 0.0 {
        // Leaving after an impact: nothing to do, unless δ went past δ_max.
        return delta1 >= 0.5 * c.max_penetration;
    }
    true
}

/// True when an event function changed its sign from `g0` to `g1` (positive against not
/// positive): the test [`relevant_crossing`] starts with.
#[inline]
pub fn crossed(g0: f64, g1: f64) -> bool {
    (g0 <= 0.0) != (g1 <= 0.0)
}

/// True when a resting contact's normal force does not push or it left its patch (evaluates
/// the current state).
pub fn resting_violated(m: &Model, d: &mut Data) -> bool {
    evaluate_current(m, d);
    (0..d.contacts.len()).any(|i| {
        d.contacts[i].law == Law::Impulse && d.contact_memory[i].active && contact_event_values(d, i, false).0 <= 0.0
    })
}

/// Applies the mode changes at an event state (`d.events.g` before, `d.events.g_new` now):
/// touch and separation of continuous contacts (logged), cuts of their force (logged), and
/// the impulse-law contacts settled. An error when a contact reached `max_penetration`.
///
/// The caller evaluated the event values at the event state `d.state`
/// ([`crate::engine::events::event_values`], which leaves the full kinematics there).
/// Without impulse-law contacts the modes change by the gaps alone, read on those kinematics
/// (the force a cut logs is the law's, as the right-hand side computes it), and only the
/// contacts whose mode or clamp function changed its sign are looked at; the integrator's
/// restart evaluates the rest there. With them, the whole evaluation (their resting forces
/// are multipliers of the constrained solve, and their impacts read the mass matrix).
pub fn handle_events(m: &Model, d: &mut Data) -> Result<(), String> {
    let impulse_law = d.contacts.iter().any(|c| c.law == Law::Impulse);
    if impulse_law {
        evaluate_current(m, d);
    }
    debug_assert!(
        d.eval_state == d.state,
        "the event values were evaluated at the event state"
    );
    let n_contacts = d.contacts.len();
    let mut impulse_work = false;
    d.events.changed.clear();
    for i in 0..n_contacts {
        let (before, now) = (d.events.g[i], d.events.g_new[i]);
        if !crossed(before, now) && !crossed(d.events.g[n_contacts + i], d.events.g_new[n_contacts + i]) {
            // (neither crossing can be relevant: nothing changes or is logged)
            continue;
        }
        let c = &d.contacts[i];
        let gap = gap(d, i);
        let mem = d.contact_memory[i];
        let relevant = relevant_crossing(d, i, before, now, gap.delta);
        // Reaching δ_max in contact is an error. (A continuous contact that is not active
        // there is a sphere passing behind a plate: not a contact at all.)
        let in_contact = if c.law == Law::Impulse { !mem.active } else { mem.active };
        if relevant && now <= 0.0 && in_contact && gap.delta >= c.max_penetration * (1.0 - 1e-9) {
            return Err(format!(
                "contact {:?}: penetration {:.6e} m reached max_penetration {:.6e} m (the contact is too \
                 soft or the impact too fast for this model, or the step too long: raise max_penetration or \
                 stiffness, or lower solver.max_step)",
                contact_name(m, d, i),
                gap.delta,
                c.max_penetration
            ));
        }
        if c.law == Law::Impulse {
            impulse_work |= relevant;
            continue;
        }
        if relevant {
            // A touch comes through δ = 0 (or over the patch edge with a small overlap);
            // entering the zone deeper than δ_max/2 is the sphere coming through the back
            // of the shape: ignored.
            if now > 0.0 && !mem.active && gap.delta < 0.5 * c.max_penetration {
                let v = gap.delta_dot.max(c.min_impact_velocity);
                let memory = &mut d.contact_memory[i];
                memory.active = true;
                memory.impact_velocity = v;
                d.events.changed.push(i);
                d.log_event(i, ContactEventKind::Touch, gap.delta, gap.delta_dot, 0.0);
            } else if now <= 0.0 && mem.active {
                d.contact_memory[i].active = false;
                d.events.changed.push(i);
                d.log_event(i, ContactEventKind::Separation, gap.delta, gap.delta_dot, 0.0);
            }
        }
        let (before, now) = (d.events.g[n_contacts + i], d.events.g_new[n_contacts + i]);
        if relevant_crossing(d, n_contacts + i, before, now, gap.delta) {
            let kind = if now <= 0.0 {
                ContactEventKind::Clamp
            } else {
                ContactEventKind::Unclamp
            };
            // (the force before this event's changes, as the evaluation at the event state
            // gives it)
            let f = if impulse_law {
                d.contact_out[i].force
            } else if mem.active {
                laws::force(&d.contacts[i], gap.delta, gap.delta_dot, mem.impact_velocity).total
            } else {
                0.0
            };
            d.log_event(i, kind, gap.delta, gap.delta_dot, f);
        }
    }
    if impulse_work {
        settle_impulse_contacts(m, d)?;
    }
    Ok(())
}

/// Resolves the impulse-law contacts at the current (evaluated) state: rounds of
/// simultaneous impacts of the touching contacts that approach, until none does (an impact
/// can make a neighbour approach: Newton's cradle); approach slower than
/// `min_impact_velocity` is plastic (e = 0). Then the touching contacts that neither
/// approach nor separate rest if their constraint force pushes (an active set: the most
/// tensile one is dropped until all push). Works on the preallocated `d.impacts`.
pub fn settle_impulse_contacts(m: &Model, d: &mut Data) -> Result<(), String> {
    let n_contacts = d.contacts.len();
    let max_rounds = 100 + 20 * n_contacts;
    let mut rounds = 0;
    loop {
        let w = &mut d.impacts;
        w.set.clear();
        w.restitution.clear();
        w.approach.clear();
        for (i, c) in d.contacts.iter().enumerate() {
            if c.law != Law::Impulse {
                continue;
            }
            let g = gap(d, i);
            if touching(c, &g, d.contact_memory[i].active) && g.delta_dot > velocity_tolerance(c) {
                let w = &mut d.impacts;
                w.set.push(i);
                w.restitution.push(impulse::restitution_for(c, g.delta_dot));
                w.approach.push((g.delta, g.delta_dot));
            }
        }
        if d.impacts.set.is_empty() {
            break;
        }
        rounds += 1;
        if rounds > max_rounds {
            let names: Vec<_> = d.impacts.set.iter().map(|&i| contact_name(m, d, i)).collect();
            return Err(format!(
                "impacts of contacts {names:?} did not come to an end after {max_rounds} rounds"
            ));
        }
        let mut w = std::mem::take(&mut d.impacts);
        let resolved = impulse::resolve_with(m, d, &mut w.solve, &w.set, &w.restitution);
        if let Ok(energy) = resolved {
            d.state[m.dissipated_index()] += energy.dissipated;
            m.add_input_work(&mut d.state, energy.input_work);
            for (k, &i) in w.set.iter().enumerate() {
                let (delta, delta_dot) = w.approach[k];
                d.log_event(i, ContactEventKind::Impact, delta, delta_dot, w.solve.impulses()[k]);
            }
        }
        d.impacts = w;
        resolved?;
    }
    // Resting set.
    d.impacts.was.clear();
    for k in 0..n_contacts {
        let active = d.contact_memory[k].active;
        d.impacts.was.push(active);
    }
    d.impacts.candidates.clear();
    for (i, c) in d.contacts.iter().enumerate() {
        if c.law != Law::Impulse {
            continue;
        }
        let g = gap(d, i);
        let rest = touching(c, &g, d.impacts.was[i]) && g.margin > 0.0 && g.delta_dot.abs() <= velocity_tolerance(c);
        d.contact_memory[i].active = rest;
        if rest {
            d.impacts.candidates.push(i);
        }
    }
    evaluate_current(m, d);
    while !d.impacts.candidates.is_empty() {
        let (k, p) = d
            .impacts
            .candidates
            .iter()
            .enumerate()
            .map(|(k, &i)| (k, resting_force(d, i)))
            .fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
        if p > 0.0 {
            break;
        }
        let i = d.impacts.candidates.remove(k);
        d.contact_memory[i].active = false;
        evaluate(m, d);
    }
    for i in 0..n_contacts {
        let (before, now) = (d.impacts.was[i], d.contact_memory[i].active);
        if d.contacts[i].law == Law::Impulse && now != before {
            let g = gap(d, i);
            let f = resting_force(d, i);
            let kind = if now {
                ContactEventKind::Rest
            } else {
                ContactEventKind::Release
            };
            d.log_event(i, kind, g.delta, g.delta_dot, f);
        }
    }
    Ok(())
}

/// Touching for the impulse law: resting, or within a hair of δ = 0 (simultaneous impacts)
/// or overlapping a little, on the patch (an overlap beyond δ_max/2 is a sphere behind a
/// plate, not a contact).
fn touching(c: &ContactElement, g: &Gap, resting: bool) -> bool {
    (resting || g.delta >= -1e-10 * c.radius) && g.margin > 0.0 && g.delta < 0.5 * c.max_penetration
}

/// Normal speeds below this count as zero for the impulse law (neither approach nor
/// separation) \[m/s\].
fn velocity_tolerance(c: &ContactElement) -> f64 {
    (1e-6 * c.min_impact_velocity).max(1e-12)
}
