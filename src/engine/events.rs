//! Event location: after each integrator step, the event functions of every contact (see
//! [`crate::engine::modes`]) are compared between the step's start and end; a relevant sign
//! change is located by root finding on the integrator's dense output. Also checked:
//! tunnelling (δ crossed zero although the mode function did not turn positive at the end
//! of the step) and, for the log, the peaks of the continuous contacts (δ̇ = 0) and the stick
//! and slip transitions of contacts with friction. Each contact has three event functions: its
//! mode, the cut of its force at zero (both interrupt the step), and (with friction) its slip
//! speed against the stiction velocity (located and logged only).

use super::modes;
use crate::contact;
use crate::contact::any_resting;
use crate::forward::{evaluate, planned_kinematics};
use crate::kinematics::{free_body_kinematics, kinematics, kinematics_path};
use crate::model::{ContactEventKind, Data, Model};
use crate::scene::Law;

/// Relative tolerance of event location in time.
const EVENT_TIME_TOL: f64 = 1e-13;

/// One scalar function the event locator can follow.
#[derive(Debug, Clone, Copy)]
enum Probe {
    /// Event function `k` of the `g` vector.
    Event(usize),
    /// Exact penetration δ of contact `i` (tunnelling check).
    Delta(usize),
    /// Penetration rate δ̇ of contact `i` (peaks).
    Rate(usize),
    /// Whether inactive contact `i` holds (positive) where the δ of a check peaked: its event
    /// function, but for the impulse law without the hold at 0 while it opens (which is for
    /// the state right after an impact, and would hide a touch at a peak, where δ̇ ≤ 0).
    Touch(usize),
}

/// Evaluates the event functions and the per-contact (δ, δ̇) at `d.eval_state` into
/// `d.events.g`/`aux` (`at_step_end`: into `g_new`/`aux_new`), after the full kinematics
/// (the evaluation when a contact rests).
pub fn event_values(m: &Model, d: &mut Data, at_step_end: bool) {
    event_values_after(m, d, at_step_end, kinematics);
}

/// The event values at the end of the method's last step (`d.eval_state` its end state), on
/// the plan's kinematics: how [`first_event`] evaluates them when it checks the step, and so
/// what a restored state that continues the step must hold there (the full kinematics round a
/// free body's velocity, and so a contact's δ̇, differently).
pub fn step_end_values(m: &Model, d: &mut Data) {
    event_values_after(m, d, true, planned_kinematics);
}

/// [`event_values`] after `kinematics_of` (the evaluation when a contact rests): the full
/// kinematics, or the plan's ([`planned_kinematics`]) where nothing after reads more than the
/// poses and velocities of the free bodies.
fn event_values_after(m: &Model, d: &mut Data, at_step_end: bool, kinematics_of: fn(&Model, &mut Data)) {
    event_kinematics(m, d, kinematics_of);
    // (the active continuous contacts' gaps are the right-hand side's when it evaluated these
    // kinematics: `d.planned_kinematics` still holds after `kinematics_of`)
    let stage_gaps = d.planned_kinematics;
    let n_contacts = d.contacts.len();
    for i in 0..n_contacts {
        let from_stage = stage_gaps && contact::exerts_force(d, i);
        let (mode, clamp_value, a) = if from_stage {
            modes::stage_event_values(d, i, d.clamp_events)
        } else {
            modes::contact_event_values(d, i, d.clamp_events)
        };
        let (g, aux) = if at_step_end {
            (&mut d.events.g_new, &mut d.events.aux_new)
        } else {
            (&mut d.events.g, &mut d.events.aux)
        };
        g[i] = mode;
        g[n_contacts + i] = clamp_value;
        aux[i] = a;
        let slip = if from_stage {
            modes::stage_slip_event_value(d, i)
        } else {
            modes::slip_event_value(d, i)
        };
        let g = if at_step_end {
            &mut d.events.g_new
        } else {
            &mut d.events.g
        };
        g[2 * n_contacts + i] = slip;
    }
    store_margin_values(m, d, at_step_end);
}

