//! The engine: a compiled [`Model`], its [`Data`] and an integrator, advanced from one
//! communication point to the next with contact events located on the way.
//!
//! The right-hand side is evaluated with the contact *mode* (which contacts are active)
//! frozen; every change of mode — touch, separation, an impact — is an event located by root
//! finding on the integrator's dense output, after which the integrator is restarted. No
//! force discontinuity is stepped over.

use crate::contact::{self, impulse};
use crate::dynamics;
use crate::integrator::{self, Integrator, OdeSystem, Stats};
use crate::model::{self, Data, Model};
use crate::scene::{Law, Scene, SceneError};
use crate::variables::VarRef;

pub use crate::model::Counters;

/// A failed advance: the last good time and what went wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("at t = {time}: {message}")]
pub struct EngineError {
    /// Last time reached with a valid state [s].
    pub time: f64,
    /// What went wrong.
    pub message: String,
}

/// The right-hand side `y' = f(t, y)` of a model.
pub struct Rhs<'a> {
    /// Model.
    pub model: &'a Model,
    /// Data (work buffers).
    pub data: &'a mut Data,
}

/// Evaluates everything at `state`: kinematics, forces, accelerations. Writes `dy` if given.
/// Returns false when the mass matrix is not positive definite.
pub fn evaluate(m: &Model, d: &mut Data, state: &[f64], dy: Option<&mut [f64]>) -> bool {
    dynamics::kinematics(m, d, state);
    let mut power = dynamics::applied_forces(m, d);
    if !m.contacts.is_empty() {
        power += contact::apply_forces(m, d);
    }
    d.dissipation = power;
    dynamics::mass_and_bias(m, d);
    let ok = dynamics::factor_mass(m, d);
    if ok {
        // The constraint rows: the loops, and the rows of resting impulse contacts (skipped
        // when there are no loops and nothing rests).
        let resting = any_resting(m, d);
        if m.nc > 0 && (resting || contact::loop_rows(m) > 0) {
            let (nq, nv) = (m.nq, m.nv);
            dynamics::constraints(m, d, &state[nq..nq + nv]);
            dynamics::solve_constrained(m, d);
            if resting {
                contact::resting_outputs(m, d);
            }
        } else {
            dynamics::solve_mass(m, &d.mass_blocks, &mut d.qacc);
        }
    } else {
        d.qacc.iter_mut().for_each(|x| *x = f64::NAN);
    }
    if let Some(dy) = dy {
        let (nq, nv) = (m.nq, m.nv);
        dynamics::position_derivative(m, state, &mut dy[..nq]);
        dy[nq..nq + nv].copy_from_slice(&d.qacc);
        dy[nq + nv] = power;
    }
    ok
}

/// True when some impulse-law contact is resting (its constraint row is on).
fn any_resting(m: &Model, d: &Data) -> bool {
    m.contacts
        .iter()
        .zip(&d.contact_memory)
        .any(|(c, mem)| mem.active && c.law == Law::Impulse)
}

impl OdeSystem for Rhs<'_> {
    fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        evaluate(self.model, self.data, y, Some(dy));
    }
}

/// What happened at a contact event (see [`ContactEvent`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactEventKind {
    /// A continuous-law contact starts (δ becomes positive inside the patch).
    Touch,
    /// A continuous-law contact ends (δ returns to zero or the sphere leaves the patch).
    Separation,
    /// An impulse-law impact (a velocity jump); `delta_dot` is the approach rate before it.
    Impact,
    /// An impulse-law contact comes to rest (resting constraint on).
    Rest,
    /// A resting contact lets go (its normal force would pull, or the sphere left the patch).
    Release,
    /// The damping term cuts the force at zero before δ does (the law would pull).
    Clamp,
    /// The cut ends (the law's force is positive again).
    Unclamp,
    /// Largest penetration of a continuous-law contact (δ̇ = 0), located on the dense output
    /// without interrupting the integration.
    Peak,
}

/// One located contact event, with the contact's state at that instant. A diagnostic log (see
/// [`Engine::contact_events`]); not part of the FMU state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactEvent {
    /// Time [s].
    pub time: f64,
    /// Contact index (scene order).
    pub contact: usize,
    /// What happened.
    pub kind: ContactEventKind,
    /// Penetration δ [m] (signed).
    pub delta: f64,
    /// Penetration rate δ̇ [m/s] (for an impact: before it).
    pub delta_dot: f64,
    /// Normal force [N] (continuous laws; resting contacts: the constraint force); for an
    /// impact, the normal impulse [N s].
    pub force: f64,
}

/// Consecutive integrator steps cut short by an event after which the advance fails (an
/// event storm: a fixed-step method overshooting a stiff contact, or a Zeno sequence).
const MAX_INTERRUPTED_STEPS: usize = 2000;

/// Relative tolerance of event location in time.
const EVENT_TIME_TOL: f64 = 1e-13;

/// Oldest entries are dropped beyond this many logged contact events.
const EVENT_LOG_CAPACITY: usize = 4096;

