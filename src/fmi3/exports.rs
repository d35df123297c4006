//! The exported C functions of FMI 3.0: every function of the standard's headers, so that any
//! host finds what it looks for. Co-Simulation and the common functions work; Model Exchange,
//! Scheduled Execution, event mode, clocks, configuration mode, intermediate update and
//! derivatives are refused with a message (their instantiation functions return NULL).
//!
//! Each function looks its instance up (a handle of this library made by
//! `fmi3InstantiateCoSimulation`; NULL, a freed handle, an FMI 2.0 instance or any other value
//! gets `fmi3Error` unlogged), checks the calling state, catches panics and forwards to the
//! [`Instance`] that the FMI 2.0 functions drive too (`crate::fmi::glue`).
//!
//! Safety, for every function: instance and FMU-state values may be anything (they are looked
//! up before use), but FMI 3.0's rule holds that one instance, and a state, is not used or
//! freed on two threads at once. Each function's `# Safety` names its other pointers.

#![allow(non_snake_case)]

use super::types::*;
use crate::fmi::glue::{self, call, string_arg};
use crate::fmi::instance::{Access, Instance, InstantiateArgs};
use crate::fmi::lifecycle::{self, LifeState, Version};
use crate::fmi::log::{Failure, FmiResult, Sink};
use std::ffi::{CStr, CString};
use std::os::raw::c_char;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::ptr;

/// Borrows the FMI 3.0 instance behind a handle (see [`glue::instance`]).
///
/// # Safety
/// While the borrow lasts, no other thread uses or frees `instance`.
unsafe fn lookup<'a>(instance: fmi3Instance) -> Option<&'a mut Instance> {
    // SAFETY: this function's contract.
    unsafe { glue::instance(instance, Version::Fmi3) }
}

/// Runs one call of an exported function on the FMI 3.0 instance behind `instance`: looked
/// up, its state checked against `mask`, panics caught, a failure logged (see `glue::call`).
/// (Only the exported functions call it, under FMI 3.0's rule that one instance is not used
/// or freed on two threads at once.)
pub(super) fn with(
    instance: fmi3Instance,
    func: &'static str,
    mask: u32,
    body: impl FnOnce(&mut Instance) -> FmiResult,
) -> fmi3Status {
    // SAFETY: the exported function calling this is under FMI 3.0's rule (see above).
    let found = unsafe { lookup(instance) };
    call(found, func, mask, body)
}

/// The [`Sink`] of an FMI 3.0 logger (none when the host gave none). The message is passed
/// as it is (FMI 3.0's logger is not a printf format), NUL bytes replaced.
fn sink(log: fmi3LogMessageCallback, environment: fmi3InstanceEnvironment) -> Option<Sink> {
    let log = log?;
    Some(Box::new(move |status, category: &CStr, message: &str| {
        let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
        // SAFETY: the logger is the host's function with the fmi3LogMessageCallback signature;
        // both strings are valid and NUL-terminated until it returns.
        unsafe { log(environment, status.into(), category.as_ptr(), text.as_ptr()) }
    }))
}

/// Logs an instantiation failure through the host's logger (there is no instance yet).
pub(super) fn report(log: fmi3LogMessageCallback, environment: fmi3InstanceEnvironment, message: &str) {
    if let Some(sink) = sink(log, environment) {
        sink(crate::fmi::fmi2Status::fmi2Error, c"logStatusError", message);
    }
}

/// `fmi3Boolean` as the byte the host reads (0 or 1).
fn byte(b: bool) -> u8 {
    u8::from(b)
}

// ---------------------------------------------------------------------------------------
// Inquire version numbers, set debug logging, create and destroy instances
// ---------------------------------------------------------------------------------------

/// `fmi3GetVersion`: `"3.0"`.
#[no_mangle]
pub extern "C" fn fmi3GetVersion() -> *const c_char {
    c"3.0".as_ptr()
}

/// `fmi3SetDebugLogging`
///
/// # Safety
/// `categories` holds `n_categories` strings, each NULL or NUL-terminated.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetDebugLogging(
    instance: fmi3Instance,
    logging_on: fmi3Boolean,
    n_categories: usize,
    categories: *const fmi3String,
) -> fmi3Status {
    with(instance, "fmi3SetDebugLogging", lifecycle::SET_DEBUG_LOGGING, |inst| {
        // SAFETY: `categories` holds `n_categories` strings (this function's contract).
        unsafe { glue::set_debug_logging(inst, logging_on, n_categories, categories) }
    })
}

