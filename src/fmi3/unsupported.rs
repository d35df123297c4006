//! The FMI 3.0 functions of what this FMU does not offer: variables of the types it does not
//! use, Model Exchange, event mode, clocks, configuration mode, dependencies at run time and
//! derivatives. Each is exported with the standard's signature (a host that looks every
//! function up finds it), looks its instance up and checks its state like the others, and
//! answers `fmi3Error` with a message saying what is not supported (a typed get or set of an
//! empty list succeeds, as for String).

#![allow(non_snake_case)]

use super::exports::{report, with};
use super::types::*;
use crate::fmi::glue;
use crate::fmi::lifecycle;
use crate::fmi::log::Failure;

/// Getters and setters of the FMI 3.0 types this model does not use: `(instance, vr, nvr,`
/// then the type's own arguments, which are not read.
macro_rules! no_variables {
    ($($name:ident ($($arg:ident : $ty:ty),*) => $type_name:literal, $mask:ident;)*) => {$(
        #[doc = concat!("`", stringify!($name), "`: this model has no ", $type_name, " variables.")]
        ///
        /// # Safety
        /// `vr` holds `nvr` elements.
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            instance: fmi3Instance,
            vr: *const fmi3ValueReference,
            nvr: usize,
            $($arg: $ty),*
        ) -> fmi3Status {
            // SAFETY: `vr` holds `nvr` elements (this function's contract).
            with(instance, stringify!($name), lifecycle::$mask, |_| unsafe { glue::none_of($type_name, vr, nvr) })
        }
    )*};
}

no_variables! {
    fmi3GetFloat32(_values: *mut fmi3Float32, _n_values: usize) => "Float32", FMI3_GET_VALUES;
    fmi3SetFloat32(_values: *const fmi3Float32, _n_values: usize) => "Float32", SET_VALUES;
    fmi3GetInt8(_values: *mut fmi3Int8, _n_values: usize) => "Int8", FMI3_GET_VALUES;
    fmi3SetInt8(_values: *const fmi3Int8, _n_values: usize) => "Int8", SET_VALUES;
    fmi3GetUInt8(_values: *mut fmi3UInt8, _n_values: usize) => "UInt8", FMI3_GET_VALUES;
    fmi3SetUInt8(_values: *const fmi3UInt8, _n_values: usize) => "UInt8", SET_VALUES;
    fmi3GetInt16(_values: *mut fmi3Int16, _n_values: usize) => "Int16", FMI3_GET_VALUES;
    fmi3SetInt16(_values: *const fmi3Int16, _n_values: usize) => "Int16", SET_VALUES;
    fmi3GetUInt16(_values: *mut fmi3UInt16, _n_values: usize) => "UInt16", FMI3_GET_VALUES;
    fmi3SetUInt16(_values: *const fmi3UInt16, _n_values: usize) => "UInt16", SET_VALUES;
    fmi3GetUInt32(_values: *mut fmi3UInt32, _n_values: usize) => "UInt32", FMI3_GET_VALUES;
    fmi3SetUInt32(_values: *const fmi3UInt32, _n_values: usize) => "UInt32", SET_VALUES;
    fmi3GetUInt64(_values: *mut fmi3UInt64, _n_values: usize) => "UInt64", FMI3_GET_VALUES;
    fmi3SetUInt64(_values: *const fmi3UInt64, _n_values: usize) => "UInt64", SET_VALUES;
    fmi3GetBinary(_value_sizes: *mut usize, _values: *mut fmi3Binary, _n_values: usize) => "Binary", FMI3_GET_VALUES;
    fmi3SetBinary(_value_sizes: *const usize, _values: *const fmi3Binary, _n_values: usize) => "Binary", SET_VALUES;
    fmi3GetClock(_values: *mut fmi3Clock) => "Clock", FMI3_GET_VALUES;
    fmi3SetClock(_values: *const fmi3Clock) => "Clock", SET_VALUES;
}