/// Model, data, integrator and event bookkeeping.
pub struct Engine {
    model: Model,
    data: Data,
    integrator: Box<dyn Integrator + Send>,
    /// Event functions at the current state: per contact its mode function (touch /
    /// separation / release), then per contact its clamp function (the force law's sign).
    g: Vec<f64>,
    g_new: Vec<f64>,
    /// Per contact (δ, δ̇) at the current state (δ is the broad-phase stand-in when skipped).
    aux: Vec<(f64, f64)>,
    aux_new: Vec<(f64, f64)>,
    y_work: Vec<f64>,
    y_event: Vec<f64>,
    /// Scratch copy of the state (the evaluation reads the state while writing `data`).
    scratch: Vec<f64>,
    /// True when the integrator holds the current state.
    started: bool,
    /// True when the outputs match the current state.
    outputs_valid: bool,
    /// Integrator counters at initialisation (counters are reported since then).
    base_stats: Stats,
    /// Step size to try at the next restart when the integrator has not run yet.
    next_h: f64,
    /// Locate the instants a damped law's force is cut at zero (and restart there).
    clamp_events: bool,
    /// Diagnostic log of contact events.
    events: Vec<ContactEvent>,
    /// Buffers of the impulse law's event handling.
    impacts: ImpactBuffers,
}

/// Preallocated buffers of the impulse law's event handling, sized at compilation by the
/// number of impulse-law contacts: resolving impacts and settling resting contacts allocate
/// nothing.
#[derive(Default)]
struct ImpactBuffers {
    /// Work arrays of [`impulse::resolve_with`].
    work: impulse::ImpulseWork,
    /// Contacts of the current round of impacts, their restitution and (δ, δ̇) before it.
    set: Vec<usize>,
    restitution: Vec<f64>,
    approach: Vec<(f64, f64)>,
    /// Per contact: active before the resting set was rebuilt.
    was: Vec<bool>,
    /// Resting candidates.
    candidates: Vec<usize>,
    /// Copy of the state (the evaluation reads it while writing the data).
    state: Vec<f64>,
}

impl ImpactBuffers {
    fn new(m: &Model) -> ImpactBuffers {
        let k = m.contacts.iter().filter(|c| c.law == Law::Impulse).count();
        ImpactBuffers {
            work: impulse::ImpulseWork::new(m, k),
            set: Vec::with_capacity(k),
            restitution: Vec::with_capacity(k),
            approach: Vec::with_capacity(k),
            was: Vec::with_capacity(m.contacts.len()),
            candidates: Vec::with_capacity(k),
            state: vec![0.0; m.nstate()],
        }
    }
}

/// One scalar function the event locator can follow.
#[derive(Debug, Clone, Copy)]
enum Probe {
    /// Event function `k` of the `g` vector.
    Event(usize),
    /// Exact penetration δ of contact `i` (tunnelling check).
    Delta(usize),
    /// Penetration rate δ̇ of contact `i` (peaks).
    Rate(usize),
}

impl Engine {
    /// Compiles a validated scene.
    pub fn compile(scene: &Scene, origin: &str) -> Result<Engine, SceneError> {
        let (mut model, data) = model::compile(scene, origin)?;
        for c in &model.contacts {
            if c.law == Law::KelvinVoigt && c.damping > 0.0 {
                let w = format!(
                    "contact {:?}: kelvin_voigt jumps to c·δ̇⁻ at touch and would pull before separation; \
                     the force is cut at zero there (docs/contact.md)",
                    c.name
                );
                model.warnings.push(w);
            }
        }
        let n = model.nstate();
        let integrator = integrator::create(&model.solver, n);
        let nc = model.contacts.len();
        let impacts = ImpactBuffers::new(&model);
        let mut e = Engine {
            model,
            data,
            integrator,
            g: vec![0.0; 2 * nc],
            g_new: vec![0.0; 2 * nc],
            aux: vec![(0.0, 0.0); nc],
            aux_new: vec![(0.0, 0.0); nc],
            y_work: vec![0.0; n],
            y_event: vec![0.0; n],
            scratch: vec![0.0; n],
            started: false,
            outputs_valid: false,
            base_stats: Stats::default(),
            next_h: 0.0,
            clamp_events: true,
            events: Vec::with_capacity(if nc > 0 { EVENT_LOG_CAPACITY } else { 0 }),
            impacts,
        };
        e.init_contacts()
            .map_err(|err| SceneError::new(origin, "contact", "-", format!("at the initial state: {}", err.message)))?;
        Ok(e)
    }

    /// The located contact events since compilation (or the last
    /// [`Engine::clear_contact_events`]), oldest first; at most the last 4096.
    pub fn contact_events(&self) -> &[ContactEvent] {
        &self.events
    }

    /// Empties the contact event log.
    pub fn clear_contact_events(&mut self) {
        self.events.clear();
    }

    /// Turns the location of force cuts ([`ContactEventKind::Clamp`]) on (default) or off.
    /// Off, the integrator steps over the kink of a damped law's force at zero, with only its
    /// error control to notice it.
    pub fn set_clamp_events(&mut self, on: bool) {
        self.clamp_events = on;
        self.started = false;
    }

    fn log(&mut self, contact: usize, kind: ContactEventKind, delta: f64, delta_dot: f64, force: f64) {
        if self.events.len() >= EVENT_LOG_CAPACITY {
            self.events.drain(..EVENT_LOG_CAPACITY / 2);
        }
        self.events.push(ContactEvent {
            time: self.data.time,
            contact,
            kind,
            delta,
            delta_dot,
            force,
        });
    }

    /// The compiled model.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The data (state, buffers, counters).
    pub fn data(&self) -> &Data {
        &self.data
    }

