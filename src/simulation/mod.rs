//! The facade that hosts use: a scene, its variable table, parameter values, and once
//! initialised a compiled [`Model`] with its [`Data`]. Both the FMI layer and the
//! `simulate` command drive the engine only through this type, so they see the same
//! variables and the same numbers.

use crate::checkpoint::Snapshot;
use crate::compile::compile_with;
use crate::contact::groups;
use crate::engine::{self, EngineError};
use crate::islands::Islands;
use crate::model::{state, ContactEvent, Counters, Data, Model};
use crate::outputs::{self, Energies};
/// How messages show a time or step size (the FMI layer's too).
pub use crate::scene::Num;
use crate::scene::{Scene, SceneError};
use crate::variables::{Causality, VarRef, Variable, VariableTable};
use std::path::Path;

mod candidates;
mod energy;
#[cfg(test)]
mod tests;
mod values;

pub use candidates::IslandReport;
use energy::Drift;
pub use energy::{ENERGY_BLOW_UP, ENERGY_DRIFT_WARNING};

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
    #[error("at t = {}: {message}", Num(*.time))]
    Step {
        /// Last time successfully reached \[s\].
        time: f64,
        /// What went wrong.
        message: String,
    },
    /// The step stopped at `solver.max_steps` integrator steps, at `time`: the state there
    /// is valid and the simulation can go on from it.
    #[error("at t = {}: {message}", Num(*.time))]
    StepLimit {
        /// Time reached \[s\].
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
    /// Log contact peaks (a diagnostic).
    log_peaks: bool,
    /// By value reference: the parameter this one follows while it keeps its start value (the
    /// scene's default for a key it does not give): `<contact>.max_penetration` follows
    /// `<contact>.radius`, `<contact>.static_friction` follows `<contact>.friction` (and a
    /// group pair's `static_friction` its `friction`).
    follows: Vec<Option<usize>>,
    /// The energy drift found and not yet taken by the host ([`Simulation::take_warnings`]).
    drift: Option<Drift>,
    /// Contact groups: how often the candidate pairs were found again (a diagnostic).
    refreshes: u64,
}

/// A compiled model and its data (and, when the scene runs as independent islands, the
/// islands: the data then receives their state at every communication point).
struct Compiled {
    model: Model,
    data: Data,
    islands: Option<Islands>,
    /// The scene runs as islands ([`crate::islands::wanted`], decided once per model).
    split: bool,
    /// The last batch of reads that were all free bodies' positions and velocities, as value
    /// references and the state slots they read ([`Simulation::get_each`]; empty: none);
    /// cleared with the model.
    direct_reads: (Vec<usize>, Vec<usize>),
    /// The values of the direct batch for [`Simulation::get_each`] (re-used).
    direct_values: Vec<f64>,
}

impl Compiled {
    /// The compiled model and its data with the state at its time (a deferred communication
    /// point's dense output taken now, [`engine::settle`]): how everything but the step and
    /// the direct reads reaches the data.
    fn settled(&mut self) -> &mut Compiled {
        engine::settle(&self.model, &mut self.data);
        self
    }

    fn new(model: Model, data: Data) -> Compiled {
        let split = crate::islands::wanted(&model);
        Compiled {
            model,
            data,
            islands: None,
            split,
            direct_reads: (Vec::new(), Vec::new()),
            direct_values: Vec::new(),
        }
    }

    /// The values of the direct batch ([`Compiled::plan_direct_reads`]) into `values`: the
    /// state at its slots, or, while the state awaits the dense output
    /// ([`Data::dense_pending`]), the dense output at them (the same numbers: the projection
    /// at a communication point of a model without loops changes only joint quaternions).
    fn read_direct(&mut self, values: &mut [f64]) {
        let (d, slots) = (&self.data, &self.direct_reads.1);
        let interpolated = d.dense_pending
            && d.solver
                .method()
                .is_some_and(|i| i.interpolate_slots(d.time, slots, values));
        if !interpolated {
            self.settled();
            let state = &self.data.state;
            for (x, &slot) in values.iter_mut().zip(&self.direct_reads.1) {
                *x = state[slot];
            }
        }
    }

