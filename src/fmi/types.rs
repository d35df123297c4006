//! The C types of the FMI 2.0 interface (`fmi2TypesPlatform.h`, `fmi2FunctionTypes.h`).

#![allow(non_camel_case_types)]

use std::os::raw::{c_char, c_double, c_int, c_uint, c_void};

/// `fmi2Component`: an opaque pointer to one instance.
pub type fmi2Component = *mut c_void;
/// `fmi2ComponentEnvironment`: the host's pointer, handed back to the logger unchanged.
pub type fmi2ComponentEnvironment = *mut c_void;
/// `fmi2FMUstate`: an opaque pointer to a saved state.
pub type fmi2FMUstate = *mut c_void;
/// `fmi2ValueReference`: a C `unsigned int`.
pub type fmi2ValueReference = c_uint;
/// `fmi2Real`
pub type fmi2Real = c_double;
/// `fmi2Integer`
pub type fmi2Integer = c_int;
/// `fmi2Boolean`: a C `int`, 0 or 1.
pub type fmi2Boolean = c_int;
/// `fmi2Char`
pub type fmi2Char = c_char;
/// `fmi2String`: a NUL-terminated UTF-8 string.
pub type fmi2String = *const c_char;
/// `fmi2Byte`
pub type fmi2Byte = c_char;

/// `fmi2True`
pub const FMI2_TRUE: fmi2Boolean = 1;
/// `fmi2False`
pub const FMI2_FALSE: fmi2Boolean = 0;

/// `fmi2Type` value of Model Exchange.
pub const FMI2_MODEL_EXCHANGE: c_int = 0;
/// `fmi2Type` value of Co-Simulation.
pub const FMI2_CO_SIMULATION: c_int = 1;

/// Declares the status enum of an FMI version: the five statuses both versions share, under
/// that version's names (`fmi_status!(fmi3Status: fmi3OK, fmi3Warning, fmi3Discard,
/// fmi3Error, fmi3Fatal)`), then the version's own ones.
macro_rules! fmi_status {
    ($(#[$meta:meta])* $name:ident: $ok:ident, $warning:ident, $discard:ident, $error:ident, $fatal:ident $(, $($own:tt)*)?) => {
        $(#[$meta])*
        ///
        /// Only ever produced by this library, so a Rust enum is safe to return.
        #[repr(C)]
        #[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
        pub enum $name {
            /// All well.
            $ok = 0,
            /// Something questionable happened; the call did its job.
            $warning = 1,
            /// The step was not completed.
            $discard = 2,
            /// This instance cannot continue (free, reset or restore a state).
            $error = 3,
            /// No instance can continue.
            $fatal = 4,
            $($($own)*)?
        }
    };
}
pub(crate) use fmi_status;

fmi_status!(
    /// `fmi2Status`.
    fmi2Status: fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal,
    /// Asynchronous step still running (never used here).
    fmi2Pending = 5,
);

/// `fmi2StatusKind` values (received as a plain `int`, never transmuted).
pub mod status_kind {
    use std::os::raw::c_int;
    /// `fmi2DoStepStatus`
    pub const DO_STEP_STATUS: c_int = 0;
    /// `fmi2PendingStatus`
    pub const PENDING_STATUS: c_int = 1;
    /// `fmi2LastSuccessfulTime`
    pub const LAST_SUCCESSFUL_TIME: c_int = 2;
    /// `fmi2Terminated`
    pub const TERMINATED: c_int = 3;
}

/// `fmi2CallbackLogger`: variadic; `message` is a printf format. This library always passes
/// `"%s"` with the text as the one argument, so a `%` in a message is harmless.
pub type fmi2CallbackLogger = Option<
    unsafe extern "C" fn(
        component_environment: fmi2ComponentEnvironment,
        instance_name: fmi2String,
        status: c_int,
        category: fmi2String,
        message: fmi2String,
        ...
    ),
>;

/// `fmi2CallbackAllocateMemory` (unused: the model description declares
/// `canNotUseMemoryManagementFunctions="true"`).
pub type fmi2CallbackAllocateMemory = Option<unsafe extern "C" fn(nobj: usize, size: usize) -> *mut c_void>;

/// `fmi2CallbackFreeMemory` (unused, see above).
pub type fmi2CallbackFreeMemory = Option<unsafe extern "C" fn(obj: *mut c_void)>;

/// `fmi2StepFinished` (unused: `fmi2DoStep` never returns `fmi2Pending`).
pub type fmi2StepFinished = Option<unsafe extern "C" fn(env: fmi2ComponentEnvironment, status: c_int)>;

/// `fmi2CallbackFunctions`: valid only during `fmi2Instantiate`; the instance copies it.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct fmi2CallbackFunctions {
    /// Logger (may be NULL: then nothing is logged).
    pub logger: fmi2CallbackLogger,
    /// Allocator (ignored).
    pub allocate_memory: fmi2CallbackAllocateMemory,
    /// Deallocator (ignored).
    pub free_memory: fmi2CallbackFreeMemory,
    /// Asynchronous step callback (ignored).
    pub step_finished: fmi2StepFinished,
    /// Handed back to the logger unchanged.
    pub component_environment: fmi2ComponentEnvironment,
}

impl Default for fmi2CallbackFunctions {
    /// No callbacks at all (a host that wants no log).
    fn default() -> Self {
        fmi2CallbackFunctions {
            logger: None,
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: std::ptr::null_mut(),
        }
    }
}
