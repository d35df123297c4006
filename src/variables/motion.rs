//! The variables of motion inputs (`joint_motion`): three inputs each, the drive force, and
//! the input work.

use super::*;
use crate::union_find::UnionFind;

/// The kind of the joint a motion input drives (prismatic when it is not a revolute joint of the
/// scene: validation has refused anything else).
fn driven_kind(scene: &Scene, joint: &str) -> JointType {
    match scene.joint.iter().find(|j| j.name == joint) {
        Some(j) if j.kind == JointType::Revolute => JointType::Revolute,
        _ => JointType::Prismatic,
    }
}

/// The three inputs of a `joint_motion` input `inp` whose values start at `first` among the
/// inputs' values: `<name>.q`, `<name>.qd`, `<name>.qdd`.
pub(super) fn motion_inputs(
    scene: &Scene,
    inp: &crate::scene::InputSpec,
    first: usize,
    start: &[f64],
) -> Vec<Variable> {
    let joint = inp.joint.clone().unwrap_or_default();
    let units = joint_units(driven_kind(scene, &joint));
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
        let (unit, what) = if driven_kind(scene, &joint) == JointType::Revolute {
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

/// For every variable of `vars` (value-reference order), the inputs that move it at once: a
/// driven joint's `<drive>.q` and `<drive>.qd` move the bodies joined to its child by joints
/// (tree and loop joints: the rest of a loop follows), so they move those bodies' outputs,
/// their joints' coordinates and the contacts on them, the energies (but the dissipated
/// energy) and the contact groups' totals.
pub(super) fn moved_by(scene: &Scene, vars: &[Variable]) -> Vec<Vec<usize>> {
    let mut out = vec![Vec::new(); vars.len()];
    let drives: Vec<&crate::scene::InputSpec> = scene
        .input
        .iter()
        .filter(|i| i.kind == InputType::JointMotion)
        .collect();
    if drives.is_empty() {
        return out;
    }
    let body = scene.body_index();
    // the bodies joined by joints (the ground joins nothing)
    let mut sets = UnionFind::new(scene.body.len());
    for j in &scene.joint {
        sets.join(
            body.get(j.parent.as_str()).copied(),
            body.get(j.child.as_str()).copied(),
        );
    }
    let component = |name: &str, sets: &mut UnionFind| body.get(name).map(|&b| sets.root(b));
    // per drive: its component and the value references of its q and qd
    let mut moving = Vec::new();
    for d in &drives {
        let child = scene
            .joint
            .iter()
            .find(|j| Some(j.name.as_str()) == d.joint.as_deref())
            .map(|j| j.child.as_str())
            .unwrap_or_default();
        let refs: Vec<usize> = vars
            .iter()
            .enumerate()
            .filter(|(_, v)| {
                v.causality == Causality::Input
                    && (v.name == format!("{}.q", d.name) || v.name == format!("{}.qd", d.name))
            })
            .map(|(vr, _)| vr)
            .collect();
        moving.push((component(child, &mut sets), refs));
    }
    let all: Vec<usize> = moving.iter().flat_map(|(_, r)| r.iter().copied()).collect();
    let of_bodies = |bodies: &[Option<usize>], sets: &mut UnionFind| -> Vec<usize> {
        let comps: Vec<usize> = bodies.iter().flatten().map(|&b| sets.root(b)).collect();
        moving
            .iter()
            .filter(|(c, _)| c.is_some_and(|c| comps.contains(&c)))
            .flat_map(|(_, r)| r.iter().copied())
            .collect()
    };
    let scene_body = |name: &str| body.get(name).copied();
    for (vr, var) in vars.iter().enumerate() {
        if var.causality != Causality::Output {
            continue;
        }
        out[vr] = match var.target {
            VarRef::BodyPosition(b, _)
            | VarRef::BodyVelocity(b, _)
            | VarRef::BodyAngularVelocity(b, _)
            | VarRef::BodyQuaternion(b, _)
            | VarRef::BodyContactForce(b, _)
            | VarRef::BodyContactTorque(b, _) => of_bodies(&[Some(b)], &mut sets),
            VarRef::JointQ(j) | VarRef::JointQd(j) => {
                let child = scene.joint.get(j).and_then(|j| scene_body(&j.child));
                of_bodies(&[child], &mut sets)
            }
            VarRef::ContactDelta(i)
            | VarRef::ContactDeltaDot(i)
            | VarRef::ContactForce(i)
            | VarRef::ContactActive(i)
            | VarRef::ContactFrictionForce(i, _)
            | VarRef::ContactSlipVelocity(i) => {
                let c = &scene.contact[i];
                of_bodies(&[scene_body(&c.sphere_body), scene_body(&c.body)], &mut sets)
            }
            VarRef::EnergyKinetic
            | VarRef::EnergyPotential
            | VarRef::EnergyContact
            | VarRef::EnergyTotal
            | VarRef::EnergyInputWork
            | VarRef::GroupActive(_)
            | VarRef::GroupLargestPenetration(_) => all.clone(),
            _ => Vec::new(),
        };
    }
    out
}