    /// Current time [s].
    pub fn time(&self) -> f64 {
        self.data.time
    }

    /// Sets the time (at initialisation).
    pub fn set_time(&mut self, t: f64) {
        self.data.time = t;
        self.started = false;
    }

    /// Sets input `i`. The integrator restarts at the next advance (the input is piecewise
    /// constant between communication points).
    pub fn set_input(&mut self, i: usize, value: f64) {
        if self.data.inputs[i] != value {
            self.data.inputs[i] = value;
            self.outputs_valid = false;
        }
    }

    /// Contacts that overlap at the initial state start active, with δ̇⁻ from the initial
    /// rate (floored); impulse-law contacts that touch are resolved (an impact at the start
    /// if they approach, resting if they press).
    fn init_contacts(&mut self) -> Result<(), EngineError> {
        let m = &self.model;
        let d = &mut self.data;
        let state = d.state.clone();
        dynamics::kinematics(m, d, &state);
        for i in 0..m.contacts.len() {
            let g = contact::gap(m, d, i);
            let c = &m.contacts[i];
            if contact::event_function(c, &g) > 0.0 && c.law != Law::Impulse {
                d.contact_memory[i].active = true;
                d.contact_memory[i].impact_velocity = g.delta_dot.max(c.min_impact_velocity);
            }
        }
        if m.contacts.iter().any(|c| c.law == Law::Impulse) {
            evaluate(m, d, &state, None);
            self.settle_impulse_contacts()?;
        }
        let state = self.data.state.clone();
        self.compute_events(&state, false);
        Ok(())
    }

    /// Evaluates the event functions and the per-contact (δ, δ̇) at `state` into `g`/`aux`
    /// (`into_new`: into `g_new`/`aux_new`).
    fn compute_events(&mut self, state: &[f64], into_new: bool) {
        let (m, d) = (&self.model, &mut self.data);
        let (g, aux) = if into_new {
            (&mut self.g_new, &mut self.aux_new)
        } else {
            (&mut self.g, &mut self.aux)
        };
        Self::event_values(m, d, state, self.clamp_events, g, aux);
    }

    fn event_values(m: &Model, d: &mut Data, state: &[f64], clamp: bool, out: &mut [f64], aux: &mut [(f64, f64)]) {
        if any_resting(m, d) {
            evaluate(m, d, state, None);
        } else {
            dynamics::kinematics(m, d, state);
        }
        let nc = m.contacts.len();
        for i in 0..nc {
            let (mode, clamp_value, a) = Self::contact_event_values(m, d, i, clamp);
            out[i] = mode;
            out[nc + i] = clamp_value;
            aux[i] = a;
        }
    }

    /// Mode function, clamp function and (δ, δ̇) of contact `i` at the evaluated state.
    fn contact_event_values(m: &Model, d: &Data, i: usize, clamp: bool) -> (f64, f64, (f64, f64)) {
        let c = &m.contacts[i];
        let mem = d.contact_memory[i];
        if c.law == Law::Impulse && mem.active {
            // Resting: holds while the normal force pushes and the sphere stays on the patch.
            let g = contact::gap(m, d, i);
            return (
                contact::resting_force(m, d, i).min(g.margin),
                1.0,
                (g.delta, g.delta_dot),
            );
        }
        if let Some(v) = contact::broad_phase(c, d) {
            return (v, 1.0, (v, 0.0));
        }
        let g = contact::gap(m, d, i);
        let clamp_value = if clamp && mem.active && c.law != Law::Impulse && contact::laws::can_clamp(c) {
            contact::laws::clamp_function(c, g.delta.max(0.0), g.delta_dot, mem.impact_velocity)
        } else {
            1.0
        };
        let mut mode = contact::event_function(c, &g);
        if c.law == Law::Impulse && g.delta_dot < 0.0 {
            // An impulse contact that separates is apart whatever its (tiny) overlap: the
            // state right after an impact (located a hair past δ = 0) must not count as in
            // contact, or a bounce shorter than one step would go unseen.
            mode = mode.min(0.0);
        }
        (mode, clamp_value, (g.delta, g.delta_dot))
    }

    /// The value of one probe at the evaluated state.
    fn probe_value(m: &Model, d: &Data, probe: Probe, clamp: bool) -> f64 {
        let nc = m.contacts.len();
        match probe {
            Probe::Event(k) if k < nc => Self::contact_event_values(m, d, k, clamp).0,
            Probe::Event(k) => Self::contact_event_values(m, d, k - nc, clamp).1,
            Probe::Delta(i) => contact::gap(m, d, i).delta,
            Probe::Rate(i) => contact::gap(m, d, i).delta_dot,
        }
    }

    /// Evaluates `probe` on the dense output at `t` (leaves the interpolated state in
    /// `y_event` and the data evaluated there).
    fn probe_at(&mut self, probe: Probe, t: f64) -> f64 {
        self.integrator.interpolate(t, &mut self.y_event);
        let (m, d) = (&self.model, &mut self.data);
        let needs_dynamics = matches!(probe, Probe::Event(k) if k < m.contacts.len()
            && m.contacts[k].law == Law::Impulse && d.contact_memory[k].active);
        if needs_dynamics {
            evaluate(m, d, &self.y_event, None);
        } else {
            let nc = m.contacts.len();
            let i = match probe {
                Probe::Event(k) => k % nc,
                Probe::Delta(i) | Probe::Rate(i) => i,
            };
            contact_kinematics(m, d, &self.y_event, i);
        }
        Self::probe_value(m, d, probe, self.clamp_events)
    }

