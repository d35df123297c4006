//! The FMI 3.0 functions of what this FMU does not offer: variables of the types it does not
//! use, Model Exchange, event mode, clocks, configuration mode, dependencies at run time and
//! derivatives. Each is exported with the standard's signature (a host that looks every
//! function up finds it), looks its instance up and checks its state like the others, and
//! answers `fmi3Error` with a message saying what is not supported (a typed get or set of an
//! empty list succeeds, as for String).

#![allow(non_snake_case)]

use super::types::*;
use crate::fmi::glue::{self, call};
use crate::fmi::instance::{Failure, FmiResult, Instance};
use crate::fmi::lifecycle::{self, Version};

/// Borrows the FMI 3.0 instance behind a handle (see `glue::instance`).
///
/// # Safety
/// While the borrow lasts, no other thread uses or frees `instance`.
unsafe fn lookup<'a>(instance: fmi3Instance) -> Option<&'a mut Instance> {
    // SAFETY: this function's contract.
    unsafe { glue::instance(instance, Version::Fmi3) }
}

/// A get or set of `type_name` variables, of which this model has none: an empty list
/// succeeds, any value reference is refused.
///
/// # Safety
/// `vr` holds `nvr` elements.
unsafe fn none_of(type_name: &str, vr: *const fmi3ValueReference, nvr: usize) -> FmiResult {
    // SAFETY: `vr` holds `nvr` elements (this function's contract).
    let vrs = unsafe { glue::slice(vr, nvr, "vr") }?;
    match vrs.first() {
        Some(v) => Err(Failure::error(format!(
            "value reference {v} is not a {type_name} variable: this model has none"
        ))),
        None => Ok(()),
    }
}

/// Getters and setters of the FMI 3.0 types this model does not use.
macro_rules! no_variables {
    ($($get:ident, $set:ident, $ty:ty, $name:literal;)*) => {$(
        #[doc = concat!("`", stringify!($get), "`: this model has no ", $name, " variables.")]
        ///
        /// # Safety
        /// `vr` holds `nvr` elements.
        #[no_mangle]
        pub unsafe extern "C" fn $get(
            instance: fmi3Instance,
            vr: *const fmi3ValueReference,
            nvr: usize,
            _values: *mut $ty,
            _n_values: usize,
        ) -> fmi3Status {
            // SAFETY: FMI 3.0: the host does not use or free `instance` meanwhile.
            let found = unsafe { lookup(instance) };
            // SAFETY: `vr` holds `nvr` elements (this function's contract).
            call(found, stringify!($get), lifecycle::GET_VALUES, |_| unsafe { none_of($name, vr, nvr) })
        }

        #[doc = concat!("`", stringify!($set), "`: this model has no ", $name, " variables.")]
        ///
        /// # Safety
        /// `vr` holds `nvr` elements.
        #[no_mangle]
        pub unsafe extern "C" fn $set(
            instance: fmi3Instance,
            vr: *const fmi3ValueReference,
            nvr: usize,
            _values: *const $ty,
            _n_values: usize,
        ) -> fmi3Status {
            // SAFETY: FMI 3.0: the host does not use or free `instance` meanwhile.
            let found = unsafe { lookup(instance) };
            // SAFETY: `vr` holds `nvr` elements (this function's contract).
            call(found, stringify!($set), lifecycle::SET_VALUES, |_| unsafe { none_of($name, vr, nvr) })
        }
    )*};
}

no_variables! {
    fmi3GetFloat32, fmi3SetFloat32, fmi3Float32, "Float32";
    fmi3GetInt8, fmi3SetInt8, fmi3Int8, "Int8";
    fmi3GetUInt8, fmi3SetUInt8, fmi3UInt8, "UInt8";
    fmi3GetInt16, fmi3SetInt16, fmi3Int16, "Int16";
    fmi3GetUInt16, fmi3SetUInt16, fmi3UInt16, "UInt16";
    fmi3GetUInt32, fmi3SetUInt32, fmi3UInt32, "UInt32";
    fmi3GetUInt64, fmi3SetUInt64, fmi3UInt64, "UInt64";
}

