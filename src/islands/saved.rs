//! The islands' part of a saved state ([`crate::model::island_state`], in the scene's data):
//! gathered from the islands when the state is saved, and the islands built from it and the
//! scene's state when it is restored.

use super::carry::Memory;
use super::{Islands, Members};
use crate::compile::Parameters;
use crate::engine;
use crate::model::island_state::{IslandsHead, ENERGIES};
use crate::model::state::{self, ISLAND_OWN};
use crate::model::{Data, Model};

impl Islands {
    /// Gathers what the islands hold beyond the scene's state into the scene's data `d`
    /// (`Data::islands`): the counters, energies and rebuilds not held by an island, the
    /// round's end, the candidate pairs with the contacts' memory, each body's island, and per
    /// island its energies, inputs, counters and integrator.
    pub fn record(&self, m: &Model, d: &mut Data) {
        let memory = self.memory_of_islands(m, &d.partition);
        let s = &mut d.islands;
        s.clear();
        s.head = IslandsHead {
            retired: self.retired,
            dissipated_base: self.dissipated_base,
            input_work_base: self.input_work_base,
            rebuilds: self.rebuilds,
            round_end: self.round_end,
        };
        s.candidates.extend_from_slice(d.partition.list());
        s.memory.extend(memory.explicit);
        s.memory.extend(memory.candidates);
        s.island_of.extend_from_slice(&d.partition.island_of);
        for island in &self.parts {
            let mut record = vec![island.dissipated(), island.input_work()];
            state::get(&island.model, &island.data, ISLAND_OWN, &mut record);
            s.records.push(record);
        }
    }

    /// The islands of the scene's model `m` and data `d` as [`Islands::record`] left them in
    /// `d.islands` (a restored state: its coordinates and reference poses are the islands';
    /// their inputs are in their records). A scene that does not run as islands, bodies not in
    /// the islands their joints, springs, inputs and candidate pairs make, and records that do
    /// not fit the islands' models are refused.
    pub fn load(params: Parameters, m: &Model, d: &mut Data) -> Result<Islands, String> {
        let saved = &d.islands;
        if !super::wanted(m) {
            return Err("saved islands: this scene runs as one integrator, not as islands".into());
        }
        // (the islands are always formed as the partition of their candidate pairs, numbered
        // by their first bodies: a body cut from the bodies it is joined to would be cut into a
        // model of its own)
        let islands = super::partition(m, &saved.candidates);
        if islands.len() != saved.count() || islands.island_of != saved.island_of {
            return Err(
                "saved islands: the bodies' islands are not those their joints, springs, inputs \
                        and candidate pairs make"
                    .into(),
            );
        }
        let mut is = Islands::bare(params, m, d);
        let n = m.groups.n_explicit;
        let memory = Memory {
            explicit: saved.memory[..n].to_vec(),
            candidates: saved.memory[n..].to_vec(),
        };
        // (the memory is by the islands' own list)
        let same: Vec<usize> = (0..saved.candidates.len()).collect();
        let mut parts = Vec::with_capacity(islands.len());
        for (k, bodies) in islands.iter().enumerate() {
            let members = Members {
                bodies,
                candidates: islands.candidates(k),
                listed: islands.listed(k),
            };
            let mut built = is
                .compile_island(m, d, members, &memory, &same)
                .map_err(|e| e.message)?;
            let (energies, own) = saved.records[k].split_at(ENERGIES);
            let (im, id) = (&built.model, &mut built.data);
            id.state[im.dissipated_index()] = energies[0];
            match im.input_work_index() {
                Some(i) => id.state[i] = energies[1],
                None if energies[1] != 0.0 => {
                    return Err(format!("saved islands: island {k} holds input work, it has no inputs"));
                }
                None => {}
            }
            state::set(im, id, ISLAND_OWN, own).map_err(|e| format!("saved islands: island {k}: {e}"))?;
            engine::resync(im, id);
            parts.push(built);
        }
        is.parts = parts;
        d.partition = islands;
        let head = saved.head;
        is.retired = head.retired;
        is.dissipated_base = head.dissipated_base;
        is.input_work_base = head.input_work_base;
        is.rebuilds = head.rebuilds;
        is.round_end = head.round_end;
        is.time = d.time;
        Ok(is)
    }
}
