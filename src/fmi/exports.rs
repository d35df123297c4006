//! The 34 exported C functions of FMI 2.0 Co-Simulation (25 common, 9 co-simulation).
//!
//! Each one catches panics (`std::panic::catch_unwind`), checks its pointers and the calling
//! state (a bit mask per function, see `lifecycle`), and forwards to [`Instance`]. A component
//! or state handle is dereferenced only after `registry` has confirmed it is live, so NULL, a
//! freed handle or a garbage value gives `fmi2Error` (unlogged: there is no instance, hence no
//! logger) instead of a read of freed memory. The registries are the only globals; everything
//! an instance allocates is freed by `fmi2FreeInstance` (saved states by `fmi2FreeFMUstate`),
//! so a host may unload the library afterwards.
//!
//! Safety, for every function: `c` and `fmi2FMUstate` values may be anything (they are looked
//! up before use), but FMI 2.0's rule holds that one instance, and a state, is not used or
//! freed on two threads at once. Each function's `# Safety` names its other pointers.

#![allow(non_snake_case)]

use super::glue::{self, call, string_arg};
use super::instance::{Access, Instance, InstantiateArgs};
use super::lifecycle::{self, LifeState, Version};
use super::log::{fmi2_sink, log_raw, Failure};
use super::types::*;
use std::os::raw::{c_char, c_int};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::ptr;

/// Borrows the FMI 2.0 instance behind a component handle (see [`glue::instance`]).
///
/// # Safety
/// While the borrow lasts, no other thread uses or frees `c` (FMI 2.0: one instance is not
/// called concurrently).
unsafe fn instance<'a>(c: fmi2Component) -> Option<&'a mut Instance> {
    // SAFETY: this function's contract.
    unsafe { glue::instance(c, Version::Fmi2) }
}

