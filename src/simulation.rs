//! The facade that hosts use: a scene, its variable table, parameter values, and once
//! initialised a compiled [`Model`] with its [`Data`]. Both the FMI layer and the
//! `simulate` command drive the engine only through this type, so they see the same
//! variables and the same numbers.

use crate::checkpoint::Snapshot;
use crate::compile::{compile_with, Parameters};
use crate::engine::{self, EngineError};
use crate::model::{state, ContactEvent, Counters, Data, Model};
use crate::outputs::{self, Energies};
use crate::scene::{Scene, SceneError};
use crate::variables::{set_parameter, Causality, VarRef, VarType, Variable, VariableTable};
use std::path::Path;

/// An error from the simulation facade, with a message for the user.
#[derive(Debug, Clone, thiserror::Error, PartialEq)]
pub enum SimError {
    /// The scene (with the current parameter values) does not compile.
    #[error("{0}")]
    Scene(#[from] SceneError),
    /// A parameter value is out of its range or cannot be set now.
    #[error("{0}")]
    Variable(String),
    /// The integration failed at `time`; the state is the last good one.
    #[error("at t = {time}: {message}")]
    Step {
        /// Last time successfully reached [s].
        time: f64,
        /// What went wrong.
        message: String,
    },
    /// The step stopped at `solver.max_steps` integrator steps, at `time`: the state there
    /// is valid and the simulation can go on from it.
    #[error("at t = {time}: {message}")]
    StepLimit {
        /// Time reached [s].
        time: f64,
        /// What happened.
        message: String,
    },
    /// Call before `initialize`.
    #[error("not initialised")]
    NotInitialized,
}

/// A scene being simulated.
pub struct Simulation {
    scene: Scene,
    origin: String,
    table: VariableTable,
    /// Current value of every parameter and input, by value reference (outputs: unused).
    values: Vec<f64>,
    /// The model compiled with the current parameter values, and its data.
    compiled: Option<Compiled>,
    /// True when `compiled` was compiled with the current parameter values.
    compiled_fresh: bool,
    initialized: bool,
    /// The integrator may step up to here (beyond it the host will not ask).
    horizon: f64,
    /// Log contact peaks (a diagnostic).
    log_peaks: bool,
}

/// A compiled model and its data.
struct Compiled {
    model: Model,
    data: Data,
}

impl Simulation {
    /// Wraps a validated scene. Nothing is compiled yet.
    pub fn new(scene: Scene, origin: &str) -> Simulation {
        let table = VariableTable::from_scene(&scene);
        let values = table.vars.iter().map(|v| v.start.unwrap_or(0.0)).collect();
        Simulation {
            scene,
            origin: origin.to_string(),
            table,
            values,
            compiled: None,
            compiled_fresh: false,
            initialized: false,
            horizon: f64::INFINITY,
            log_peaks: false,
        }
    }

    /// Reads, parses and validates a scene file.
    pub fn from_file(path: &Path) -> Result<Simulation, SceneError> {
        let scene = Scene::from_file(path)?;
        Ok(Simulation::new(scene, &path.display().to_string()))
    }

    /// Parses and validates scene text; `origin` names it in messages.
    pub fn from_scene_str(text: &str, origin: &str) -> Result<Simulation, SceneError> {
        Ok(Simulation::new(Scene::from_str(text, origin)?, origin))
    }

    /// The scene as given (without parameter changes).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The variables; the index is the value reference.
    pub fn variables(&self) -> &[Variable] {
        &self.table.vars
    }

    /// Value references of the outputs, in table order.
    pub fn output_indices(&self) -> Vec<usize> {
        let vars = self.variables();
        (0..vars.len())
            .filter(|&i| vars[i].causality == Causality::Output)
            .collect()
    }

    /// The variable table.
    pub fn table(&self) -> &VariableTable {
        &self.table
    }

    /// True after a successful [`Simulation::initialize`] (or a restore of an initialised
    /// state).
    pub fn is_initialized(&self) -> bool {
        self.initialized
    }

    /// Current simulation time [s] (0 before initialisation).
    pub fn time(&self) -> f64 {
        match (&self.compiled, self.initialized) {
            (Some(c), true) => c.data.time,
            _ => 0.0,
        }
    }