/// The event values at the current state after an event's handling changed the modes of
/// `d.events.changed` and nothing else (no impulse-law contacts, the state as it was): those
/// at the step's end (`g_new`, `aux_new`, evaluated at this state before the handling) with
/// the changed contacts' evaluated again, on the kinematics the handling left (the same
/// state's), into `g` and `aux` — what [`event_values`] would give there.
pub fn values_after_mode_changes(d: &mut Data) {
    let n_contacts = d.contacts.len();
    let ev = &mut d.events;
    ev.g.copy_from_slice(&ev.g_new);
    ev.aux.copy_from_slice(&ev.aux_new);
    for k in 0..d.events.changed.len() {
        let i = d.events.changed[k];
        let (mode, clamp_value, a) = modes::contact_event_values(d, i, d.clamp_events);
        let slip = modes::slip_event_value(d, i);
        let ev = &mut d.events;
        ev.g[i] = mode;
        ev.g[n_contacts + i] = clamp_value;
        ev.g[2 * n_contacts + i] = slip;
        ev.aux[i] = a;
    }
}

/// The contact groups' entry of the event values at `d.eval_state` (kinematics evaluated
/// there): (time to move half the margin, largest displacement) into `aux` (`at_step_end`:
/// `aux_new`).
fn store_margin_values(m: &Model, d: &mut Data, at_step_end: bool) {
    let (moved, time) = contact::groups::margin_values(m, d);
    let aux = if at_step_end {
        d.events.margin_pending = false;
        &mut d.events.aux_new
    } else {
        &mut d.events.aux
    };
    aux[d.contacts.len()] = (time, moved);
}

/// What the event values are evaluated on at `d.eval_state`: the whole evaluation while a
/// contact rests (its mode function reads the resting force), else `kinematics_of`.
fn event_kinematics(m: &Model, d: &mut Data, kinematics_of: fn(&Model, &mut Data)) {
    if any_resting(d) {
        evaluate(m, d);
    } else {
        kinematics_of(m, d);
    }
}

/// The contact groups' entry of the event values alone at `d.eval_state` (after the broad
/// phase's reference poses changed: the contacts' entries do not depend on them), on what
/// [`first_event`] and [`step_end_values`] evaluate it on at a step's end (the plan's
/// kinematics and the whole ones round a free body's velocity differently).
pub fn margin_event_values(m: &Model, d: &mut Data, at_step_end: bool) {
    event_kinematics(m, d, planned_kinematics);
    store_margin_values(m, d, at_step_end);
}

/// Kinematics of the two bodies of contact `i` (and their ancestors) only: enough for its
/// gap, broad phase and event functions; a free body's by the plan's lean kinematics (its
/// pose and velocity, as the right-hand side and the event functions at a step's end compute
/// them). Every other body's entries in `d` are left stale, so whatever follows a probe and
/// looks at other bodies, or at motion subspaces and inertias, recomputes the full kinematics
/// (`event_values`, `evaluate`, `project_state` all do).
fn contact_kinematics(m: &Model, d: &mut Data, i: usize) {
    d.planned_kinematics = false;
    let c = &d.contacts[i];
    for body in [c.sphere_body, c.body] {
        match body.and_then(|b| m.plan.free_body(b)) {
            Some(fb) => free_body_kinematics(m, d, fb),
            None => kinematics_path(m, d, body),
        }
    }
}

/// Puts the dense output at `t` into `d.eval_state`.
fn interpolate(d: &mut Data, t: f64) {
    if let Some(method) = d.solver.method() {
        method.interpolate(t, &mut d.eval_state);
    }
}

/// The most coordinates [`interpolate_contact`] interpolates: two free bodies' poses and
/// velocities.
const CONTACT_SLOTS: usize = 26;

