//! The FMI 3.0 Co-Simulation interface: the `fmi3…` C functions, in the same library as the
//! `fmi2…` ones (docs/fmi3.md says why one library).
//!
//! Glue only, like the FMI 2.0 layer: the functions check handles, pointers and the calling
//! state and forward to the version-neutral [`crate::fmi::Instance`], which drives the
//! [`crate::simulation::Simulation`] facade. The state machine, the registries of live handles,
//! the saved states and their bytes are those of `crate::fmi`; what differs (the logger, the
//! value types, `fmi3DoStep`'s early return at contact events) is decided by the instance's
//! [`crate::fmi::lifecycle::Version`].
//!
//! - `types`: the C types of `fmi3PlatformTypes.h` and `fmi3FunctionTypes.h`.
//! - `exports`: instantiation, initialisation, values (Float64, Int32, Int64 for
//!   enumerations, Boolean), FMU states, `fmi3DoStep`.
//! - `unsupported`: the rest of the standard's functions, refused with a message.

pub mod exports;
pub mod types;
pub mod unsupported;

pub use types::fmi3Status;
