//! The islands' own part of a saved state (declared in [`crate::model::island_state`]): the
//! counters, energies and rebuilds not held by an island, the end of the present round, the
//! candidate pairs, and per island its bodies and whole state.

use super::{candidate_body, Islands, Members};
use crate::compile::Parameters;
use crate::engine;
use crate::model::groups::Candidate;
use crate::model::island_state::{self, IslandsHead};
use crate::model::{state, Data, Model};

impl Islands {
    /// Appends the islands' own part ([`island_state::get`]).
    pub fn save(&self, out: &mut Vec<f64>) {
        let head = IslandsHead {
            retired: self.retired,
            dissipated_base: self.dissipated_base,
            input_work_base: self.input_work_base,
            rebuilds: self.rebuilds,
            round_end: self.round_end,
        };
        let bodies = self.parts.iter().map(|island| &island.bodies[..]);
        island_state::get(
            &head,
            &self.candidates,
            bodies,
            |k, out| state::get(&self.parts[k].model, &self.parts[k].data, state::FULL, out),
            out,
        );
    }

    /// The islands saved by [`Islands::save`], for the scene's model `m` and data `d` (both
    /// restored from the same saved state). Anything that does not fit is refused.
    pub fn load(params: Parameters, m: &Model, d: &Data, v: &[f64]) -> Result<Islands, String> {
        let (head, candidates, saved) = island_state::set(m, d.time, v)?;
        let mut is = Islands::bare(params, m, d);
        is.candidates = candidates;
        // (the memory by the islands' list; each island's saved state then sets its own)
        let memory = is.memory_of_scene(m, d);
        let same: Vec<usize> = (0..is.candidates.len()).collect();
        let mut parts = Vec::with_capacity(saved.len());
        for island in saved {
            let bodies = island.bodies;
            let (candidates, listed): (Vec<Candidate>, Vec<usize>) = is
                .candidates
                .iter()
                .enumerate()
                .filter(|(_, c)| candidate_body(m, c).is_some_and(|b| bodies.binary_search(&b).is_ok()))
                .map(|(i, c)| (*c, i))
                .unzip();
            let members = Members {
                bodies,
                candidates,
                listed,
            };
            let mut built = is
                .compile_island(m, d, members, &memory, &same)
                .map_err(|e| e.message)?;
            if state::group_candidates(&built.model, island.state).as_ref() != Some(&built.data.candidates)
                && built.model.groups.is_active()
            {
                return Err("saved islands: an island's candidate pairs are not the scene's".into());
            }
            state::set(&built.model, &mut built.data, state::FULL, island.state)?;
            engine::resync(&built.model, &mut built.data);
            parts.push(built);
        }
        for (k, island) in parts.iter().enumerate() {
            for &b in &island.bodies {
                is.island_of[b] = k;
            }
        }
        is.parts = parts;
        is.retired = head.retired;
        is.dissipated_base = head.dissipated_base;
        is.input_work_base = head.input_work_base;
        is.rebuilds = head.rebuilds;
        is.round_end = head.round_end;
        is.time = d.time;
        Ok(is)
    }
}