    /// Records `vrs` and their state slots in `direct_reads` when every one is a free body's
    /// position or velocity (read from the coordinates at the current state, as
    /// [`outputs::evaluated`] does); else leaves it empty. Re-uses the buffers (no allocation
    /// once they have grown to the largest batch).
    fn plan_direct_reads(&mut self, table: &VariableTable, vrs: impl Iterator<Item = usize>) {
        let (list, slots) = &mut self.direct_reads;
        list.clear();
        slots.clear();
        for vr in vrs {
            let slot = table.vars.get(vr).and_then(|var| match var.causality {
                Causality::Parameter | Causality::Input => None,
                _ => outputs::state_slot(&self.model, var.target),
            });
            let Some(slot) = slot else {
                list.clear();
                slots.clear();
                return;
            };
            list.push(vr);
            slots.push(slot);
        }
    }
}

impl Simulation {
    /// Wraps a validated scene. Nothing is compiled yet.
    pub fn new(scene: Scene, origin: &str) -> Simulation {
        let table = VariableTable::from_scene(&scene);
        let values = table.vars.iter().map(|v| v.start.unwrap_or(0.0)).collect();
        let follows = values::follows(&scene, &table);
        Simulation {
            scene,
            origin: origin.to_string(),
            table,
            values,
            compiled: None,
            compiled_fresh: false,
            initialized: false,
            log_peaks: false,
            follows,
            drift: None,
            refreshes: 0,
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

    /// Current simulation time \[s\] (0 before initialisation).
    pub fn time(&self) -> f64 {
        match (&self.compiled, self.initialized) {
            (Some(c), true) => c.data.time,
            _ => 0.0,
        }
    }

    /// Reads a variable. Outputs and calculated parameters need a compiled engine: before
    /// initialisation one is compiled from the current parameter values (the initial state).
    /// Only what the variable needs is evaluated at the current state ([`outputs::needs`]).
    pub fn get(&mut self, vr: usize) -> Result<f64, SimError> {
        let var = variable(&self.table, vr)?;
        match var.causality {
            Causality::Parameter | Causality::Input => Ok(self.value(vr)),
            _ => {
                let target = var.target;
                if outputs::needs(target) == outputs::Needs::Everything {
                    self.sync_islands()?;
                }
                let c = self.ensure_compiled()?;
                outputs::prepare(&c.model, &mut c.data, outputs::needs(target));
                Ok(outputs::evaluated(&c.model, &c.data, target).unwrap_or(f64::NAN))
            }
        }
    }

    /// Reads several variables at once, as `fmi2GetReal` receives them: `values[k]` is
    /// [`Simulation::get`]`(vrs[k])`, the same number, for one check of the compiled model
    /// and one evaluation, at the current state, of what the outputs among them need. An
    /// unknown value reference is an error before anything is read.
    pub fn get_many(&mut self, vrs: &[usize], values: &mut [f64]) -> Result<(), SimError> {
        if values.len() != vrs.len() {
            return Err(SimError::Variable(format!(
                "{} value references and {} values",
                vrs.len(),
                values.len()
            )));
        }
        if let Some(c) = self.direct_batch(|last| last == vrs) {
            c.read_direct(values);
            return Ok(());
        }
        self.get_each(vrs.iter().copied(), |k, x| values[k] = x)
    }

    /// The compiled model when `same(batch)` holds for the last batch of reads that were all
    /// free bodies' positions and velocities ([`Compiled::plan_direct_reads`]): its values
    /// are then the state at the slots found at its first read ([`Compiled::read_direct`]).
    fn direct_batch(&mut self, same: impl FnOnce(&[usize]) -> bool) -> Option<&mut Compiled> {
        match (self.compiled.as_mut(), self.compiled_fresh) {
            (Some(c), true) if !c.direct_reads.0.is_empty() && same(&c.direct_reads.0) => Some(c),
            _ => None,
        }
    }

    /// [`Simulation::get_many`] for value references of any integer type: calls `put(k, x)`
    /// with the value `x` of the `k`-th variable of `vrs`.
    pub fn get_each<I>(&mut self, vrs: I, mut put: impl FnMut(usize, f64)) -> Result<(), SimError>
    where
        I: Iterator<Item = usize> + Clone,
    {
        // A host reads the same outputs at every communication point: a batch of free bodies'
        // positions and velocities is read by the state slots found at its first read, from
        // the state or the dense output ([`Compiled::read_direct`]; the same numbers as below).
        if let Some(c) = self.direct_batch(|last| same_batch(vrs.clone(), last)) {
            let mut values = std::mem::take(&mut c.direct_values);
            values.resize(c.direct_reads.1.len(), 0.0);
            c.read_direct(&mut values);
            values.iter().enumerate().for_each(|(k, &x)| put(k, x));
            c.direct_values = values;
            return Ok(());
        }
        if let (Some(c), true) = (self.compiled.as_mut(), self.compiled_fresh) {
            if vrs.clone().nth(1).is_some() {
                c.plan_direct_reads(&self.table, vrs.clone());
            }
        }
        let mut needs: Option<outputs::Needs> = None;
        for vr in vrs.clone() {
            let var = variable(&self.table, vr)?;
            if !matches!(var.causality, Causality::Parameter | Causality::Input) {
                let n = outputs::needs(var.target);
                needs = Some(needs.map_or(n, |m| m.max(n)));
            }
        }
        if needs == Some(outputs::Needs::Everything) {
            self.sync_islands()?;
        }
        if let Some(n) = needs {
            let c = self.ensure_compiled()?;
            outputs::prepare(&c.model, &mut c.data, n);
        }
        let compiled = self.compiled.as_ref();
        let mut reader = outputs::Reader::default();
        for (k, vr) in vrs.enumerate() {
            let var = &self.table.vars[vr];
            let x = match (var.causality, compiled) {
                (Causality::Parameter | Causality::Input, _) => self.value(vr),
                (_, Some(c)) => reader.read(&c.model, &c.data, var.target).unwrap_or(f64::NAN),
                (_, None) => return Err(SimError::NotInitialized),
            };
            put(k, x);
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
            data.log_peaks = self.log_peaks;
            self.compiled = Some(Compiled::new(model, data));
            self.compiled_fresh = true;
        }
        // (a match, not `ok_or`: that builds and drops an error on every successful call)
        match self.compiled.as_mut() {
            Some(c) => Ok(c.settled()),
            None => Err(SimError::NotInitialized),
        }
    }

    /// The initialised model and data (settled: [`Compiled::settled`]).
    fn running(&mut self) -> Result<&mut Compiled, SimError> {
        self.running_deferred().map(Compiled::settled)
    }

    /// [`Simulation::running`] whose state may still await the dense output of a deferred
    /// communication point: for the step, which goes on from there.
    fn running_deferred(&mut self) -> Result<&mut Compiled, SimError> {
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
        // (compiled anew: the data, its energy watch included, is fresh)
        engine::set_start_time(&mut c.data, start_time);
        self.initialized = true;
        Ok(())
    }

    /// Integrates to `t_end` (> current time). On failure the state is the last good one and
    /// the error carries its time.
    pub fn step_to(&mut self, t_end: f64) -> Result<(), SimError> {
        self.step(t_end, false).map(|_| ())
    }

    /// [`Simulation::step_to`] that ends early, right after a located contact event before
    /// `t_end` at which a contact changed its mode (touch, separation, impact, rest, release):
    /// then `Ok(true)`, and [`Simulation::time`] is the event's time. The next step goes on
    /// from there as the uninterrupted one would have (the same integrator steps).
    pub fn step_to_event(&mut self, t_end: f64) -> Result<bool, SimError> {
        self.step(t_end, true)
    }

    fn step(&mut self, t_end: f64, stop_at_events: bool) -> Result<bool, SimError> {
        if !self.initialized {
            return Err(SimError::NotInitialized);
        }
        if !self.watch().started {
            self.start_watch()?;
        }
        let c = self.running_deferred()?;
        if c.split || c.islands.is_some() {
            if c.islands.is_none() {
                let params = self.parameters();
                let Some(c) = self.compiled.as_mut().map(Compiled::settled) else {
                    return Err(SimError::NotInitialized);
                };
                c.islands = Some(Islands::new(params, &c.model, &mut c.data).map_err(step_error)?);
            }
            let at_event = self.step_islands(t_end, stop_at_events)?;
            return self.watch_energy().map(|()| at_event);
        }
        // solver.max_steps bounds the steps of this call, across the advances between which
        // the contact groups' candidate pairs are found again (with a small margin, after
        // every step)
        let (mut steps_before, mut refreshes) = (None, 0u64);
        let at_event = loop {
            let c = self.running_deferred()?;
            let budget = c.model.solver.max_steps;
            let taken = c.data.counters.steps - *steps_before.get_or_insert(c.data.counters.steps);
            c.data.max_steps = Some(budget - taken.min(budget));
            let advanced = engine::advance_deferring(&c.model, &mut c.data, t_end, stop_at_events, true);
            c.data.max_steps = None;
            let at_event = match advanced {
                Err(e) if e.step_limit && refreshes > 0 => {
                    return Err(refreshes_over_budget(&c.model, e.time, t_end, refreshes))
                }
                other => other.map_err(step_error)?,
            };
            if at_event || !groups::stale(&c.model, &c.data) {
                break at_event;
            }
            self.refresh_candidates()?;
            refreshes += 1;
        };
        self.watch_energy().map(|()| at_event)
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
        for t in communication_points(self.time(), stop_time, interval) {
            self.step_to(t).map_err(RunError::Step)?;
            each(self).map_err(RunError::Setup)?;
        }
        Ok(())
    }

    /// Saves everything needed to continue from here (`host`: numbers of the host layer,
    /// returned unchanged by [`Simulation::restore`]).
    pub fn snapshot(&mut self, host: Vec<f64>) -> Snapshot {
        let mut st = Vec::new();
        if self.initialized {
            // (the scene's contact list made the islands', as reading a contact output makes
            // it: the state saved does not depend on whether outputs were read; should the list
            // not be made, the state saved with the former one continues as well)
            let _ = self.sync_islands();
        }
        if let (true, Some(c)) = (self.initialized, self.compiled.as_mut().map(Compiled::settled)) {
            // (the islands' own state is gathered into the data for the one state spec)
            match &c.islands {
                Some(is) => is.record(&c.model, &mut c.data),
                None => c.data.islands.clear(),
            }
            state::get(&c.model, &c.data, state::FULL, &mut st);
            c.data.islands.clear();
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
        // (an input's value is the host's: the one in the model's state, which is finite)
        let input_values: Vec<(usize, f64, String)> = (self.table.vars.iter().zip(&s.values))
            .filter_map(|(var, &x)| match (var.causality, var.target) {
                (Causality::Input, VarRef::Input(i)) => Some((i, x, var.name.clone())),
                _ => None,
            })
            .collect();
        // Compile for the snapshot's parameter values; keep the current ones if that fails.
        let kept_values = std::mem::replace(&mut self.values, s.values.clone());
        let kept_fresh = self.compiled_fresh;
        let mut kept_compiled = None;
        if kept_values != self.values {
            self.compiled_fresh = false;
            // (the running model and data, put back if the state is refused)
            kept_compiled = self.compiled.take();
        }
        let params = self.parameters();
        let restored = self.ensure_compiled().and_then(|c| {
            // contact groups: the contact list of the snapshot's candidate pairs; the present
            // list and state are put back if the snapshot is refused
            let kept = c.data.candidates.clone();
            let mut before = Vec::new();
            engine::settle(&c.model, &mut c.data);
            state::get(&c.model, &c.data, state::FULL, &mut before);
            let put_back = |c: &mut Compiled| {
                if c.data.candidates != kept {
                    // (the list was made before: it makes again)
                    let _ = crate::contact::elements::set_candidates(&c.model, &mut c.data, &kept);
                }
                let _ = state::set(&c.model, &mut c.data, state::FULL, &before);
                engine::resync(&c.model, &mut c.data);
            };
            if let Some(found) = state::group_candidates(&c.model, &s.state) {
                if found != c.data.candidates {
                    crate::contact::elements::set_candidates(&c.model, &mut c.data, &found)
                        .map_err(SimError::Variable)?;
                    c.direct_reads.0.clear();
                }
            }
            if let Err(e) = state::set(&c.model, &mut c.data, state::FULL, &s.state) {
                // (a refused state changed nothing but the contact list)
                if c.data.candidates != kept {
                    put_back(c);
                }
                return Err(SimError::Variable(e));
            }
            if let Some((i, x, name)) = input_values.iter().find(|(i, x, _)| c.data.inputs.get(*i) != Some(x)) {
                let held = c.data.inputs.get(*i).copied().unwrap_or(f64::NAN);
                let what = if x.is_finite() { "" } else { ", not a finite number," };
                put_back(c);
                return Err(SimError::Variable(format!(
                    "state holds input {name} = {x}{what} among its values and {held} in the model's state"
                )));
            }
            engine::resync(&c.model, &mut c.data);
            let islands = match c.data.islands.count() {
                0 => Ok(None),
                _ => Islands::load(params.clone(), &c.model, &mut c.data).map(Some),
            };
            c.data.islands.clear();
            match islands {
                Ok(islands) => {
                    if islands.is_none() {
                        c.data.partition.clear();
                    }
                    c.islands = islands;
                }
                Err(e) => {
                    // (the present state and islands stay; a state it saved always fits)
                    put_back(c);
                    return Err(SimError::Variable(e));
                }
            }
            Ok(())
        });
        if let Err(e) = restored {
            if self.values != kept_values {
                self.values = kept_values;
                self.compiled = kept_compiled;
            }
            self.compiled_fresh = kept_fresh;
            return Err(e);
        }
        self.initialized = true;
        Ok(())
    }

    /// The value of an output or calculated parameter at the current state (`None` for
    /// parameters and inputs: read those with [`Simulation::get`]).
    pub fn output(&mut self, target: VarRef) -> Result<Option<f64>, SimError> {
        self.sync_islands()?;
        let c = self.ensure_compiled()?;
        Ok(outputs::output(&c.model, &mut c.data, target))
    }

    /// The compiled model (compiled from the current parameter values if needed).
    pub fn model(&mut self) -> Result<&Model, SimError> {
        self.sync_islands()?;
        Ok(&self.ensure_compiled()?.model)
    }

    /// The data's contact list (the declared contacts, then the contact groups' candidate
    /// pairs as the broad phase last listed them), after compilation.
    pub fn contacts(&mut self) -> Result<&[crate::model::contact::ContactElement], SimError> {
        self.sync_islands()?;
        Ok(&self.ensure_compiled()?.data.contacts)
    }

    /// The data (state, buffers, counters), after compilation.
    pub fn data(&mut self) -> Option<&Data> {
        self.compiled.as_mut().map(Compiled::settled).map(|c| &c.data)
    }

    /// Warnings of the model compilation (inconsistent initial velocities, ...).
    pub fn warnings(&mut self) -> Result<Vec<String>, SimError> {
        Ok(self.ensure_compiled()?.model.warnings.clone())
    }

    /// Work counters since initialisation (zero before).
    pub fn counters(&self) -> Counters {
        self.compiled.as_ref().map(|c| c.data.counters).unwrap_or_default()
    }

    /// The energies at the current state.
    pub fn energies(&mut self) -> Result<Energies, SimError> {
        let c = self.ensure_compiled()?;
        if let Some(is) = c.islands.as_mut() {
            return Ok(candidates::islands_energies(is));
        }
        Ok(outputs::energies(&c.model, &mut c.data))
    }

    /// Largest constraint residual |Φ| at the current state.
    pub fn constraint_residual(&mut self) -> Result<f64, SimError> {
        self.sync_islands()?;
        let c = self.ensure_compiled()?;
        Ok(outputs::constraint_residual(&c.model, &mut c.data))
    }

    /// The located contact events since initialisation (or the last
    /// [`Simulation::clear_contact_events`]), oldest first; at most the last 4096.
    pub fn contact_events(&self) -> &[ContactEvent] {
        self.compiled.as_ref().map_or(&[], |c| c.data.event_log.as_slice())
    }

    /// Empties the contact event log.
    pub fn clear_contact_events(&mut self) {
        if let Some(c) = self.compiled.as_mut() {
            c.data.event_log.clear();
        }
    }

    /// Logs the largest penetration of every continuous contact as a `Peak` contact event
    /// (off by default: it costs event-location work and changes no result).
    pub fn set_peak_events(&mut self, on: bool) {
        self.log_peaks = on;
        if let Some(c) = self.compiled.as_mut() {
            c.data.log_peaks = on;
            let clamp = c.data.clamp_events;
            if let Some(is) = c.islands.as_mut() {
                is.set_flags(on, clamp);
            }
        }
    }

    /// Turns the location of force cuts (the damped laws' force reaching zero before δ does)
    /// on (default) or off. Off, the integrator steps over that kink with only its error
    /// control to notice it.
    pub fn set_clamp_events(&mut self, on: bool) -> Result<(), SimError> {
        let c = self.ensure_compiled()?;
        c.data.clamp_events = on;
        c.data.solver.started = false;
        let peaks = c.data.log_peaks;
        if let Some(is) = c.islands.as_mut() {
            is.set_flags(peaks, on);
        }
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

/// True when `vrs` lists exactly the value references of `last`, in order.
fn same_batch(mut vrs: impl Iterator<Item = usize>, last: &[usize]) -> bool {
    last.iter().all(|&vr| vrs.next() == Some(vr)) && vrs.next().is_none()
}

/// The variable with value reference `vr`.
fn variable(table: &VariableTable, vr: usize) -> Result<&Variable, SimError> {
    table
        .vars
        .get(vr)
        .ok_or_else(|| SimError::Variable(format!("unknown value reference {vr}")))
}

/// An engine's error as the facade's.
fn step_error(e: EngineError) -> SimError {
    let EngineError {
        time,
        message,
        step_limit,
    } = e;
    if step_limit {
        SimError::StepLimit { time, message }
    } else {
        SimError::Step { time, message }
    }
}

/// One integrator's budget ran out over advances between which the contact groups' candidate
/// pairs were found again `refreshes` times: when that was after most steps, the margin is too
/// small for the bodies' speeds.
fn refreshes_over_budget(m: &Model, time: f64, t_end: f64, refreshes: u64) -> SimError {
    let budget = m.solver.max_steps;
    let advice = if refreshes >= budget / 2 {
        format!(
            "each time a body had moved {} of broad_phase.margin = {:e} m: raise the margin (or \
             solver.max_steps)",
            m.groups.stale_fraction, m.groups.margin
        )
    } else {
        "take shorter communication steps or raise solver.max_steps".to_string()
    };
    SimError::StepLimit {
        time,
        message: format!(
            "solver.max_steps = {budget} integrator steps did not reach t = {t_end} (stopped at t = {time}); \
             the contact groups' candidate pairs were found again {refreshes} times in them, {advice}",
            t_end = Num(t_end),
            time = Num(time),
        ),
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
