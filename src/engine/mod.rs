//! The driver: advances a [`Model`]'s [`Data`] from one communication point to the next.
//!
//! The right-hand side ([`crate::forward`]) is evaluated with the contact *mode* (which
//! contacts are active) frozen; every change of mode — touch, separation, an impact — is an
//! event located on the integrator's dense output ([`events`]), handled by
//! [`crate::engine::modes`], after which the integrator restarts. No force discontinuity is
//! stepped over. One `advance`:
//!
//! 1. when something changed since the last advance (an input, a restored state without the
//!    method's step, the first advance): settle resting contacts an input change made pull,
//!    and restart the method at `d.state`; otherwise *continue* the method's last step;
//! 2. per step: take it (it may reach past `t_end`); if an event lies inside before `t_end`,
//!    move to it, change the modes there and restart; if the step ends by `t_end`, accept
//!    it (and project onto the loop constraints when they drifted); if it reaches past
//!    `t_end`, the state at `t_end` comes from the dense output and the step stays pending
//!    for the next advance. So the communication grid does not bound the steps.

pub mod events;
pub mod modes;

use crate::contact;
use crate::contact::any_resting;
use crate::dynamics;
use crate::forward::{evaluate, Rhs};
use crate::integrator::IntegratorError;
use crate::kinematics::{kinematics, poses_and_velocities_at_state};
use crate::model::data::Stepper;
use crate::model::{Data, Model};
use crate::scene::{Law, Num, RUNAWAY_SPEED};

/// A failed advance: the last good time and what went wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("at t = {}: {message}", Num(*.time))]
pub struct EngineError {
    /// Last time reached with a valid state \[s\].
    pub time: f64,
    /// What went wrong.
    pub message: String,
    /// True when the advance stopped at `solver.max_steps` steps: the state at `time` is
    /// valid and the simulation can go on from there.
    pub step_limit: bool,
}

/// Consecutive integrator steps cut short by an event after which the advance fails (an
/// event storm: a fixed-step method overshooting a stiff contact, or a Zeno sequence).
const MAX_INTERRUPTED_STEPS: usize = 2000;

fn fail(d: &Data, message: impl Into<String>) -> EngineError {
    EngineError {
        time: d.time,
        message: message.into(),
        step_limit: false,
    }
}

/// Prepares freshly compiled data for its first advance: contacts that overlap at the
/// initial state start active, with δ̇⁻ from the initial rate (floored); impulse-law contacts
/// that touch are resolved (an impact at the start if they approach, resting if they press);
/// the event functions are evaluated.
pub fn start(m: &Model, d: &mut Data) -> Result<(), EngineError> {
    d.eval_state.copy_from_slice(&d.state);
    kinematics(m, d);
    for i in 0..d.contacts.len() {
        let g = contact::gap(d, i);
        let c = &d.contacts[i];
        if contact::event_function(c, &g) > 0.0 && c.law != Law::Impulse {
            d.contact_memory[i].active = true;
            d.contact_memory[i].impact_velocity = g.delta_dot.max(c.min_impact_velocity);
        }
    }
    if d.contacts.iter().any(|c| c.law == Law::Impulse) {
        evaluate(m, d);
        modes::settle_impulse_contacts(m, d).map_err(|e| fail(d, e))?;
    }
    resync(m, d);
    Ok(())
}

/// Re-evaluates the event functions after the state was set from outside (restored): at the
/// current state, or, when the method has a last step, at the step's start and end (the end as
/// the step's check evaluated it, [`events::step_end_values`]: the values the continued step
/// goes on with), in the places the step left them: the end's as the next values while the
/// step reaches past the data's time, as the current ones once it ended there (accepted). The
/// workspace then holds those evaluations: the outputs and kinematics at the state are
/// evaluated again when read.
pub fn resync(m: &Model, d: &mut Data) {
    d.outputs_valid = false;
    d.kinematics_valid = false;
    let Some(i) = d.solver.method().filter(|_| d.solver.started) else {
        d.eval_state.copy_from_slice(&d.state);
        events::event_values(m, d, false);
        return;
    };
    // (a step that ended at the data's time, or a rounding error short of it, was accepted:
    // its end values are the current ones and its start values the former ones, as
    // `accept_step` leaves them; a restart took no step)
    let accepted = i.t() <= d.time && i.t() > i.t_prev();
    d.eval_state.copy_from_slice(&i.core().y_prev);
    events::event_values(m, d, false);
    if let Some(i) = d.solver.method() {
        d.eval_state.copy_from_slice(i.y());
    }
    events::step_end_values(m, d);
    if accepted {
        take_step_end_values(d);
    }
}