/// Exported functions that look up their instance, check the calling state and forward to
/// the instance or to the bodies both FMI versions share (`glue`), as FMI 3.0's: `fn
/// name(arguments after the component) [lifecycle mask] |instance| body;`.
macro_rules! forward {
    ($($(#[$doc:meta])* fn $name:ident($($arg:ident: $ty:ty),* $(,)?) [$mask:ident] |$inst:pat_param| $body:expr;)*) => {$(
        $(#[$doc])*
        #[no_mangle]
        pub unsafe extern "C" fn $name(c: fmi2Component, $($arg: $ty),*) -> fmi2Status {
            // SAFETY: FMI 2.0: the host does not call or free `c` on another thread meanwhile.
            let found = unsafe { instance(c) };
            call(found, stringify!($name), lifecycle::$mask, |$inst| $body)
        }
    )*};
}

// ---------------------------------------------------------------------------------------
// Common functions
// ---------------------------------------------------------------------------------------

/// `fmi2GetTypesPlatform`: `"default"`.
#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

/// `fmi2GetVersion`: `"2.0"`.
#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

forward! {
    /// `fmi2SetDebugLogging`
    ///
    /// # Safety
    /// `categories` holds `n_categories` strings, each NULL or NUL-terminated.
    fn fmi2SetDebugLogging(logging_on: fmi2Boolean, n_categories: usize, categories: *const fmi2String)
        [SET_DEBUG_LOGGING] |inst| {
            // SAFETY: `categories` holds `n_categories` strings (this function's contract).
            unsafe { glue::set_debug_logging(inst, logging_on != FMI2_FALSE, n_categories, categories) }
        };
}

/// `fmi2Instantiate`: reads `<resources>/scene.toml`, checks the GUID, copies the callbacks
/// and strings. Returns NULL (after logging why) on any problem.
///
/// # Safety
/// FMI 2.0 calling conventions: string arguments are NULL or NUL-terminated, `functions`
/// is NULL or points to a callbacks struct.
#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: fmi2String,
    fmu_type: c_int,
    fmu_guid: fmi2String,
    fmu_resource_location: fmi2String,
    functions: *const fmi2CallbackFunctions,
    _visible: fmi2Boolean,
    logging_on: fmi2Boolean,
) -> fmi2Component {
    let result = catch_unwind(AssertUnwindSafe(|| {
        if functions.is_null() {
            return ptr::null_mut();
        }
        // SAFETY: `functions` is not NULL and points to a callbacks struct (this function's
        // contract); the struct is `Copy`.
        let callbacks = unsafe { *functions };
        // SAFETY: string arguments are NULL or NUL-terminated (this function's contract).
        let (name, guid, location) = unsafe {
            (
                string_arg(instance_name),
                string_arg(fmu_guid),
                string_arg(fmu_resource_location),
            )
        };
        let name = name.unwrap_or_default();
        let report = |message: &str| {
            let cname = std::ffi::CString::new(name.replace('\0', " ")).unwrap_or_default();
            log_raw(
                callbacks.logger,
                callbacks.component_environment,
                &cname,
                fmi2Status::fmi2Error,
                c"logStatusError",
                message,
            );
        };
        let (Some(guid), Some(location)) = (guid, location) else {
            report("fmi2Instantiate: fmuGUID and fmuResourceLocation must not be NULL");
            return ptr::null_mut();
        };
        if fmu_type != FMI2_CO_SIMULATION {
            report(&format!(
                "fmi2Instantiate: this FMU supports Co-Simulation only (fmuType = {fmu_type}, expected fmi2CoSimulation = {FMI2_CO_SIMULATION})"
            ));
            return ptr::null_mut();
        }
        let cname = std::ffi::CString::new(name.replace('\0', " ")).unwrap_or_default();
        let args = InstantiateArgs {
            version: Version::Fmi2,
            function: "fmi2Instantiate",
            instance_name: &name,
            guid: &guid,
            resource_location: &location,
            sink: fmi2_sink(callbacks.logger, callbacks.component_environment, &cname),
            logging_on: logging_on != FMI2_FALSE,
            early_return: false,
        };
        glue::instantiate(args, report)
    }));
    result.unwrap_or(ptr::null_mut())
}

/// `fmi2FreeInstance`: frees everything the instance holds (allowed in every state). NULL, a
/// handle freed before or any other value that is not a live instance is ignored.
///
/// # Safety
/// No other thread uses `c` during or after the call (FMI 2.0).
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: fmi2Component) {
    // SAFETY: nothing uses the instance any more (this function's contract).
    unsafe { glue::free_instance(c, Version::Fmi2) }
}

