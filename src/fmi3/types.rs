//! The C types of the FMI 3.0 interface (`fmi3PlatformTypes.h`, `fmi3FunctionTypes.h`), for
//! the functions this library exports. (Why they are declared here rather than taken from a
//! binding crate: docs/fmi3.md, "The C declarations".)

#![allow(non_camel_case_types)]

use crate::fmi::types::{fmi2Status, fmi_status};
use std::os::raw::{c_char, c_void};

/// Declares type aliases, each documented with its C name.
macro_rules! c_types {
    ($($name:ident = $ty:ty),* $(,)?) => {$(
        #[doc = concat!("`", stringify!($name), "`")]
        pub type $name = $ty;
    )*};
}

// `fmi3Instance`, `fmi3InstanceEnvironment` (the host's pointer, handed back to the logger)
// and `fmi3FMUState` are opaque pointers; the numbers are C's fixed-width types.
c_types!(fmi3Instance = *mut c_void, fmi3InstanceEnvironment = *mut c_void, fmi3FMUState = *mut c_void);
c_types!(
    fmi3ValueReference = u32,
    fmi3Float32 = f32,
    fmi3Float64 = f64,
    fmi3Int8 = i8,
    fmi3UInt8 = u8
);
c_types!(
    fmi3Int16 = i16,
    fmi3UInt16 = u16,
    fmi3Int32 = i32,
    fmi3UInt32 = u32,
    fmi3Int64 = i64,
    fmi3UInt64 = u64
);
// `fmi3Boolean` and `fmi3Clock` are C's `bool` (one byte). Passed by value an `fmi3Boolean` is
// the host's C `bool` (0 or 1); arrays of it are read as bytes, any nonzero byte true, so that
// no byte a host writes is an invalid Rust `bool`. Strings are NUL-terminated UTF-8; a binary
// value is a pointer to bytes.
c_types!(fmi3Boolean = bool, fmi3Clock = bool, fmi3Char = c_char, fmi3String = *const c_char);
c_types!(fmi3Byte = u8, fmi3Binary = *const u8);

fmi_status!(
    /// `fmi3Status`.
    fmi3Status: fmi3OK, fmi3Warning, fmi3Discard, fmi3Error, fmi3Fatal
);

impl From<fmi2Status> for fmi3Status {
    /// The status of the same value (FMI 2.0's `fmi2Pending`, never produced, becomes an error).
    fn from(s: fmi2Status) -> fmi3Status {
        match s {
            fmi2Status::fmi2OK => fmi3Status::fmi3OK,
            fmi2Status::fmi2Warning => fmi3Status::fmi3Warning,
            fmi2Status::fmi2Discard => fmi3Status::fmi3Discard,
            fmi2Status::fmi2Error | fmi2Status::fmi2Pending => fmi3Status::fmi3Error,
            fmi2Status::fmi2Fatal => fmi3Status::fmi3Fatal,
        }
    }
}

/// `fmi3DependencyKind`, received and written as a plain `int` (never transmuted).
pub type fmi3DependencyKind = std::os::raw::c_int;

/// `fmi3IntervalQualifier`, as a plain `int`.
pub type fmi3IntervalQualifier = std::os::raw::c_int;

/// `fmi3LogMessageCallback`: not variadic (unlike FMI 2.0's logger); the message is plain
/// text.
pub type fmi3LogMessageCallback = Option<
    unsafe extern "C" fn(
        instance_environment: fmi3InstanceEnvironment,
        status: fmi3Status,
        category: fmi3String,
        message: fmi3String,
    ),
>;

/// `fmi3IntermediateUpdateCallback` (never called: `providesIntermediateUpdate` is false).
pub type fmi3IntermediateUpdateCallback = Option<
    unsafe extern "C" fn(
        instance_environment: fmi3InstanceEnvironment,
        intermediate_update_time: fmi3Float64,
        intermediate_variable_set_requested: fmi3Boolean,
        intermediate_variable_get_allowed: fmi3Boolean,
        intermediate_step_finished: fmi3Boolean,
        can_return_early: fmi3Boolean,
        early_return_requested: *mut fmi3Boolean,
        early_return_time: *mut fmi3Float64,
    ),
>;

/// `fmi3ClockUpdateCallback` (Scheduled Execution, not supported).
pub type fmi3ClockUpdateCallback = Option<unsafe extern "C" fn(instance_environment: fmi3InstanceEnvironment)>;

/// `fmi3LockPreemptionCallback` and `fmi3UnlockPreemptionCallback` (Scheduled Execution,
/// not supported).
pub type fmi3PreemptionCallback = Option<unsafe extern "C" fn()>;