/// Puts the dense output at `t` into the coordinates of `d.eval_state` that contact `i`'s
/// [`contact_kinematics`] reads when its bodies are free bodies (or the ground): their poses
/// and velocities alone (the same numbers as [`interpolate`]'s); the whole state when a body
/// is on a joint or the method does not interpolate single components. The other
/// coordinates are left as they were: whatever follows a probe and evaluates more than its
/// contact puts its own state into `d.eval_state` first (every other evaluation does).
fn interpolate_contact(m: &Model, d: &mut Data, i: usize, t: f64) {
    let c = &d.contacts[i];
    let mut slots = [0usize; CONTACT_SLOTS];
    let mut n = 0;
    for body in [c.sphere_body, c.body].into_iter().flatten() {
        let Some(fb) = m.plan.free_body(body) else {
            interpolate(d, t);
            return;
        };
        for k in 0..7 {
            slots[n + k] = fb.qpos + k;
        }
        for k in 0..6 {
            slots[n + 7 + k] = m.nq + fb.qvel + k;
        }
        n += 13;
    }
    let Some(method) = d.solver.method() else { return };
    let mut values = [0.0; CONTACT_SLOTS];
    if method.interpolate_slots(t, &slots[..n], &mut values[..n]) {
        for (&slot, &value) in slots[..n].iter().zip(&values[..n]) {
            d.eval_state[slot] = value;
        }
    } else {
        method.interpolate(t, &mut d.eval_state);
    }
}

/// Evaluates `probe` on the dense output at `t` (leaves the interpolated state in
/// `d.eval_state` and the data evaluated there: for a probe of one contact's kinematics, the
/// coordinates of its bodies only, [`interpolate_contact`]).
fn probe_at(m: &Model, d: &mut Data, probe: Probe, t: f64) -> f64 {
    let n_contacts = d.contacts.len();
    let needs_dynamics = matches!(probe, Probe::Event(k) if k < n_contacts
        && d.contacts[k].law == Law::Impulse && d.contact_memory[k].active);
    if needs_dynamics {
        interpolate(d, t);
        evaluate(m, d);
    } else {
        let i = match probe {
            Probe::Event(k) => k % n_contacts,
            Probe::Delta(i) | Probe::Rate(i) | Probe::Touch(i) => i,
        };
        interpolate_contact(m, d, i, t);
        contact_kinematics(m, d, i);
    }
    match probe {
        Probe::Event(k) if k < n_contacts => modes::contact_event_values(d, k, d.clamp_events).0,
        Probe::Event(k) if k < 2 * n_contacts => modes::contact_event_values(d, k - n_contacts, d.clamp_events).1,
        Probe::Event(k) => modes::slip_event_value(d, k - 2 * n_contacts),
        Probe::Delta(i) => contact::gap(d, i).delta,
        Probe::Rate(i) => contact::gap(d, i).delta_dot,
        Probe::Touch(i) => {
            let c = &d.contacts[i];
            if c.law == Law::Impulse && !d.contact_memory[i].active {
                match contact::broad_phase(c, d) {
                    Some((stand_in, _)) => stand_in,
                    None => contact::event_function(c, &contact::gap(d, i)),
                }
            } else {
                modes::contact_event_values(d, i, d.clamp_events).0
            }
        }
    }
}

/// Finds the right end of the bracket of a sign change of `probe` in `[t0, t1]` (values
/// `g0`, `g1` at the ends) by the Illinois method; stops early once the bracket lies beyond
/// `t_limit` (a crossing found earlier wins).
#[allow(clippy::too_many_arguments)]
fn locate(m: &Model, d: &mut Data, probe: Probe, t0: f64, t1: f64, g0: f64, g1: f64, t_limit: f64) -> f64 {
    let (mut a, mut b, mut ga, mut gb) = (t0, t1, g0, g1);
    let mut side = 0;
    let tol = EVENT_TIME_TOL * t1.abs().max(1e-3);
    for _ in 0..200 {
        if b - a <= tol || a >= t_limit {
            break;
        }
        let mut t = b - gb * (b - a) / (gb - ga);
        if !(t > a && t < b) {
            t = 0.5 * (a + b);
        }
        let gt = probe_at(m, d, probe, t);
        if (gt <= 0.0) == (ga <= 0.0) {
            a = t;
            ga = gt;
            if side == -1 {
                gb *= 0.5;
            }
            side = -1;
        } else {
            b = t;
            gb = gt;
            if side == 1 {
                ga *= 0.5;
            }
            side = 1;
        }
    }
    b
}

