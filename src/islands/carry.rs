//! What a new island carries over from the islands before it: the contacts' memory (active
//! flag, δ̇⁻, impact count) by the scene's numbering, found for each candidate pair of a new
//! list by its index in the former list (`contact::elements::former_indices`).

use super::Islands;
use crate::contact::elements::{former_indices, kept_memory};
use crate::model::contact::ContactMemory;
use crate::model::groups::Candidate;
use crate::model::partition::Partition;
use crate::model::{Data, Model};

/// The contacts' memory, by the scene's numbering: declared contacts by index, candidate
/// pairs by their index in the islands' list (their partition's, [`Partition::list`]).
pub(super) struct Memory {
    /// Per declared contact.
    pub(super) explicit: Vec<ContactMemory>,
    /// Per candidate pair of the islands' list.
    pub(super) candidates: Vec<ContactMemory>,
}

/// The memory of the scene's data `d` (model `m`), by the list of candidate pairs `list`.
pub(super) fn memory_of_scene(m: &Model, d: &Data, list: &[Candidate]) -> Memory {
    let n = m.groups.n_explicit;
    let mut at = Vec::new();
    former_indices(&d.candidates, list, &mut at);
    Memory {
        explicit: d.contact_memory[..n].to_vec(),
        candidates: kept_memory(m, d, &at).collect(),
    }
}

impl Islands {
    /// The memory the islands hold, by the list of their partition `p` (their candidate pairs'
    /// places in it).
    pub(super) fn memory_of_islands(&self, m: &Model, p: &Partition) -> Memory {
        let mut memory = Memory {
            explicit: vec![ContactMemory::default(); m.groups.n_explicit],
            candidates: vec![ContactMemory::default(); p.list().len()],
        };
        for (j, island) in self.parts.iter().enumerate() {
            let mem = &island.data.contact_memory;
            for (k, &g) in island.numbering.explicit.iter().enumerate() {
                memory.explicit[g] = mem[k];
            }
            let n = island.numbering.explicit.len();
            for (k, &i) in p.listed(j).iter().enumerate() {
                memory.candidates[i] = mem[n + k];
            }
        }
        memory
    }
}
