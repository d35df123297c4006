//! Contact groups and islands seen from the facade: the data's contact list made anew for
//! new candidate pairs (found again by the broad phase, or the islands'). The model does not
//! change.

use super::{Compiled, SimError, Simulation};
use crate::contact::{self, elements, groups};
use crate::engine;

impl Simulation {
    /// With islands: when the islands' candidate pairs changed since the scene's data last took
    /// them, makes its contact list theirs and gives it their contact memory (done when
    /// something reads the contacts, not at every communication point).
    pub(super) fn sync_islands(&mut self) -> Result<(), SimError> {
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
        if is.candidates == data.candidates {
            return Ok(());
        }
        elements::set_candidates(model, data, &is.candidates).map_err(|message| SimError::Step {
            time: data.time,
            message,
        })?;
        is.gather_contacts(data);
        data.outputs_valid = false;
        direct_reads.0.clear();
        Ok(())
    }

    /// Contact groups: finds the candidate pairs again at the current state and makes the
    /// data's contact list theirs (the contact memory of the pairs kept carries over). A pair
    /// that is new to the list and already touches was missed by the bounds on the step: an
    /// error (it cannot happen while no body is accelerated far beyond gravity within one
    /// step), raised before the data changes.
    pub(super) fn refresh_candidates(&mut self) -> Result<(), SimError> {
        let Some(c) = self.compiled.as_mut().map(Compiled::settled) else {
            return Err(SimError::NotInitialized);
        };
        let (m, d) = (&c.model, &mut c.data);
        d.eval_state.copy_from_slice(&d.state);
        crate::kinematics::kinematics(m, d);
        let found = m.groups.find(&|b| groups::pose(d, b));
        let time = d.time;
        let contacts = elements::contact_list(m, d, &found).map_err(|message| SimError::Step { time, message })?;
        // a pair new to the list that touches already: checked before the list changes
        let n = m.groups.n_explicit;
        let before: rustc_hash::FxHashSet<_> = d.candidates.iter().collect();
        for (k, e) in found.iter().zip(&contacts[n..]).filter(|(k, _)| !before.contains(k)) {
            if contact::event_function(e, &contact::gap_of(e, d)) > 0.0 {
                return Err(SimError::Step {
                    time,
                    message: format!(
                        "contact {:?} touched before the broad phase listed it: a body moved more than half the \
                         broad-phase margin ({} m) within one step; raise [broad_phase] margin",
                        m.groups.element_name(k),
                        m.groups.margin
                    ),
                });
            }
        }
        elements::set_contact_list(m, d, &found, contacts);
        for b in 0..m.bodies.len() {
            d.broad_reference[b] = (d.body_pos[b], d.body_quat[b]);
        }
        d.outputs_valid = false;
        d.kinematics_valid = false;
        d.planned_kinematics = false;
        // the step was accepted: the event values at the current state start the next one
        engine::events::event_values(m, d, false);
        c.direct_reads.0.clear();
        self.refreshes += 1;
        Ok(())
    }
}