forward! {
    /// `fmi2SetupExperiment`
    ///
    /// # Safety
    /// See the module docs (only `c`, which is looked up before use).
    fn fmi2SetupExperiment(
        tolerance_defined: fmi2Boolean,
        tolerance: fmi2Real,
        start_time: fmi2Real,
        stop_time_defined: fmi2Boolean,
        stop_time: fmi2Real,
    )
        [SETUP_EXPERIMENT] |inst| {
            let warning = inst.setup_experiment(
                (tolerance_defined != FMI2_FALSE).then_some(tolerance),
                start_time,
                (stop_time_defined != FMI2_FALSE).then_some(stop_time),
            )?;
            Failure::warn_of(warning)
        };

    /// `fmi2EnterInitializationMode`
    ///
    /// # Safety
    /// See the module docs (only `c`, which is looked up before use).
    fn fmi2EnterInitializationMode() [ENTER_INITIALIZATION_MODE] |inst| inst.enter_initialization_mode();

    /// `fmi2ExitInitializationMode`: checks every parameter's range (the message names the
    /// variable) and compiles the model.
    ///
    /// # Safety
    /// See the module docs (only `c`, which is looked up before use).
    fn fmi2ExitInitializationMode() [EXIT_INITIALIZATION_MODE] |inst| inst.exit_initialization_mode();

    /// `fmi2Terminate`
    ///
    /// # Safety
    /// See the module docs (only `c`, which is looked up before use).
    fn fmi2Terminate() [TERMINATE] |inst| inst.terminate();

    /// `fmi2Reset`
    ///
    /// # Safety
    /// See the module docs (only `c`, which is looked up before use).
    fn fmi2Reset() [RESET] |inst| inst.reset();

    /// `fmi2GetReal`
    ///
    /// # Safety
    /// `vr` and `value` hold `nvr` elements.
    fn fmi2GetReal(vr: *const fmi2ValueReference, nvr: usize, value: *mut fmi2Real)
        [GET_VALUES] |inst| {
            // SAFETY: `vr` and `value` hold `nvr` elements (this function's contract).
            unsafe { glue::get_values(inst, Access::Real, vr, nvr, value, nvr, |x| x) }
        };

    /// `fmi2GetInteger` (Integer and enumeration variables)
    ///
    /// # Safety
    /// `vr` and `value` hold `nvr` elements.
    fn fmi2GetInteger(vr: *const fmi2ValueReference, nvr: usize, value: *mut fmi2Integer)
        [GET_VALUES] |inst| {
            // SAFETY: `vr` and `value` hold `nvr` elements (this function's contract).
            unsafe { glue::get_values(inst, Access::Integer, vr, nvr, value, nvr, |x| x.round() as fmi2Integer) }
        };

    /// `fmi2GetBoolean`
    ///
    /// # Safety
    /// `vr` and `value` hold `nvr` elements.
    fn fmi2GetBoolean(vr: *const fmi2ValueReference, nvr: usize, value: *mut fmi2Boolean)
        [GET_VALUES] |inst| {
            // SAFETY: `vr` and `value` hold `nvr` elements (this function's contract).
            unsafe {
                glue::get_values(inst, Access::Boolean, vr, nvr, value, nvr, |x| {
                    fmi2Boolean::from(x != 0.0)
                })
            }
        };

    /// `fmi2GetString` (this model has no String variables: only `nvr = 0` succeeds)
    ///
    /// # Safety
    /// `vr` and `value` hold `nvr` elements.
    fn fmi2GetString(vr: *const fmi2ValueReference, nvr: usize, _value: *mut fmi2String)
        [GET_VALUES] |_| {
            // SAFETY: `vr` holds `nvr` elements (this function's contract).
            unsafe { glue::none_of("String", vr, nvr) }
        };

    /// `fmi2SetReal`
    ///
    /// # Safety
    /// `vr` and `value` hold `nvr` elements.
    fn fmi2SetReal(vr: *const fmi2ValueReference, nvr: usize, value: *const fmi2Real)
        [SET_VALUES] |inst| {
            // SAFETY: `vr` and `value` hold `nvr` elements (this function's contract).
            unsafe { glue::set_values(inst, Access::Real, vr, nvr, value, nvr, |x| x) }
        };

    /// `fmi2SetInteger` (Integer and enumeration variables)
    ///
    /// # Safety
    /// `vr` and `value` hold `nvr` elements.
    fn fmi2SetInteger(vr: *const fmi2ValueReference, nvr: usize, value: *const fmi2Integer)
        [SET_VALUES] |inst| {
            // SAFETY: `vr` and `value` hold `nvr` elements (this function's contract).
            unsafe { glue::set_values(inst, Access::Integer, vr, nvr, value, nvr, f64::from) }
        };

    /// `fmi2SetBoolean`
    ///
    /// # Safety
    /// `vr` and `value` hold `nvr` elements.
    fn fmi2SetBoolean(vr: *const fmi2ValueReference, nvr: usize, value: *const fmi2Boolean)
        [SET_VALUES] |inst| {
            // SAFETY: `vr` and `value` hold `nvr` elements (this function's contract).
            unsafe {
                glue::set_values(inst, Access::Boolean, vr, nvr, value, nvr, |b| {
                    f64::from(u8::from(b != FMI2_FALSE))
                })
            }
        };

    /// `fmi2SetString` (this model has no String variables: only `nvr = 0` succeeds)
    ///
    /// # Safety
    /// `vr` and `value` hold `nvr` elements.
    fn fmi2SetString(vr: *const fmi2ValueReference, nvr: usize, _value: *const fmi2String)
        [SET_VALUES] |_| {
            // SAFETY: `vr` holds `nvr` elements (this function's contract).
            unsafe { glue::none_of("String", vr, nvr) }
        };

    /// `fmi2GetFMUstate`: allocates a state when `*state` is NULL, otherwise overwrites it.
    ///
    /// # Safety
    /// `state` is NULL or valid for reading and writing one handle (whose value is looked up
    /// before use).
    fn fmi2GetFMUstate(state: *mut fmi2FMUstate)
        [FMU_STATE] |inst| {
            let saved = inst.save();
            // SAFETY: `state` points to NULL or to a live state (this function's contract).
            unsafe { glue::store_state(state, saved, inst) }
        };

    /// `fmi2SetFMUstate`: copies the state into the instance (the state stays valid), including
    /// its lifecycle state, time and stop time.
    ///
    /// # Safety
    /// See the module docs (`state` is looked up before use).
    fn fmi2SetFMUstate(state: fmi2FMUstate)
        [FMU_STATE] |inst| {
            // SAFETY: the host does not free `state` during the call (FMI 2.0).
            unsafe { glue::set_state(inst, state) }
        };

    /// `fmi2FreeFMUstate`: frees `*state` (NULL is ignored) and sets it to NULL.
    ///
    /// # Safety
    /// `state` is NULL or valid for reading and writing one handle (whose value is looked up
    /// before use).
    fn fmi2FreeFMUstate(state: *mut fmi2FMUstate)
        [FMU_STATE] |_| {
            // SAFETY: `state` is NULL or a readable and writable handle (this function's contract);
            // no other thread uses it (FMI 2.0).
            unsafe { glue::free_state(state) }
        };

    /// `fmi2SerializedFMUstateSize`
    ///
    /// # Safety
    /// `size` is NULL or writable (`state` is looked up before use).
    fn fmi2SerializedFMUstateSize(state: fmi2FMUstate, size: *mut usize)
        [FMU_STATE] |_| {
            // SAFETY: `size` is NULL or writable; the host does not free `state` during the call.
            unsafe { glue::serialized_size(state, size) }
        };

    /// `fmi2SerializeFMUstate`: writes exactly `fmi2SerializedFMUstateSize` bytes.
    ///
    /// # Safety
    /// `serialized` holds `size` writable bytes (`state` is looked up before use).
    fn fmi2SerializeFMUstate(state: fmi2FMUstate, serialized: *mut fmi2Byte, size: usize)
        [FMU_STATE] |_| {
            // SAFETY: `serialized` holds `size` writable bytes; the host does not free `state`.
            unsafe { glue::serialize(state, serialized as *mut u8, size) }
        };

    /// `fmi2DeSerializeFMUstate`: checks magic, version and length, then allocates a state (or
    /// overwrites `*state` when it is not NULL).
    ///
    /// # Safety
    /// `serialized` holds `size` bytes; `state` is NULL or valid for reading and writing one
    /// handle (whose value is looked up before use).
    fn fmi2DeSerializeFMUstate(serialized: *const fmi2Byte, size: usize, state: *mut fmi2FMUstate)
        [FMU_STATE] |inst| {
            // SAFETY: `serialized` holds `size` bytes; `state` is NULL or a valid handle slot.
            unsafe { glue::deserialize(inst, serialized as *const u8, size, state) }
        };

    /// `fmi2GetDirectionalDerivative`: not supported (`providesDirectionalDerivative` is false).
    ///
    /// # Safety
    /// See the module docs (only `c`, which is looked up before use).
    fn fmi2GetDirectionalDerivative(
        _v_unknown_ref: *const fmi2ValueReference,
        _n_unknown: usize,
        _v_known_ref: *const fmi2ValueReference,
        _n_known: usize,
        _dv_known: *const fmi2Real,
        _dv_unknown: *mut fmi2Real,
    )
        [GET_DIRECTIONAL_DERIVATIVE] |_| Err(Failure::error("not supported (providesDirectionalDerivative is false)"));
}

