//! Setting values: parameters before initialisation (checked against their ranges when it
//! ends), tunable parameters between steps (the model compiled again, the data kept), inputs at
//! any time (a driven joint moved at once), and the parameters that follow another while they
//! keep their start value.

use super::{variable, Compiled, SimError, Simulation};
use crate::compile::{self, Parameters};
use crate::engine;
use crate::model::{Data, Model};
use crate::outputs;
use crate::scene::Scene;
use crate::variables::{set_parameter, Causality, VarRef, VarType, Variability, VariableTable};

impl Simulation {
    /// Sets a parameter (before initialisation; a tunable one also after it) or an input (at
    /// any time). The range of a parameter set before initialisation is checked by
    /// [`Simulation::initialize`], so that a host may set values in any order; a tunable one
    /// set after it is checked at once (see `Simulation::retune`).
    pub fn set(&mut self, vr: usize, value: f64) -> Result<(), SimError> {
        let var = variable(&self.table, vr)?;
        match var.causality {
            Causality::Parameter => {
                if self.initialized {
                    if var.variability == Variability::Tunable {
                        return self.retune(vr, value);
                    }
                    return Err(SimError::Variable(format!(
                        "{} is a fixed parameter and cannot change after initialisation (only the tunable \
                         contact-law constants can)",
                        var.name
                    )));
                }
                if self.values[vr] != value {
                    self.values[vr] = value;
                    self.compiled_fresh = false;
                }
                Ok(())
            }
            Causality::Input => {
                if !value.is_finite() {
                    return Err(SimError::Variable(format!(
                        "input {} must be finite (got {value})",
                        var.name
                    )));
                }
                let VarRef::Input(i) = var.target else {
                    self.values[vr] = value;
                    return Ok(());
                };
                let moves_a_drive = self
                    .compiled
                    .as_ref()
                    .is_some_and(|c| c.model.drives.iter().any(|dr| i == dr.value || i == dr.value + 1));
                if moves_a_drive && self.initialized {
                    // (the value is the host's once the joint moved: a refused move changes
                    // nothing, and the value and the model's input stay equal)
                    self.move_drive(i, value)?;
                } else if let Some(c) = self.compiled.as_mut() {
                    // (no settling: an input that moves no drive changes no state, and a
                    // changed value restarts the method, which settles first)
                    set_input(&c.model, &mut c.data, i, value);
                }
                self.values[vr] = value;
                Ok(())
            }
            _ => Err(SimError::Variable(format!(
                "{} is not a parameter or input and cannot be set",
                var.name
            ))),
        }
    }

    /// Sets a driven joint's coordinate or rate (input value `i`) of an initialised
    /// simulation: the joint moves there at once, and the energy that this changes (kinetic,
    /// potential, contact) counts as work of the inputs, so that the energy balance holds
    /// across the jump.
    pub(super) fn move_drive(&mut self, i: usize, value: f64) -> Result<(), SimError> {
        self.sync_islands()?;
        let Some(c) = self.compiled.as_mut().map(Compiled::settled) else {
            return Err(SimError::NotInitialized);
        };
        let before = outputs::energies(&c.model, &mut c.data).total();
        set_input(&c.model, &mut c.data, i, value);
        engine::follow_drives(&c.model, &mut c.data);
        let work = outputs::energies(&c.model, &mut c.data).total() - before;
        match c.islands.as_mut() {
            Some(is) => is.add_input_work(work),
            None => c.model.add_input_work(&mut c.data.state, work),
        }
        Ok(())
    }

    /// Changes the tunable parameter `vr` of an initialised simulation: checks the value
    /// against its range and together with the others, recompiles the model with it and keeps
    /// the data (state, contact memory, counters, time); the integrator restarts at the
    /// current state, so the value acts from the next step on. A refused value changes
    /// nothing. The energy watch's reference moves by the change of the balance the new
    /// value makes at this instant (a stiffer law stores more energy in a loaded contact).
    pub(super) fn retune(&mut self, vr: usize, value: f64) -> Result<(), SimError> {
        if self.values[vr] == value {
            return Ok(());
        }
        // the value it has (a parameter that follows another has the other's): nothing to
        // compile, and the method goes on undisturbed; it no longer follows
        if value.to_bits() == self.value(vr).to_bits() {
            self.values[vr] = value;
            return Ok(());
        }
        let before = if self.watch().started { self.balance()? } else { 0.0 };
        // the islands end here: the data first gets their candidate pairs and memory
        self.sync_islands()?;
        let old = std::mem::replace(&mut self.values[vr], value);
        // the contact groups keep their candidate pairs (the data's contact memory is theirs)
        let candidates = self.running()?.data.candidates.clone();
        let compiled = self.check_parameter(vr).and_then(|()| {
            Ok(compile::compile_with_candidates(
                &self.scene,
                &self.parameters(),
                &self.origin,
                Some(&candidates),
            )?)
        });
        let kept = self.running()?;
        let model = match compiled {
            Ok((model, _)) if same_layout(&model, &kept.model, &kept.data) => model,
            Ok(_) => {
                self.values[vr] = old;
                return Err(SimError::Variable(format!(
                    "{} cannot change after initialisation: it changes the size of the state",
                    self.table.vars[vr].name
                )));
            }
            Err(e) => {
                self.values[vr] = old;
                return Err(e);
            }
        };
        let c = self.running()?;
        c.model = model;
        c.data.take_contacts(&c.model);
        c.direct_reads.0.clear();
        // the islands are formed again, with the new value, at the next step
        c.islands = None;
        c.data.partition.clear();
        c.data.outputs_valid = false;
        c.data.kinematics_valid = false;
        // the right-hand side changed: the method restarts at the current state, with the
        // step size it would have tried next
        c.data.solver.next_h = c.data.solver.pending_step();
        c.data.solver.started = false;
        if self.watch().started {
            let after = self.balance()?;
            self.running()?.data.energy_watch.reference += after - before;
        }
        Ok(())
    }