    /// The step size the next restart will try.
    fn pending_step(&self) -> f64 {
        if self.started {
            self.integrator.next_step()
        } else {
            self.next_h
        }
    }

    /// After an accepted step: projects the state back onto the loop constraints when their
    /// residual exceeds [`dynamics::PROJECTION_TOL`] (and rescales drifted joint quaternions),
    /// then restarts the integrator from the corrected state (deterministic, so restored FMU
    /// states still continue bit for bit).
    fn project_after_step(&mut self) {
        if !dynamics::project_state(&self.model, &mut self.data, dynamics::PROJECTION_TOL) {
            return;
        }
        if !self.model.contacts.is_empty() {
            // The correction moves bodies by about the tolerance. If that alone changed the
            // sign of an event function, keep the step's own end state (still held by the
            // integrator, in `y_work`) so that the event is located on the dense output as
            // usual; a later step projects.
            self.y_event.copy_from_slice(&self.data.state);
            let ye = std::mem::take(&mut self.y_event);
            self.compute_events(&ye, true);
            self.y_event = ye;
            if self.g.iter().zip(&self.g_new).any(|(a, b)| (*a <= 0.0) != (*b <= 0.0)) {
                self.data.state.copy_from_slice(&self.y_work);
                return;
            }
        }
        self.restart_with(self.integrator.next_step(), false);
    }

    /// After a failed step: the next advance restarts the integrator, without memory.
    fn stop_after_failure(&mut self) {
        self.started = false;
        // an empty memory is always accepted
        let _ = self.integrator.set_warm_state(&[]);
    }

    /// Restarts the integrator from the current state with first step `h`: `warm` (nothing
    /// changed the right-hand side: a plain communication point) keeps an implicit method's
    /// Jacobian and controller memory, which [`Engine::save_state`] saves; otherwise (after an
    /// event, an impulse, a projection) everything is dropped.
    fn restart_with(&mut self, h: f64, warm: bool) {
        let mut state = std::mem::take(&mut self.scratch);
        state.copy_from_slice(&self.data.state);
        let t = self.data.time;
        let mut rhs = Rhs {
            model: &self.model,
            data: &mut self.data,
        };
        if warm {
            self.integrator.restart(&mut rhs, t, &state, h);
        } else {
            self.integrator.reset(&mut rhs, t, &state, h);
        }
        self.compute_events(&state, false);
        self.scratch = state;
        self.started = true;
    }

    /// True when the crossing of event function `k` from `g0` to `g1` needs handling (an
    /// impulse contact leaving its zone after an impact does not; a cut of the force only
    /// matters while the contact is active).
    fn relevant_crossing(&self, k: usize, g0: f64, g1: f64, delta1: f64) -> bool {
        let crossed = (g0 <= 0.0) != (g1 <= 0.0);
        if !crossed {
            return false;
        }
        let nc = self.model.contacts.len();
        if k >= nc {
            return self.data.contact_memory[k - nc].active;
        }
        let c = &self.model.contacts[k];
        if c.law == Law::Impulse && !self.data.contact_memory[k].active && g1 <= 0.0 {
            // Leaving after an impact: nothing to do, unless δ went past δ_max.
            return delta1 >= 0.5 * c.max_penetration;
        }
        true
    }