// ---------------------------------------------------------------------------------------
// Co-simulation functions
// ---------------------------------------------------------------------------------------

forward! {
    /// `fmi2SetRealInputDerivatives`: not supported (`canInterpolateInputs` is false).
    ///
    /// # Safety
    /// See the module docs (only `c`, which is looked up before use).
    fn fmi2SetRealInputDerivatives(
        _vr: *const fmi2ValueReference,
        _nvr: usize,
        _order: *const fmi2Integer,
        _value: *const fmi2Real,
    )
        [SET_REAL_INPUT_DERIVATIVES] |_| Err(Failure::error("not supported (canInterpolateInputs is false)"));

    /// `fmi2GetRealOutputDerivatives`: not supported (`maxOutputDerivativeOrder` is 0).
    ///
    /// # Safety
    /// See the module docs (only `c`, which is looked up before use).
    fn fmi2GetRealOutputDerivatives(
        _vr: *const fmi2ValueReference,
        _nvr: usize,
        _order: *const fmi2Integer,
        _value: *mut fmi2Real,
    )
        [GET_REAL_OUTPUT_DERIVATIVES] |_| Err(Failure::error("not supported (maxOutputDerivativeOrder is 0)"));

    /// `fmi2DoStep`: integrates from `current_communication_point` (which must be the current
    /// time) to exactly `current_communication_point + communication_step_size`.
    ///
    /// # Safety
    /// See the module docs (only `c`, which is looked up before use).
    fn fmi2DoStep(
        current_communication_point: fmi2Real,
        communication_step_size: fmi2Real,
        _no_set_fmu_state_prior_to_current_point: fmi2Boolean,
    )
        [DO_STEP] |inst| {
            inst.do_step(current_communication_point, communication_step_size)
                .map(|_| ())
        };

    /// `fmi2CancelStep`: never allowed, since `fmi2DoStep` never returns `fmi2Pending`.
    ///
    /// # Safety
    /// See the module docs (only `c`, which is looked up before use).
    fn fmi2CancelStep() [CANCEL_STEP] |_| Ok(());

    /// `fmi2GetStatus`: not supported (only meaningful after `fmi2Pending`, never returned).
    ///
    /// # Safety
    /// See the module docs (only `c`, which is looked up before use).
    fn fmi2GetStatus(_kind: c_int, _value: *mut c_int)
        [GET_STATUS] |_| {
            Err(Failure::discard(
                "not supported: fmi2DoStep is synchronous and never returns fmi2Pending",
            ))
        };

    /// `fmi2GetRealStatus`: answers `fmi2LastSuccessfulTime`.
    ///
    /// # Safety
    /// `value` is NULL or writable.
    fn fmi2GetRealStatus(kind: c_int, value: *mut fmi2Real)
        [GET_STATUS] |inst| {
            let x = inst.real_status(kind)?;
            // SAFETY: `value` is NULL or writable (this function's contract).
            let out = unsafe { glue::slice_mut(value, 1, "value") }?;
            out[0] = x;
            Ok(())
        };

    /// `fmi2GetIntegerStatus`: FMI 2.0 defines no Integer status; always `fmi2Discard` (the
    /// instance stays as it was).
    ///
    /// # Safety
    /// See the module docs (only `c`, which is looked up before use).
    fn fmi2GetIntegerStatus(kind: c_int, _value: *mut fmi2Integer)
        [GET_STATUS] |_| {
            Err(Failure::discard(format!("status kind {kind} has no Integer value")))
        };

    /// `fmi2GetBooleanStatus`: answers `fmi2Terminated`.
    ///
    /// # Safety
    /// `value` is NULL or writable.
    fn fmi2GetBooleanStatus(kind: c_int, value: *mut fmi2Boolean)
        [GET_STATUS] |inst| {
            let b = inst.boolean_status(kind)?;
            // SAFETY: `value` is NULL or writable (this function's contract).
            let out = unsafe { glue::slice_mut(value, 1, "value") }?;
            out[0] = if b { FMI2_TRUE } else { FMI2_FALSE };
            Ok(())
        };

    /// `fmi2GetStringStatus`: not supported (`fmi2PendingStatus` needs an asynchronous step).
    ///
    /// # Safety
    /// See the module docs (only `c`, which is looked up before use).
    fn fmi2GetStringStatus(kind: c_int, _value: *mut fmi2String)
        [GET_STATUS] |_| {
            Err(Failure::discard(format!(
                "not supported (status kind {kind}; fmi2PendingStatus needs an asynchronous step)"
            )))
        };
}

