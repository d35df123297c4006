//! `[[input]]`: the FMU's real inputs (forces, torques, joint forces, joint motions).

use super::*;

/// Input types.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum InputType {
    /// Force on a body's centre of mass along a world direction \[N\].
    Force,
    /// Torque on a body about a world direction \[N m\].
    Torque,
    /// Generalised force on a 1-DOF joint \[N or N m\].
    JointForce,
    /// Prescribed motion of a 1-DOF tree joint: three inputs `<name>.q`, `<name>.qd`,
    /// `<name>.qdd` (coordinate, rate and acceleration at the start of the communication step;
    /// between communication points the joint follows `q + qd τ + qdd τ²/2`) and one output
    /// `<name>.force`, the generalised force the drive exerts.
    JointMotion,
}

impl InputSpec {
    /// How many input values this input takes: three for a `joint_motion` (coordinate, rate,
    /// acceleration), one otherwise.
    pub fn values(&self) -> usize {
        match self.kind {
            InputType::JointMotion => 3,
            _ => 1,
        }
    }

    /// The scene index of the joint this input names, by `joint_index`
    /// ([`Scene::joint_index`]); 0 when it names none (validation rejects that).
    pub(crate) fn joint_in(&self, joint_index: &HashMap<&str, usize>) -> usize {
        self.joint
            .as_deref()
            .and_then(|n| joint_index.get(n))
            .copied()
            .unwrap_or(0)
    }
}

impl Scene {
    /// The rate of a 1-DOF joint that the scene's body velocities give it at the initial
    /// configuration (rad/s about, or m/s along, its axis): the child's angular velocity
    /// relative to the parent's (revolute), or the child's centre-of-mass velocity relative to
    /// the parent's frame (prismatic), on the axis. 0 for other joints.
    pub fn joint_rate(&self, joint: &JointSpec) -> f64 {
        let v3 = |a: [f64; 3]| nalgebra::Vector3::new(a[0], a[1], a[2]);
        let motion = |name: &str| {
            self.body.iter().find(|b| b.name == name).map_or(
                (
                    nalgebra::Vector3::zeros(),
                    nalgebra::Vector3::zeros(),
                    nalgebra::Vector3::zeros(),
                ),
                |b| (v3(b.position), v3(b.velocity), v3(b.angular_velocity)),
            )
        };
        let axis = v3(joint.axis.unwrap_or([0.0, 0.0, 1.0]));
        let axis = if axis.norm() > 0.0 { axis.normalize() } else { axis };
        let (rp, vp, wp) = motion(&joint.parent);
        let (rc, vc, wc) = motion(&joint.child);
        match joint.kind {
            JointType::Revolute => (wc - wp).dot(&axis),
            JointType::Prismatic => (vc - vp - wp.cross(&(rc - rp))).dot(&axis),
            _ => 0.0,
        }
    }

    /// The start values of all inputs' values, in order: a `joint_motion`'s coordinate 0 (the
    /// scene's configuration), its joint's rate ([`Scene::joint_rate`]) and acceleration 0; the
    /// `start` of every other input.
    pub fn input_start_values(&self) -> Vec<f64> {
        let mut out = Vec::new();
        for i in &self.input {
            match i.kind {
                InputType::JointMotion => {
                    let rate = i
                        .joint
                        .as_deref()
                        .and_then(|n| self.joint.iter().find(|j| j.name == n))
                        .map_or(0.0, |j| self.joint_rate(j));
                    out.extend([0.0, rate, 0.0]);
                }
                _ => out.push(i.start),
            }
        }
        out
    }

    /// The index of each input's first value among all inputs' values (in scene order; a
    /// `joint_motion` takes three, [`InputSpec::values`]), and the number of values.
    pub fn input_values(&self) -> (Vec<usize>, usize) {
        let mut first = Vec::with_capacity(self.input.len());
        let mut n = 0;
        for i in &self.input {
            first.push(n);
            n += i.values();
        }
        (first, n)
    }
}

/// `[[input]]`
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct InputSpec {
    /// Name: the FMU input variable.
    pub name: String,
    /// Type.
    #[serde(rename = "type")]
    pub kind: InputType,
    /// Body (force, torque).
    pub body: Option<String>,
    /// Joint (joint_force).
    pub joint: Option<String>,
    /// Several joints (joint_force): the same generalised force on each (e.g. a brake torque
    /// on every wheel).
    pub joints: Option<Vec<String>>,
    /// World direction (force, torque).
    #[serde(default, deserialize_with = "crate::scene::exact::option_array")]
    pub direction: Option<[f64; 3]>,
    /// Start value.
    #[serde(default)]
    pub start: f64,
}
