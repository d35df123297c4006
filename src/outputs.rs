//! Outputs: the values of the FMU's output variables and calculated parameters, read from a
//! model's data in one place. The data is evaluated once at the current state when an
//! output is first read after a step ([`refresh`]); later reads cost nothing.
//!
//! [`evaluated`] and [`needs`] match every [`VarRef`] without a catch-all arm, so a variable
//! added to the table and not wired here does not compile.

use crate::contact;
use crate::dynamics;
use crate::forward::{evaluate_output_kinematics, evaluate_outputs};
use crate::kinematics::com_velocity;
use crate::model::{Data, Model};
use crate::variables::{LawKey, VarRef};
use nalgebra::Vector3;

/// The energies of the energy balance \[J\]: `total() + dissipated` stays at its initial value.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Energies {
    /// Kinetic energy.
    pub kinetic: f64,
    /// Potential energy of gravity and springs.
    pub potential: f64,
    /// Elastic energy stored in the contacts.
    pub contact: f64,
    /// Work removed by dampers, contact damping and impacts since initialisation.
    pub dissipated: f64,
    /// Work done on the system by the inputs since initialisation.
    pub input_work: f64,
}

impl Energies {
    /// Kinetic + potential + contact.
    pub fn total(&self) -> f64 {
        self.kinetic + self.potential + self.contact
    }

    /// The energy balance `total + dissipated − input_work`, which the equations of motion
    /// hold at its initial value.
    pub fn balance(&self) -> f64 {
        self.total() + self.dissipated - self.input_work
    }
}

/// Evaluates the data at the current state unless that was done since the state changed
/// (kinematics and contact forces: [`evaluate_outputs`]).
pub fn refresh(m: &Model, d: &mut Data) {
    if !d.outputs_valid {
        evaluate_outputs(m, d);
        if m.groups.is_active() {
            contact_totals(m, d);
        }
        d.outputs_valid = true;
        d.kinematics_valid = true;
    }
}

/// What reading a variable needs evaluated at the current state (ordered: each level
/// includes the ones before it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Needs {
    /// Nothing: a parameter, an input, a counter, a constant of the compiled model.
    Nothing,
    /// The bodies' positions, orientations (quaternions) and centre-of-mass velocities: the
    /// state itself for free bodies (their coordinates are these), the kinematics for the
    /// others.
    State,
    /// The bodies' kinematics (positions, orientations, velocities).
    Kinematics,
    /// Everything [`refresh`] evaluates (contact forces, energies, loop joints).
    Everything,
}

/// What reading `target` needs ([`prepare`]): the state for the bodies' positions,
/// orientations and centre-of-mass velocities (the kinematics of the bodies that are not
/// free), the kinematics for their angular velocities; nothing for the counters and the
/// compiled stiffness; a full
/// evaluation for every other output (and for anything added later that says otherwise
/// nowhere). Parameters and inputs are read from the settings and do not come here.
pub fn needs(target: VarRef) -> Needs {
    match target {
        VarRef::BodyPosition(..) | VarRef::BodyVelocity(..) | VarRef::BodyQuaternion(..) => Needs::State,
        VarRef::BodyAngularVelocity(..) => Needs::Kinematics,
        VarRef::SolverSteps | VarRef::SolverRhsEvals | VarRef::SolverEvents | VarRef::Contact(_, LawKey::Stiffness) => {
            Needs::Nothing
        }
        _ => Needs::Everything,
    }
}

/// Evaluates what a batch of reads `needs` at the current state, unless that was done since
/// the state changed; then [`evaluated`] gives each value.
pub fn prepare(m: &Model, d: &mut Data, needs: Needs) {
    match needs {
        Needs::Nothing => {}
        // every body free: its coordinates are what is read
        Needs::State if m.plan.general.bodies.is_empty() => {}
        Needs::State | Needs::Kinematics => {
            if !d.kinematics_valid {
                if evaluate_output_kinematics(m, d) {
                    d.kinematics_valid = true;
                } else {
                    refresh(m, d);
                }
            }
        }
        Needs::Everything => refresh(m, d),
    }
}