/// The event values at the end of the step just accepted become the current ones (the
/// current ones the step's start's).
fn take_step_end_values(d: &mut Data) {
    std::mem::swap(&mut d.events.g, &mut d.events.g_new);
    std::mem::swap(&mut d.events.aux, &mut d.events.aux_new);
}

/// [`resync`] after the broad phase's reference poses changed and nothing else did: while the
/// method's last step reaches past the data's time, the contacts' entries are those of the
/// step's ends already (they do not depend on the reference poses) and only the contact
/// groups' entry at the step's end is to be evaluated again: when the step is accepted
/// ([`EventWork::margin_pending`](crate::model::data::EventWork::margin_pending); the next
/// advance accepts the step, or stops at an event inside it and evaluates everything there,
/// before it reads the entry, and a step may span several of these changes); otherwise
/// everything is evaluated now.
pub fn resync_margins(m: &Model, d: &mut Data) {
    if d.solver.method().is_some() && d.solver.ahead_of(d.time) {
        d.events.margin_pending = true;
    } else {
        resync(m, d);
    }
}

/// The contact groups' entry of the event values at the end of the method's last step, with
/// the present reference poses, when [`resync_margins`] left it pending.
fn settle_margins(m: &Model, d: &mut Data) {
    if !d.events.margin_pending {
        return;
    }
    if let Some(i) = d.solver.method() {
        d.eval_state.copy_from_slice(i.y());
        events::margin_event_values(m, d, true);
    }
    d.events.margin_pending = false;
}

/// After a host moved a driven joint (its coordinate or rate written into `d.state`): the rest
/// of the state follows onto the loop constraints (positions, then velocities, in the mass
/// metric, the drives held), and the integrator restarts there at the next advance.
pub fn follow_drives(m: &Model, d: &mut Data) {
    dynamics::project_state(m, d, dynamics::PROJECTION_TOL, contact::resting_rows);
    d.solver.started = false;
    d.outputs_valid = false;
    d.kinematics_valid = false;
    resync(m, d);
}

/// Integrates to `t_end`, locating and handling contact events. The method continues its last
/// step when nothing changed since the previous advance; it may step past `t_end` (up to
/// and the state at `t_end` then comes from its dense output (projected onto the loop
/// constraints). Its steps do not depend on `t_end` nor on the stop time, so the results do
/// not depend on the communication grid beyond the tolerance.
pub fn advance(m: &Model, d: &mut Data, t_end: f64) -> Result<(), EngineError> {
    advance_with(m, d, t_end, false).map(|_| ())
}

/// [`advance`], which with `stop_at_events` ends right after a located event before `t_end`
/// at which a contact changed its mode (touch, separation, impact, rest, release; not a force
/// cut, stick or slip): `Ok(true)`, `d.time` the event's time, the integrator restarted there.
/// The next advance goes on from there as this one would have, so the steps, and the states at
/// later times, do not depend on where an advance stopped.
pub fn advance_with(m: &Model, d: &mut Data, t_end: f64, stop_at_events: bool) -> Result<bool, EngineError> {
    advance_deferring(m, d, t_end, stop_at_events, false)
}

/// Whether an advance to `t_end` takes no step: the method continues its last step, which
/// reaches past `t_end` before any pending event. The advance then takes the state at `t_end`
/// from the dense output and, in a model without loops, changes nothing but the time, the
/// state (its coordinates) and the flags of what the workspace holds (with loops, the
/// projection onto them also evaluates kinematics and constraint work).
pub fn interpolates_to(m: &Model, d: &Data, t_end: f64) -> bool {
    t_end >= d.time
        && d.solver.method().is_some_and(|i| i.t() > t_end)
        && m.solver.continuation
        && d.solver.started
        && d.solver.pending_event > t_end
}