/// The fraction of the predicted time to separation ([`time_to_separation`]) that a step
/// toward the separation of an active continuous contact may take. The steps that end before
/// the separation are seen by the error estimate (Dormand-Prince on a force `(t_s − t)^{3/2}`
/// that vanishes a quarter of a step or more beyond the step's end: the estimate is as large
/// as the error; 0.5-0.3 of it when the end is closer), only the step that crosses it is not,
/// and that one is bounded by the floor ([`touch_step`]). So the fraction only has to keep the
/// steps short of the separation while the prediction holds. With 0.5 and `δ/|δ̇|` (before)
/// every separation in the bundled pile's settled phase took about ten halving steps; 0.75 on
/// the linear prediction alone took 22 % fewer steps there but overran separations at loose
/// tolerances (bouncing ball, rtol 1e-3: error 3.0e-3 → 8.9e-3), which the quadratic
/// prediction prevents (2.9e-3; docs/contact.md, docs/benchmarks.md §16).
const SEPARATION_APPROACH: f64 = 0.75;

/// The predicted time to the separation of an opening contact at penetration `delta` > 0 and
/// rate `rate` < 0: `δ/|δ̇|`, or, where the rate fell over the last step (`rate_before` at its
/// start, `last_step` ago: the contact force still pushes the bodies apart), the root of
/// `δ + δ̇ t + δ̈ t²/2` with that mean `δ̈`, which comes earlier. (The mean over the last step
/// is larger than the present `|δ̈|` while the force fades toward the separation: the
/// prediction errs early.)
fn time_to_separation(delta: f64, rate: f64, rate_before: f64, last_step: f64) -> f64 {
    let linear = delta / -rate;
    if !(last_step > 0.0 && rate < rate_before) {
        return linear;
    }
    let acceleration = (rate - rate_before) / last_step;
    // the root in a form without cancellation
    let quadratic = 2.0 * delta / (-rate + (rate * rate - 2.0 * acceleration * delta).sqrt());
    quadratic.min(linear)
}

/// Largest step \[s\] from the current state before an inactive contact could close its gap and
/// one sphere radius more (and, for active contacts that close, the time to penetrate half of
/// `max_penetration` further): per contact the time `t` in which `v t + a t²/2 = gap + R`, with
/// `v` the closing speed (0 when it opens), `a` the magnitude of gravity (the acceleration
/// that turns a ball round in free flight) and `R` the sphere's radius; the least of them.
/// Gap and speed come from `d.events.aux` (those of the bounding spheres when the broad phase
/// skipped the exact detection). So no step carries a sphere through a shape, and each touch
/// shows as a sign change at a step's end; a contact touched and left inside one step (a
/// graze) is found by [`first_event`]. Infinite in weightless flight apart: free flight needs
/// no largest step.
pub fn time_to_contact(m: &Model, d: &Data) -> f64 {
    let a = m.gravity.norm();
    let mut bound = f64::INFINITY;
    // the last step's length, over which `aux_new` holds the rates at its start (after an
    // accepted step; 0 after a restart)
    let last_step = d.solver.method().map_or(0.0, |s| s.t() - s.t_prev());
    for (i, c) in d.contacts.iter().enumerate() {
        let (delta, closing) = d.events.aux[i];
        if d.contact_memory[i].active {
            // An active continuous contact that still closes: the time to penetrate half of
            // max_penetration further at the present speed, so that the first step after a
            // touch (which restarts with the step of free flight) cannot carry the bodies
            // past each other with every stage outside the contact (a glancing blow). (Not
            // the time to reach max_penetration: that would shrink toward it without end.)
            if c.law != Law::Impulse && closing > 0.0 {
                bound = bound.min(0.5 * c.max_penetration / closing);
            }
            // One that opens: [`SEPARATION_APPROACH`] of the time to separation at the
            // present speed, but not less than `0.5 rtol^{1/(n+1)} δ_max / v`
            // ([`touch_step`]), so that the steps shrink toward the separation. The step that
            // crosses it integrates through the end of the force `K δⁿ`, whose derivatives
            // are unbounded there and which the error estimate does not see; the velocity it
            // changes grows as its length to the power n + 1, so a length ∝ rtol^{1/(n+1)}
            // keeps that error in proportion to rtol (two spheres, error of the final
            // velocities: rtol 1e-6 3.3e-5 → 7.3e-7, 1e-8 5.1e-7 → 8.7e-9, 1e-10 3.2e-9 →
            // 9.4e-11, for 2-8 % more evaluations). (The floor is computed only where it
            // could be the least bound: the same bound, without its power at every step.)
            if c.law != Law::Impulse && closing < 0.0 && delta > 0.0 {
                let approach =
                    SEPARATION_APPROACH * time_to_separation(delta, closing, d.events.aux_new[i].1, last_step);
                if approach < bound {
                    if let Some(floor) = touch_step(m, d, i, -closing, d.step_rtol_powers[i][1]) {
                        bound = bound.min(approach.max(floor));
                    }
                }
            }
            continue;
        }
        // (an inactive contact may overlap a hair: an impulse contact right after its impact)
        let reach = c.radius + (-delta).max(0.0);
        let v = closing.max(0.0);
        // the positive root of a t²/2 + v t − reach = 0, in a form exact for a = 0
        let t = 2.0 * reach / (v + (v * v + 2.0 * a * reach).sqrt());
        bound = bound.min(t);
    }
    bound.min(contact::groups::time_to_margin(m, d))
}

