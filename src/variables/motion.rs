//! The variables of motion inputs (`joint_motion`): three inputs each, the drive force, and
//! the input work.

use super::*;

/// The three inputs of a `joint_motion` input `inp` whose values start at `first` among the
/// inputs' values: `<name>.q`, `<name>.qd`, `<name>.qdd`.
pub(super) fn motion_inputs(
    scene: &Scene,
    inp: &crate::scene::InputSpec,
    first: usize,
    start: &[f64],
) -> Vec<Variable> {
    let joint = inp.joint.clone().unwrap_or_default();
    let revolute = scene
        .joint
        .iter()
        .any(|j| j.name == joint && j.kind == JointType::Revolute);
    let units: [&'static str; 3] = if revolute {
        ["rad", "rad/s", "rad/s2"]
    } else {
        ["m", "m/s", "m/s2"]
    };
    let what = [
        format!(
            "coordinate of joint '{joint}' set at the start of the communication step (0: the scene's \
             configuration); setting it moves the joint there at once"
        ),
        format!(
            "rate of joint '{joint}' at the start of the communication step; setting it sets the joint's rate \
             at once (a host that sets only the coordinate gets zero rate)"
        ),
        format!("acceleration of joint '{joint}' over the communication step: the joint follows q + qd t + qdd t^2/2"),
    ];
    (0..3)
        .map(|k| Variable {
            name: format!("{}.{}", inp.name, ["q", "qd", "qdd"][k]),
            vtype: VarType::Real,
            causality: Causality::Input,
            variability: Variability::Continuous,
            start: Some(start[first + k]),
            unit: Some(units[k]),
            display_unit: None,
            description: what[k].clone(),
            range: None,
            target: VarRef::Input(first + k),
            depends_on_inputs: false,
        })
        .collect()
}

/// The outputs added with motion inputs and input work, after every other variable (so that
/// no value reference of an earlier scene moves): `energy.input_work`, and per `joint_motion`
/// input its drive force `<name>.force`.
pub(super) fn motion_outputs(scene: &Scene, v: &mut Vec<Variable>) {
    v.push(output_variable(
        "energy.input_work".into(),
        VarType::Real,
        Some("J"),
        VarRef::EnergyInputWork,
        "work done on the system by every input since initialisation (forces, torques, joint forces, drives): \
         energy.total + energy.dissipated - energy.input_work stays at its initial value"
            .into(),
        false,
    ));
    for (k, inp) in scene
        .input
        .iter()
        .filter(|i| i.kind == InputType::JointMotion)
        .enumerate()
    {
        let joint = inp.joint.clone().unwrap_or_default();
        let revolute = scene
            .joint
            .iter()
            .any(|j| j.name == joint && j.kind == JointType::Revolute);
        let (unit, what) = if revolute {
            ("N.m", "torque the drive exerts on the child body about the axis")
        } else {
            ("N", "force the drive exerts on the child body along the axis")
        };
        v.push(output_variable(
            format!("{}.force", inp.name),
            VarType::Real,
            Some(unit),
            VarRef::DriveForce(k),
            format!("generalised {what} of joint '{joint}' (what an actuator supplies to follow the motion)"),
            true,
        ));
    }
}
