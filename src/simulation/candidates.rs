//! Contact groups and islands seen from the facade: the data's contact list made anew for
//! new candidate pairs (found again by the broad phase, or the islands'). The model does not
//! change.

use super::{Compiled, SimError, Simulation};
use crate::contact::{elements, groups};
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
        if data.partition.list() == data.candidates {
            return Ok(());
        }
        let list = data.partition.list().to_vec();
        elements::set_candidates(model, data, &list).map_err(|message| SimError::Step {
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
        let mut former = Vec::new();
        elements::former_indices(&d.candidates, &found, &mut former);
        elements::check_new_pairs(m, d, &found, &former).map_err(|message| SimError::Step { time, message })?;
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