/// The first step \[s\] after a touch: for each continuous-law contact that has just touched
/// (active, closing, its penetration still below 1e-6 of `max_penetration`, from
/// `d.events.aux_new` at the event), `0.5 rtol^p` of the time `δ_max / v` it takes to
/// reach the penetration `δ_max` at which the law `F = K δⁿ` stores the kinetic energy of the
/// sphere's body at the closing speed `v` (`K δ_maxⁿ⁺¹/(n + 1) = m v²/2`); the least of them
/// (infinite when nothing touched). The step of the free flight before is far too long for
/// the contact, and the integrator would otherwise cut it down by several rejected steps.
/// The power `p` is
/// [`ContactElement::touch_power`](crate::model::contact::ContactElement::touch_power):
/// `1/(n + 1)` for the Hertz exponent, whose force grows as `t^{3/2}` from the touch; the
/// first step's velocity error grows as its length to the power `n + 1` and the error
/// estimate does not see it (ball on a plane at the first touch, with `p = 1/5`: energy lost
/// in the first step 0.31 rtol at rtol 1e-7, 9.9 at 1e-10, 31 at 1e-11, ∝ rtol^{1/2}; with
/// `p = 1/(n + 1)` below 0.001 rtol).
pub fn first_contact_step(m: &Model, d: &Data) -> f64 {
    let mut bound = f64::INFINITY;
    for (i, c) in d.contacts.iter().enumerate() {
        let (delta, closing) = d.events.aux_new[i];
        let touched = contact::exerts_force(d, i) && delta <= 1e-6 * c.max_penetration;
        if !touched || closing.is_nan() || closing <= 0.0 {
            continue;
        }
        if let Some(h) = touch_step(m, d, i, closing, d.step_rtol_powers[i][0]) {
            bound = bound.min(h);
        }
    }
    bound
}

/// `0.5 rtol_power δ_max / v` for contact `i` at the normal speed `v`, with `δ_max` the
/// penetration that stores the sphere's kinetic energy at that speed (see
/// [`first_contact_step`]) and `rtol_power` a power of `rtol` ([`Data::step_rtol_powers`]);
/// None for a contact without a sphere body or with a law that stores no energy.
fn touch_step(m: &Model, d: &Data, i: usize, speed: f64, rtol_power: f64) -> Option<f64> {
    Some(0.5 * rtol_power * energy_penetration(m, d, i, speed)? / speed)
}

/// The penetration `δ_max` \[m\] at which the law `F = K δⁿ` of contact `i` stores the kinetic
/// energy of its sphere's body at the normal speed `speed` (`K δ_maxⁿ⁺¹/(n + 1) = m v²/2`);
/// None for a contact without a sphere body or with a law that stores no energy.
fn energy_penetration(m: &Model, d: &Data, i: usize, speed: f64) -> Option<f64> {
    let c = &d.contacts[i];
    let b = c.sphere_body?;
    let (k, n) = (c.stiffness, c.exponent);
    let mass = m.bodies[b].mass;
    if !(k > 0.0 && n > 0.0 && mass > 0.0 && speed > 0.0) {
        return None;
    }
    Some(crate::math::powf(
        (n + 1.0) * mass * speed * speed / (2.0 * k),
        1.0 / (n + 1.0),
    ))
}

