//! What a new island carries over from the islands before it: the contacts' memory (active
//! flag, δ̇⁻, impact count) by the scene's numbering, and for each candidate pair of a new
//! list its index in the former list (the memory is found by it, and a pair new to the list is
//! checked for a touch).

use super::Islands;
use crate::model::contact::ContactMemory;
use crate::model::groups::Candidate;
use crate::model::partition::Partition;
use crate::model::{Data, Model};
use rustc_hash::FxHashMap as HashMap;

/// The contacts' memory, by the scene's numbering: declared contacts by index, candidate
/// pairs by their index in the islands' list (their partition's, [`Partition::list`]).
pub(super) struct Memory {
    /// Per declared contact.
    pub(super) explicit: Vec<ContactMemory>,
    /// Per candidate pair of the islands' list.
    pub(super) candidates: Vec<ContactMemory>,
}

/// [`former_indices`]: a candidate pair not in the former list.
pub(super) const NOT_LISTED: usize = usize::MAX;

/// Per candidate pair of the list `new`, its index in the list `old` ([`NOT_LISTED`]: none),
/// into `out`: by one walk through both when both are sorted (the broad phase's lists are),
/// by a map of `old` otherwise (a pair listed twice: its last index).
pub(super) fn former_indices(old: &[Candidate], new: &[Candidate], out: &mut Vec<usize>) {
    out.clear();
    let sorted = |l: &[Candidate]| l.windows(2).all(|w| w[0] < w[1]);
    if sorted(old) && sorted(new) {
        let mut i = 0;
        for c in new {
            while i < old.len() && old[i] < *c {
                i += 1;
            }
            out.push(if old.get(i) == Some(c) { i } else { NOT_LISTED });
        }
    } else {
        let index: HashMap<Candidate, usize> = old.iter().enumerate().map(|(i, c)| (*c, i)).collect();
        out.extend(new.iter().map(|c| index.get(c).copied().unwrap_or(NOT_LISTED)));
    }
}

/// The memory of the scene's data `d` (model `m`), by the list of candidate pairs `list`.
pub(super) fn memory_of_scene(m: &Model, d: &Data, list: &[Candidate]) -> Memory {
    let n = m.groups.n_explicit;
    let mut at = Vec::new();
    former_indices(&d.candidates, list, &mut at);
    Memory {
        explicit: d.contact_memory[..n].to_vec(),
        candidates: at
            .iter()
            .map(|&i| match i {
                NOT_LISTED => ContactMemory::default(),
                i => d.contact_memory.get(n + i).copied().unwrap_or_default(),
            })
            .collect(),
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
