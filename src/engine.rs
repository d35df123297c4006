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
        if m.nc > 0 {
            let (nq, nv) = (m.nq, m.nv);
            dynamics::constraints(m, d, &state[nq..nq + nv]);
        }
        dynamics::solve_constrained(m, d);
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

impl OdeSystem for Rhs<'_> {
    fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        evaluate(self.model, self.data, y, Some(dy));
    }
}

/// Model, data, integrator and event bookkeeping.
pub struct Engine {
    model: Model,
    data: Data,
    integrator: Box<dyn Integrator + Send>,
    /// Event functions at the current state.
    g: Vec<f64>,
    g_new: Vec<f64>,
    y_work: Vec<f64>,
    y_event: Vec<f64>,
    /// True when the integrator holds the current state.
    started: bool,
    /// True when the outputs match the current state.
    outputs_valid: bool,
    /// Integrator counters at initialisation (counters are reported since then).
    base_stats: Stats,
    /// Step size to try at the next restart when the integrator has not run yet.
    next_h: f64,
}

/// Relative tolerance of event location in time.
const EVENT_TIME_TOL: f64 = 1e-13;

impl Engine {
    /// Compiles a validated scene.
    pub fn compile(scene: &Scene, origin: &str) -> Result<Engine, SceneError> {
        let (model, data) = model::compile(scene, origin)?;
        let n = model.nstate();
        let integrator = integrator::create(&model.solver, n);
        let nc = model.contacts.len();
        let mut e = Engine {
            model,
            data,
            integrator,
            g: vec![0.0; nc],
            g_new: vec![0.0; nc],
            y_work: vec![0.0; n],
            y_event: vec![0.0; n],
            started: false,
            outputs_valid: false,
            base_stats: Stats::default(),
            next_h: 0.0,
        };
        e.init_contacts();
        Ok(e)
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
    /// rate (floored).
    fn init_contacts(&mut self) {
        let m = &self.model;
        let d = &mut self.data;
        let state = d.state.clone();
        dynamics::kinematics(m, d, &state);
        for i in 0..m.contacts.len() {
            let g = contact::gap(m, d, i);
            let c = &m.contacts[i];
            let ev = contact::event_function(c, &g);
            self.g[i] = ev;
            if ev > 0.0 && c.law != Law::Impulse {
                d.contact_memory[i].active = true;
                d.contact_memory[i].impact_velocity = g.delta_dot.max(c.min_impact_velocity);
            }
        }
    }

    fn event_values(m: &Model, d: &mut Data, state: &[f64], out: &mut [f64]) {
        dynamics::kinematics(m, d, state);
        for (i, o) in out.iter_mut().enumerate() {
            let c = &m.contacts[i];
            *o = contact::event_function(c, &contact::gap(m, d, i));
        }
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
        if dynamics::project_state(&self.model, &mut self.data, dynamics::PROJECTION_TOL) {
            self.restart_with(self.integrator.next_step());
        }
    }

    fn restart_with(&mut self, h: f64) {
        let state = self.data.state.clone();
        let t = self.data.time;
        let mut rhs = Rhs {
            model: &self.model,
            data: &mut self.data,
        };
        self.integrator.reset(&mut rhs, t, &state, h);
        let (m, d) = (&self.model, &mut self.data);
        Self::event_values(m, d, &state, &mut self.g);
        self.started = true;
    }

    /// Integrates to `t_end`, locating and handling contact events.
    pub fn advance(&mut self, t_end: f64) -> Result<(), EngineError> {
        if !(t_end >= self.data.time) {
            return Err(EngineError {
                time: self.data.time,
                message: format!("cannot integrate backwards to {t_end}"),
            });
        }
        self.outputs_valid = false;
        // Every advance restarts the method from the current state (one extra evaluation),
        // so that a restored FMU state continues bit for bit like the original.
        self.restart_with(self.pending_step());
        let nc = self.model.contacts.len();
        while self.data.time < t_end {
            {
                let mut rhs = Rhs {
                    model: &self.model,
                    data: &mut self.data,
                };
                if let Err(e) = self.integrator.step(&mut rhs, t_end) {
                    self.started = false;
                    return Err(EngineError {
                        time: self.data.time,
                        message: e.to_string(),
                    });
                }
            }
            let t1 = self.integrator.t();
            self.y_work.copy_from_slice(self.integrator.y());
            if !self.y_work.iter().all(|v| v.is_finite()) {
                self.started = false;
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
            let (m, d) = (&self.model, &mut self.data);
            let mut gn = std::mem::take(&mut self.g_new);
            Self::event_values(m, d, &self.y_work, &mut gn);
            self.g_new = gn;
            let crossed = |a: f64, b: f64| (a <= 0.0) != (b <= 0.0);
            if !(0..nc).any(|i| crossed(self.g[i], self.g_new[i])) {
                self.data.state.copy_from_slice(&self.y_work);
                self.data.time = t1;
                std::mem::swap(&mut self.g, &mut self.g_new);
                self.project_after_step();
                continue;
            }
            // Locate the earliest crossing by bisection-secant (Illinois) on each crossing
            // function, then take the right end of its bracket.
            let t0 = self.integrator.t_prev();
            let mut t_first = t1;
            for i in 0..nc {
                if crossed(self.g[i], self.g_new[i]) {
                    let tr = self.locate(i, t0, t1, self.g[i], self.g_new[i], t_first);
                    if tr < t_first {
                        t_first = tr;
                    }
                }
            }
            self.integrator.interpolate(t_first, &mut self.y_event);
            self.data.state.copy_from_slice(&self.y_event);
            self.data.time = t_first;
            self.data.counters.events += 1;
            let mut gn = std::mem::take(&mut self.g_new);
            let (m, d) = (&self.model, &mut self.data);
            Self::event_values(m, d, &self.y_event, &mut gn);
            self.g_new = gn;
            let result = self.handle_events();
            let h = self.integrator.next_step();
            self.restart_with(h);
            result?;
        }
        self.data.time = t_end;
        self.sync_counters();
        Ok(())
    }

    /// Finds the right end of the bracket of a sign change of event `i` in `[t0, t1]`.
    fn locate(&mut self, i: usize, t0: f64, t1: f64, g0: f64, g1: f64, t_limit: f64) -> f64 {
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
            self.integrator.interpolate(t, &mut self.y_event);
            let (m, d) = (&self.model, &mut self.data);
            dynamics::kinematics(m, d, &self.y_event);
            let gt = contact::event_function(&m.contacts[i], &contact::gap(m, d, i));
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

    /// Applies the mode changes at an event state (`self.g` before, `self.g_new` now).
    fn handle_events(&mut self) -> Result<(), EngineError> {
        let m = &self.model;
        let state = self.data.state.clone();
        evaluate(m, &mut self.data, &state, None);
        let mut impacts: Vec<usize> = Vec::new();
        for i in 0..m.contacts.len() {
            let (before, now) = (self.g[i], self.g_new[i]);
            let c = &m.contacts[i];
            let gap = contact::gap(m, &self.data, i);
            if before <= 0.0 && now > 0.0 {
                // touch
                if c.law == Law::Impulse {
                    if gap.delta_dot > 0.0 {
                        impacts.push(i);
                    }
                } else {
                    let mem = &mut self.data.contact_memory[i];
                    mem.active = true;
                    mem.impact_velocity = gap.delta_dot.max(c.min_impact_velocity);
                }
            } else if before > 0.0 && now <= 0.0 {
                let mem = &mut self.data.contact_memory[i];
                if mem.active && gap.delta >= c.max_penetration * (1.0 - 1e-9) {
                    return Err(EngineError {
                        time: self.data.time,
                        message: format!(
                            "contact {:?}: penetration {:.6e} m reached max_penetration {:.6e} m (the contact is too soft or the impact too fast for this model)",
                            c.name, gap.delta, c.max_penetration
                        ),
                    });
                }
                mem.active = false;
            }
        }
        if !impacts.is_empty() {
            let lost = impulse::resolve(m, &mut self.data, &impacts).map_err(|message| EngineError {
                time: self.data.time,
                message,
            })?;
            let di = m.dissipated_index();
            self.data.state[di] += lost;
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
            let state = self.data.state.clone();
            evaluate(&self.model, &mut self.data, &state, None);
            self.outputs_valid = true;
        }
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
                Err(_) => f64::NAN,
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
    /// next step size, counters.
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
        v
    }

    /// Restores a state written by [`Engine::save_state`] for the same model.
    pub fn load_state(&mut self, v: &[f64]) -> Result<(), String> {
        let d = &mut self.data;
        let need = 2 + d.state.len() + d.inputs.len() + 3 * d.contact_memory.len() + 9;
        if v.len() != need {
            return Err(format!("state has {} numbers, this model needs {need}", v.len()));
        }
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
        let (m, d) = (&self.model, &mut self.data);
        let state = d.state.clone();
        Self::event_values(m, d, &state, &mut self.g);
        Ok(())
    }
}