/// `fmi3InstantiateCoSimulation`: reads `<resourcePath>/scene.toml`, checks the
/// instantiation token, copies the strings. `earlyReturnAllowed` makes every `fmi3DoStep` end
/// at the first contact event in it. Event mode and intermediate update are not offered
/// (`hasEventMode`, `providesIntermediateUpdate` are false): asking for them is refused.
/// Returns NULL (after logging why) on any problem.
///
/// # Safety
/// String arguments are NULL or NUL-terminated; `required_intermediate_variables` holds
/// `n_required_intermediate_variables` value references.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn fmi3InstantiateCoSimulation(
    instance_name: fmi3String,
    instantiation_token: fmi3String,
    resource_path: fmi3String,
    _visible: fmi3Boolean,
    logging_on: fmi3Boolean,
    event_mode_used: fmi3Boolean,
    early_return_allowed: fmi3Boolean,
    _required_intermediate_variables: *const fmi3ValueReference,
    n_required_intermediate_variables: usize,
    instance_environment: fmi3InstanceEnvironment,
    log_message: fmi3LogMessageCallback,
    _intermediate_update: fmi3IntermediateUpdateCallback,
) -> fmi3Instance {
    let result = catch_unwind(AssertUnwindSafe(|| {
        let fail = |message: &str| {
            report(log_message, instance_environment, message);
            ptr::null_mut()
        };
        // SAFETY: string arguments are NULL or NUL-terminated (this function's contract).
        let (name, token, path) = unsafe {
            (
                string_arg(instance_name),
                string_arg(instantiation_token),
                string_arg(resource_path),
            )
        };
        let (Some(name), Some(token)) = (name, token) else {
            return fail("fmi3InstantiateCoSimulation: instanceName and instantiationToken must not be NULL");
        };
        let Some(path) = path else {
            return fail(
                "fmi3InstantiateCoSimulation: resourcePath is NULL, but the scene is in the FMU's resources folder",
            );
        };
        if event_mode_used {
            return fail("fmi3InstantiateCoSimulation: eventModeUsed is true, but this FMU has no event mode (hasEventMode is false)");
        }
        if n_required_intermediate_variables > 0 {
            return fail(&format!(
                "fmi3InstantiateCoSimulation: {n_required_intermediate_variables} required intermediate variables, but this FMU provides no intermediate update"
            ));
        }
        let args = InstantiateArgs {
            version: Version::Fmi3,
            function: "fmi3InstantiateCoSimulation",
            instance_name: &name,
            guid: &token,
            resource_location: &path,
            sink: sink(log_message, instance_environment),
            logging_on,
            early_return: early_return_allowed,
        };
        glue::instantiate(args, |message| report(log_message, instance_environment, message))
    }));
    result.unwrap_or(ptr::null_mut())
}

/// `fmi3FreeInstance`: frees everything the instance holds (allowed in every state). NULL, a
/// freed handle, an FMI 2.0 instance or any other value is ignored.
///
/// # Safety
/// No other thread uses `instance` during or after the call.
#[no_mangle]
pub unsafe extern "C" fn fmi3FreeInstance(instance: fmi3Instance) {
    // SAFETY: nothing uses the instance any more (this function's contract).
    unsafe { glue::free_instance(instance, Version::Fmi3) }
}

// ---------------------------------------------------------------------------------------
// Initialisation, termination, reset
// ---------------------------------------------------------------------------------------

/// `fmi3EnterInitializationMode`: the experiment's tolerance (it becomes `solver.rtol`), start
/// and stop time, as `fmi2SetupExperiment` takes them.
///
/// # Safety
/// See the module docs (only `instance`, which is looked up before use).
#[no_mangle]
pub unsafe extern "C" fn fmi3EnterInitializationMode(
    instance: fmi3Instance,
    tolerance_defined: fmi3Boolean,
    tolerance: fmi3Float64,
    start_time: fmi3Float64,
    stop_time_defined: fmi3Boolean,
    stop_time: fmi3Float64,
) -> fmi3Status {
    with(
        instance,
        "fmi3EnterInitializationMode",
        lifecycle::ENTER_INITIALIZATION_MODE,
        |inst| {
            let warning = inst.setup_experiment(
                tolerance_defined.then_some(tolerance),
                start_time,
                stop_time_defined.then_some(stop_time),
            )?;
            inst.enter_initialization_mode()?;
            Failure::warn_of(warning)
        },
    )
}