/// The active continuous-law contact with the shortest time scale `δ_max / v` at the current
/// state (`v` its normal speed: its closing speed there, at least the speed it touched with,
/// which is floored at its `min_impact_velocity`; `δ_max` as in [`first_contact_step`]):
/// (contact, time scale \[s\], `v` \[m/s\]). A Hertz contact lasts about 2.94 of it. None when
/// no such contact is active.
pub fn shortest_contact_time(m: &Model, d: &Data) -> Option<(usize, f64, f64)> {
    let mut shortest: Option<(usize, f64, f64)> = None;
    for i in 0..d.contacts.len() {
        if !contact::exerts_force(d, i) {
            continue;
        }
        let speed = d.events.aux[i].1.max(d.contact_memory[i].impact_velocity);
        let Some(delta_max) = energy_penetration(m, d, i, speed) else {
            continue;
        };
        let time = delta_max / speed;
        if shortest.is_none_or(|(_, t, _)| time < t) {
            shortest = Some((i, time, speed));
        }
    }
    shortest
}

/// True when `a` and `b` hold the same numbers bit for bit (a test without an early exit,
/// which the compiler vectorises: the states compared are equal at nearly every step).
fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .fold(0, |differ, (x, y)| differ | (x.to_bits() ^ y.to_bits()))
            == 0
}

/// False when no contact passes the first test of any check of [`first_event`] over the
/// step whose start and end values are in `d.events` (`g`, `aux`; `g_new`, `aux_new`): no
/// event function changed its sign, no contact apart crossed δ = 0 or turned from closing to
/// opening with its event function not positive, none was in and opening at the step's start
/// (a return after an impact), and no active one passed a peak (when peaks are logged). The
/// common step: one pass instead of the checks' several.
fn anything_to_check(d: &Data) -> bool {
    let n = d.contacts.len();
    let ev = &d.events;
    let (g, g_new) = (&ev.g[..3 * n], &ev.g_new[..3 * n]);
    (0..n).any(|i| {
        let active = d.contact_memory[i].active;
        modes::crossed(g[i], g_new[i])
            || modes::crossed(g[n + i], g_new[n + i])
            || modes::crossed(g[2 * n + i], g_new[2 * n + i])
            || (!active && (may_tunnel(d, i) || may_visit(d, i) || may_return(d, i)))
            || (d.log_peaks && active && passed_peak(d, i))
    })
}

/// The first test of the tunnelling check: contact `i`'s δ crossed zero over the step.
fn may_tunnel(d: &Data, i: usize) -> bool {
    d.events.aux[i].0 <= 0.0 && d.events.aux_new[i].0 > 0.0
}

/// The first test of the visit check: contact `i` closed at the step's start and opens at
/// its end.
fn may_visit(d: &Data, i: usize) -> bool {
    d.events.aux[i].1 > 0.0 && d.events.aux_new[i].1 < 0.0
}

/// The first test of the return check: contact `i` was in and opening at the step's start
/// (right after an impact, which is located a hair past δ = 0).
fn may_return(d: &Data, i: usize) -> bool {
    d.events.aux[i].0 > 0.0 && d.events.aux[i].1 < 0.0
}

/// Samples of the dense output over a step that starts right after an impact, where the
/// contact may have left, come back in and left again ([`returned_within`]).
const RETURN_SAMPLES: usize = 16;