    /// Integrates to `t_end`, locating and handling contact events.
    pub fn advance(&mut self, t_end: f64) -> Result<(), EngineError> {
        if t_end.is_nan() || t_end < self.data.time {
            return Err(EngineError {
                time: self.data.time,
                message: format!("cannot integrate backwards to {t_end}"),
            });
        }
        self.outputs_valid = false;
        // An input changed at this communication point may have made a resting contact pull.
        let settled = any_resting(&self.model, &self.data) && self.resting_violated();
        if settled {
            self.settle_impulse_contacts()?;
        }
        // Every advance restarts the method from the current state (one extra evaluation),
        // so that a restored FMU state continues bit for bit like the original; a plain
        // restart keeps an implicit method's Jacobian (saved with the state).
        self.restart_with(self.pending_step(), !settled);
        let nc = self.model.contacts.len();
        // A remainder of a few ulps (a step or an event that ended a rounding error short of
        // t_end) is not a step any method can take.
        let t_close = 16.0 * f64::EPSILON * t_end.abs().max(1e-300);
        let mut interrupted = 0usize;
        while t_end - self.data.time > t_close {
            {
                let mut rhs = Rhs {
                    model: &self.model,
                    data: &mut self.data,
                };
                if let Err(e) = self.integrator.step(&mut rhs, t_end) {
                    self.stop_after_failure();
                    return Err(EngineError {
                        time: self.data.time,
                        message: e.to_string(),
                    });
                }
            }
            let t1 = self.integrator.t();
            self.y_work.copy_from_slice(self.integrator.y());
            if !self.y_work.iter().all(|v| v.is_finite()) {
                self.stop_after_failure();
                return Err(EngineError {
                    time: self.data.time,
                    message: "the state became non-finite".into(),
                });
            }
            if nc == 0 {
                self.data.state.copy_from_slice(&self.y_work);
                self.data.time = t1;
                self.project_after_step();
                continue;
            }
            let y1 = std::mem::take(&mut self.y_work);
            self.compute_events(&y1, true);
            self.y_work = y1;
            let t0 = self.integrator.t_prev();
            // Earliest relevant crossing.
            let mut t_first = t1;
            let mut any = false;
            for k in 0..2 * nc {
                let delta1 = self.aux_new[k % nc].0;
                if self.relevant_crossing(k, self.g[k], self.g_new[k], delta1) {
                    let t = self.locate(Probe::Event(k), t0, t1, self.g[k], self.g_new[k], t_first);
                    any = true;
                    t_first = t_first.min(t);
                }
            }
            // Tunnelling: δ of a contact that is not in contact crossed zero without its event
            // function turning positive at the end of the step (it passed δ_max or the patch).
            for i in 0..nc {
                let (d0, d1) = (self.aux[i].0, self.aux_new[i].0);
                if self.data.contact_memory[i].active || !(d0 <= 0.0 && d1 > 0.0) || self.g_new[i] > 0.0 {
                    continue;
                }
                let d0_exact = {
                    self.integrator.interpolate(t0, &mut self.y_event);
                    let (m, d) = (&self.model, &mut self.data);
                    contact_kinematics(m, d, &self.y_event, i);
                    contact::gap(m, d, i).delta
                };
                if d0_exact > 0.0 {
                    continue;
                }
                let t = self.locate(Probe::Delta(i), t0, t1, d0_exact, d1, t_first);
                if t < t_first && self.probe_at(Probe::Event(i), t) > 0.0 {
                    any = true;
                    t_first = t;
                }
            }
            // Peaks of continuous contacts inside the accepted part of the step (diagnostic).
            for i in 0..nc {
                let c = &self.model.contacts[i];
                if c.law == Law::Impulse || !self.data.contact_memory[i].active {
                    continue;
                }
                let (r0, r1) = (self.aux[i].1, self.aux_new[i].1);
                if r0 > 0.0 && r1 <= 0.0 {
                    let t = self.locate(Probe::Rate(i), t0, t1, r0, r1, t1);
                    if t <= t_first {
                        self.integrator.interpolate(t, &mut self.y_event);
                        let (m, d) = (&self.model, &mut self.data);
                        contact_kinematics(m, d, &self.y_event, i);
                        let g = contact::gap(m, d, i);
                        let mem = d.contact_memory[i];
                        let f =
                            contact::laws::force(&m.contacts[i], g.delta.max(0.0), g.delta_dot, mem.impact_velocity);
                        let saved = self.data.time;
                        self.data.time = t;
                        self.log(i, ContactEventKind::Peak, g.delta, g.delta_dot, f.total);
                        self.data.time = saved;
                    }
                }
            }
            if !any {
                interrupted = 0;
                self.data.state.copy_from_slice(&self.y_work);
                self.data.time = t1;
                std::mem::swap(&mut self.g, &mut self.g_new);
                std::mem::swap(&mut self.aux, &mut self.aux_new);
                self.project_after_step();
                continue;
            }
            interrupted += 1;
            if interrupted > MAX_INTERRUPTED_STEPS {
                self.stop_after_failure();
                return Err(EngineError {
                    time: self.data.time,
                    message: format!(
                        "{MAX_INTERRUPTED_STEPS} steps in a row were cut short by contact events (touch and \
                         separation chatter): the step is too large for the contact stiffness; use an adaptive \
                         method or a smaller solver.max_step"
                    ),
                });
            }
            self.integrator.interpolate(t_first, &mut self.y_event);
            self.data.state.copy_from_slice(&self.y_event);
            self.data.time = t_first;
            self.data.counters.events += 1;
            let ye = std::mem::take(&mut self.y_event);
            self.compute_events(&ye, true);
            self.y_event = ye;
            let result = self.handle_events();
            let h = self.integrator.next_step();
            self.restart_with(h, false);
            result?;
        }
        self.data.time = t_end;
        self.sync_counters();
        Ok(())
    }

