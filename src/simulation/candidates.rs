//! Contact groups and islands seen from the facade: the data's contact list made anew for
//! new candidate pairs (found again by the broad phase, or the islands'), the islands'
//! advance and what they report. The model does not change.

use super::{step_error, Compiled, SimError, Simulation};
use crate::contact::{elements, groups};
use crate::engine;
use crate::islands::Islands;
use crate::model::Counters;
use crate::outputs::{self, Energies};

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
        let time = d.time;
        // (a pair new to the list that touches already is refused before the data changes)
        let (found, former) =
            groups::find_candidates(m, d, &d.candidates).map_err(|message| SimError::Step { time, message })?;
        let contacts = elements::contact_list(m, d, &found).map_err(|message| SimError::Step { time, message })?;
        // The method's last step reaches past this point when the list went stale at a restart
        // inside an advance (an input a host changed, or a contact event) and the advance
        // ended at a communication point within the next step: that step's end values are
        // of the former list and reference poses (the new list's are not evaluated there), so
        // the method starts again here.
        let restart = d.solver.ahead_of(d.time);
        elements::set_contact_list(m, d, &found, &former, contacts);
        if restart {
            d.solver.started = false;
        }
        groups::take_reference_poses(m, d);
        d.outputs_valid = false;
        d.kinematics_valid = false;
        d.planned_kinematics = false;
        // the step was accepted: the event values at the current state start the next one
        engine::events::event_values(m, d, false);
        c.direct_reads.0.clear();
        self.refreshes += 1;
        Ok(())
    }

    /// Contact groups: how often the candidate pairs were found again since this simulation
    /// was created (a diagnostic, not part of the state).
    pub fn candidate_refreshes(&self) -> u64 {
        let islands = self.compiled.as_ref().and_then(|c| c.islands.as_ref());
        self.refreshes + islands.map_or(0, |is| is.rebuilds)
    }

    /// Diagnostics of the islands: (rounds, islands formed, models cut for them: the others
    /// took a model from the pool, shared with islands of alike bodies).
    pub fn island_diagnostics(&self) -> (u64, u64, u64) {
        let islands = self.compiled.as_ref().and_then(|c| c.islands.as_ref());
        islands.map_or((0, 0, 0), |is| (is.rounds, is.compiled, is.compiled - is.pooled))
    }

    /// The independent islands the scene runs as (empty when it runs as one: a single
    /// island, or `solver.islands = false`, or before the first step).
    pub fn islands(&mut self) -> Vec<IslandReport> {
        let Some(c) = self.compiled.as_mut() else {
            return Vec::new();
        };
        let Some(is) = c.islands.as_mut() else {
            return Vec::new();
        };
        let partition = &c.data.partition;
        is.parts
            .iter_mut()
            .enumerate()
            .map(|(k, i)| IslandReport {
                bodies: partition
                    .bodies(k)
                    .iter()
                    .map(|&b| self.scene.body[b].name.clone())
                    .collect(),
                counters: i.data.counters,
                energies: outputs::energies(&i.model, &mut i.data),
                time: i.data.time,
            })
            .collect()
    }

    /// [`Simulation::step_to`] for a scene that runs as islands: they advance, and the scene's
    /// data gets their state (and their contacts' memory when it lists their candidate pairs).
    pub(super) fn step_islands(&mut self, t_end: f64, stop_at_events: bool) -> Result<bool, SimError> {
        let Some(Compiled {
            model, data, islands, ..
        }) = self.compiled.as_mut().map(Compiled::settled)
        else {
            return Err(SimError::NotInitialized);
        };
        let Some(is) = islands.as_mut() else {
            return Err(SimError::NotInitialized);
        };
        let result = is.advance(model, data, t_end, stop_at_events);
        is.gather(model, data);
        if !is.formed {
            // (every island ended, its counters and energies gathered; the next step forms
            // them anew from the scene's data)
            *islands = None;
            data.partition.clear();
        } else if data.partition.list() == data.candidates {
            is.gather_contacts(data);
        }
        result.map_err(step_error)
    }
}

/// One independent island at the current state (see [`Simulation::islands`]).
#[derive(Debug, Clone)]
pub struct IslandReport {
    /// Its bodies, in scene order.
    pub bodies: Vec<String>,
    /// Its work counters since it was formed.
    pub counters: Counters,
    /// Its energies (its dissipated energy: since it was formed).
    pub energies: Energies,
    /// Its time \[s\].
    pub time: f64,
}

/// The energies of a scene that runs as islands: the islands' summed, the work that no
/// present island holds added ([`Islands::work_not_in_islands`]).
pub(super) fn islands_energies(is: &mut Islands) -> Energies {
    let (dissipated, input_work) = is.work_not_in_islands();
    let mut e = Energies {
        dissipated,
        input_work,
        ..Default::default()
    };
    for island in &mut is.parts {
        let i = outputs::energies(&island.model, &mut island.data);
        e.kinetic += i.kinetic;
        e.potential += i.potential;
        e.contact += i.contact;
        e.dissipated += i.dissipated;
        e.input_work += i.input_work;
    }
    e
}