/// Reads outputs one after the other from data prepared for them ([`prepare`]), as
/// [`evaluated`] does, computing a body's centre-of-mass velocity once for its three
/// components (the same numbers).
#[derive(Debug, Default)]
pub struct Reader {
    /// The last body whose centre-of-mass velocity was computed, and that velocity.
    com: Option<(usize, Vector3<f64>)>,
}

impl Reader {
    /// [`evaluated`]`(m, d, target)`.
    #[inline]
    pub fn read(&mut self, m: &Model, d: &Data, target: VarRef) -> Option<f64> {
        if let VarRef::BodyVelocity(b, k) = target {
            if m.plan.free_body(b).is_some() {
                return evaluated(m, d, target);
            }
            let v = match self.com {
                Some((last, v)) if last == b => v,
                _ => {
                    let v = com_velocity(d, b);
                    self.com = Some((b, v));
                    v
                }
            };
            return Some(v[k]);
        }
        evaluated(m, d, target)
    }
}

/// The totals the contact-group outputs read: per body the contact force and torque (about
/// its centre of mass, world frame) of every contact, per group pair the number of contacts
/// in contact and their largest penetration.
fn contact_totals(m: &Model, d: &mut Data) {
    for w in d.body_contact.iter_mut() {
        *w = [0.0; 6];
    }
    for o in d.group_out.iter_mut() {
        *o = (0.0, 0.0);
    }
    for i in 0..d.contacts.len() {
        if !d.contact_memory[i].active {
            continue;
        }
        let c = &d.contacts[i];
        let out = d.contact_out[i];
        if let Some(k) = i.checked_sub(m.groups.n_explicit).map(|k| d.candidates[k]) {
            let o = &mut d.group_out[k.pair];
            o.0 += 1.0;
            o.1 = o.1.max(out.delta);
        }
        let g = contact::gap(d, i);
        let f = g.normal * out.force + out.friction_force;
        for (body, sign) in [(c.sphere_body, 1.0), (c.body, -1.0)] {
            if let Some(b) = body {
                let t = (g.point - d.body_pos[b]).cross(&f) * sign;
                let w = &mut d.body_contact[b];
                for k in 0..3 {
                    w[k] += sign * f[k];
                    w[3 + k] += t[k];
                }
            }
        }
    }
}

/// The energies at the current state.
pub fn energies(m: &Model, d: &mut Data) -> Energies {
    refresh(m, d);
    energies_evaluated(m, d)
}

/// The energies, from data evaluated at the current state ([`refresh`]).
fn energies_evaluated(m: &Model, d: &Data) -> Energies {
    Energies {
        kinetic: dynamics::kinetic_energy(m, d),
        potential: dynamics::potential_energy(m, d),
        contact: d.contact_out.iter().map(|o| o.elastic_energy).sum(),
        dissipated: d.state[m.dissipated_index()],
        input_work: m.input_work(&d.state),
    }
}

/// Largest loop-constraint (and resting-contact) residual |Φ| at the current state.
pub fn constraint_residual(m: &Model, d: &mut Data) -> f64 {
    refresh(m, d);
    if d.nc == 0 {
        return 0.0;
    }
    dynamics::constraints(m, d, contact::resting_rows);
    d.phi.iter().fold(0.0_f64, |a, b| a.max(b.abs()))
}

/// The value of an output or calculated parameter at the current state; `None` for the
/// variables whose value the host sets (parameters and inputs: the caller holds those).
pub fn output(m: &Model, d: &mut Data, target: VarRef) -> Option<f64> {
    refresh(m, d);
    evaluated(m, d, target)
}

/// The state slot an output reads as it is: a free body's centre-of-mass position or
/// velocity component (None for anything else).
pub fn state_slot(m: &Model, target: VarRef) -> Option<usize> {
    match target {
        VarRef::BodyPosition(b, k) => m.plan.free_body(b).map(|fb| fb.qpos + k),
        VarRef::BodyVelocity(b, k) => m.plan.free_body(b).map(|fb| m.nq + fb.qvel + k),
        _ => None,
    }
}