/// The instant contact `i`, in and opening at the step's start `t0` (right after an impact),
/// touched again within the step (before `t_first`), if it left and came back in: its least δ
/// is the first root of its rate, bracketed by the first of [`RETURN_SAMPLES`] instants of the
/// dense output at which it closes (it closes from there until δ is largest, which the samples
/// miss only where that is shorter than their spacing); its largest δ after that the next root
/// (or the step's end); a touch where δ crossed zero in between, on the patch. (A ball
/// bouncing in a groove, or on a convex cylinder, under a step of free flight came back
/// through the wall unseen when its event function was not positive at the step's end:
/// beyond max_penetration, or out again.)
fn returned_within(m: &Model, d: &mut Data, i: usize, t0: f64, t1: f64, t_first: f64) -> Option<f64> {
    let sample = |k: usize| {
        if k == RETURN_SAMPLES {
            t1
        } else {
            t0 + (t1 - t0) * k as f64 / RETURN_SAMPLES as f64
        }
    };
    let r0 = probe_at(m, d, Probe::Rate(i), t0);
    if r0.is_nan() || r0 >= 0.0 {
        return None;
    }
    // the least δ: the first sample at which it closes brackets it (up to `t_first`)
    let (mut ta, mut ra, mut next) = (t0, r0, None);
    for k in 1..=RETURN_SAMPLES {
        let t = sample(k).min(t_first);
        let r = probe_at(m, d, Probe::Rate(i), t);
        if r.is_nan() {
            return None;
        }
        if r > 0.0 {
            next = Some((k, t, r));
            break;
        }
        if t >= t_first {
            return None;
        }
        (ta, ra) = (t, r);
    }
    let (k_closing, tb, rb) = next?;
    let t_least = locate(m, d, Probe::Rate(i), ta, tb, ra, rb, t_first);
    let d_least = probe_at(m, d, Probe::Delta(i), t_least);
    if t_least >= t_first || d_least > 0.0 {
        return None;
    }
    // the largest δ after it: the first later sample at which it opens brackets it
    let (mut tc, mut rc, mut t_most) = (tb, rb, t1);
    for k in k_closing + 1..=RETURN_SAMPLES {
        let t = sample(k);
        let r = probe_at(m, d, Probe::Rate(i), t);
        if r.is_nan() {
            return None;
        }
        if r <= 0.0 {
            t_most = locate(m, d, Probe::Rate(i), tc, t, rc, r, t_first);
            break;
        }
        (tc, rc) = (t, r);
    }
    let d_most = probe_at(m, d, Probe::Delta(i), t_most);
    if d_most <= 0.0 {
        return None;
    }
    let t = locate(m, d, Probe::Delta(i), t_least, t_most, d_least, d_most, t_first);
    (t < t_first && probe_at(m, d, Probe::Touch(i), t) > 0.0).then_some(t)
}

/// The first test of the peak log: contact `i` closed at the step's start and no longer at
/// its end.
fn passed_peak(d: &Data, i: usize) -> bool {
    d.events.aux[i].1 > 0.0 && d.events.aux_new[i].1 <= 0.0
}

