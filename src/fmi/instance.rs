//! One FMU instance: the FMI state machine, logging and value access in safe Rust, on top of
//! the [`Simulation`] facade. The `extern "C"` functions (`exports` for FMI 2.0,
//! `crate::fmi3::exports` for FMI 3.0) only check pointers and call states, catch panics and
//! forward here; an instance knows the version it was made by, for its messages, its value
//! types and its saved states.
//!
//! The statuses of FMI 2.0 and 3.0 have the same values (OK, Warning, Discard, Error, Fatal =
//! 0..4): an instance speaks `fmi2Status`, and the FMI 3.0 functions hand it on as
//! `fmi3Status`.

use super::lifecycle::{LifeState, Version};
use super::log::{category_of, Failure, FmiResult, Sink, LOG_ALL, LOG_CATEGORIES, LOG_EVENTS};
use super::saved::SavedState;
use super::types::*;
use super::uri::{resource_dir, resource_folder};
use crate::simulation::{Num, SimError, Simulation};
use crate::variables::{Causality, VarType, Variability, Variable};
use std::ffi::{CStr, CString};
use std::os::raw::c_int;

/// The value type a `Get/Set` function accesses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// `fmi2Real`, `fmi3Float64`
    Real,
    /// `fmi2Integer` (in FMI 2.0 also enumerations), `fmi3Int32`
    Integer,
    /// `fmi3Int64`: FMI 3.0's enumerations
    Int64,
    /// `fmi2Boolean`, `fmi3Boolean` (String variables this model has none of:
    /// `crate::fmi::glue::none_of`)
    Boolean,
}

impl Access {
    fn name(self, v: Version) -> &'static str {
        match self {
            Access::Real => v.type_element(VarType::Real),
            Access::Integer => v.type_element(VarType::Integer),
            Access::Int64 => "Int64",
            Access::Boolean => v.type_element(VarType::Boolean),
        }
    }
    fn accepts(self, t: VarType, v: Version) -> bool {
        matches!(
            (self, t, v),
            (Access::Real, VarType::Real, _)
                | (Access::Integer, VarType::Integer, _)
                | (Access::Integer, VarType::Enumeration(_), Version::Fmi2)
                | (Access::Int64, VarType::Enumeration(_), Version::Fmi3)
                | (Access::Boolean, VarType::Boolean, _)
        )
    }
}

fn type_name(t: VarType, v: Version) -> &'static str {
    match (t, v) {
        (VarType::Enumeration(_), Version::Fmi2) => "Enumeration (accessed as Integer)",
        (VarType::Enumeration(_), Version::Fmi3) => "Enumeration (accessed as Int64)",
        _ => v.type_element(t),
    }
}

/// What an instantiation function received, decoded into Rust values.
pub struct InstantiateArgs<'a> {
    /// The FMI version of the function called.
    pub version: Version,
    /// The function's name, for messages (`fmi2Instantiate`, `fmi3InstantiateCoSimulation`).
    pub function: &'static str,
    /// Instance name.
    pub instance_name: &'a str,
    /// The GUID (FMI 2.0) or instantiation token (FMI 3.0) the host read from the model
    /// description.
    pub guid: &'a str,
    /// The resource folder: a URI (FMI 2.0) or a path (FMI 3.0).
    pub resource_location: &'a str,
    /// The host's logger.
    pub sink: Option<Sink>,
    /// Debug logging requested.
    pub logging_on: bool,
    /// FMI 3.0's `earlyReturnAllowed`: a step may end at a contact event.
    pub early_return: bool,
}

/// One FMU instance.
pub struct Instance {
    name: CString,
    /// The FMI version of the function that made it.
    pub(crate) version: Version,
    sink: Option<Sink>,
    logging_on: bool,
    /// FMI 3.0: steps end at contact events.
    early_return: bool,
    enabled: [bool; LOG_CATEGORIES.len()],
    /// Whether a `SetDebugLogging` call has chosen categories (before, events are logged by
    /// the instantiation's `loggingOn` alone).
    categories_chosen: bool,
    /// The state-machine state.
    pub(crate) state: LifeState,
    sim: Simulation,
    scene_text: String,
    origin: String,
    model_hash: u64,
    start_time: f64,
    stop_time: Option<f64>,
    /// Set after a panic inside a call: the simulation may be half-updated, so restoring a
    /// state rebuilds it first.
    pub(crate) poisoned: bool,
    /// The values of one getter call (kept to be reused: a call allocates nothing once it has
    /// grown to the longest list).
    read_buffer: Vec<f64>,
}

