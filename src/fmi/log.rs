//! What an instance logs and how its calls fail: the log categories of the model description,
//! the host's logger as a [`Sink`], and the [`Failure`] (status and message) a call returns.

use super::types::*;
use crate::simulation::SimError;
use std::ffi::{CStr, CString};
use std::os::raw::c_int;

/// The log categories declared in the model description: (name, description; the FMI 3.0
/// description says `fmi3` where this says `fmi2`).
pub const LOG_CATEGORIES: [(&CStr, &str); 6] = [
    (c"logEvents", "Instantiation, initialisation, reset, restored states"),
    (c"logStatusWarning", "Calls that return fmi2Warning"),
    (c"logStatusDiscard", "Calls that return fmi2Discard"),
    (
        c"logStatusError",
        "Calls that return fmi2Error (always logged unless disabled)",
    ),
    (
        c"logStatusFatal",
        "Calls that return fmi2Fatal (always logged unless disabled)",
    ),
    (c"logAll", "All of the above"),
];

pub(crate) const LOG_EVENTS: usize = 0;
pub(crate) const LOG_ALL: usize = 5;

/// The log category of a status.
pub(crate) fn category_of(status: fmi2Status) -> usize {
    match status {
        fmi2Status::fmi2OK | fmi2Status::fmi2Pending => LOG_EVENTS,
        fmi2Status::fmi2Warning => 1,
        fmi2Status::fmi2Discard => 2,
        fmi2Status::fmi2Error => 3,
        fmi2Status::fmi2Fatal => 4,
    }
}

/// A failed call: the status to return and the message to log.
#[derive(Debug, Clone, PartialEq)]
pub struct Failure {
    /// `fmi2Error` or `fmi2Fatal` (or a milder status).
    pub status: fmi2Status,
    /// What went wrong, for the log.
    pub message: String,
}

impl Failure {
    /// The result of a call that did what it was asked, with the `warning` (when there is one)
    /// of what was not quite as asked: `fmi2Warning`, logged, and the state does not change.
    pub fn warn_of(warning: Option<String>) -> FmiResult {
        match warning {
            Some(message) => Err(Failure {
                status: fmi2Status::fmi2Warning,
                message,
            }),
            None => Ok(()),
        }
    }

    /// An `fmi2Discard` with a message: what a status query answers that it cannot answer
    /// (FMI 2.0, co-simulation: "If a status is required which cannot be retrieved by the
    /// slave it returns fmi2Discard"); the instance stays as it was.
    pub fn discard(message: impl Into<String>) -> Failure {
        Failure {
            status: fmi2Status::fmi2Discard,
            message: message.into(),
        }
    }

    /// An `fmi2Error` with a message.
    pub fn error(message: impl Into<String>) -> Failure {
        Failure {
            status: fmi2Status::fmi2Error,
            message: message.into(),
        }
    }
}

impl From<SimError> for Failure {
    fn from(e: SimError) -> Failure {
        Failure::error(e.to_string())
    }
}

/// The result of an instance method.
pub type FmiResult<T = ()> = Result<T, Failure>;

/// Where an instance's messages go: the host's logger called with (status, category, text).
pub type Sink = Box<dyn Fn(fmi2Status, &CStr, &str)>;

/// The [`Sink`] of an FMI 2.0 logger (none when the host gave none).
pub fn fmi2_sink(logger: fmi2CallbackLogger, environment: fmi2ComponentEnvironment, name: &CStr) -> Option<Sink> {
    logger?;
    let name = name.to_owned();
    Some(Box::new(move |status, category, message| {
        log_raw(logger, environment, &name, status, category, message)
    }))
}

/// Sends one message through a host's logger, if there is one. The format string is always
/// `"%s"`, so the text may contain `%`; NUL bytes in it are replaced.
pub(crate) fn log_raw(
    logger: fmi2CallbackLogger,
    environment: fmi2ComponentEnvironment,
    instance_name: &CStr,
    status: fmi2Status,
    category: &CStr,
    message: &str,
) {
    let Some(logger) = logger else { return };
    let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
    // SAFETY: the logger is the host's function with the fmi2CallbackLogger signature; every
    // pointer passed is a valid NUL-terminated string that lives until the call returns.
    unsafe {
        logger(
            environment,
            instance_name.as_ptr(),
            status as c_int,
            category.as_ptr(),
            c"%s".as_ptr(),
            text.as_ptr(),
        );
    }
}