// ---------------------------------------------------------------------------------------
// Getting and setting values: Float64 (Real), Int32 (Integer), Int64 (Enumeration), Boolean
// ---------------------------------------------------------------------------------------

/// Exported functions that check their instance and state and forward to the instance or to
/// the bodies both FMI versions share (`crate::fmi::glue`): `fn name(arguments after the
/// instance) [lifecycle mask] |instance| body;`.
macro_rules! forward {
    ($($(#[$doc:meta])* fn $name:ident($($arg:ident: $ty:ty),*) [$mask:ident] |$inst:pat_param| $body:expr;)*) => {$(
        $(#[$doc])*
        #[no_mangle]
        pub unsafe extern "C" fn $name(instance: fmi3Instance, $($arg: $ty),*) -> fmi3Status {
            with(instance, stringify!($name), lifecycle::$mask, |$inst| $body)
        }
    )*};
}

forward! {
    /// `fmi3GetFloat64`
    ///
    /// # Safety
    /// `vr` holds `nvr` elements and `values` `n_values` writable ones.
    fn fmi3GetFloat64(vr: *const fmi3ValueReference, nvr: usize, values: *mut fmi3Float64, n_values: usize)
        [FMI3_GET_VALUES] |inst| unsafe {
            glue::get_values(inst, Access::Real, vr, nvr, values.cast(), n_values, |x: f64| x)
        };

    /// `fmi3SetFloat64`
    ///
    /// # Safety
    /// `vr` holds `nvr` elements and `values` `n_values`.
    fn fmi3SetFloat64(vr: *const fmi3ValueReference, nvr: usize, values: *const fmi3Float64, n_values: usize)
        [SET_VALUES] |inst| unsafe {
            glue::set_values(inst, Access::Real, vr, nvr, values.cast(), n_values, |x: f64| x)
        };

    /// `fmi3GetInt32`
    ///
    /// # Safety
    /// `vr` holds `nvr` elements and `values` `n_values` writable ones.
    fn fmi3GetInt32(vr: *const fmi3ValueReference, nvr: usize, values: *mut fmi3Int32, n_values: usize)
        [FMI3_GET_VALUES] |inst| unsafe {
            glue::get_values(inst, Access::Integer, vr, nvr, values.cast(), n_values, |x: f64| x.round() as i32)
        };

    /// `fmi3SetInt32`
    ///
    /// # Safety
    /// `vr` holds `nvr` elements and `values` `n_values`.
    fn fmi3SetInt32(vr: *const fmi3ValueReference, nvr: usize, values: *const fmi3Int32, n_values: usize)
        [SET_VALUES] |inst| unsafe {
            glue::set_values(inst, Access::Integer, vr, nvr, values.cast(), n_values, |x: i32| f64::from(x))
        };

    /// `fmi3GetInt64`
    ///
    /// # Safety
    /// `vr` holds `nvr` elements and `values` `n_values` writable ones.
    fn fmi3GetInt64(vr: *const fmi3ValueReference, nvr: usize, values: *mut fmi3Int64, n_values: usize)
        [FMI3_GET_VALUES] |inst| unsafe {
            glue::get_values(inst, Access::Int64, vr, nvr, values.cast(), n_values, |x: f64| x.round() as i64)
        };

    /// `fmi3SetInt64`
    ///
    /// # Safety
    /// `vr` holds `nvr` elements and `values` `n_values`.
    fn fmi3SetInt64(vr: *const fmi3ValueReference, nvr: usize, values: *const fmi3Int64, n_values: usize)
        [SET_VALUES] |inst| unsafe {
            glue::set_values(inst, Access::Int64, vr, nvr, values.cast(), n_values, |x: i64| x as f64)
        };

    /// `fmi3GetBoolean` (read and written as bytes: any nonzero byte is true)
    ///
    /// # Safety
    /// `vr` holds `nvr` elements and `values` `n_values` writable ones.
    fn fmi3GetBoolean(vr: *const fmi3ValueReference, nvr: usize, values: *mut fmi3Boolean, n_values: usize)
        [FMI3_GET_VALUES] |inst| unsafe {
            glue::get_values(inst, Access::Boolean, vr, nvr, values.cast(), n_values, |x: f64| byte(x != 0.0))
        };

    /// `fmi3SetBoolean` (read and written as bytes: any nonzero byte is true)
    ///
    /// # Safety
    /// `vr` holds `nvr` elements and `values` `n_values`.
    fn fmi3SetBoolean(vr: *const fmi3ValueReference, nvr: usize, values: *const fmi3Boolean, n_values: usize)
        [SET_VALUES] |inst| unsafe {
            glue::set_values(inst, Access::Boolean, vr, nvr, values.cast(), n_values, |b: u8| f64::from(byte(b != 0)))
        };
}

forward! {
    /// `fmi3ExitInitializationMode`: checks every parameter's range and compiles the model;
    /// the instance is then in Step Mode.
    ///
    /// # Safety
    /// See the module docs (only `instance`, which is looked up before use).
    fn fmi3ExitInitializationMode() [EXIT_INITIALIZATION_MODE] |inst| inst.exit_initialization_mode();

    /// `fmi3Terminate`
    ///
    /// # Safety
    /// See the module docs (only `instance`, which is looked up before use).
    fn fmi3Terminate() [TERMINATE] |inst| inst.terminate();

    /// `fmi3Reset`: back to the instantiated state with the start values.
    ///
    /// # Safety
    /// See the module docs (only `instance`, which is looked up before use).
    fn fmi3Reset() [RESET] |inst| inst.reset();

    /// `fmi3GetString` (this model has no String variables: only an empty list succeeds)
    ///
    /// # Safety
    /// `vr` holds `nvr` elements.
    fn fmi3GetString(vr: *const fmi3ValueReference, nvr: usize, _values: *mut fmi3String, _n_values: usize)
        [FMI3_GET_VALUES] |_| unsafe { glue::none_of("String", vr, nvr) };

    /// `fmi3SetString` (this model has no String variables: only an empty list succeeds)
    ///
    /// # Safety
    /// `vr` holds `nvr` elements.
    fn fmi3SetString(vr: *const fmi3ValueReference, nvr: usize, _values: *const fmi3String, _n_values: usize)
        [SET_VALUES] |_| unsafe { glue::none_of("String", vr, nvr) };

    /// `fmi3GetFMUState`: allocates a state when `*state` is NULL, otherwise overwrites it.
    ///
    /// # Safety
    /// `state` is NULL or valid for reading and writing one handle (looked up before use).
    fn fmi3GetFMUState(state: *mut fmi3FMUState) [FMU_STATE] |inst| {
        let saved = inst.save();
        // SAFETY: `state` points to NULL or to a live state (this function's contract).
        unsafe { glue::store_state(state, saved, inst) }
    };

    /// `fmi3SetFMUState`: restores a state of this FMU saved by an FMI 3.0 instance (an FMI
    /// 2.0 state is refused with a message).
    ///
    /// # Safety
    /// The host does not free `state` during the call (it is looked up before use).
    fn fmi3SetFMUState(state: fmi3FMUState) [FMU_STATE] |inst| unsafe { glue::set_state(inst, state) };

    /// `fmi3FreeFMUState`: frees `*state` (NULL is ignored) and sets it to NULL.
    ///
    /// # Safety
    /// `state` is NULL or valid for reading and writing one handle (looked up before use).
    fn fmi3FreeFMUState(state: *mut fmi3FMUState) [FMU_STATE] |_| unsafe { glue::free_state(state) };

    /// `fmi3SerializedFMUStateSize`
    ///
    /// # Safety
    /// `size` is NULL or writable (`state` is looked up before use).
    fn fmi3SerializedFMUStateSize(state: fmi3FMUState, size: *mut usize)
        [FMU_STATE] |_| unsafe { glue::serialized_size(state, size) };

    /// `fmi3SerializeFMUState`: the bytes of the one state format (docs/fmi.md, "FMU
    /// states"), marked as FMI 3.0's.
    ///
    /// # Safety
    /// `serialized` holds `size` writable bytes (`state` is looked up before use).
    fn fmi3SerializeFMUState(state: fmi3FMUState, serialized: *mut fmi3Byte, size: usize)
        [FMU_STATE] |_| unsafe { glue::serialize(state, serialized, size) };

    /// `fmi3DeserializeFMUState`: checks the bytes (format, checksum, model, FMI version) and
    /// allocates a state (or overwrites `*state` when it is not NULL).
    ///
    /// # Safety
    /// `serialized` holds `size` bytes; `state` is NULL or valid for reading and writing one
    /// handle (looked up before use).
    fn fmi3DeserializeFMUState(serialized: *const fmi3Byte, size: usize, state: *mut fmi3FMUState)
        [FMU_STATE] |inst| unsafe { glue::deserialize(inst, serialized, size, state) };
}

// ---------------------------------------------------------------------------------------
// Co-Simulation
// ---------------------------------------------------------------------------------------

/// `fmi3DoStep`: integrates from `current_communication_point` (the current time) to
/// `current_communication_point + communication_step_size`, or, when the instance was made
/// with `earlyReturnAllowed`, to the first contact event (touch, separation, impact, rest,
/// release) before that: then `*early_return` is true and `*last_successful_time` the event's
/// time, from which the host's next step goes on. A step that reaches `solver.max_steps`
/// integrator steps returns early too, with `fmi3Warning` (without early return it fails:
/// FMI 3.0 allows `fmi3Discard` only for an FMU left as it was before the call, which is one
/// that reached no further, see `Instance::do_step`).
/// `*last_successful_time` is the time reached after every call (also a failed one);
/// `*event_handling_needed` and `*terminate_simulation` are always false.
///
/// # Safety
/// The four output pointers are NULL (refused) or writable.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn fmi3DoStep(
    instance: fmi3Instance,
    current_communication_point: fmi3Float64,
    communication_step_size: fmi3Float64,
    _no_set_fmu_state_prior_to_current_point: fmi3Boolean,
    event_handling_needed: *mut fmi3Boolean,
    terminate_simulation: *mut fmi3Boolean,
    early_return: *mut fmi3Boolean,
    last_successful_time: *mut fmi3Float64,
) -> fmi3Status {
    with(instance, "fmi3DoStep", lifecycle::DO_STEP, |inst| {
        let outputs = [event_handling_needed, terminate_simulation, early_return];
        if outputs.iter().any(|p| p.is_null()) || last_successful_time.is_null() {
            return Err(Failure::error(
                "eventHandlingNeeded, terminateSimulation, earlyReturn and lastSuccessfulTime must not be NULL",
            ));
        }
        let result = inst.do_step(current_communication_point, communication_step_size);
        // (at a contact event, or, with a warning, at the step budget: see `Instance::do_step`)
        let stopped_early = match &result {
            Ok(at_event) => *at_event,
            Err(f) => f.status == crate::fmi::types::fmi2Status::fmi2Warning,
        };
        // SAFETY: the pointers are not NULL and writable (this function's contract); the
        // booleans are written as the bytes 0 and 1.
        unsafe {
            event_handling_needed.cast::<u8>().write(0);
            terminate_simulation.cast::<u8>().write(0);
            early_return.cast::<u8>().write(byte(stopped_early));
            last_successful_time.write(inst.time());
        }
        result.map(|_| ())
    })
}

/// `fmi3EnterStepMode`: only allowed in Event Mode, which this FMU does not have: always an
/// illegal call sequence (the instance is in Step Mode after `fmi3ExitInitializationMode`).
///
/// # Safety
/// See the module docs (only `instance`, which is looked up before use).
#[no_mangle]
pub unsafe extern "C" fn fmi3EnterStepMode(instance: fmi3Instance) -> fmi3Status {
    with(instance, "fmi3EnterStepMode", lifecycle::ENTER_STEP_MODE, |_| Ok(()))
}

/// The state-machine state of an FMI 3.0 instance, or `None` when `instance` is not a live
/// one (for tests).
///
/// # Safety
/// No other thread uses or frees `instance` during the call.
pub unsafe fn instance_state(instance: fmi3Instance) -> Option<LifeState> {
    // SAFETY: nothing else uses `instance` meanwhile (this function's contract).
    unsafe { lookup(instance) }.map(|i| i.state)
}