/// `fmi3GetBinary`: this model has no Binary variables.
///
/// # Safety
/// `vr` holds `nvr` elements.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetBinary(
    instance: fmi3Instance,
    vr: *const fmi3ValueReference,
    nvr: usize,
    _value_sizes: *mut usize,
    _values: *mut fmi3Binary,
    _n_values: usize,
) -> fmi3Status {
    // SAFETY: FMI 3.0: the host does not use or free `instance` meanwhile.
    let found = unsafe { lookup(instance) };
    // SAFETY: `vr` holds `nvr` elements (this function's contract).
    call(found, "fmi3GetBinary", lifecycle::GET_VALUES, |_| unsafe {
        none_of("Binary", vr, nvr)
    })
}

/// `fmi3SetBinary`: this model has no Binary variables.
///
/// # Safety
/// `vr` holds `nvr` elements.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetBinary(
    instance: fmi3Instance,
    vr: *const fmi3ValueReference,
    nvr: usize,
    _value_sizes: *const usize,
    _values: *const fmi3Binary,
    _n_values: usize,
) -> fmi3Status {
    // SAFETY: FMI 3.0: the host does not use or free `instance` meanwhile.
    let found = unsafe { lookup(instance) };
    // SAFETY: `vr` holds `nvr` elements (this function's contract).
    call(found, "fmi3SetBinary", lifecycle::SET_VALUES, |_| unsafe {
        none_of("Binary", vr, nvr)
    })
}

/// `fmi3GetClock`: this model has no clocks.
///
/// # Safety
/// `vr` holds `nvr` elements.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetClock(
    instance: fmi3Instance,
    vr: *const fmi3ValueReference,
    nvr: usize,
    _values: *mut fmi3Clock,
) -> fmi3Status {
    // SAFETY: FMI 3.0: the host does not use or free `instance` meanwhile.
    let found = unsafe { lookup(instance) };
    // SAFETY: `vr` holds `nvr` elements (this function's contract).
    call(found, "fmi3GetClock", lifecycle::GET_VALUES, |_| unsafe {
        none_of("Clock", vr, nvr)
    })
}

/// `fmi3SetClock`: this model has no clocks.
///
/// # Safety
/// `vr` holds `nvr` elements.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetClock(
    instance: fmi3Instance,
    vr: *const fmi3ValueReference,
    nvr: usize,
    _values: *const fmi3Clock,
) -> fmi3Status {
    // SAFETY: FMI 3.0: the host does not use or free `instance` meanwhile.
    let found = unsafe { lookup(instance) };
    // SAFETY: `vr` holds `nvr` elements (this function's contract).
    call(found, "fmi3SetClock", lifecycle::SET_VALUES, |_| unsafe {
        none_of("Clock", vr, nvr)
    })
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
            // SAFETY: FMI 3.0: the host does not use or free `instance` meanwhile.
            let found = unsafe { lookup(instance) };
            call(found, stringify!($name), lifecycle::ANY_BUT_FATAL, |_| {
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
    fmi3GetDirectionalDerivative(
        _unknowns: *const fmi3ValueReference,
        _n_unknowns: usize,
        _knowns: *const fmi3ValueReference,
        _n_knowns: usize,
        _seed: *const fmi3Float64,
        _n_seed: usize,
        _sensitivity: *mut fmi3Float64,
        _n_sensitivity: usize
    ) => "providesDirectionalDerivatives is false";
    fmi3GetAdjointDerivative(
        _unknowns: *const fmi3ValueReference,
        _n_unknowns: usize,
        _knowns: *const fmi3ValueReference,
        _n_knowns: usize,
        _seed: *const fmi3Float64,
        _n_seed: usize,
        _sensitivity: *mut fmi3Float64,
        _n_sensitivity: usize
    ) => "providesAdjointDerivatives is false";
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
