//! The facade that hosts use: a scene, its variable table, parameter values, and once
//! initialised a compiled [`Model`] with its [`Data`]. Both the FMI layer and the
//! `simulate` command drive the engine only through this type, so they see the same
//! variables and the same numbers.

use crate::engine::{self, Engine, EngineError};
use crate::scene::{Scene, SceneError};
use crate::variables::{Causality, VarRef, VarType, Variable, VariableTable};
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
    engine: Option<Engine>,
    /// True when `engine` was compiled with the current parameter values.
    engine_fresh: bool,
    initialized: bool,
}

/// A saved state: parameter and input values plus the engine's dynamic state. Restoring it
/// continues bit for bit.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// Parameter and input values.
    pub values: Vec<f64>,
    /// Whether the simulation had been initialised.
    pub initialized: bool,
    /// The engine's dynamic state (empty when not initialised).
    pub state: Vec<f64>,
}

const SNAPSHOT_MAGIC: u32 = 0x4346_4d55; // "CFMU"
const SNAPSHOT_VERSION: u32 = 1;

impl Snapshot {
    /// Plain bytes: magic, version, lengths, values (little-endian f64). No pointers.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(24 + 8 * (self.values.len() + self.state.len()));
        b.extend_from_slice(&SNAPSHOT_MAGIC.to_le_bytes());
        b.extend_from_slice(&SNAPSHOT_VERSION.to_le_bytes());
        b.extend_from_slice(&(self.initialized as u32).to_le_bytes());
        b.extend_from_slice(&(self.values.len() as u32).to_le_bytes());
        b.extend_from_slice(&(self.state.len() as u32).to_le_bytes());
        for x in self.values.iter().chain(self.state.iter()) {
            b.extend_from_slice(&x.to_le_bytes());
        }
        b
    }

    /// Parses bytes written by [`Snapshot::to_bytes`], checking magic, version and length.
    pub fn from_bytes(b: &[u8]) -> Result<Snapshot, String> {
        let word = |i: usize| -> Result<u32, String> {
            b.get(4 * i..4 * i + 4)
                .map(|s| u32::from_le_bytes(s.try_into().unwrap_or([0; 4])))
                .ok_or_else(|| "serialized state is truncated".to_string())
        };
        if word(0)? != SNAPSHOT_MAGIC {
            return Err("serialized state has a wrong magic number (not a contact-fmu state)".into());
        }
        if word(1)? != SNAPSHOT_VERSION {
            return Err(format!(
                "serialized state version {} is not supported (expected {SNAPSHOT_VERSION})",
                word(1)?
            ));
        }
        let initialized = word(2)? != 0;
        let nv = word(3)? as usize;
        let ns = word(4)? as usize;
        if b.len() != 20 + 8 * (nv + ns) {
            return Err(format!(
                "serialized state has {} bytes, expected {}",
                b.len(),
                20 + 8 * (nv + ns)
            ));
        }
        let f = |k: usize| f64::from_le_bytes(b[20 + 8 * k..28 + 8 * k].try_into().unwrap_or([0; 8]));
        Ok(Snapshot {
            values: (0..nv).map(f).collect(),
            initialized,
            state: (nv..nv + ns).map(f).collect(),
        })
    }
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
            engine: None,
            engine_fresh: false,
            initialized: false,
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

    /// The variable table.
    pub fn table(&self) -> &VariableTable {
        &self.table
    }

    /// True after a successful [`Simulation::initialize`].
    pub fn is_initialized(&self) -> bool {
        self.initialized
    }

    /// Current simulation time [s] (0 before initialisation).
    pub fn time(&self) -> f64 {
        self.engine.as_ref().map(|e| e.time()).unwrap_or(0.0)
    }

    /// Sets a parameter (before initialisation only) or an input (at any time). The range of a
    /// parameter is checked by [`Simulation::initialize`], so that a host may set values in
    /// any order.
    pub fn set(&mut self, vr: usize, value: f64) -> Result<(), SimError> {
        let var = self
            .table
            .vars
            .get(vr)
            .ok_or_else(|| SimError::Variable(format!("unknown value reference {vr}")))?;
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
                    self.engine_fresh = false;
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
                if let (Some(e), VarRef::Input(i)) = (self.engine.as_mut(), var.target) {
                    e.set_input(i, value);
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
        let var = self
            .table
            .vars
            .get(vr)
            .ok_or_else(|| SimError::Variable(format!("unknown value reference {vr}")))?;
        match var.causality {
            Causality::Parameter | Causality::Input => Ok(self.values[vr]),
            _ => {
                let target = var.target;
                self.ensure_engine()?;
                let e = self.engine.as_mut().ok_or(SimError::NotInitialized)?;
                Ok(e.output(target))
            }
        }
    }

    /// The scene with the current parameter values applied.
    pub fn effective_scene(&self) -> Scene {
        let mut s = self.scene.clone();
        for (vr, var) in self.table.vars.iter().enumerate() {
            if var.causality != Causality::Parameter {
                continue;
            }
            let x = self.values[vr];
            match var.target {
                VarRef::YoungsModulus(i) => s.material[i].youngs_modulus = x,
                VarRef::PoissonRatio(i) => s.material[i].poisson_ratio = x,
                VarRef::Mass(i) => s.body[i].mass = x,
                VarRef::ContactLaw(i) => {
                    if let Some(l) = crate::scene::Law::from_index(x as i64) {
                        s.contact[i].law = l
                    }
                }
                VarRef::Restitution(i) => s.contact[i].restitution = x,
                VarRef::Exponent(i) => s.contact[i].exponent = Some(x),
                VarRef::Damping(i) => s.contact[i].damping = Some(x),
                VarRef::MaxPenetration(i) => s.contact[i].max_penetration = Some(x),
                VarRef::MinImpactVelocity(i) => s.contact[i].min_impact_velocity = Some(x),
                VarRef::Stiffness(i) => s.contact[i].stiffness = Some(x),
                VarRef::SolverMethod => {
                    if let Some(m) = crate::scene::Method::from_index(x as i64) {
                        s.solver.method = m
                    }
                }
                VarRef::SolverRtol => s.solver.rtol = x,
                VarRef::SolverAtol => s.solver.atol = x,
                VarRef::SolverMaxStep => s.solver.max_step = x,
                _ => {}
            }
        }
        for (i, inp) in s.input.iter_mut().enumerate() {
            if let Some(vr) = self.table.vars.iter().position(|v| v.target == VarRef::Input(i)) {
                inp.start = self.values[vr];
            }
        }
        s
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

    fn ensure_engine(&mut self) -> Result<(), SimError> {
        if self.engine.is_none() || !self.engine_fresh {
            self.check_parameters()?;
            let scene = self.effective_scene();
            scene.validate(&self.origin)?;
            self.engine = Some(Engine::compile(&scene, &self.origin)?);
            self.engine_fresh = true;
        }
        Ok(())
    }

    /// Ends initialisation: checks every parameter, compiles the model and sets the state to
    /// the scene's initial configuration at `start_time`.
    pub fn initialize(&mut self, start_time: f64) -> Result<(), SimError> {
        if !start_time.is_finite() {
            return Err(SimError::Variable(format!(
                "start time must be finite (got {start_time})"
            )));
        }
        self.engine_fresh = false;
        self.ensure_engine()?;
        let e = self.engine.as_mut().ok_or(SimError::NotInitialized)?;
        e.set_time(start_time);
        self.initialized = true;
        Ok(())
    }

    /// Integrates to `t_end` (> current time). On failure the state is the last good one and
    /// the error carries its time.
    pub fn step_to(&mut self, t_end: f64) -> Result<(), SimError> {
        if !self.initialized {
            return Err(SimError::NotInitialized);
        }
        let e = self.engine.as_mut().ok_or(SimError::NotInitialized)?;
        e.advance(t_end)
            .map_err(|EngineError { time, message }| SimError::Step { time, message })
    }

    /// Saves everything needed to continue from here.
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            values: self.values.clone(),
            initialized: self.initialized,
            state: if self.initialized {
                self.engine.as_ref().map(|e| e.save_state()).unwrap_or_default()
            } else {
                Vec::new()
            },
        }
    }

    /// Restores a snapshot taken from a simulation of the same scene (into a fresh,
    /// terminated or running one alike).
    pub fn restore(&mut self, s: &Snapshot) -> Result<(), SimError> {
        if s.values.len() != self.values.len() {
            return Err(SimError::Variable(format!(
                "state holds {} values, this model has {}: not a state of this model",
                s.values.len(),
                self.values.len()
            )));
        }
        if self.values != s.values {
            self.values.clone_from(&s.values);
            self.engine_fresh = false;
        }
        if s.initialized {
            self.ensure_engine()?;
            let e = self.engine.as_mut().ok_or(SimError::NotInitialized)?;
            e.load_state(&s.state).map_err(SimError::Variable)?;
            for (vr, var) in self.table.vars.iter().enumerate() {
                if let VarRef::Input(i) = var.target {
                    e.set_input(i, self.values[vr]);
                }
            }
        } else {
            self.engine_fresh = false;
        }
        self.initialized = s.initialized;
        Ok(())
    }

    /// Direct access to the engine (after initialisation), for tests and benchmarks.
    pub fn engine(&self) -> Option<&Engine> {
        self.engine.as_ref()
    }

    /// Mutable access to the engine, for tests and benchmarks.
    pub fn engine_mut(&mut self) -> Option<&mut Engine> {
        self.engine.as_mut()
    }
}

/// Re-exported for callers that only need the engine counters.
pub use engine::Counters;