    /// Sets a parameter (before initialisation only) or an input (at any time). The range of a
    /// parameter is checked by [`Simulation::initialize`], so that a host may set values in
    /// any order.
    pub fn set(&mut self, vr: usize, value: f64) -> Result<(), SimError> {
        let var = variable(&self.table, vr)?;
        match var.causality {
            Causality::Parameter => {
                if self.initialized {
                    return Err(SimError::Variable(format!(
                        "{} is a fixed parameter and cannot change after initialisation",
                        var.name
                    )));
                }
                if self.values[vr] != value {
                    self.values[vr] = value;
                    self.compiled_fresh = false;
                }
                Ok(())
            }
            Causality::Input => {
                if !value.is_finite() {
                    return Err(SimError::Variable(format!(
                        "input {} must be finite (got {value})",
                        var.name
                    )));
                }
                self.values[vr] = value;
                if let (Some(c), VarRef::Input(i)) = (self.compiled.as_mut(), var.target) {
                    set_input(&mut c.data, i, value);
                }
                Ok(())
            }
            _ => Err(SimError::Variable(format!(
                "{} is not a parameter or input and cannot be set",
                var.name
            ))),
        }
    }

    /// Sets a variable by name (CLI `--set NAME=VALUE`).
    pub fn set_by_name(&mut self, name: &str, value: f64) -> Result<(), SimError> {
        let vr = self
            .table
            .index_of(name)
            .ok_or_else(|| SimError::Variable(format!("unknown variable {name:?}")))?;
        self.set(vr, value)
    }

    /// Reads a variable. Outputs and calculated parameters need a compiled engine: before
    /// initialisation one is compiled from the current parameter values (the initial state).
    pub fn get(&mut self, vr: usize) -> Result<f64, SimError> {
        let var = variable(&self.table, vr)?;
        match var.causality {
            Causality::Parameter | Causality::Input => Ok(self.values[vr]),
            _ => {
                let target = var.target;
                let c = self.ensure_compiled()?;
                Ok(outputs::output(&c.model, &mut c.data, target).unwrap_or(f64::NAN))
            }
        }
    }

    /// The current parameter values (and input start values), as the compiler reads them.
    pub fn parameters(&self) -> Parameters {
        let mut p = Parameters::of_scene(&self.scene);
        for (var, &x) in self.table.vars.iter().zip(&self.values) {
            if matches!(var.causality, Causality::Parameter | Causality::Input) {
                set_parameter(&mut p, var.target, x);
            }
        }
        p
    }

    /// Checks every parameter against its range; the message names the variable and range.
    pub fn check_parameters(&self) -> Result<(), SimError> {
        for (vr, var) in self.table.vars.iter().enumerate() {
            if var.causality != Causality::Parameter {
                continue;
            }
            let x = self.values[vr];
            if let Some(r) = var.range {
                let integral = matches!(var.vtype, VarType::Integer | VarType::Enumeration(_));
                if !r.contains(x) || (integral && x.fract() != 0.0) {
                    return Err(SimError::Variable(format!(
                        "parameter {} = {} is out of its allowed range {}",
                        var.name,
                        x,
                        r.describe()
                    )));
                }
            }
        }
        Ok(())
    }

    /// The model compiled with the current parameter values (compiled now if it is not).
    fn ensure_compiled(&mut self) -> Result<&mut Compiled, SimError> {
        if self.compiled.is_none() || !self.compiled_fresh {
            self.check_parameters()?;
            let (model, mut data) = compile_with(&self.scene, &self.parameters(), &self.origin)?;
            engine::start(&model, &mut data).map_err(|err| {
                SceneError::new(
                    &self.origin,
                    "contact",
                    "-",
                    format!("at the initial state: {}", err.message),
                )
            })?;
            data.solver.horizon = self.horizon;
            data.log_peaks = self.log_peaks;
            self.compiled = Some(Compiled { model, data });
            self.compiled_fresh = true;
        }
        // (a match, not `ok_or`: that builds and drops an error on every successful call)
        match self.compiled.as_mut() {
            Some(c) => Ok(c),
            None => Err(SimError::NotInitialized),
        }
    }

    /// The initialised model and data.
    fn running(&mut self) -> Result<&mut Compiled, SimError> {
        if !self.initialized {
            return Err(SimError::NotInitialized);
        }
        // (a match, not `ok_or`: that builds and drops an error on every successful call)
        match self.compiled.as_mut() {
            Some(c) => Ok(c),
            None => Err(SimError::NotInitialized),
        }
    }

