//! The integration tests, linked into one binary (one link of the library instead of one per
//! file): each file of this folder is a module, `common/` holds their shared helpers.
//!
//! `cargo test --release --test integration` runs them all; `cargo test --release --test
//! integration motion::` the tests of one file; `-- --nocapture` shows what they print.

#[path = "common/alloc_counter.rs"]
mod alloc_counter;
mod common;
#[path = "common/fmu_session.rs"]
mod fmu_session;

mod batch_read;
mod constant_rows;
mod contact;
mod contact_detection;
mod contact_groups;
mod contact_groups_as_contacts;
mod contact_impacts;
mod continuation;
mod early_return;
mod examples;
mod export_binaries;
mod fmi3_abi;
mod fmi_abi;
mod fmi_overflow;
mod fmi_shared_library;
mod fmi_threads;
mod friction;
mod islands;
mod kinematics_path;
mod model_description;
mod motion;
mod multibody;
mod multibody_joints;
mod multibody_loops;
mod no_alloc;
mod parameters;
mod regressions;
mod scene_builder;
mod scene_errors;
mod scene_fuzz;
mod scene_inputs;
mod snapshot;
mod sparse_linear;
mod state_property;
mod stress;
mod tunable;
