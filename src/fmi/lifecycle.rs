//! The co-simulation state machine of FMI 2.0 (section 4.2.4) as bit masks: each function
//! lists the states it may be called in, in the style of the Reference-FMUs. A call outside
//! them is logged as "illegal call sequence" and answered with an error.
//!
//! FMI 3.0 Co-Simulation without event mode, intermediate update and configuration mode (what
//! this FMU declares) has the same states under other names: 3.0's Step Mode is *step
//! complete* (an FMI 3.0 instance that discards a step stays in Step Mode: never in *step failed*);
//! `fmi3EnterInitializationMode` (which takes the experiment's times) is allowed where
//! `fmi2SetupExperiment` is. So both versions share these masks (FMI 3.0's getters also read
//! in the instantiated state: [`FMI3_GET_VALUES`]); [`LifeState::name_in`] names a state as
//! each version does.

use crate::variables::VarType;

/// The FMI version of an instance (of the function that made it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Version {
    /// FMI 2.0 Co-Simulation.
    Fmi2,
    /// FMI 3.0 Co-Simulation.
    Fmi3,
}

impl Version {
    /// The prefix of its functions: `fmi2`, `fmi3`.
    pub fn prefix(self) -> &'static str {
        match self {
            Version::Fmi2 => "fmi2",
            Version::Fmi3 => "fmi3",
        }
    }

    /// `2.0`, `3.0`.
    pub fn number(self) -> &'static str {
        match self {
            Version::Fmi2 => "2.0",
            Version::Fmi3 => "3.0",
        }
    }

    /// What the model description's identity check is called: `GUID`, `instantiationToken`.
    pub fn token_name(self) -> &'static str {
        match self {
            Version::Fmi2 => "GUID",
            Version::Fmi3 => "instantiationToken",
        }
    }

    /// The model description's element of a variable of type `t`: `Real` or `Float64`,
    /// `Integer` or `Int32`, `Boolean`, `Enumeration`.
    pub fn type_element(self, t: VarType) -> &'static str {
        match (t, self) {
            (VarType::Real, Version::Fmi2) => "Real",
            (VarType::Real, Version::Fmi3) => "Float64",
            (VarType::Integer, Version::Fmi2) => "Integer",
            (VarType::Integer, Version::Fmi3) => "Int32",
            (VarType::Boolean, _) => "Boolean",
            (VarType::Enumeration(_), _) => "Enumeration",
        }
    }
}

named_enum! {
    /// The states an instance can be in, by the names log messages give them (FMI 2.0's;
    /// [`LifeState::name_in`] for either). (`StepInProgress` does not occur: `fmi2DoStep` is
    /// synchronous.)
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    #[repr(u32)]
    pub enum LifeState {
        /// After `fmi2Instantiate` or `fmi2Reset`.
        Instantiated = 1 << 0 => "instantiated",
        /// Between `fmi2EnterInitializationMode` and `fmi2ExitInitializationMode`.
        InitializationMode = 1 << 1 => "initialization mode",
        /// Ready for `fmi2DoStep`.
        StepComplete = 1 << 2 => "step complete",
        /// A step returned `fmi2Discard` (FMI 2.0: a step stopped by `solver.max_steps`).
        StepFailed = 1 << 3 => "step failed",
        /// A step was canceled (not produced by this library).
        StepCanceled = 1 << 4 => "step canceled",
        /// After `fmi2Terminate`.
        Terminated = 1 << 5 => "terminated",
        /// A call returned `fmi2Error`: only free, reset, get values or restore a state.
        Error = 1 << 6 => "error",
        /// A call returned `fmi2Fatal`.
        Fatal = 1 << 7 => "fatal",
    }
}

impl LifeState {
    /// The state's bit.
    pub fn bit(self) -> u32 {
        self as u32
    }

    /// A stable number for serialized states.
    pub fn code(self) -> u32 {
        self as u32
    }

    /// Inverse of [`LifeState::code`].
    pub fn from_code(code: u32) -> Option<LifeState> {
        LifeState::from_value(code.into())
    }

    /// The name in the given version of FMI.
    pub fn name_in(self, v: Version) -> &'static str {
        match (self, v) {
            (LifeState::StepComplete, Version::Fmi3) => "step mode",
            (LifeState::StepFailed, Version::Fmi3) => "step discarded",
            _ => self.name(),
        }
    }
}

