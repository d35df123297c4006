//! One island: its model cut from the scene's (shared by alike islands) and its data, how its coordinates, inputs,
//! contacts and shapes map onto the scene's, and the state it saves at a round's start to be
//! taken back to.

use super::part::Numbering;
use crate::engine;
use crate::model::groups::Candidate;
use crate::model::{state, Data, Model};
use std::sync::Arc;

/// One island: a model cut from the scene's, and its data.
pub struct Island {
    /// The island's model (shared with the islands of alike bodies and the pool).
    pub model: Arc<Model>,
    /// The island's data (boxed: forming and the spare data move a pointer, not the data).
    pub data: Box<Data>,
    /// How its coordinates, inputs, declared contacts and shapes map onto the scene's.
    pub(super) numbering: Numbering,
    /// Its state at the start of the round: the whole state, or (`saved_light`) its time and
    /// coordinates ([`Island::save_round_start`]).
    pub(super) saved: Vec<f64>,
    pub(super) saved_light: bool,
    /// The length of its event log then.
    pub(super) saved_log: usize,
}

impl Island {
    /// Sets the island's coordinates and time from the scene's state; its integrator restarts
    /// at the next advance.
    pub(super) fn copy_coordinates(&mut self, d: &Data) {
        let dl = &mut self.data;
        for &(l, g) in &self.numbering.coords {
            dl.state[l] = d.state[g];
        }
        dl.time = d.time;
        dl.solver.started = false;
    }

    /// [`Island::copy_coordinates`], and evaluates its event values there.
    pub(super) fn take_coordinates(&mut self, d: &Data) {
        self.copy_coordinates(d);
        engine::resync(&self.model, &mut self.data);
    }

    /// [`Island::copy_coordinates`] for a new island: nothing is evaluated there (the advance
    /// that starts its integrator evaluates the event values there).
    pub(super) fn take_new_coordinates(&mut self, d: &Data) {
        self.copy_coordinates(d);
        let dl = &mut self.data;
        dl.outputs_valid = false;
        dl.kinematics_valid = false;
    }

    /// Saves the island's state at the start of a round that ends at `t_round`, to take it
    /// back to ([`Island::restore`]): the whole state; with `light`, when its advance to `t_round`
    /// takes no step ([`engine::interpolates_to`]: it only interpolates its method's last step)
    /// and it has no loops (whose projection after the interpolation evaluates kinematics),
    /// only its time and coordinates, which are all that advance changes. (Half the islands'
    /// saves on 1,000 spheres were of such islands.)
    pub(super) fn save_round_start(&mut self, t_round: f64, light: bool) {
        self.saved.clear();
        self.saved_log = self.data.event_log.len();
        self.saved_light =
            light && self.model.loop_rows() == 0 && engine::interpolates_to(&self.model, &self.data, t_round);
        if self.saved_light {
            self.saved.push(self.data.time);
            self.saved.extend_from_slice(&self.data.state);
        } else {
            state::get(&self.model, &self.data, state::FULL, &mut self.saved);
        }
    }

    /// Copies the island's coordinates into the scene's state.
    pub(super) fn put_coordinates(&self, state: &mut [f64]) {
        for &(l, g) in &self.numbering.coords {
            state[g] = self.data.state[l];
        }
    }

    /// Takes the scene's input values, and its coordinates when a host moved a driven joint;
    /// a change restarts the integrator.
    pub(super) fn take_inputs(&mut self, d: &Data) {
        for &(l, g) in &self.numbering.inputs {
            if self.data.inputs[l] != d.inputs[g] {
                self.data.inputs[l] = d.inputs[g];
                self.data.solver.started = false;
            }
        }
        // a host moved a driven joint (and the rest of the scene's state followed it onto the
        // loops): the island takes all its coordinates
        if self
            .numbering
            .driven
            .iter()
            .any(|&(l, g)| self.data.state[l] != d.state[g])
        {
            self.take_coordinates(d);
        }
    }

    /// The island's dissipated energy \[J\].
    pub fn dissipated(&self) -> f64 {
        self.data.state[self.model.dissipated_index()]
    }

    /// The work of the island's inputs \[J\].
    pub fn input_work(&self) -> f64 {
        self.model.input_work(&self.data.state)
    }

    /// The scene's index of the island's contact `k` (its declared contacts', then its
    /// candidate pairs' after them: `listed` holds their places in the islands' list).
    pub(super) fn scene_contact(&self, k: usize, n_explicit: usize, listed: &[usize]) -> Option<usize> {
        match self.numbering.explicit.get(k) {
            Some(&g) => Some(g),
            None => listed.get(k - self.numbering.explicit.len()).map(|i| n_explicit + i),
        }
    }

    /// `message` of the island's engine with the names of its candidate pairs' contacts
    /// (quoted, by the island's numbering of the shapes) by the scene's numbering, as the scene
    /// names them.
    pub(super) fn in_scene_names(&self, message: &str) -> String {
        let (g, shapes) = (&self.model.groups, &self.numbering.shapes);
        let mut out = String::with_capacity(message.len());
        for (k, part) in message.split('"').enumerate() {
            if k > 0 {
                out.push('"');
            }
            let local = (k % 2 == 1)
                .then(|| self.data.candidates.iter().find(|c| g.element_name(c) == part))
                .flatten();
            match local {
                Some(c) => out.push_str(&g.element_name(&Candidate {
                    sphere: shapes[c.sphere],
                    other: shapes[c.other],
                    ..*c
                })),
                None => out.push_str(part),
            }
        }
        out
    }

    /// Takes the island back to its state at the start of the round.
    pub(super) fn restore(&mut self) {
        if self.saved_light {
            // (its method, modes, counters and event values are those of the round's start)
            let d = &mut self.data;
            d.time = self.saved[0];
            d.state.copy_from_slice(&self.saved[1..]);
            d.dense_pending = false;
            d.outputs_valid = false;
            d.kinematics_valid = false;
        } else if state::set(&self.model, &mut self.data, state::FULL, &self.saved).is_ok() {
            // (a state the island saved itself always fits)
            engine::resync(&self.model, &mut self.data);
        }
        self.data.event_log.truncate(self.saved_log);
    }
}
