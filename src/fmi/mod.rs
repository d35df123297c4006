//! The FMI 2.0 Co-Simulation interface: the C functions a host such as fmpy calls, and the
//! version-neutral core that the FMI 3.0 layer (`crate::fmi3`) shares.
//!
//! This layer knows nothing of physics; it drives the [`crate::simulation::Simulation`]
//! facade. One library serves every exported scene: `fmi2Instantiate` reads the scene from
//! the FMU's `resources/scene.toml` and checks the host's GUID against the one derived from
//! that text (see [`crate::guid::guid`]). It does not depend on the exporter.
//!
//! - `types`: the C types of `fmi2TypesPlatform.h` and `fmi2FunctionTypes.h`.
//! - `lifecycle`: the state machine, one bit mask of allowed states per function.
//! - `instance`: one instance in safe Rust (values, steps, states).
//! - `log`: the log categories, the host's logger as a sink, a failed call's status and message.
//! - `saved`: `fmi2FMUstate` and its serialized bytes.
//! - `registry`: the live instance and state handles, checked before any is dereferenced.
//! - `uri`: decoding `fmuResourceLocation`.
//! - `glue`: what the C functions of both versions share (handles, panics, arrays, states).
//! - `exports`: the 34 `extern "C"` functions.

pub mod exports;
pub(crate) mod glue;
pub mod instance;
pub mod lifecycle;
pub mod log;
mod registry;
pub mod saved;
pub mod types;
pub mod uri;

pub use instance::Instance;
pub use log::LOG_CATEGORIES;
pub use types::fmi2Status;