/// [`advance_with`]; `defer`: a communication point inside the method's step leaves the state
/// to its dense output ([`Data::dense_pending`], taken by [`settle`]) in a model without loops
/// (whose projection at the point changes only joint quaternions).
#[inline]
pub fn advance_deferring(
    m: &Model,
    d: &mut Data,
    t_end: f64,
    stop_at_events: bool,
    defer: bool,
) -> Result<bool, EngineError> {
    // A communication point inside the method's last step, before its pending event (most
    // points of a fine grid): the state from the dense output, as the loop of
    // `advance_steps` gives it.
    if interpolates_to(m, d, t_end) {
        d.outputs_valid = false;
        d.kinematics_valid = false;
        if defer && m.loop_rows() == 0 {
            d.time = t_end;
            d.dense_pending = true;
        } else {
            interpolate_to(m, d, t_end);
        }
        sync_counters(d);
        return Ok(false);
    }
    advance_steps(m, d, t_end, stop_at_events)
}

/// [`advance_with`] past the communication points inside the method's step: restarts, steps,
/// events.
fn advance_steps(m: &Model, d: &mut Data, t_end: f64, stop_at_events: bool) -> Result<bool, EngineError> {
    if t_end.is_nan() || t_end < d.time {
        return Err(fail(d, format!("cannot integrate backwards to {}", Num(t_end))));
    }
    d.outputs_valid = false;
    d.kinematics_valid = false;
    let continuation = m.solver.continuation;
    settle(m, d);
    if !d.solver.started || !continuation {
        // An input changed at this communication point may have made a resting contact pull.
        let settled = any_resting(d) && modes::resting_violated(m, d);
        if settled {
            modes::settle_impulse_contacts(m, d).map_err(|e| fail(d, e))?;
        }
        restart(m, d, d.solver.pending_step(), !settled)?;
    }
    // A remainder of a few ulps (a step or an event that ended a rounding error short of
    // t_end) is not a step any method can take.
    let t_close = 16.0 * f64::EPSILON * t_end.abs().max(1e-300);
    let mut interrupted = 0usize;
    let mut steps = 0u64;
    loop {
        if d.solver.ahead_of(d.time) {
            let t_step = d.solver.method().map_or(d.time, |i| i.t());
            if d.solver.pending_event <= t_end {
                interrupted += 1;
                if interrupted > MAX_INTERRUPTED_STEPS {
                    stop_after_failure(d);
                    return Err(fail(d, event_storm()));
                }
                stop_at_event(m, d, d.solver.pending_event)?;
                if stop_at_events && t_end - d.time > t_close && mode_changed_now(d) {
                    sync_counters(d);
                    return Ok(true);
                }
            } else if t_step <= t_end {
                interrupted = 0;
                accept_step(m, d)?;
                if contact::groups::stale(m, d) {
                    // the caller makes the candidate pairs of the contact groups again
                    break;
                }
            } else {
                interpolate_to(m, d, t_end);
                break;
            }
        } else if t_end - d.time <= t_close {
            d.time = t_end;
            break;
        } else {
            let max_steps = d.max_steps.unwrap_or(m.solver.max_steps);
            if steps == max_steps {
                sync_counters(d);
                return Err(step_limit(d, max_steps, t_end));
            }
            steps += 1;
            let limit = if continuation { f64::INFINITY } else { t_end };
            // (from the method's time, where the event values that bound the step are: after
            // an advance that ended a rounding error short of its end, `d.time` is that end)
            let t_method = d.solver.method().map_or(d.time, |i| i.t());
            let limit = limit.min(t_method + events::time_to_contact(m, d));
            take_step(m, d, limit)?;
            d.solver.pending_event = events::first_event(m, d).unwrap_or(f64::INFINITY);
        }
    }
    sync_counters(d);
    Ok(false)
}

/// True when the event just handled (at `d.time`) changed a contact's mode: the log's last
/// entries at that time (the handling logs every change it makes there) name one.
fn mode_changed_now(d: &Data) -> bool {
    let mut at_event = d.event_log.iter().rev().take_while(|e| e.time == d.time);
    at_event.any(|e| e.kind.changes_mode())
}

