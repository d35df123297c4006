//! contact-fmu: rigid multibody dynamics in joint coordinates with contact and impact,
//! shipped as FMI 2.0 Co-Simulation FMUs.
//!
//! The pipeline: a [`scene`] file is compiled by [`model`] into a read-only `Model` and a
//! mutable `Data`; [`dynamics`] evaluates the equations of motion, [`contact`] detects
//! contacts and computes their forces and impulses, an [`integrator`] advances the state and
//! the [`engine`] locates contact events between communication points. [`simulation`] is the
//! facade that both the FMI layer and the command line drive, through the variable table of
//! [`variables`].

pub mod bench;
pub mod contact;
pub mod dynamics;
pub mod engine;
pub mod export;
pub mod fmi;
pub mod integrator;
pub mod linalg;
pub mod model;
pub mod run;
pub mod scene;
pub mod scene_builder;
pub mod simulation;
pub mod spatial;
pub mod variables;