    /// Ends initialisation: checks every parameter, compiles the model and sets the state to
    /// the scene's initial configuration at `start_time`.
    pub fn initialize(&mut self, start_time: f64) -> Result<(), SimError> {
        if !start_time.is_finite() {
            return Err(SimError::Variable(format!(
                "start time must be finite (got {start_time})"
            )));
        }
        self.compiled_fresh = false;
        let c = self.ensure_compiled()?;
        engine::set_start_time(&mut c.data, start_time);
        self.initialized = true;
        Ok(())
    }

    /// Integrates to `t_end` (> current time). On failure the state is the last good one and
    /// the error carries its time.
    pub fn step_to(&mut self, t_end: f64) -> Result<(), SimError> {
        let c = self.running()?;
        engine::advance(&c.model, &mut c.data, t_end).map_err(
            |EngineError {
                 time,
                 message,
                 step_limit,
             }| {
                if step_limit {
                    SimError::StepLimit { time, message }
                } else {
                    SimError::Step { time, message }
                }
            },
        )
    }

    /// Runs from the current state over the communication points (the multiples of
    /// `interval`, see [`communication_points`]) to `stop_time` (the last one exactly
    /// there), calling `each` after every point.
    pub fn run(
        &mut self,
        stop_time: f64,
        interval: f64,
        mut each: impl FnMut(&mut Simulation) -> Result<(), String>,
    ) -> Result<(), RunError> {
        if !(interval > 0.0 && interval.is_finite()) {
            return Err(RunError::Setup(format!("interval must be > 0 (got {interval})")));
        }
        if !(stop_time.is_finite() && stop_time > self.time()) {
            return Err(RunError::Setup(format!(
                "stop time must be finite and after the current time {} (got {stop_time})",
                self.time()
            )));
        }
        self.set_stop_time(Some(stop_time));
        for t in communication_points(self.time(), stop_time, interval) {
            self.step_to(t).map_err(RunError::Step)?;
            each(self).map_err(RunError::Setup)?;
        }
        Ok(())
    }

    /// Saves everything needed to continue from here (`host`: numbers of the host layer,
    /// returned unchanged by [`Simulation::restore`]).
    pub fn snapshot(&self, host: Vec<f64>) -> Snapshot {
        let mut st = Vec::new();
        if let (true, Some(c)) = (self.initialized, &self.compiled) {
            state::get(&c.model, &c.data, state::FULL, &mut st);
        }
        Snapshot {
            host,
            values: self.values.clone(),
            initialized: self.initialized,
            state: st,
        }
    }

    /// Restores a snapshot taken from a simulation of the same scene (into a fresh,
    /// terminated or running one alike). A snapshot that does not fit is refused and the
    /// simulation is left as it was.
    pub fn restore(&mut self, s: &Snapshot) -> Result<(), SimError> {
        if s.values.len() != self.values.len() {
            return Err(SimError::Variable(format!(
                "state holds {} values, this model has {}: not a state of this model",
                s.values.len(),
                self.values.len()
            )));
        }
        if !s.initialized {
            if !s.state.is_empty() {
                return Err(SimError::Variable(
                    "state of an uninitialised model holds a state".into(),
                ));
            }
            self.values.clone_from(&s.values);
            self.compiled_fresh = false;
            self.initialized = false;
            return Ok(());
        }
        // Compile for the snapshot's parameter values; keep the current ones if that fails.
        let kept_values = std::mem::replace(&mut self.values, s.values.clone());
        let kept_fresh = self.compiled_fresh;
        if kept_values != self.values {
            self.compiled_fresh = false;
        }
        let restored = self.ensure_compiled().and_then(|c| {
            state::set(&c.model, &mut c.data, state::FULL, &s.state).map_err(SimError::Variable)?;
            engine::resync(&c.model, &mut c.data);
            Ok(())
        });
        if let Err(e) = restored {
            if self.values != kept_values {
                self.values = kept_values;
                self.compiled_fresh = false;
            } else {
                self.compiled_fresh = kept_fresh;
            }
            return Err(e);
        }
        self.initialized = true;
        Ok(())
    }

    /// The value of an output or calculated parameter at the current state (`None` for
    /// parameters and inputs: read those with [`Simulation::get`]).
    pub fn output(&mut self, target: VarRef) -> Result<Option<f64>, SimError> {
        let c = self.ensure_compiled()?;
        Ok(outputs::output(&c.model, &mut c.data, target))
    }