impl Instance {
    /// Checks the arguments of `fmi2Instantiate`, reads `<resources>/scene.toml` and builds the
    /// instance; the error is the message to log.
    pub fn new(args: InstantiateArgs) -> Result<Instance, String> {
        let function = args.function;
        // (both versions: "a non-empty string ... with at least one character that is not a
        // white space")
        if args.instance_name.trim().is_empty() {
            return Err(format!(
                "{function}: the instance name {:?} is empty or white space only",
                args.instance_name
            ));
        }
        let dir = match args.version {
            Version::Fmi2 => resource_dir(args.resource_location),
            Version::Fmi3 => resource_folder(args.resource_location),
        }
        .map_err(|e| format!("{function}: {e}"))?;
        let path = dir.join("scene.toml");
        let scene_text = std::fs::read_to_string(&path)
            .map_err(|e| format!("{function}: cannot read the scene {}: {e}", path.display()))?;
        let expected = crate::guid::guid(&scene_text);
        if args.guid != expected {
            return Err(format!(
                "{function}: {} mismatch: the host passed {:?} but this FMU's model description has {expected:?} (modelDescription.xml and resources/scene.toml do not belong together)",
                args.version.token_name(),
                args.guid
            ));
        }
        let origin = path.display().to_string();
        let sim = Simulation::from_scene_str(&scene_text, &origin).map_err(|e| format!("{function}: {e}"))?;
        let name = CString::new(args.instance_name.replace('\0', " ")).unwrap_or_default();
        let inst = Instance {
            name,
            version: args.version,
            sink: args.sink,
            logging_on: args.logging_on,
            early_return: args.early_return,
            enabled: [true; LOG_CATEGORIES.len()],
            categories_chosen: false,
            state: LifeState::Instantiated,
            sim,
            model_hash: crate::guid::model_hash(&scene_text),
            scene_text,
            origin,
            start_time: 0.0,
            stop_time: None,
            poisoned: false,
            read_buffer: Vec::new(),
        };
        inst.log_event(&format!(
            "{function}: {}: model {} from {}",
            crate::guid::BUILD,
            inst.sim.scene().model.name,
            inst.origin
        ));
        Ok(inst)
    }

    /// The instance name given by the host.
    pub fn name(&self) -> &CStr {
        &self.name
    }

    /// The simulation (for tests).
    pub fn simulation(&self) -> &Simulation {
        &self.sim
    }

    /// Current communication point (s).
    pub fn time(&self) -> f64 {
        if self.sim.is_initialized() {
            self.sim.time()
        } else {
            self.start_time
        }
    }

    /// Hash of the scene text (saved states carry it).
    pub fn model_hash(&self) -> u64 {
        self.model_hash
    }

    /// Logs a message. Messages with a status of Warning or worse are delivered unless their
    /// category was switched off by `fmi2SetDebugLogging`; `logEvents` messages only when
    /// debug logging is on.
    pub fn log(&self, status: fmi2Status, message: &str) {
        let cat = category_of(status);
        let wanted = self.enabled[cat] && (status > fmi2Status::fmi2OK || self.logging_on);
        if let (true, Some(sink)) = (wanted, &self.sink) {
            sink(status, LOG_CATEGORIES[cat].0, message);
        }
    }