/// The advance stopped after `max_steps` steps short of `t_end`.
fn step_limit(d: &Data, max_steps: u64, t_end: f64) -> EngineError {
    EngineError {
        time: d.time,
        message: format!(
            "solver.max_steps = {max_steps} integrator steps did not reach t = {} (stopped at t = {}); \
             take shorter communication steps or raise solver.max_steps",
            Num(t_end),
            Num(d.time)
        ),
        step_limit: true,
    }
}

fn event_storm() -> String {
    format!(
        "{MAX_INTERRUPTED_STEPS} steps in a row were cut short by contact events (touch and separation \
         chatter): the step is too large for the contact stiffness; use an adaptive method or a smaller \
         solver.max_step"
    )
}

/// The state at `t` inside the method's last step, from its dense output, projected onto the
/// loop constraints (and unit quaternions) when the interpolation left them by more than
/// [`dynamics::PROJECTION_TOL`]: the outputs at a communication point satisfy the constraints
/// as well as a step's end does. The method's step is not changed.
fn interpolate_to(m: &Model, d: &mut Data, t: f64) {
    if let Some(method) = d.solver.method() {
        method.interpolate(t, &mut d.state);
    }
    d.time = t;
    d.dense_pending = false;
    dynamics::project_state(m, d, dynamics::PROJECTION_TOL, contact::resting_rows);
}

/// Takes the state a deferred communication point left to the dense output
/// ([`Data::dense_pending`]): the same numbers as an advance that did not defer. Whatever
/// reads or changes the state, or restarts the method, settles first.
pub fn settle(m: &Model, d: &mut Data) {
    if d.dense_pending {
        interpolate_to(m, d, d.time);
    }
}

/// Runs `f` with the integrator taken out of the data (so that the right-hand side can
/// borrow the data) and puts it back.
fn with_stepper<R>(m: &Model, d: &mut Data, f: impl FnOnce(&mut Stepper, &mut Rhs) -> R) -> Result<R, EngineError> {
    let Some(mut stepper) = d.solver.stepper.take() else {
        return Err(fail(
            d,
            "the integrator was lost after an internal error; reset the instance",
        ));
    };
    let result = f(&mut stepper, &mut Rhs { model: m, data: d });
    d.solver.stepper = Some(stepper);
    Ok(result)
}

/// Takes one integrator step toward `t_end` (the data's state is unchanged).
fn take_step(m: &Model, d: &mut Data, t_end: f64) -> Result<(), EngineError> {
    // (the modes stay through the step: the right-hand side reads the list of the contacts
    // whose forces it computes)
    d.force_contacts_listed = contact::list_force_contacts(d);
    let stepped = with_stepper(m, d, |s, rhs| s.method.step(rhs, t_end));
    d.force_contacts_listed = false;
    if let Err(e) = stepped? {
        let mut message = e.to_string();
        if let IntegratorError::StepSizeUnderflow(_) = e {
            message.push_str(&too_short_contact(m, d).unwrap_or_default());
        }
        stop_after_failure(d);
        return Err(fail(d, message));
    }
    if let Some(what) = d.solver.method().and_then(|i| runaway(m, i.y())) {
        stop_after_failure(d);
        let message = format!("{}; the state is the last good one", blow_up(m, d.time, &what));
        return Err(fail(d, message));
    }
    Ok(())
}

/// What makes the state `y` of a step's end a blow-up, if anything: a non-finite number, or a
/// velocity beyond [`RUNAWAY_SPEED`]. (Positions are not bounded: bodies flying apart for a
/// host's step of 1e300 s reach any distance without anything going wrong.)
fn runaway(m: &Model, y: &[f64]) -> Option<String> {
    let (nq, nv) = (m.nq, m.nv);
    // (first passes without an early exit, which the compiler vectorises: nearly every state
    // is sound)
    let not_finite = y.iter().fold(false, |any, v| any | !v.is_finite());
    let too_fast = y[nq..nq + nv]
        .iter()
        .fold(false, |any, v| any | (v.abs() > RUNAWAY_SPEED));
    if !(not_finite || too_fast) {
        return None;
    }
    if let Some(k) = y.iter().position(|v| !v.is_finite()) {
        return Some(format!("state component {k} became {}", y[k]));
    }
    y[nq..nq + nv]
        .iter()
        .find(|v| v.abs() > RUNAWAY_SPEED)
        .map(|v| format!("a velocity reached {v:.3e}"))
}

