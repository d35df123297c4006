//! The islands' partition of a scene, in its data (`Data::partition`): which bodies and which
//! candidate pairs of the contact groups advance together. Island forming fills it
//! (`islands::partition`) after the broad phase; everything that cuts, saves or reports the
//! islands reads it.

use super::groups::Candidate;

/// The islands of a scene: the candidate pairs they were formed for (the broad phase's list),
/// the bodies of each island (in scene order, the islands ordered by their first body) and
/// its candidate pairs (in the list's order), each in one list (no allocation per island).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Partition {
    /// The candidate pairs (sorted, as the broad phase lists them).
    list: Vec<Candidate>,
    /// Per body, its island.
    pub island_of: Vec<usize>,
    /// The bodies of island `k` are `bodies[body_starts[k]..body_starts[k + 1]]`.
    bodies: Vec<usize>,
    body_starts: Vec<usize>,
    /// The candidate pairs of island `k` are `candidates[candidate_starts[k]..candidate_starts[k
    /// + 1]]`, and `listed` holds the index of each in the list the partition was made from.
    candidates: Vec<Candidate>,
    listed: Vec<usize>,
    candidate_starts: Vec<usize>,
}

impl Partition {
    /// The partition of the list `candidates` whose islands `island_of` gives per body
    /// (numbered in the order of their first bodies, from 0), each candidate pair in the
    /// island of its `body` (None: a pair of no body, in no island).
    pub fn new(
        island_of: Vec<usize>,
        candidates: &[Candidate],
        body: impl Fn(&Candidate) -> Option<usize>,
    ) -> Partition {
        let n = island_of.iter().map(|&k| k + 1).max().unwrap_or(0);
        let mut p = Partition {
            list: candidates.to_vec(),
            island_of,
            body_starts: vec![0; n + 1],
            candidate_starts: vec![0; n + 1],
            ..Partition::default()
        };
        for &k in &p.island_of {
            p.body_starts[k + 1] += 1;
        }
        let of_pair: Vec<Option<usize>> = candidates.iter().map(|c| body(c).map(|b| p.island_of[b])).collect();
        for &k in of_pair.iter().flatten() {
            p.candidate_starts[k + 1] += 1;
        }
        for k in 1..=n {
            p.body_starts[k] += p.body_starts[k - 1];
            p.candidate_starts[k] += p.candidate_starts[k - 1];
        }
        let mut next = p.body_starts.clone();
        p.bodies = vec![0; p.island_of.len()];
        for (b, &k) in p.island_of.iter().enumerate() {
            p.bodies[next[k]] = b;
            next[k] += 1;
        }
        next.clone_from(&p.candidate_starts);
        let m = p.candidate_starts[n];
        p.candidates = vec![
            Candidate {
                pair: 0,
                sphere: 0,
                other: 0
            };
            m
        ];
        p.listed = vec![0; m];
        for (i, (c, k)) in candidates.iter().zip(&of_pair).enumerate() {
            if let Some(k) = *k {
                p.candidates[next[k]] = *c;
                p.listed[next[k]] = i;
                next[k] += 1;
            }
        }
        p
    }

    /// The candidate pairs the islands were formed for.
    pub fn list(&self) -> &[Candidate] {
        &self.list
    }

    /// The number of islands.
    pub fn len(&self) -> usize {
        self.body_starts.len().saturating_sub(1)
    }

    /// True when there is no island (no body, or not formed).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The bodies of island `k`.
    pub fn bodies(&self, k: usize) -> &[usize] {
        &self.bodies[self.body_starts[k]..self.body_starts[k + 1]]
    }

    /// The candidate pairs of island `k`, in the list's order.
    pub fn candidates(&self, k: usize) -> &[Candidate] {
        &self.candidates[self.candidate_starts[k]..self.candidate_starts[k + 1]]
    }

    /// The index in the list of each candidate pair of island `k`.
    pub fn listed(&self, k: usize) -> &[usize] {
        &self.listed[self.candidate_starts[k]..self.candidate_starts[k + 1]]
    }

    /// The islands' bodies, in order.
    pub fn iter(&self) -> impl Iterator<Item = &[usize]> {
        (0..self.len()).map(|k| self.bodies(k))
    }

    /// No islands (keeping the buffers).
    pub fn clear(&mut self) {
        for v in [
            &mut self.island_of,
            &mut self.bodies,
            &mut self.body_starts,
            &mut self.listed,
            &mut self.candidate_starts,
        ] {
            v.clear();
        }
        self.candidates.clear();
        self.list.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::Partition;
    use crate::model::groups::Candidate;

    /// Each island's bodies and candidate pairs are those a filter of the bodies and of the
    /// list finds, in their order, with their places in the list; a pair of no body is in none.
    #[test]
    fn islands_hold_what_a_filter_finds() {
        let island_of = vec![0, 1, 0, 2, 1, 2, 2];
        let pair = |sphere: usize, other: usize| Candidate { pair: 0, sphere, other };
        // (here a pair's body is its sphere; 99: no body)
        let list = [
            pair(4, 9),
            pair(0, 9),
            pair(99, 9),
            pair(3, 6),
            pair(2, 9),
            pair(1, 4),
            pair(6, 9),
        ];
        let body = |c: &Candidate| (c.sphere != 99).then_some(c.sphere);
        let p = Partition::new(island_of.clone(), &list, body);
        assert_eq!(p.len(), 3);
        for k in 0..3 {
            let bodies: Vec<usize> = (0..island_of.len()).filter(|&b| island_of[b] == k).collect();
            assert_eq!(p.bodies(k), bodies);
            let listed: Vec<usize> = (0..list.len())
                .filter(|&i| body(&list[i]).map(|b| island_of[b]) == Some(k))
                .collect();
            assert_eq!(p.listed(k), listed);
            assert_eq!(p.candidates(k), listed.iter().map(|&i| list[i]).collect::<Vec<_>>());
        }
        assert_eq!(p.iter().map(<[usize]>::len).sum::<usize>(), island_of.len());
        let mut q = p.clone();
        q.clear();
        assert!(q.is_empty() && q == Partition::default());
    }
}