    /// `fmi2` or `fmi3`: the prefix of the functions that made this instance.
    fn prefix(&self) -> &'static str {
        self.version.prefix()
    }

    /// The name of the state-machine state in this instance's version of FMI.
    pub fn state_name(&self) -> &'static str {
        self.state.name_in(self.version)
    }

    fn log_event(&self, message: &str) {
        self.log(fmi2Status::fmi2OK, message);
    }

    /// Logs a failure of `func`, moves to the error (or fatal) state and returns the status.
    pub fn fail(&mut self, func: &str, failure: Failure) -> fmi2Status {
        self.log(failure.status, &format!("{func}: {}", failure.message));
        // (a discarded call leaves the state as it is: FMI 2.0's discarded step has moved the
        // instance to step failed itself, FMI 3.0's leaves it in Step Mode, and a status no
        // query can answer is discarded with the instance as it was)
        match failure.status {
            fmi2Status::fmi2Error if self.state != LifeState::Fatal => self.state = LifeState::Error,
            fmi2Status::fmi2Fatal => self.state = LifeState::Fatal,
            _ => {}
        }
        failure.status
    }

    /// `fmi2SetDebugLogging`
    pub fn set_debug_logging(&mut self, logging_on: bool, categories: &[String]) -> FmiResult {
        if categories.is_empty() {
            // (with no categories named, the switch applies to every category: off, nothing
            // is logged, not even errors)
            self.logging_on = logging_on;
            self.enabled = [logging_on; LOG_CATEGORIES.len()];
            self.categories_chosen = true;
            return Ok(());
        }
        // Each call switches the categories it names, on or off, and leaves the others as
        // they are; the first that switches categories on also ends the events' default
        // (logged with the instantiation's loggingOn), so that events are logged only once
        // named ("only debug messages according to the categories argument shall be
        // printed"). Errors are logged unless switched off.
        let mut enabled = self.enabled;
        if logging_on && !self.categories_chosen {
            enabled[LOG_EVENTS] = false;
        }
        for c in categories {
            let Some(i) = LOG_CATEGORIES
                .iter()
                .position(|(name, _)| name.to_bytes() == c.as_bytes())
            else {
                let known: Vec<&str> = LOG_CATEGORIES.iter().filter_map(|(n, _)| n.to_str().ok()).collect();
                return Err(Failure::error(format!(
                    "unknown log category {c:?} (known: {})",
                    known.join(", ")
                )));
            };
            if i == LOG_ALL {
                enabled = [logging_on; LOG_CATEGORIES.len()];
            } else {
                enabled[i] = logging_on;
            }
        }
        // (an unknown category above leaves the settings as they were)
        self.enabled = enabled;
        self.categories_chosen = true;
        if logging_on {
            self.logging_on = true;
        }
        Ok(())
    }

    /// `fmi2SetupExperiment`. A defined tolerance becomes `solver.rtol` (a later explicit
    /// `fmi2SetReal` of `solver.rtol` wins); one outside its range is taken at the nearest
    /// bound. Returns the warning that says so (for [`Failure::warn_of`]).
    pub fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> FmiResult<Option<String>> {
        if !start_time.is_finite() {
            return Err(Failure::error(format!(
                "startTime must be finite (got {start_time})",
                start_time = Num(start_time)
            )));
        }
        if let Some(stop) = stop_time {
            if !(stop.is_finite() && stop >= start_time) {
                return Err(Failure::error(format!(
                    "stopTime = {stop} must be finite and >= startTime = {start_time}",
                    start_time = Num(start_time),
                    stop = Num(stop)
                )));
            }
        }
        let mut warning = None;
        if let Some(tol) = tolerance {
            if !(tol.is_finite() && tol > 0.0) {
                return Err(Failure::error(format!("tolerance = {tol} must be > 0", tol = Num(tol))));
            }
            let vr = self.sim.table().index_of("solver.rtol").unwrap_or(usize::MAX);
            let scene_rtol = self.sim.get(vr)?;
            let setup = match self.version {
                Version::Fmi2 => "fmi2SetupExperiment",
                Version::Fmi3 => "fmi3EnterInitializationMode",
            };
            // (a co-simulation FMU may ignore the host's tolerance: one outside solver.rtol's
            // range is taken as the nearest bound rather than failing the initialisation)
            let (lo, hi) = self
                .sim
                .variables()
                .get(vr)
                .and_then(|v| v.range)
                .map_or((tol, tol), |r| (r.min, r.max));
            let taken = tol.clamp(lo, hi);
            if taken != tol {
                warning = Some(format!(
                    "the host's tolerance {tol:e} is outside solver.rtol's range [{lo:e}, {hi:e}]; solver.rtol = \
                     {taken:e} is taken"
                ));
            }
            let tol = taken;
            self.sim.set_by_name("solver.rtol", tol)?;
            if tol != scene_rtol {
                self.log_event(&format!(
                    "{setup}: the host's tolerance {tol:e} replaces solver.rtol = {scene_rtol:e} of \
                         the scene (set solver.rtol after {setup} to keep another value)"
                ));
            }
        }
        self.start_time = start_time;
        self.stop_time = stop_time;
        Ok(warning)
    }

    /// `fmi2EnterInitializationMode`
    pub fn enter_initialization_mode(&mut self) -> FmiResult {
        self.state = LifeState::InitializationMode;
        Ok(())
    }

    /// `fmi2ExitInitializationMode`: checks every parameter and compiles the model; then
    /// every output and calculated parameter at the initial state must be a finite number
    /// (see `Instance::finite`).
    pub fn exit_initialization_mode(&mut self) -> FmiResult {
        self.sim.initialize(self.start_time)?;
        for vr in 0..self.sim.variables().len() {
            if computed(&self.sim.variables()[vr]) {
                let x = self.sim.get(vr)?;
                self.finite(vr, x)?;
            }
        }
        self.state = LifeState::StepComplete;
        self.log_event(&format!(
            "{}ExitInitializationMode: initialised at t = {}",
            self.prefix(),
            self.start_time
        ));
        Ok(())
    }

    /// `fmi2Terminate`
    pub fn terminate(&mut self) -> FmiResult {
        self.state = LifeState::Terminated;
        Ok(())
    }

    /// `fmi2Reset`: back to the state after `fmi2Instantiate`, with the start values.
    pub fn reset(&mut self) -> FmiResult {
        self.sim =
            Simulation::from_scene_str(&self.scene_text, &self.origin).map_err(|e| Failure::error(e.to_string()))?;
        self.state = LifeState::Instantiated;
        self.start_time = 0.0;
        self.stop_time = None;
        self.poisoned = false;
        self.log_event(&format!(
            "{}Reset: back to the instantiated state with start values",
            self.prefix()
        ));
        Ok(())
    }

    /// FMI 3.0's independent variable `time`: its value reference, after every variable of
    /// the table (so that the others keep FMI 2.0's).
    pub fn time_vr(&self) -> Option<fmi2ValueReference> {
        let n = self.sim.variables().len() as fmi2ValueReference;
        (self.version == Version::Fmi3).then_some(n)
    }

    fn variable(&self, vr: fmi2ValueReference, access: Access) -> FmiResult<&Variable> {
        let v = self.version;
        if Some(vr) == self.time_vr() {
            return Err(Failure::error(format!(
                "value reference {vr} is the independent variable time: it is read with fmi3GetFloat64 and cannot be set"
            )));
        }
        let var = self.sim.variables().get(vr as usize).ok_or_else(|| {
            Failure::error(format!(
                "unknown value reference {vr} (this model has {} variables)",
                self.sim.variables().len()
            ))
        })?;
        if !access.accepts(var.vtype, v) {
            return Err(Failure::error(format!(
                "value reference {vr} ({}) is of type {}, not {}",
                var.name,
                type_name(var.vtype, v),
                access.name(v)
            )));
        }
        Ok(var)
    }

    /// Reads variables of one type as `f64` (Integer and Boolean values are whole numbers).
    pub fn get_values(
        &mut self,
        access: Access,
        vrs: &[fmi2ValueReference],
        mut put: impl FnMut(usize, f64),
    ) -> FmiResult {
        // (FMI 3.0's time is read as a Float64 beside the table's variables)
        let time = self.time_vr().filter(|_| access == Access::Real);
        for &vr in vrs {
            if Some(vr) != time {
                self.variable(vr, access)?;
            }
        }
        // one batch read (one evaluation of what the outputs among them need), then the checks
        let mut values = std::mem::take(&mut self.read_buffer);
        values.clear();
        values.resize(vrs.len(), 0.0);
        let table_vrs = vrs.iter().filter(|&&vr| Some(vr) != time);
        let read = self
            .sim
            .get_each(table_vrs.map(|&vr| vr as usize), |k, x| values[k] = x);
        let now = self.time();
        let result = read.map_err(Failure::from).and_then(|()| {
            let mut read = values.iter();
            for (k, &vr) in vrs.iter().enumerate() {
                let x = if Some(vr) == time {
                    now
                } else {
                    let x = read.next().copied().unwrap_or(f64::NAN);
                    self.finite(vr as usize, x)?;
                    x
                };
                put(k, x);
            }
            Ok(())
        });
        self.read_buffer = values;
        result
    }

    /// An output or calculated parameter is never handed to the host as NaN or infinity:
    /// parameter values inside their ranges can still overflow double precision (a mass near
    /// 1.8e308 makes the energies infinite or NaN), and so can finite inputs (a force of
    /// 1.8e308 on a contact resting under the impulse law); such a value is an error naming
    /// the variable instead. Parameters and inputs read back what the host set.
    fn finite(&self, vr: usize, x: f64) -> FmiResult {
        let var = &self.sim.variables()[vr];
        if x.is_finite() || !computed(var) {
            return Ok(());
        }
        Err(Failure::error(format!(
            "{} = {x} is not a finite number: the parameter or input values overflow double \
             precision (a mass, modulus, length or force near 1.8e308?); set smaller ones",
            var.name
        )))
    }

    /// Sets variables of one type, checking that each may be set in the current state.
    pub fn set_values(
        &mut self,
        access: Access,
        vrs: &[fmi2ValueReference],
        value: impl Fn(usize) -> f64,
    ) -> FmiResult {
        for (k, &vr) in vrs.iter().enumerate() {
            let var = self.variable(vr, access)?;
            match var.causality {
                Causality::Input => {}
                Causality::Parameter => {
                    let tunable = var.variability == Variability::Tunable;
                    let allowed = match self.state {
                        LifeState::Instantiated | LifeState::InitializationMode => true,
                        LifeState::StepComplete => tunable,
                        _ => false,
                    };
                    if !allowed {
                        return Err(Failure::error(if tunable {
                            format!(
                                "{} is a tunable parameter: it can be set before {}ExitInitializationMode or between \
                                 steps (state is {})",
                                var.name,
                                self.prefix(),
                                self.state_name()
                            )
                        } else {
                            format!(
                                "{} is a fixed parameter: it can be set only before {}ExitInitializationMode (state is {})",
                                var.name,
                                self.prefix(),
                                self.state_name()
                            )
                        }));
                    }
                }
                Causality::CalculatedParameter => {
                    return Err(Failure::error(format!(
                        "{} is a calculated parameter and cannot be set",
                        var.name
                    )))
                }
                Causality::Output => {
                    return Err(Failure::error(format!("{} is an output and cannot be set", var.name)))
                }
            }
            self.sim.set(vr as usize, value(k))?;
        }
        Ok(())
    }

    /// `fmi2DoStep`, `fmi3DoStep`: integrates from the current time to `current + h`; when
    /// the host allowed early returns (FMI 3.0), only to the first contact event before it,
    /// and then `Ok(true)`.
    pub fn do_step(&mut self, current: f64, h: f64) -> FmiResult<bool> {
        if !(h.is_finite() && h > 0.0) {
            return Err(Failure::error(format!(
                "communicationStepSize = {h} must be > 0",
                h = Num(h)
            )));
        }
        let now = self.time();
        let scale = now.abs().max(h);
        if !current.is_finite() || (current - now).abs() > 1e-9 * scale {
            return Err(Failure::error(format!(
                "currentCommunicationPoint = {current} is not the FMU's current time {now}",
                current = Num(current),
                now = Num(now)
            )));
        }
        let t_end = current + h;
        if !t_end.is_finite() {
            return Err(Failure::error(format!(
                "the step from {current} by {h} ends at a time that is not a finite number",
                h = Num(h),
                current = Num(current)
            )));
        }
        if t_end <= now {
            return Err(Failure::error(format!(
                "the step from {current} by {h} does not advance past the current time {now}",
                h = Num(h),
                current = Num(current),
                now = Num(now)
            )));
        }
        if let Some(stop) = self.stop_time {
            if t_end > stop + 1e-9 * stop.abs().max(h) {
                return Err(Failure::error(format!(
                    "the step to t = {t_end} goes past stopTime = {stop}",
                    stop = Num(stop),
                    t_end = Num(t_end)
                )));
            }
        }
        let result = if self.early_return {
            self.sim.step_to_event(t_end)
        } else {
            self.sim.step_to(t_end).map(|()| false)
        };
        for warning in self.sim.take_warnings() {
            self.log(fmi2Status::fmi2Warning, &format!("{}DoStep: {warning}", self.prefix()));
        }
        let last_time = match self.version {
            Version::Fmi2 => "fmi2LastSuccessfulTime",
            Version::Fmi3 => "lastSuccessfulTime",
        };
        match result {
            Ok(at_event) => Ok(at_event),
            Err(SimError::Step { time, message }) => Err(Failure::error(format!(
                "the step from t = {current} to {t_end} failed at t = {time}: {message}",
                current = Num(current),
                t_end = Num(t_end),
                time = Num(time)
            ))),
            Err(SimError::StepLimit { time, message }) => {
                let message = format!(
                    "the step from t = {current} to {t_end} stopped at t = {time} ({last_time}): {message}",
                    current = Num(current),
                    t_end = Num(t_end),
                    time = Num(time)
                );
                // FMI 2.0: fmi2Discard, the subinterval computed (the instance goes to step
                // failed). FMI 3.0 allows fmi3Discard only for an FMU in the state it was in
                // before the call, which one that reached no further is (islands whose first
                // round ran out of steps are taken back to its start): the host may try a
                // shorter step. One that went on returns early there with a warning where the
                // host allows early returns (and goes on from lastSuccessfulTime), else fails.
                let status = match (self.version, self.early_return, time > now) {
                    (Version::Fmi2, _, _) => {
                        self.state = LifeState::StepFailed;
                        fmi2Status::fmi2Discard
                    }
                    (Version::Fmi3, _, false) => fmi2Status::fmi2Discard,
                    (Version::Fmi3, true, true) => fmi2Status::fmi2Warning,
                    (Version::Fmi3, false, true) => fmi2Status::fmi2Error,
                };
                Err(Failure { status, message })
            }
            Err(e) => Err(e.into()),
        }
    }

    /// `fmi2GetRealStatus`
    pub fn real_status(&self, kind: c_int) -> FmiResult<f64> {
        if kind == status_kind::LAST_SUCCESSFUL_TIME {
            // the simulation's time: after a failed step, the last good one
            Ok(self.time())
        } else {
            Err(Failure::discard(format!(
                "status kind {kind} has no Real value (only fmi2LastSuccessfulTime = 2)"
            )))
        }
    }

    /// `fmi2GetBooleanStatus`: `fmi2Terminated` is true once the instance is terminated.
    pub fn boolean_status(&self, kind: c_int) -> FmiResult<bool> {
        if kind == status_kind::TERMINATED {
            Ok(self.state == LifeState::Terminated)
        } else {
            Err(Failure::discard(format!(
                "status kind {kind} has no Boolean value (only fmi2Terminated = 3)"
            )))
        }
    }

    /// `fmi2GetFMUstate`: everything needed to come back here.
    pub fn save(&mut self) -> SavedState {
        SavedState::new(
            self.model_hash,
            self.version,
            self.state,
            self.start_time,
            self.stop_time,
            self.sim.snapshot(Vec::new()),
        )
    }

    /// `fmi2SetFMUstate`: restores values, engine state and lifecycle (also into a fresh or a
    /// terminated instance).
    pub fn restore(&mut self, saved: &SavedState) -> FmiResult {
        self.check_version(saved)?;
        if saved.model_hash != self.model_hash {
            return Err(Failure::error(
                "the FMU state belongs to a different model (its scene differs from this instance's)",
            ));
        }
        if self.poisoned {
            self.sim = Simulation::from_scene_str(&self.scene_text, &self.origin)
                .map_err(|e| Failure::error(e.to_string()))?;
            self.poisoned = false;
        }
        self.sim.restore(&saved.snapshot)?;
        self.state = saved.lifecycle;
        self.start_time = saved.start_time;
        self.stop_time = saved.stop_time;
        let function = match self.version {
            Version::Fmi2 => "fmi2SetFMUstate",
            Version::Fmi3 => "fmi3SetFMUState",
        };
        self.log_event(&format!(
            "{function}: restored a state at t = {} ({})",
            self.time(),
            self.state_name()
        ));
        Ok(())
    }

    /// A saved state of the other FMI version is refused: the lifecycles differ.
    pub fn check_version(&self, saved: &SavedState) -> FmiResult {
        if saved.version == self.version {
            return Ok(());
        }
        Err(Failure::error(format!(
            "the FMU state was saved by an FMI {} instance; an FMI {} instance does not restore it (save and \
             restore states with the same FMI version of this FMU)",
            saved.version.number(),
            self.version.number()
        )))
    }
}

/// True for the variables the model computes (outputs, calculated parameters).
fn computed(var: &Variable) -> bool {
    matches!(var.causality, Causality::Output | Causality::CalculatedParameter)
}

#[cfg(test)]
mod tests {
    use super::Num;

    #[test]
    fn numbers_in_messages_are_short() {
        for (x, text) in [
            (1e300, "1e300"),
            (-1e300, "-1e300"),
            (5e-324, "5e-324"),
            (f64::MAX, "1.7976931348623157e308"),
            (1e3, "1000"),
            (0.001, "0.001"),
            (0.0, "0"),
            (-0.0, "-0"),
            (f64::NAN, "NaN"),
            (f64::INFINITY, "inf"),
            (1e-5, "1e-5"),
        ] {
            assert_eq!(Num(x).to_string(), text);
        }
    }
}