/// The message for an integration that blew up in the step after `time` (`what` happened):
/// the cause and the remedy for the method in use.
pub fn blow_up(m: &Model, time: f64, what: &str) -> String {
    use crate::scene::Method;
    let s = &m.solver;
    let remedy = match s.method {
        Method::Rk4 => format!(
            "the fixed-step method rk4 with a step of {} s is unstable here: use solver.method = auto (adaptive, \
             the default) or a shorter solver.max_step",
            if s.max_step > 0.0 { s.max_step } else { 1e-3 }
        ),
        _ => format!(
            "tighten solver.rtol (now {:e}) and solver.atol (now {:e}), or bound the step with solver.max_step",
            s.rtol, s.atol
        ),
    };
    format!(
        "the integration blew up in the step after t = {} ({what}): {remedy}",
        Num(time)
    )
}

/// The note a step size underflow gets when an active contact is too stiff (or its body too
/// light) for any step to resolve: its first step after a touch (`0.5 rtol^{1/(n+1)}` of its
/// time scale, [`events::first_contact_step`]) is not longer than the rounding gap under which
/// the integrator gives up (`ROUNDOFF_GAP` times the time, counted as at least 1 s, so that a
/// contact too stiff at t = 0 is named too). The contact named, its time scale, stiffness,
/// body and speed; None when no active contact is that short (the underflow has another cause).
fn too_short_contact(m: &Model, d: &Data) -> Option<String> {
    use crate::integrator::core::ROUNDOFF_GAP;
    use crate::scene::short;
    let (i, time, speed) = events::shortest_contact_time(m, d)?;
    let first_step = 0.5 * d.step_rtol_powers[i][0] * time;
    (first_step <= ROUNDOFF_GAP * d.time.abs().max(1.0)).then_some(())?;
    let c = &d.contacts[i];
    let body = &m.bodies[c.sphere_body?];
    // (derived numbers to three digits, in the shorter notation)
    let three = |x: f64| short(format!("{x:.2e}").parse().unwrap_or(x));
    Some(format!(
        "; contact {:?} is in contact there with a time scale of {} s (the penetration that stores the \
         kinetic energy of its sphere's body at its normal speed, over that speed: stiffness {}, body {:?} of \
         {} kg, normal speed {} m/s), too short for any step to resolve: check its stiffness (or materials) \
         and the body's mass",
        contact::elements::contact_name(m, d, i),
        three(time),
        three(c.stiffness),
        body.name,
        short(body.mass),
        three(speed),
    ))
}

/// Accepts the whole step: the state moves to its end; the event functions there become the
/// current ones.
fn accept_step(m: &Model, d: &mut Data) -> Result<(), EngineError> {
    if let Some(method) = d.solver.method() {
        d.state.copy_from_slice(method.y());
        d.time = method.t();
    }
    settle_margins(m, d);
    take_step_end_values(d);
    project_after_step(m, d)
}

/// Moves the state to the event at `t` (on the dense output), applies the mode changes
/// there and restarts the integrator.
fn stop_at_event(m: &Model, d: &mut Data, t: f64) -> Result<(), EngineError> {
    if let Some(method) = d.solver.method() {
        method.interpolate(t, &mut d.state);
    }
    d.time = t;
    d.counters.events += 1;
    d.eval_state.copy_from_slice(&d.state);
    events::event_values(m, d, true);
    let result = modes::handle_events(m, d);
    let h = d.solver.method().map_or(0.0, |i| i.next_step());
    let h = h.min(events::first_contact_step(m, d));
    if result.is_ok() && !d.contacts.iter().any(|c| c.law == Law::Impulse) {
        // The handling changed no state, only the modes of `d.events.changed`: the event
        // values at the restart are those just evaluated at this state, except those
        // contacts' (their clamp and slip functions read the mode), evaluated again on the
        // same kinematics — the numbers `restart` would evaluate, without every contact's.
        events::values_after_mode_changes(d);
        return restart_with_values(m, d, h);
    }
    restart(m, d, h, false)?;
    result.map_err(|e| fail(d, e))
}

