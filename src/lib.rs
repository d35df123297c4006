//! contact-fmu: rigid multibody dynamics in joint coordinates with contact and impact,
//! shipped as FMI 2.0 Co-Simulation FMUs.
//!
//! The layers, bottom up (docs/architecture.md has the whole map):
//! - [`scene`] (the TOML scene), [`spatial`], [`linalg`], [`math`]: no physics state;
//! - [`integrator`]: the time-stepping methods behind one trait;
//! - [`model`]: the compiled, read-only `Model`, the mutable `Data` and the state spec;
//! - [`kinematics`], [`dynamics`], [`contact`], [`forward`] (the right-hand side pipeline);
//! - [`compile`] (scene → model and data), [`engine`] (the driver: steps, events, modes),
//!   [`islands`] (independent parts of a scene, each with its own engine);
//! - [`outputs`], [`checkpoint`], [`variables`], [`simulation`]: the facade that the FMI
//!   layer, the command line, the benchmarks and the tests all drive;
//! - [`fmi`], [`export`], [`run`], [`mod@bench`]: the hosts.
//! - [`guid`]: a scene's GUID and model hash, shared by the exporter and the FMI runtime.

// An unsafe operation inside an `unsafe fn` needs its own `unsafe {}` block, with a
// `// SAFETY:` comment saying why it holds.
#![deny(unsafe_op_in_unsafe_fn)]

#[macro_use]
mod named_enum;

pub mod bench;
pub mod checkpoint;
pub mod compile;
pub mod contact;
pub mod dynamics;
pub mod engine;
pub mod export;
pub mod fmi;
pub mod fmi3;
pub mod forward;
pub mod guid;
pub mod integrator;
pub mod islands;
pub mod kinematics;
pub mod linalg;
pub mod math;
pub mod model;
pub mod outputs;
pub mod run;
pub mod scene;
pub mod scene_builder;
pub mod simulation;
pub mod spatial;
pub mod union_find;
pub mod variables;