    /// The compiled model (compiled from the current parameter values if needed).
    pub fn model(&mut self) -> Result<&Model, SimError> {
        Ok(&self.ensure_compiled()?.model)
    }

    /// The data (state, buffers, counters), after compilation.
    pub fn data(&self) -> Option<&Data> {
        self.compiled.as_ref().map(|c| &c.data)
    }

    /// Warnings of the model compilation (inconsistent initial velocities, ...).
    pub fn warnings(&mut self) -> Result<Vec<String>, SimError> {
        Ok(self.ensure_compiled()?.model.warnings.clone())
    }

    /// Work counters since initialisation (zero before).
    pub fn counters(&self) -> Counters {
        self.data().map(|d| d.counters).unwrap_or_default()
    }

    /// The energies at the current state.
    pub fn energies(&mut self) -> Result<Energies, SimError> {
        let c = self.ensure_compiled()?;
        Ok(outputs::energies(&c.model, &mut c.data))
    }

    /// Largest constraint residual |Φ| at the current state.
    pub fn constraint_residual(&mut self) -> Result<f64, SimError> {
        let c = self.ensure_compiled()?;
        Ok(outputs::constraint_residual(&c.model, &mut c.data))
    }

    /// The located contact events since initialisation (or the last
    /// [`Simulation::clear_contact_events`]), oldest first; at most the last 4096.
    pub fn contact_events(&self) -> &[ContactEvent] {
        self.data().map(|d| d.event_log.as_slice()).unwrap_or(&[])
    }

    /// Empties the contact event log.
    pub fn clear_contact_events(&mut self) {
        if let Some(c) = self.compiled.as_mut() {
            c.data.event_log.clear();
        }
    }

    /// The time beyond which no step will be asked for (the stop time; None: open-ended). The
    /// integrator continues across communication points and may step past one; it never
    /// steps past this.
    pub fn set_stop_time(&mut self, stop: Option<f64>) {
        self.horizon = stop.unwrap_or(f64::INFINITY);
        if let Some(c) = self.compiled.as_mut() {
            c.data.solver.horizon = self.horizon;
        }
    }

    /// Logs the largest penetration of every continuous contact as a `Peak` contact event
    /// (off by default: it costs event-location work and changes no result).
    pub fn set_peak_events(&mut self, on: bool) {
        self.log_peaks = on;
        if let Some(c) = self.compiled.as_mut() {
            c.data.log_peaks = on;
        }
    }

    /// Turns the location of force cuts (the damped laws' force reaching zero before δ does)
    /// on (default) or off. Off, the integrator steps over that kink with only its error
    /// control to notice it.
    pub fn set_clamp_events(&mut self, on: bool) -> Result<(), SimError> {
        let c = self.ensure_compiled()?;
        c.data.clamp_events = on;
        c.data.solver.started = false;
        Ok(())
    }
}

/// The communication points after `t0` up to `stop_time`: the multiples of `interval` (so
/// that a run resumed from a checkpoint meets the same points as the uninterrupted one),
/// the last one exactly `stop_time`.
pub fn communication_points(t0: f64, stop_time: f64, interval: f64) -> impl Iterator<Item = f64> {
    let first = ((t0 / interval) * (1.0 + 1e-12)).floor() as u64 + 1;
    let n = (stop_time / interval - 1e-9).ceil().max(1.0) as u64;
    let first = first.min(n);
    (first..=n).map(move |k| if k == n { stop_time } else { k as f64 * interval })
}

/// The variable with value reference `vr`.
fn variable(table: &VariableTable, vr: usize) -> Result<&Variable, SimError> {
    table
        .vars
        .get(vr)
        .ok_or_else(|| SimError::Variable(format!("unknown value reference {vr}")))
}

/// Sets input `i`; the integrator restarts at the next advance (inputs are piecewise constant
/// between communication points).
fn set_input(d: &mut Data, i: usize, value: f64) {
    if d.inputs[i] != value {
        d.inputs[i] = value;
        d.outputs_valid = false;
        // the right-hand side changed: the method restarts at the current state
        d.solver.started = false;
    }
}

/// A failed [`Simulation::run`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RunError {
    /// The integration failed.
    #[error("{0}")]
    Step(SimError),
    /// A setting, or the caller's `each`, failed.
    #[error("{0}")]
    Setup(String),
}