/// The instantiation functions of the interfaces this FMU does not offer: they log why through
/// the host's logger (the arguments named after `env` and `log`) and return NULL.
macro_rules! not_offered {
    ($($name:ident ($($arg:ident : $ty:ty),*) env $env:ident log $log:ident;)*) => {$(
        #[doc = concat!("`", stringify!($name), "`: not offered (the model description has only `CoSimulation`); logs why and returns NULL.")]
        ///
        /// # Safety
        /// Only the logger is called.
        #[no_mangle]
        #[allow(clippy::too_many_arguments)]
        pub unsafe extern "C" fn $name($($arg: $ty),*) -> fmi3Instance {
            let message = concat!(stringify!($name), ": this FMU supports Co-Simulation only");
            let _ = std::panic::catch_unwind(|| report($log, $env, message));
            std::ptr::null_mut()
        }
    )*};
}

not_offered! {
    fmi3InstantiateModelExchange(_name: fmi3String, _token: fmi3String, _path: fmi3String, _visible: fmi3Boolean,
        _logging_on: fmi3Boolean, environment: fmi3InstanceEnvironment, log_message: fmi3LogMessageCallback)
        env environment log log_message;
    fmi3InstantiateScheduledExecution(_name: fmi3String, _token: fmi3String, _path: fmi3String, _visible: fmi3Boolean,
        _logging_on: fmi3Boolean, environment: fmi3InstanceEnvironment, log_message: fmi3LogMessageCallback,
        _clock_update: fmi3ClockUpdateCallback, _lock: fmi3PreemptionCallback, _unlock: fmi3PreemptionCallback)
        env environment log log_message;
}

/// Functions refused whatever their arguments (which are not read): each names what this FMU
/// does not offer.
macro_rules! refused {
    ($($name:ident ($($arg:ident : $ty:ty),*) => $why:literal;)*) => {$(
        #[doc = concat!("`", stringify!($name), "`: not supported (", $why, ").")]
        ///
        /// # Safety
        /// Only `instance` is read (looked up before use).
        #[no_mangle]
        pub unsafe extern "C" fn $name(instance: fmi3Instance, $($arg: $ty),*) -> fmi3Status {
            with(instance, stringify!($name), lifecycle::ANY_BUT_FATAL, |_| {
                Err(Failure::error(concat!("not supported: ", $why)))
            })
        }
    )*};
}