    /// Sets a variable by name (CLI `--set NAME=VALUE`).
    pub fn set_by_name(&mut self, name: &str, value: f64) -> Result<(), SimError> {
        let vr = self
            .table
            .index_of(name)
            .ok_or_else(|| SimError::Variable(format!("unknown variable {name:?}")))?;
        self.set(vr, value)
    }

    /// The value of parameter or input `vr`: the value set, except that a
    /// `<contact>.max_penetration` that keeps its start value (the scene gives none) is the
    /// current `<contact>.radius`.
    pub(super) fn value(&self, vr: usize) -> f64 {
        match self.follows[vr] {
            Some(leader) if self.values[vr].to_bits() == self.start(vr).to_bits() => self.value(leader),
            _ => self.values[vr],
        }
    }

    /// The start value of variable `vr` (0 for outputs).
    pub(super) fn start(&self, vr: usize) -> f64 {
        self.table.vars[vr].start.unwrap_or(0.0)
    }

    /// The current parameter values (and input start values), as the compiler reads them.
    pub fn parameters(&self) -> Parameters {
        let mut p = Parameters::of_scene(&self.scene);
        for (vr, var) in self.table.vars.iter().enumerate() {
            if matches!(var.causality, Causality::Parameter | Causality::Input) {
                set_parameter(&mut p, var.target, self.value(vr));
            }
        }
        p
    }

    /// Checks every parameter against its range; the message names the variable and range.
    pub fn check_parameters(&self) -> Result<(), SimError> {
        (0..self.table.vars.len()).try_for_each(|vr| self.check_parameter(vr))
    }

    /// Checks parameter `vr` against its range (other variables pass).
    pub(super) fn check_parameter(&self, vr: usize) -> Result<(), SimError> {
        let var = &self.table.vars[vr];
        if var.causality != Causality::Parameter {
            return Ok(());
        }
        let x = self.values[vr];
        if let Some(r) = var.range {
            let integral = matches!(var.vtype, VarType::Integer | VarType::Enumeration(_));
            if !r.contains(x) || (integral && x.fract() != 0.0) {
                return Err(SimError::Variable(format!(
                    "parameter {} = {} is out of its allowed range {}",
                    var.name,
                    crate::scene::short(x),
                    r.describe()
                )));
            }
        }
        Ok(())
    }
}

/// By value reference: the parameter each one follows while it keeps its start value (one pass
/// over the table): a contact's `max_penetration` its `radius`, and its `static_friction` its
/// `friction`, where the scene gives no such key; a group pair's `static_friction` its
/// `friction`, likewise.
pub(super) fn follows(scene: &Scene, table: &VariableTable) -> Vec<Option<usize>> {
    use crate::variables::LawKey::{Friction, MaxPenetration, StaticFriction};
    let reference: std::collections::HashMap<VarRef, usize> = table
        .vars
        .iter()
        .enumerate()
        .map(|(vr, var)| (var.target, vr))
        .collect();
    let mut follows = vec![None; table.vars.len()];
    let mut follow = |follower: VarRef, leader: VarRef| {
        if let (Some(&f), Some(&l)) = (reference.get(&follower), reference.get(&leader)) {
            follows[f] = Some(l);
        }
    };
    for (i, c) in scene.contact.iter().enumerate() {
        if c.max_penetration.is_none() {
            follow(VarRef::Contact(i, MaxPenetration), VarRef::SphereRadius(i));
        }
        if c.static_friction.is_none() {
            follow(VarRef::Contact(i, StaticFriction), VarRef::Contact(i, Friction));
        }
    }
    for (p, g) in scene.contact_group.iter().enumerate() {
        if g.static_friction.is_none() {
            follow(VarRef::Group(p, StaticFriction), VarRef::Group(p, Friction));
        }
    }
    follows
}

/// True when the data `d` of model `b` serves model `a` as well, `a` compiled for the data's
/// candidate pairs: the same coordinates, fixed constraint rows, and contacts with the same
/// laws as the data's list (what a tunable parameter may not change; the data's list, not
/// `b`'s initial one, which the broad phase left behind).
pub(super) fn same_layout(a: &Model, b: &Model, d: &Data) -> bool {
    a.nq == b.nq
        && a.nv == b.nv
        && a.fixed_rows() == b.fixed_rows()
        && a.initial_contacts.len() == d.contacts.len()
        && a.initial_contacts.iter().zip(&d.contacts).all(|(x, y)| x.law == y.law)
}

/// Sets input value `i`; the integrator restarts at the next advance (inputs are piecewise
/// constant between communication points). A driven joint's coordinate or rate (`<drive>.q`,
/// `<drive>.qd`) also moves the joint to it, every time it is set (its motion then goes on from
/// there: `q + qd τ + qdd τ²/2`).
pub(super) fn set_input(m: &Model, d: &mut Data, i: usize, value: f64) {
    let mut changed = d.inputs[i] != value;
    d.inputs[i] = value;
    for dr in &m.drives {
        let at = if i == dr.value {
            dr.qpos
        } else if i == dr.value + 1 {
            m.nq + dr.qvel
        } else {
            continue;
        };
        if d.state[at] != value {
            d.state[at] = value;
            changed = true;
        }
    }
    if changed {
        d.outputs_valid = false;
        d.kinematics_valid = false;
        // the right-hand side changed: the method restarts at the current state
        d.solver.started = false;
    }
}