    /// Finds the right end of the bracket of a sign change of `probe` in `[t0, t1]` (values
    /// `g0`, `g1` at the ends) by the Illinois method; stops early once the bracket lies
    /// beyond `t_limit` (a crossing found earlier wins).
    fn locate(&mut self, probe: Probe, t0: f64, t1: f64, g0: f64, g1: f64, t_limit: f64) -> f64 {
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
            let gt = self.probe_at(probe, t);
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

    /// True when a resting contact's normal force does not push or it left its patch.
    fn resting_violated(&mut self) -> bool {
        self.evaluate_current();
        let (m, d) = (&self.model, &mut self.data);
        (0..m.contacts.len()).any(|i| {
            m.contacts[i].law == Law::Impulse
                && d.contact_memory[i].active
                && Self::contact_event_values(m, d, i, false).0 <= 0.0
        })
    }

    /// Applies the mode changes at an event state (`self.g` before, `self.g_new` now).
    fn handle_events(&mut self) -> Result<(), EngineError> {
        self.evaluate_current();
        let nc = self.model.contacts.len();
        let mut impulse_work = false;
        for i in 0..nc {
            let c = &self.model.contacts[i];
            let gap = contact::gap(&self.model, &self.data, i);
            let mem = self.data.contact_memory[i];
            let (before, now) = (self.g[i], self.g_new[i]);
            let crossed = self.relevant_crossing(i, before, now, gap.delta);
            // Reaching δ_max in contact is an error. (A continuous contact that is not active
            // there is a sphere passing behind a plate: not a contact at all.)
            let in_contact = if c.law == Law::Impulse { !mem.active } else { mem.active };
            if crossed && now <= 0.0 && in_contact && gap.delta >= c.max_penetration * (1.0 - 1e-9) {
                return Err(EngineError {
                    time: self.data.time,
                    message: format!(
                        "contact {:?}: penetration {:.6e} m reached max_penetration {:.6e} m (the contact is too \
                         soft or the impact too fast for this model, or the step too long: raise max_penetration or \
                         stiffness, or lower solver.max_step)",
                        c.name, gap.delta, c.max_penetration
                    ),
                });
            }
            if c.law == Law::Impulse {
                impulse_work |= crossed;
                continue;
            }
            if crossed {
                // A touch comes through δ = 0 (or over the patch edge with a small overlap);
                // entering the zone deeper than δ_max/2 is the sphere coming through the back
                // of the shape: ignored.
                if now > 0.0 && !mem.active && gap.delta < 0.5 * c.max_penetration {
                    let v = gap.delta_dot.max(c.min_impact_velocity);
                    let m = &mut self.data.contact_memory[i];
                    m.active = true;
                    m.impact_velocity = v;
                    self.log(i, ContactEventKind::Touch, gap.delta, gap.delta_dot, 0.0);
                } else if now <= 0.0 && mem.active {
                    self.data.contact_memory[i].active = false;
                    self.log(i, ContactEventKind::Separation, gap.delta, gap.delta_dot, 0.0);
                }
            }
            if self.relevant_crossing(nc + i, self.g[nc + i], self.g_new[nc + i], gap.delta) {
                let kind = if self.g_new[nc + i] <= 0.0 {
                    ContactEventKind::Clamp
                } else {
                    ContactEventKind::Unclamp
                };
                let f = self.data.contact_out[i].force;
                self.log(i, kind, gap.delta, gap.delta_dot, f);
            }
        }
        if impulse_work {
            self.settle_impulse_contacts()?;
        }
        Ok(())
    }

    /// Resolves the impulse-law contacts at the current (evaluated) state: rounds of
    /// simultaneous impacts of the touching contacts that approach, until none does
    /// (an impact can make a neighbour approach: Newton's cradle); approach slower than
    /// `min_impact_velocity` is plastic (e = 0). Then the touching contacts that neither
    /// approach nor separate rest if their constraint force pushes (an active set: the most
    /// tensile one is dropped until all push).
    fn settle_impulse_contacts(&mut self) -> Result<(), EngineError> {
        let mut bufs = std::mem::take(&mut self.impacts);
        let result = self.settle_with(&mut bufs);
        self.impacts = bufs;
        result
    }

    /// [`Engine::settle_impulse_contacts`] on the preallocated buffers (taken out of `self`).
    fn settle_with(&mut self, bufs: &mut ImpactBuffers) -> Result<(), EngineError> {
        let nc = self.model.contacts.len();
        let err = |time: f64, message: String| EngineError { time, message };
        let time = self.data.time;
        let max_rounds = 100 + 20 * nc;
        let mut rounds = 0;
        loop {
            let (m, d) = (&self.model, &mut self.data);
            bufs.set.clear();
            bufs.restitution.clear();
            bufs.approach.clear();
            for (i, c) in m.contacts.iter().enumerate() {
                if c.law != Law::Impulse {
                    continue;
                }
                let g = contact::gap(m, d, i);
                if touching(c, &g, d.contact_memory[i].active) && g.delta_dot > velocity_tolerance(c) {
                    bufs.set.push(i);
                    bufs.restitution.push(impulse::restitution_for(c, g.delta_dot));
                    bufs.approach.push((g.delta, g.delta_dot));
                }
            }
            if bufs.set.is_empty() {
                break;
            }
            rounds += 1;
            if rounds > max_rounds {
                let names: Vec<&str> = bufs.set.iter().map(|&i| m.contacts[i].name.as_str()).collect();
                return Err(err(
                    time,
                    format!("impacts of contacts {names:?} did not come to an end after {max_rounds} rounds"),
                ));
            }
            let energy_lost = impulse::resolve_with(m, d, &mut bufs.work, &bufs.set, &bufs.restitution)
                .map_err(|msg| err(time, msg))?;
            let di = m.dissipated_index();
            d.state[di] += energy_lost;
            for (k, &i) in bufs.set.iter().enumerate() {
                let impulse = bufs.work.impulses()[k];
                self.log(
                    i,
                    ContactEventKind::Impact,
                    bufs.approach[k].0,
                    bufs.approach[k].1,
                    impulse,
                );
            }
        }
        // Resting set.
        let (m, d) = (&self.model, &mut self.data);
        bufs.was.clear();
        bufs.was.extend(d.contact_memory.iter().map(|x| x.active));
        bufs.candidates.clear();
        for (i, c) in m.contacts.iter().enumerate() {
            if c.law != Law::Impulse {
                continue;
            }
            let g = contact::gap(m, d, i);
            let rest = touching(c, &g, bufs.was[i]) && g.margin > 0.0 && g.delta_dot.abs() <= velocity_tolerance(c);
            d.contact_memory[i].active = rest;
            if rest {
                bufs.candidates.push(i);
            }
        }
        let state = &mut bufs.state;
        state.copy_from_slice(&d.state);
        evaluate(m, d, state, None);
        while !bufs.candidates.is_empty() {
            let (k, p) = bufs
                .candidates
                .iter()
                .enumerate()
                .map(|(k, &i)| (k, contact::resting_force(m, d, i)))
                .fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
            if p > 0.0 {
                break;
            }
            let i = bufs.candidates.remove(k);
            d.contact_memory[i].active = false;
            evaluate(m, d, state, None);
        }
        for (i, &before) in bufs.was.iter().enumerate() {
            let now = self.data.contact_memory[i].active;
            if self.model.contacts[i].law == Law::Impulse && now != before {
                let g = contact::gap(&self.model, &self.data, i);
                let f = contact::resting_force(&self.model, &self.data, i);
                let kind = if now {
                    ContactEventKind::Rest
                } else {
                    ContactEventKind::Release
                };
                self.log(i, kind, g.delta, g.delta_dot, f);
            }
        }
        Ok(())
    }

    fn sync_counters(&mut self) {
        let s = self.integrator.stats();
        let c = &mut self.data.counters;
        c.steps = s.steps - self.base_stats.steps;
        c.rejected = s.rejected - self.base_stats.rejected;
        c.rhs_evals = s.rhs_evals - self.base_stats.rhs_evals;
        c.jac_evals = s.jac_evals - self.base_stats.jac_evals;
    }

    /// Counters since initialisation.
    pub fn counters(&self) -> Counters {
        self.data.counters
    }

    fn refresh_outputs(&mut self) {
        if !self.outputs_valid {
            self.evaluate_current();
            self.outputs_valid = true;
        }
    }

    /// Evaluates everything at the current state (through a scratch copy: no allocation).
    fn evaluate_current(&mut self) {
        let mut state = std::mem::take(&mut self.scratch);
        state.copy_from_slice(&self.data.state);
        evaluate(&self.model, &mut self.data, &state, None);
        self.scratch = state;
    }

    /// Energies (kinetic, potential, contact, dissipated) at the current state [J].
    pub fn energies(&mut self) -> [f64; 4] {
        self.refresh_outputs();
        let (m, d) = (&self.model, &self.data);
        let contact: f64 = d.contact_out.iter().map(|o| o.elastic_energy).sum();
        [
            dynamics::kinetic_energy(m, d),
            dynamics::potential_energy(m, d),
            contact,
            d.state[m.dissipated_index()],
        ]
    }

    /// Largest loop-constraint residual |Φ| at the current state.
    pub fn constraint_residual(&mut self) -> f64 {
        self.refresh_outputs();
        if self.model.nc == 0 {
            return 0.0;
        }
        let state = self.data.state.clone();
        let (m, d) = (&self.model, &mut self.data);
        dynamics::constraints(m, d, &state[m.nq..m.nq + m.nv]);
        d.phi.iter().fold(0.0_f64, |a, b| a.max(b.abs()))
    }

    /// The value of an output or calculated parameter.
    pub fn output(&mut self, target: VarRef) -> f64 {
        self.refresh_outputs();
        let (m, d) = (&self.model, &self.data);
        match target {
            VarRef::Stiffness(i) => m.contacts[i].stiffness,
            VarRef::BodyPosition(b, k) => d.body_pos[b][k],
            VarRef::BodyVelocity(b, k) => dynamics::com_velocity(d, b)[k],
            VarRef::BodyAngularVelocity(b, k) => d.body_vel[b].ang[k],
            VarRef::BodyQuaternion(b, k) => {
                let q = d.body_quat[b].quaternion();
                [q.w, q.i, q.j, q.k][k]
            }
            VarRef::JointQ(j) | VarRef::JointQd(j) => match m.scene_joint[j] {
                Ok(t) => {
                    let tj = &m.joints[t];
                    if matches!(target, VarRef::JointQ(_)) {
                        d.state[tj.qpos]
                    } else {
                        d.state[m.nq + tj.qvel]
                    }
                }
                Err(li) => {
                    let (q, qd) = dynamics::loop_joint_coordinate(m, d, li);
                    if matches!(target, VarRef::JointQ(_)) {
                        q
                    } else {
                        qd
                    }
                }
            },
            VarRef::ContactDelta(i) => d.contact_out[i].delta,
            VarRef::ContactDeltaDot(i) => {
                if d.contact_memory[i].active {
                    d.contact_out[i].delta_dot
                } else {
                    0.0
                }
            }
            VarRef::ContactForce(i) => d.contact_out[i].force,
            VarRef::ContactActive(i) => d.contact_memory[i].active as u8 as f64,
            VarRef::ContactImpacts(i) => d.contact_memory[i].impacts as f64,
            VarRef::EnergyKinetic => self.energies()[0],
            VarRef::EnergyPotential => self.energies()[1],
            VarRef::EnergyContact => self.energies()[2],
            VarRef::EnergyTotal => {
                let e = self.energies();
                e[0] + e[1] + e[2]
            }
            VarRef::EnergyDissipated => self.energies()[3],
            VarRef::SolverSteps => d.counters.steps as f64,
            VarRef::SolverRhsEvals => d.counters.rhs_evals as f64,
            _ => f64::NAN,
        }
    }

    /// The dynamic state as plain numbers: time, state vector, inputs, contact memory,
    /// next step size, counters, then the integrator's warm-restart memory (its length, then
    /// [`Integrator::warm_state`]: nothing for explicit methods; controller memory and the
    /// Jacobian, up to [`integrator::WARM_JACOBIAN_MAX`] numbers, for implicit ones).
    pub fn save_state(&self) -> Vec<f64> {
        let d = &self.data;
        let mut v = Vec::with_capacity(8 + d.state.len() + d.inputs.len() + 3 * d.contact_memory.len());
        v.push(d.time);
        v.push(self.pending_step());
        v.extend_from_slice(&d.state);
        v.extend_from_slice(&d.inputs);
        for mem in &d.contact_memory {
            v.push(mem.active as u8 as f64);
            v.push(mem.impact_velocity);
            v.push(mem.impacts as f64);
        }
        let s = self.integrator.stats();
        let c = &d.counters;
        v.extend_from_slice(&[
            c.steps as f64,
            c.rejected as f64,
            c.rhs_evals as f64,
            c.jac_evals as f64,
            c.events as f64,
        ]);
        v.extend_from_slice(&[
            s.steps as f64,
            s.rejected as f64,
            s.rhs_evals as f64,
            s.jac_evals as f64,
        ]);
        let at = v.len();
        v.push(0.0);
        self.integrator.warm_state(&mut v);
        v[at] = (v.len() - at - 1) as f64;
        v
    }

    /// Restores a state written by [`Engine::save_state`] for the same model (a state without
    /// the integrator memory, as written before it was added, restarts the method cold).
    pub fn load_state(&mut self, v: &[f64]) -> Result<(), String> {
        let d = &self.data;
        let need = 2 + d.state.len() + d.inputs.len() + 3 * d.contact_memory.len() + 9;
        let warm: &[f64] = match v.len().cmp(&need) {
            std::cmp::Ordering::Less => {
                return Err(format!("state has {} numbers, this model needs {need}", v.len()));
            }
            std::cmp::Ordering::Equal => &[],
            std::cmp::Ordering::Greater => {
                let len = v[need];
                if len.fract() != 0.0 || !(0.0..v.len() as f64).contains(&len) || need + 1 + len as usize != v.len() {
                    return Err(format!(
                        "state has {} numbers, this model needs {need} plus the integrator memory ({len} numbers)",
                        v.len()
                    ));
                }
                &v[need + 1..]
            }
        };
        self.integrator.set_warm_state(warm)?;
        let d = &mut self.data;
        let mut it = v.iter().copied();
        let mut next = || it.next().unwrap_or(0.0);
        d.time = next();
        let h = next();
        for x in d.state.iter_mut() {
            *x = next();
        }
        for x in d.inputs.iter_mut() {
            *x = next();
        }
        for mem in d.contact_memory.iter_mut() {
            mem.active = next() != 0.0;
            mem.impact_velocity = next();
            mem.impacts = next() as u64;
        }
        let c = &mut d.counters;
        c.steps = next() as u64;
        c.rejected = next() as u64;
        c.rhs_evals = next() as u64;
        c.jac_evals = next() as u64;
        c.events = next() as u64;
        let s = Stats {
            steps: next() as u64,
            rejected: next() as u64,
            rhs_evals: next() as u64,
            jac_evals: next() as u64,
        };
        // counters since initialisation = integrator stats − base
        self.base_stats = Stats {
            steps: s.steps.saturating_sub(c.steps),
            rejected: s.rejected.saturating_sub(c.rejected),
            rhs_evals: s.rhs_evals.saturating_sub(c.rhs_evals),
            jac_evals: s.jac_evals.saturating_sub(c.jac_evals),
        };
        self.integrator.set_stats(s);
        self.outputs_valid = false;
        self.started = false;
        self.next_h = h;
        let state = self.data.state.clone();
        self.compute_events(&state, false);
        Ok(())
    }
}

/// Touching for the impulse law: resting, or within a hair of δ = 0 (simultaneous impacts)
/// or overlapping a little, on the patch (an overlap beyond δ_max/2 is a sphere behind a
/// plate, not a contact).
/// Kinematics of the two bodies of contact `i` (and their ancestors) only: enough for its
/// gap, broad phase and event functions. Every other body's entries in `d` are left stale,
/// so whatever follows a probe and looks at other bodies recomputes the full kinematics
/// (`compute_events`, `evaluate`, `project_state` all do).
fn contact_kinematics(m: &Model, d: &mut Data, state: &[f64], i: usize) {
    let c = &m.contacts[i];
    dynamics::kinematics_path(m, d, state, c.sphere_body);
    dynamics::kinematics_path(m, d, state, c.body);
}

fn touching(c: &contact::ContactElement, g: &contact::Gap, resting: bool) -> bool {
    (resting || g.delta >= -1e-10 * c.radius) && g.margin > 0.0 && g.delta < 0.5 * c.max_penetration
}

/// Normal speeds below this count as zero for the impulse law (neither approach nor
/// separation) [m/s].
fn velocity_tolerance(c: &contact::ContactElement) -> f64 {
    (1e-6 * c.min_impact_velocity).max(1e-12)
}