/// Checks the step the integrator just took (from `t_prev` to `t`): the event functions at
/// its end go to `d.events.g_new`, and the earliest relevant event inside it is returned
/// (None: the step can be accepted whole). Peaks of continuous contacts before that event
/// are logged.
pub fn first_event(m: &Model, d: &mut Data) -> Option<f64> {
    let n_contacts = d.contacts.len();
    let method = d.solver.method()?;
    // (contact groups without candidates still follow how far their shapes moved)
    if n_contacts == 0 && !m.groups.is_active() {
        return None;
    }
    let (t0, t1) = (method.t_prev(), method.t());
    // The event functions need the poses and velocities only (what follows the step, an
    // event's handling or a projection, evaluates the full kinematics again): the plan's. When
    // the right-hand side's lean path left them at the step's end (Dormand-Prince's last
    // stage; `d.planned_kinematics`), they are not computed again.
    let evaluated = d.planned_kinematics && same_bits(&d.eval_state, method.y());
    if evaluated {
        event_values_after(m, d, true, |_, _| {});
    } else {
        d.eval_state.copy_from_slice(method.y());
        step_end_values(m, d);
    }
    if !anything_to_check(d) {
        return None;
    }
    // Earliest relevant crossing.
    let mut t_first = t1;
    let mut any = false;
    for k in 0..2 * n_contacts {
        let (g0, g1) = (d.events.g[k], d.events.g_new[k]);
        // (the sign change first: most functions keep their sign)
        if modes::crossed(g0, g1) && modes::relevant_crossing(d, k, g0, g1, d.events.aux_new[k % n_contacts].0) {
            let t = locate(m, d, Probe::Event(k), t0, t1, g0, g1, t_first);
            any = true;
            t_first = t_first.min(t);
        }
    }
    // Tunnelling: δ of a contact that is not in contact crossed zero without its event
    // function turning positive at the end of the step (it passed δ_max or the patch).
    for i in 0..n_contacts {
        if d.contact_memory[i].active || !may_tunnel(d, i) || d.events.g_new[i] > 0.0 {
            continue;
        }
        let d1 = d.events.aux_new[i].0;
        interpolate_contact(m, d, i, t0);
        contact_kinematics(m, d, i);
        let d0_exact = contact::gap(d, i).delta;
        if d0_exact > 0.0 {
            continue;
        }
        let t = locate(m, d, Probe::Delta(i), t0, t1, d0_exact, d1, t_first);
        if t < t_first && probe_at(m, d, Probe::Event(i), t) > 0.0 {
            any = true;
            t_first = t;
        }
    }
    // A visit inside the step: an inactive contact that closed at the step's start and opens
    // at its end, with no sign change of its event function, passed a largest δ in between
    // (δ̇ = 0); if the contact holds there, it touched and left within the step: locate the
    // touch between the start and that instant.
    for i in 0..n_contacts {
        let (g0, g1) = (d.events.g[i], d.events.g_new[i]);
        if d.contact_memory[i].active || !may_visit(d, i) || g0 > 0.0 || g1 > 0.0 {
            continue;
        }
        // the exact rates (the broad phase's are those of the bounding spheres)
        let r0 = probe_at(m, d, Probe::Rate(i), t0);
        let r1 = probe_at(m, d, Probe::Rate(i), t1);
        if !(r0 > 0.0 && r1 <= 0.0) {
            continue;
        }
        let t_peak = locate(m, d, Probe::Rate(i), t0, t1, r0, r1, t_first);
        if t_peak >= t_first {
            continue;
        }
        let g_peak = probe_at(m, d, Probe::Touch(i), t_peak);
        if g_peak > 0.0 {
            let g_start = probe_at(m, d, Probe::Touch(i), t0);
            let t = locate(m, d, Probe::Touch(i), t0, t_peak, g_start, g_peak, t_first);
            any = true;
            t_first = t_first.min(t);
        }
    }
    // A return: an inactive contact in and opening at the step's start (right after an
    // impact) that left and came back in within the step, with no sign change of its event
    // function (beyond max_penetration at the step's end, or out again).
    for i in 0..n_contacts {
        if d.contact_memory[i].active || !may_return(d, i) || d.events.g_new[i] > 0.0 {
            continue;
        }
        if let Some(t) = returned_within(m, d, i, t0, t1, t_first) {
            any = true;
            t_first = t_first.min(t);
        }
    }
    // Stick and slip of contacts with friction inside the accepted part of the step: the
    // friction law is C¹ across the stiction velocity, so the crossing is located and logged
    // without interrupting the integration (a restart there would cost, not gain: a wheel
    // rolling near the stiction velocity crosses it often).
    for i in 0..n_contacts {
        let k = 2 * n_contacts + i;
        let (g0, g1) = (d.events.g[k], d.events.g_new[k]);
        if !(modes::crossed(g0, g1) && modes::relevant_crossing(d, k, g0, g1, d.events.aux_new[i].0)) {
            continue;
        }
        let t = locate(m, d, Probe::Event(k), t0, t1, g0, g1, t1);
        if t <= t_first {
            interpolate_contact(m, d, i, t);
            contact_kinematics(m, d, i);
            let g = contact::gap(d, i);
            let kind = if g1 <= 0.0 {
                ContactEventKind::Stick
            } else {
                ContactEventKind::Slip
            };
            d.log_event_at(t, i, kind, g.delta, g.delta_dot, 0.0);
        }
    }
    // Peaks of continuous contacts inside the accepted part of the step (a diagnostic, when
    // asked for).
    for i in 0..n_contacts {
        if !d.log_peaks {
            break;
        }
        if d.contacts[i].law == Law::Impulse || !d.contact_memory[i].active {
            continue;
        }
        let (r0, r1) = (d.events.aux[i].1, d.events.aux_new[i].1);
        if passed_peak(d, i) {
            let t = locate(m, d, Probe::Rate(i), t0, t1, r0, r1, t1);
            if t <= t_first {
                interpolate_contact(m, d, i, t);
                contact_kinematics(m, d, i);
                let g = contact::gap(d, i);
                let mem = d.contact_memory[i];
                let f = contact::laws::force(&d.contacts[i], g.delta.max(0.0), g.delta_dot, mem.impact_velocity);
                d.log_event_at(t, i, ContactEventKind::Peak, g.delta, g.delta_dot, f.total);
            }
        }
    }
    any.then_some(t_first)
}