const INSTANTIATED: u32 = LifeState::Instantiated as u32;
const INIT: u32 = LifeState::InitializationMode as u32;
const COMPLETE: u32 = LifeState::StepComplete as u32;
const FAILED: u32 = LifeState::StepFailed as u32;
const CANCELED: u32 = LifeState::StepCanceled as u32;
const TERMINATED: u32 = LifeState::Terminated as u32;
const ERROR: u32 = LifeState::Error as u32;

/// Every state except fatal.
pub const ANY_BUT_FATAL: u32 = INSTANTIATED | INIT | COMPLETE | FAILED | CANCELED | TERMINATED | ERROR;

/// `fmi2SetDebugLogging`
pub const SET_DEBUG_LOGGING: u32 = ANY_BUT_FATAL;
/// `fmi2SetupExperiment`
pub const SETUP_EXPERIMENT: u32 = INSTANTIATED;
/// `fmi2EnterInitializationMode`
pub const ENTER_INITIALIZATION_MODE: u32 = INSTANTIATED;
/// `fmi2ExitInitializationMode`
pub const EXIT_INITIALIZATION_MODE: u32 = INIT;
/// `fmi2Terminate`
pub const TERMINATE: u32 = COMPLETE | FAILED;
/// `fmi2Reset`
pub const RESET: u32 = ANY_BUT_FATAL;
/// `fmi2GetReal` and the other getters.
pub const GET_VALUES: u32 = INIT | COMPLETE | FAILED | CANCELED | TERMINATED | ERROR;
/// `fmi3GetFloat64` and the other getters of FMI 3.0, which also reads the start values in
/// the instantiated state (FMI 3.0 section 2.3.2; FMI 2.0 does not list the getters there).
pub const FMI3_GET_VALUES: u32 = INSTANTIATED | GET_VALUES;
/// `fmi2SetReal` and the other setters (which variables may be set is checked per state).
pub const SET_VALUES: u32 = INSTANTIATED | INIT | COMPLETE;
/// `fmi2GetFMUstate`, `fmi2SetFMUstate`, `fmi2FreeFMUstate` and (de)serialization.
pub const FMU_STATE: u32 = ANY_BUT_FATAL;
/// `fmi2GetDirectionalDerivative` (unsupported)
pub const GET_DIRECTIONAL_DERIVATIVE: u32 = INIT | COMPLETE | FAILED | CANCELED | TERMINATED | ERROR;
/// `fmi2SetRealInputDerivatives` (unsupported)
pub const SET_REAL_INPUT_DERIVATIVES: u32 = INSTANTIATED | INIT | COMPLETE;
/// `fmi2GetRealOutputDerivatives` (unsupported)
pub const GET_REAL_OUTPUT_DERIVATIVES: u32 = COMPLETE | FAILED | CANCELED | TERMINATED | ERROR;
/// `fmi2DoStep`
pub const DO_STEP: u32 = COMPLETE;
/// `fmi2CancelStep` (only meaningful while a step is pending, which never happens)
pub const CANCEL_STEP: u32 = 0;
/// `fmi3EnterStepMode`: only from Event Mode, which this FMU does not have (`hasEventMode` is
/// false): never allowed.
pub const ENTER_STEP_MODE: u32 = 0;
/// `fmi2GetStatus` and its typed variants. Error is included so that a host can ask for the
/// last successful time after a failed step.
pub const GET_STATUS: u32 = COMPLETE | FAILED | CANCELED | TERMINATED | ERROR;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip_and_bits_are_distinct() {
        let all = [
            LifeState::Instantiated,
            LifeState::InitializationMode,
            LifeState::StepComplete,
            LifeState::StepFailed,
            LifeState::StepCanceled,
            LifeState::Terminated,
            LifeState::Error,
            LifeState::Fatal,
        ];
        let mut seen = 0u32;
        for s in all {
            assert_eq!(LifeState::from_code(s.code()), Some(s));
            assert_eq!(seen & s.bit(), 0);
            seen |= s.bit();
        }
        assert_eq!(LifeState::from_code(3), None);
    }

    #[test]
    fn the_calling_sequence_of_a_co_simulation() {
        assert_ne!(DO_STEP & LifeState::StepComplete.bit(), 0);
        assert_eq!(DO_STEP & LifeState::Instantiated.bit(), 0);
        assert_eq!(DO_STEP & LifeState::InitializationMode.bit(), 0);
        assert_eq!(GET_VALUES & LifeState::Instantiated.bit(), 0);
        assert_eq!(FMU_STATE & LifeState::Fatal.bit(), 0);
        assert_ne!(FMU_STATE & LifeState::Terminated.bit(), 0);
        assert_eq!(SET_VALUES & LifeState::Terminated.bit(), 0);
    }
}