/// [`output`] from data prepared for it ([`prepare`] with at least [`needs`]`(target)`).
pub fn evaluated(m: &Model, d: &Data, target: VarRef) -> Option<f64> {
    let value = match target {
        VarRef::YoungsModulus(_)
        | VarRef::PoissonRatio(_)
        | VarRef::Mass(_)
        | VarRef::Inertia(..)
        | VarRef::SphereRadius(_)
        | VarRef::OtherRadius(_)
        | VarRef::PlaneSize(..)
        | VarRef::CylinderRadius(_)
        | VarRef::CylinderLength(_)
        | VarRef::SolverMethod
        | VarRef::SolverRtol
        | VarRef::SolverAtol
        | VarRef::SolverMaxStep
        | VarRef::SolverMaxSteps
        | VarRef::SpringStiffness(_)
        | VarRef::SpringDamping(_)
        | VarRef::SpringFreeLength(_)
        | VarRef::InitialVelocity(..)
        | VarRef::InitialAngularVelocity(..)
        | VarRef::Group(..)
        | VarRef::Input(_) => return None,
        // (a contact's law constants are parameters, but a stiffness the materials give)
        VarRef::Contact(i, LawKey::Stiffness) => d.contacts[i].stiffness,
        VarRef::Contact(..) => return None,
        // a free body's coordinates: its centre of mass, the quaternion (normalised as the
        // kinematics do), the centre-of-mass velocity
        VarRef::BodyPosition(b, k) => match state_slot(m, target) {
            Some(slot) => d.state[slot],
            None => d.body_pos[b][k],
        },
        VarRef::BodyVelocity(b, k) => match state_slot(m, target) {
            Some(slot) => d.state[slot],
            None => com_velocity(d, b)[k],
        },
        VarRef::BodyAngularVelocity(b, k) => d.body_vel[b].ang[k],
        VarRef::BodyQuaternion(b, k) => {
            let unit = match m.plan.free_body(b) {
                Some(fb) => crate::kinematics::quat_at(&d.state[fb.qpos + 3..fb.qpos + 7]),
                None => d.body_quat[b],
            };
            let q = unit.quaternion();
            [q.w, q.i, q.j, q.k][k]
        }
        VarRef::JointQ(j) | VarRef::JointQd(j) => {
            let (q, qd) = match m.scene_joint[j] {
                Ok(t) => {
                    let tj = &m.joints[t];
                    (d.state[tj.qpos], d.state[m.nq + tj.qvel])
                }
                Err(li) => dynamics::loop_joint_coordinate(m, d, li),
            };
            if matches!(target, VarRef::JointQ(_)) {
                q
            } else {
                qd
            }
        }
        VarRef::ContactDelta(i) => d.contact_out[i].delta,
        VarRef::ContactDeltaDot(i) => {
            if d.contact_memory[i].active {
                d.contact_out[i].delta_dot
            } else {
                0.0
            }
        }
        VarRef::ContactForce(i) => d.contact_out[i].force,
        VarRef::ContactActive(i) => d.contact_memory[i].active as u8 as f64,
        VarRef::ContactImpacts(i) => d.contact_memory[i].impacts as f64,
        VarRef::ContactFrictionForce(i, k) => d.contact_out[i].friction_force[k],
        VarRef::ContactSlipVelocity(i) => d.contact_out[i].slip_speed,
        VarRef::EnergyKinetic => energies_evaluated(m, d).kinetic,
        VarRef::EnergyPotential => energies_evaluated(m, d).potential,
        VarRef::EnergyContact => energies_evaluated(m, d).contact,
        VarRef::EnergyTotal => energies_evaluated(m, d).total(),
        VarRef::EnergyDissipated => energies_evaluated(m, d).dissipated,
        VarRef::EnergyInputWork => m.input_work(&d.state),
        VarRef::DriveForce(k) => dynamics::drive_force(m, d, k),
        VarRef::SolverSteps => d.counters.steps as f64,
        VarRef::SolverRhsEvals => d.counters.rhs_evals as f64,
        VarRef::SolverEvents => d.counters.events as f64,
        VarRef::BodyContactForce(b, k) => d.body_contact[b][k],
        VarRef::BodyContactTorque(b, k) => d.body_contact[b][3 + k],
        VarRef::GroupActive(p) => d.group_out[p].0,
        VarRef::GroupLargestPenetration(p) => d.group_out[p].1,
    };
    Some(value)
}
