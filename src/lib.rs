//! contact-fmu: rigid multibody dynamics in joint coordinates with contact and impact,
//! shipped as FMI 2.0 Co-Simulation FMUs.
//!
//! The pipeline: a [`scene`] file is compiled by [`model`] into a read-only `Model` and a
//! mutable `Data`; [`dynamics`] evaluates the equations of motion, [`contact`] detects
//! contacts and computes their forces and impulses, an [`integrator`] advances the state and
//! the [`engine`] locates contact events between communication points. [`simulation`] is the
//! facade that both the FMI layer and the command line drive, through the variable table of
//! [`variables`]. [`guid`] derives a scene's GUID and model hash, shared by the exporter
//! and the FMI runtime.

// An unsafe operation inside an `unsafe fn` needs its own `unsafe {}` block, with a
// `// SAFETY:` comment saying why it holds.
#![deny(unsafe_op_in_unsafe_fn)]

pub mod bench;
pub mod contact;
pub mod dynamics;
pub mod engine;
pub mod export;
pub mod fmi;
pub mod guid;
// The test-only counting allocator in `integrator` calls `System` without `unsafe {}` blocks;
// this exemption applies to test builds only and can go once those calls are wrapped.
#[cfg_attr(test, allow(unsafe_op_in_unsafe_fn))]
pub mod integrator;
pub mod linalg;
pub mod model;
pub mod run;
pub mod scene;
pub mod simulation;
pub mod spatial;
pub mod variables;
