//! The pool that keeps the compiled part of an island ([`Compiled`]) when the island ends: an
//! island formed again from the same bodies — a sphere alone again after a collision, a pair
//! that meets again, whatever its candidate pairs — takes its model from there instead of
//! cutting it from the scene's model anew. A model depends on nothing else (the scene and the
//! parameter values are the islands' own), so a pooled model is the one cutting would give,
//! and the results do not depend on the pool.

use super::cut_model::ModelCutter;
use super::part::{Compiled, Key};
use super::Source;
use crate::compile::Parameters;
use crate::model::Model;
use rustc_hash::FxHashMap as HashMap;
use std::collections::VecDeque;

/// The part of the island of the bodies `key` cut anew (into no one's buffers) from the
/// scene's model `m` of the islands `is` (compiled from `src`): what [`Pool::cut`] gives
/// without a spare part.
#[cfg(test)]
pub(super) fn fresh_cut(src: &Source, is: &mut super::Islands, m: &Model, key: &Key) -> Compiled {
    Pool::default().cut(src, &is.params, &mut is.cutter, m, &is.joint_coords, key)
}

/// The compiled parts of islands that ended, by their bodies, and spare parts to cut into.
/// Every one-body part is kept (a body alone again takes its part back, however long after),
/// the multi-body parts up to [`MULTI_BODY_PARTS`], the oldest put leaving first (those taken
/// again mostly are within a few rounds): the parts that leave, and those dropped when the
/// pool starts empty again, become spares, up to [`SPARE_PARTS`], whose buffers the cuts
/// reuse.
#[derive(Default)]
pub(super) struct Pool {
    parts: HashMap<Key, Compiled>,
    /// The keys of the multi-body parts held, oldest put first.
    multi: VecDeque<Key>,
    /// Parts to cut into, with their numbers of bodies.
    spares: Vec<(usize, Compiled)>,
}

/// The pool keeps up to this many multi-body parts (measured on 1,000 spheres, docs/benchmarks.md
/// §16: 0, 16, 32, 64 and 128 formed the islands in 273.6, 271.7, 271.0, 273.1 and 274.1 M
/// instructions: fewer pool hits, or fewer spares).
const MULTI_BODY_PARTS: usize = 32;

/// The pool keeps up to this many spare parts (16 and 256 instead of 64: 275.6 and 271.1 M
/// instructions instead of 271.0 M).
const SPARE_PARTS: usize = 64;

impl Pool {
    /// The part compiled for `key`, taken out of the pool (with the key), if there is one.
    pub(super) fn take(&mut self, key: &Key) -> Option<(Key, Compiled)> {
        let taken = self.parts.remove_entry(key)?;
        if key.len() > 1 {
            // (those taken again are mostly among the last put)
            if let Some(i) = self.multi.iter().rposition(|k| k == key) {
                self.multi.remove(i);
            }
        }
        Some(taken)
    }

    /// The part of the island of the bodies `key` cut by `cutter` into a spare part's
    /// buffers, if there is one (else into new ones).
    pub(super) fn cut(
        &mut self,
        src: &Source,
        params: &Parameters,
        cutter: &mut ModelCutter,
        m: &Model,
        joint_coords: &[(usize, usize)],
        key: &Key,
    ) -> Compiled {
        let mut part = self.take_spare(key.len()).unwrap_or_else(|| Compiled::empty(params));
        cutter.cut_into(src.scene, params, m, joint_coords, key, &mut part);
        part
    }

    /// The keys of the parts the pool holds.
    #[cfg(test)]
    pub(super) fn keys(&self) -> impl Iterator<Item = &Key> {
        self.parts.keys()
    }

    /// The spare part of the fewest bodies from `n` on (whose buffers are most likely large
    /// enough), else of the most.
    fn take_spare(&mut self, n: usize) -> Option<Compiled> {
        let fit = |&(m, _): &(usize, Compiled)| if m >= n { m - n } else { usize::MAX - m };
        let (i, _) = self.spares.iter().enumerate().min_by_key(|(_, s)| fit(s))?;
        Some(self.spares.swap_remove(i).1)
    }