refused! {
    fmi3EnterEventMode() => "hasEventMode is false";
    fmi3EvaluateDiscreteStates() => "this FMU has no event mode and no clocks";
    fmi3UpdateDiscreteStates(
        _discrete_states_need_update: *mut fmi3Boolean,
        _terminate_simulation: *mut fmi3Boolean,
        _nominals_changed: *mut fmi3Boolean,
        _values_changed: *mut fmi3Boolean,
        _next_event_time_defined: *mut fmi3Boolean,
        _next_event_time: *mut fmi3Float64
    ) => "hasEventMode is false";
    fmi3EnterConfigurationMode() => "this FMU has no structural parameters";
    fmi3ExitConfigurationMode() => "this FMU has no structural parameters";
    fmi3GetNumberOfVariableDependencies(_vr: fmi3ValueReference, _n: *mut usize)
        => "the dependencies are in the model description's ModelStructure";
    fmi3GetVariableDependencies(
        _dependent: fmi3ValueReference,
        _element_indices_of_dependent: *mut usize,
        _independents: *mut fmi3ValueReference,
        _element_indices_of_independents: *mut usize,
        _dependency_kinds: *mut fmi3DependencyKind,
        _n_dependencies: usize
    ) => "the dependencies are in the model description's ModelStructure";
    // (unknowns, knowns, seed, sensitivity: each an array and its length)
    fmi3GetDirectionalDerivative(_u: *const fmi3ValueReference, _nu: usize, _k: *const fmi3ValueReference, _nk: usize,
        _seed: *const fmi3Float64, _ns: usize, _sensitivity: *mut fmi3Float64, _n: usize)
        => "providesDirectionalDerivatives is false";
    fmi3GetAdjointDerivative(_u: *const fmi3ValueReference, _nu: usize, _k: *const fmi3ValueReference, _nk: usize,
        _seed: *const fmi3Float64, _ns: usize, _sensitivity: *mut fmi3Float64, _n: usize)
        => "providesAdjointDerivatives is false";
    fmi3GetOutputDerivatives(
        _vr: *const fmi3ValueReference,
        _nvr: usize,
        _orders: *const fmi3Int32,
        _values: *mut fmi3Float64,
        _n_values: usize
    ) => "maxOutputDerivativeOrder is 0";
    fmi3GetIntervalDecimal(
        _vr: *const fmi3ValueReference,
        _nvr: usize,
        _intervals: *mut fmi3Float64,
        _qualifiers: *mut fmi3IntervalQualifier
    ) => "this FMU has no clocks";
    fmi3GetIntervalFraction(
        _vr: *const fmi3ValueReference,
        _nvr: usize,
        _counters: *mut fmi3UInt64,
        _resolutions: *mut fmi3UInt64,
        _qualifiers: *mut fmi3IntervalQualifier
    ) => "this FMU has no clocks";
    fmi3GetShiftDecimal(_vr: *const fmi3ValueReference, _nvr: usize, _shifts: *mut fmi3Float64)
        => "this FMU has no clocks";
    fmi3GetShiftFraction(
        _vr: *const fmi3ValueReference,
        _nvr: usize,
        _counters: *mut fmi3UInt64,
        _resolutions: *mut fmi3UInt64
    ) => "this FMU has no clocks";
    fmi3SetIntervalDecimal(_vr: *const fmi3ValueReference, _nvr: usize, _intervals: *const fmi3Float64)
        => "this FMU has no clocks";
    fmi3SetIntervalFraction(
        _vr: *const fmi3ValueReference,
        _nvr: usize,
        _counters: *const fmi3UInt64,
        _resolutions: *const fmi3UInt64
    ) => "this FMU has no clocks";
    fmi3SetShiftDecimal(_vr: *const fmi3ValueReference, _nvr: usize, _shifts: *const fmi3Float64)
        => "this FMU has no clocks";
    fmi3SetShiftFraction(
        _vr: *const fmi3ValueReference,
        _nvr: usize,
        _counters: *const fmi3UInt64,
        _resolutions: *const fmi3UInt64
    ) => "this FMU has no clocks";
    fmi3ActivateModelPartition(_clock_reference: fmi3ValueReference, _activation_time: fmi3Float64)
        => "Scheduled Execution is not offered";
    fmi3EnterContinuousTimeMode() => "Model Exchange is not offered";
    fmi3CompletedIntegratorStep(
        _no_set_fmu_state_prior_to_current_point: fmi3Boolean,
        _enter_event_mode: *mut fmi3Boolean,
        _terminate_simulation: *mut fmi3Boolean
    ) => "Model Exchange is not offered";
    fmi3SetTime(_time: fmi3Float64) => "Model Exchange is not offered";
    fmi3SetContinuousStates(_states: *const fmi3Float64, _n: usize) => "Model Exchange is not offered";
    fmi3GetContinuousStateDerivatives(_derivatives: *mut fmi3Float64, _n: usize) => "Model Exchange is not offered";
    fmi3GetEventIndicators(_indicators: *mut fmi3Float64, _n: usize) => "Model Exchange is not offered";
    fmi3GetContinuousStates(_states: *mut fmi3Float64, _n: usize) => "Model Exchange is not offered";
    fmi3GetNominalsOfContinuousStates(_nominals: *mut fmi3Float64, _n: usize) => "Model Exchange is not offered";
    fmi3GetNumberOfEventIndicators(_n: *mut usize) => "Model Exchange is not offered";
    fmi3GetNumberOfContinuousStates(_n: *mut usize) => "Model Exchange is not offered";
}