/// The state-machine state of an instance, or `None` when `c` is not a live instance (for
/// tests).
///
/// # Safety
/// No other thread uses or frees `c` during the call.
pub unsafe fn instance_state(c: fmi2Component) -> Option<LifeState> {
    // SAFETY: nothing else uses `c` meanwhile (this function's contract).
    unsafe { instance(c) }.map(|i| i.state)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ffi::CString;

    /// An instance of the bundled bouncing ball, unpacked into a temporary folder.
    fn instantiate(tag: &str) -> (fmi2Component, std::path::PathBuf) {
        let text =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/fmu/bouncing_ball/scene.toml")).unwrap();
        let dir = std::env::temp_dir().join(format!("contact-fmu-exports-{}-{tag}", std::process::id()));
        std::fs::create_dir_all(dir.join("resources")).unwrap();
        std::fs::write(dir.join("resources/scene.toml"), &text).unwrap();
        let uri = CString::new(format!("file://{}", dir.join("resources").display())).unwrap();
        let guid = CString::new(crate::guid::guid(&text)).unwrap();
        let callbacks = fmi2CallbackFunctions::default();
        // SAFETY: valid strings and callbacks for the duration of the call.
        let c = unsafe {
            fmi2Instantiate(
                c"panic".as_ptr(),
                FMI2_CO_SIMULATION,
                guid.as_ptr(),
                uri.as_ptr(),
                &callbacks,
                0,
                0,
            )
        };
        assert!(!c.is_null());
        (c, dir)
    }

    #[test]
    fn a_panic_inside_a_call_becomes_an_error_and_a_state_restore_recovers() {
        let (c, dir) = instantiate("panic");
        // SAFETY: `c` is a live instance; the state slot is valid.
        unsafe {
            assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), fmi2Status::fmi2OK);
            assert_eq!(fmi2EnterInitializationMode(c), fmi2Status::fmi2OK);
            assert_eq!(fmi2ExitInitializationMode(c), fmi2Status::fmi2OK);
            assert_eq!(fmi2DoStep(c, 0.0, 1e-3, 1), fmi2Status::fmi2OK);
            let mut state: fmi2FMUstate = ptr::null_mut();
            assert_eq!(fmi2GetFMUstate(c, &mut state), fmi2Status::fmi2OK);

            let status: fmi2Status = call(instance(c), "fmi2Test", lifecycle::ANY_BUT_FATAL, |_| {
                panic!("deliberate")
            });
            assert_eq!(status, fmi2Status::fmi2Error);
            assert_eq!(instance_state(c), Some(LifeState::Error));
            assert_eq!(
                fmi2DoStep(c, 1e-3, 1e-3, 1),
                fmi2Status::fmi2Error,
                "no stepping after an error"
            );

            assert_eq!(fmi2SetFMUstate(c, state), fmi2Status::fmi2OK);
            assert_eq!(instance_state(c), Some(LifeState::StepComplete));
            assert_eq!(fmi2DoStep(c, 1e-3, 1e-3, 1), fmi2Status::fmi2OK);
            assert_eq!(fmi2FreeFMUstate(c, &mut state), fmi2Status::fmi2OK);
            fmi2FreeInstance(c);
        }
        let _ = std::fs::remove_dir_all(dir);
    }
}