    /// Keeps `part` (of `n` bodies) as a spare, if there is room.
    fn spare(&mut self, n: usize, part: Compiled) {
        if self.spares.len() < SPARE_PARTS {
            self.spares.push((n, part));
        }
    }

    /// Keeps the part of an island that ended, its model's largest step count set back to
    /// `max_steps` (the parameter values': the rounds set it before every advance). Beyond
    /// `limit` parts the pool starts empty again.
    pub(super) fn put(&mut self, key: Key, mut part: Compiled, max_steps: u64, limit: usize) {
        if self.parts.len() >= limit {
            self.multi.clear();
            for (k, old) in std::mem::take(&mut self.parts) {
                self.spare(k.len(), old);
            }
        }
        part.model.solver.max_steps = max_steps;
        let (n, multi) = (key.len(), (key.len() > 1).then(|| key.clone()));
        if let Some(old) = self.parts.insert(key, part) {
            // (a part of the same bodies: its key is listed already)
            self.spare(n, old);
        } else if let Some(key) = multi {
            self.multi.push_back(key);
            if self.multi.len() > MULTI_BODY_PARTS {
                if let Some((k, old)) = self.multi.pop_front().and_then(|k| self.parts.remove_entry(&k)) {
                    self.spare(k.len(), old);
                }
            }
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::tests::{on_64_spheres, snapshot};
    use super::{Compiled, Key};

    /// Every model the pool holds after islands merged and split is the one compilation
    /// gives for its bodies and candidate pairs (compared field by field through their
    /// debug form, which prints every number so that it reads back exactly), with the same
    /// numbering against the scene.
    #[test]
    fn pooled_parts_are_those_compilation_gives() {
        on_64_spheres("pool test", |src, m, d, is| {
            is.advance(src, m, d, 0.02, false).unwrap();
            assert!(
                is.rebuilds > 0 && is.pooled > 0,
                "rebuilds {}, pooled {}",
                is.rebuilds,
                is.pooled
            );
            assert!(!is.pool.parts.is_empty());
            let pooled = std::mem::take(&mut is.pool.parts);
            for (key, part) in &pooled {
                let fresh = super::fresh_cut(src, is, m, key);
                assert_same_part(part, &fresh, key);
            }
        });
    }

    /// Islands formed with the data (and integrators) of islands that ended take the same
    /// steps as islands formed with new data: on 64 grouped spheres that collide, every
    /// island's whole state (its integrator's included), the counters and the dissipated
    /// energy are the same bit for bit.
    #[test]
    fn reused_data_gives_the_trajectories_of_new_data() {
        let run = |spare_limit: usize| {
            on_64_spheres("reuse test", |src, m, d, is| {
                is.spare_limit = spare_limit;
                is.advance(src, m, d, 0.02, false).unwrap();
                let (states, scene_state, counters) = snapshot(is, m, d);
                (states, scene_state, counters, is.compiled, is.reused)
            })
        };
        let (with, without) = (run(super::super::SPARE_DATA), run(0));
        assert!(
            with.3 > 64 && with.4 > 0,
            "islands formed {}, with ended islands' data {}",
            with.3,
            with.4
        );
        assert_eq!(without.4, 0);
        assert_eq!(with.0, without.0, "the islands' whole states");
        assert_eq!(with.1, without.1, "the scene's state");
        assert_eq!(with.2, without.2, "the counters");
        assert_eq!(with.3, without.3);
    }

    /// Asserts that two parts of the island `key` are the same: their models field by field
    /// through their debug form (which prints every number so that it reads back exactly, the
    /// sign of a zero too) and their numbering against the scene.
    pub(in super::super) fn assert_same_part(a: &Compiled, b: &Compiled, key: &Key) {
        assert_eq!(format!("{:?}", a.model), format!("{:?}", b.model), "bodies {key:?}");
        assert_eq!(a.coords, b.coords);
        assert_eq!(a.explicit, b.explicit);
        assert_eq!(a.inputs, b.inputs);
        assert_eq!(a.driven, b.driven);
        assert_eq!(a.shapes, b.shapes);
    }
}
