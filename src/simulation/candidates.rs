//! Contact groups and islands seen from the facade: the model compiled again for new candidate
//! pairs (found again by the broad phase, or the islands'), with the data carried over.

use super::{Compiled, SimError, Simulation};
use crate::compile;
use crate::contact::groups;
use crate::engine;
use crate::model::state;

impl Simulation {
    /// With islands: when the islands' candidate pairs changed since the model was compiled,
    /// compiles it with theirs and gives its data their contact memory (done when something
    /// reads the contacts, not at every communication point).
    pub(super) fn sync_islands(&mut self) -> Result<(), SimError> {
        let (scene, origin) = (&self.scene, &self.origin);
        let Some(Compiled {
            model,
            data,
            islands: Some(is),
            direct_reads,
            ..
        }) = self.compiled.as_mut().map(Compiled::settled)
        else {
            return Ok(());
        };
        if is.candidates == model.groups.candidates {
            return Ok(());
        }
        let (m2, mut d2) = compile::compile_with_candidates(scene, is.params(), origin, Some(&is.candidates))?;
        d2.time = data.time;
        d2.state.copy_from_slice(&data.state);
        d2.inputs.copy_from_slice(&data.inputs);
        d2.counters = data.counters;
        d2.clamp_events = data.clamp_events;
        d2.log_peaks = data.log_peaks;
        d2.event_log = std::mem::take(&mut data.event_log);
        d2.broad_reference.copy_from_slice(&data.broad_reference);
        d2.solver.base = data.solver.base;
        is.gather_contacts(&m2, &mut d2);
        *model = m2;
        *data = d2;
        direct_reads.0.clear();
        Ok(())
    }

    /// Contact groups: finds the candidate pairs again at the current state, compiles the
    /// model with them and carries the data over (the state, the integrator with its step,
    /// the contact memory of the pairs kept, the counters, the event log). A pair that is new
    /// to the list and already touches was missed by the bounds on the step: an error (it
    /// cannot happen while no body is accelerated far beyond gravity within one step).
    pub(super) fn refresh_candidates(&mut self) -> Result<(), SimError> {
        let params = self.parameters();
        let (scene, origin) = (&self.scene, &self.origin);
        let Some(c) = self.compiled.as_mut().map(Compiled::settled) else {
            return Err(SimError::NotInitialized);
        };
        let (m, d) = (&c.model, &mut c.data);
        d.eval_state.copy_from_slice(&d.state);
        crate::kinematics::kinematics(m, d);
        let found = m.groups.find(&|b| groups::pose(d, b));
        let (m2, mut d2) = compile::compile_with_candidates(scene, &params, origin, Some(&found))?;
        let mask = state::FULL & !(state::StatePart::ContactMemory as u32);
        let mut v = Vec::new();
        state::get(m, d, mask, &mut v);
        state::set(&m2, &mut d2, mask, &v).map_err(SimError::Variable)?;
        let n = m.groups.n_explicit;
        d2.contact_memory[..n].copy_from_slice(&d.contact_memory[..n]);
        let old: std::collections::HashMap<_, _> = m
            .groups
            .candidates
            .iter()
            .zip(&d.contact_memory[n..])
            .map(|(k, mem)| (*k, *mem))
            .collect();
        d2.eval_state.copy_from_slice(&d2.state);
        crate::kinematics::kinematics(&m2, &mut d2);
        for (k, cand) in m2.groups.candidates.iter().enumerate() {
            match old.get(cand) {
                Some(mem) => d2.contact_memory[n + k] = *mem,
                None => {
                    let g = crate::contact::gap(&d2, n + k);
                    if crate::contact::event_function(&m2.contacts[n + k], &g) > 0.0 {
                        return Err(SimError::Step {
                            time: d.time,
                            message: format!(
                                "contact {:?} touched before the broad phase listed it: a body moved more than \
                                 half the broad-phase margin ({} m) within one step; raise [broad_phase] margin",
                                m2.contacts[n + k].name,
                                m2.groups.margin
                            ),
                        });
                    }
                }
            }
        }
        for b in 0..m2.bodies.len() {
            d2.broad_reference[b] = (d2.body_pos[b], d2.body_quat[b]);
        }
        d2.clamp_events = d.clamp_events;
        d2.log_peaks = d.log_peaks;
        d2.solver.base = d.solver.base;
        d2.event_log = std::mem::take(&mut d.event_log);
        // the step was accepted: the event values at the current state start the next one
        d2.eval_state.copy_from_slice(&d2.state);
        engine::events::event_values(&m2, &mut d2, false);
        c.model = m2;
        c.direct_reads.0.clear();
        c.data = d2;
        self.refreshes += 1;
        Ok(())
    }
}