/// Restarts the integrator from the current state with first step `h`: `warm` (nothing
/// changed the right-hand side: a plain communication point) keeps an implicit method's
/// Jacobian and controller memory, which the saved state holds; otherwise (after an event,
/// an impulse, a projection) everything is dropped.
fn restart(m: &Model, d: &mut Data, h: f64, warm: bool) -> Result<(), EngineError> {
    let t = d.time;
    with_stepper(m, d, |s, rhs| {
        s.start.copy_from_slice(&rhs.data.state);
        if warm {
            s.method.restart(rhs, t, &s.start, h);
        } else {
            s.method.reset(rhs, t, &s.start, h);
        }
    })?;
    d.eval_state.copy_from_slice(&d.state);
    events::event_values(m, d, false);
    d.solver.started = true;
    Ok(())
}

/// [`restart`] after an event (nothing kept) whose event values at the current state are in
/// `d.events.g` and `aux` already, evaluated there on the full kinematics: the poses and
/// velocities there evaluated again (so that the data hold what `restart` leaves: the
/// method's evaluations at the start overwrite the free bodies' poses and velocities with
/// the plan's, and only those; their other kinematics are still those of the event values),
/// not the event functions.
fn restart_with_values(m: &Model, d: &mut Data, h: f64) -> Result<(), EngineError> {
    let t = d.time;
    with_stepper(m, d, |s, rhs| {
        s.start.copy_from_slice(&rhs.data.state);
        s.method.reset(rhs, t, &s.start, h);
    })?;
    poses_and_velocities_at_state(m, d);
    d.solver.started = true;
    Ok(())
}

/// After an accepted step: projects the state back onto the loop constraints when their
/// residual exceeds [`dynamics::PROJECTION_TOL`] (and rescales drifted joint quaternions),
/// then restarts the integrator from the corrected state (deterministic, so restored states
/// still continue bit for bit).
fn project_after_step(m: &Model, d: &mut Data) -> Result<(), EngineError> {
    if !dynamics::project_state(m, d, dynamics::PROJECTION_TOL, contact::resting_rows) {
        return Ok(());
    }
    if !d.contacts.is_empty() {
        // The correction moves bodies by about the tolerance. If that alone changed the
        // sign of an event function, keep the step's own end state (still held by the
        // integrator) so that the event is located on the dense output as usual; a later
        // step projects.
        d.eval_state.copy_from_slice(&d.state);
        events::event_values(m, d, true);
        let flipped = d
            .events
            .g
            .iter()
            .zip(&d.events.g_new)
            .any(|(&a, &b)| modes::crossed(a, b));
        if flipped {
            if let Some(method) = d.solver.method() {
                d.state.copy_from_slice(method.y());
            }
            return Ok(());
        }
    }
    let h = d.solver.method().map_or(0.0, |i| i.next_step());
    restart(m, d, h, false)
}

/// After a failed step: the next advance restarts the integrator, without memory.
fn stop_after_failure(d: &mut Data) {
    d.solver.started = false;
    if let Some(s) = d.solver.stepper.as_mut() {
        // an empty memory is always accepted
        let _ = s.method.set_warm_state(&[]);
    }
}

/// Copies the integrator's counters (since initialisation) into `d.counters`.
fn sync_counters(d: &mut Data) {
    let Some(s) = d.solver.method().map(|i| i.stats()) else {
        return;
    };
    let (b, c) = (d.solver.base, &mut d.counters);
    c.steps = s.steps - b.steps;
    c.rejected = s.rejected - b.rejected;
    c.rhs_evals = s.rhs_evals - b.rhs_evals;
    c.jac_evals = s.jac_evals - b.jac_evals;
}

/// Sets the time at initialisation: the counters count from here, the integrator restarts.
pub fn set_start_time(d: &mut Data, t: f64) {
    d.time = t;
    d.solver.started = false;
}
