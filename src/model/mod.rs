//! The model and its data, in the manner of MuJoCo's `mjModel`/`mjData`: a [`Model`]
//! compiled once and read-only afterwards (`compiled`), a [`Data`] holding everything that
//! changes (`data`; what it counts and logs: `log`), and the declaration of the part of the
//! data that a saved state holds (`state`, and `island_state` for a scene that runs as
//! independent islands; `partition`, which bodies and candidate pairs advance together).
//! Every function of the engine takes `(&Model, &mut Data)`.

pub mod compiled;
pub mod contact;
pub mod data;
pub mod groups;
pub mod island_state;
pub mod log;
pub mod partition;
pub mod state;
pub mod work;

pub use compiled::{
    nq_of, nv_of, quaternion_coordinates, step_rtol_powers, Body, Drive, FreeBody, Input, LoopConstraint, Model, Part,
    Plan, Rotor, SpringDamper, TreeJoint,
};
pub use data::Data;
pub use log::{ContactEvent, ContactEventKind, Counters, EnergyWatch};
