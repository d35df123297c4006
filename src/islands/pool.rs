//! The pool of the models cut for islands: an island formed of bodies whose model was cut
//! before — a sphere alone again after a collision, a pair that meets again, whatever its
//! candidate pairs, or bodies alike to those ([`super::part::alike_bodies`]) — shares that
//! model instead of cutting one anew. A model depends on nothing else (the scene and the
//! parameter values are the islands' own), so a pooled model is the one cutting would give,
//! and the results do not depend on the pool.

use super::cut_model::ModelCutter;
use super::part::{empty_model, Compiled, Key, Numbering};
use crate::compile::Parameters;
use crate::model::Model;
use rustc_hash::FxHashMap as HashMap;
use std::collections::VecDeque;
use std::sync::Arc;

/// The part of the island of the bodies `bodies` cut anew (into no one's buffers) from the
/// scene's model `m` of the islands `is`: what [`Pool::part`] gives for
/// a key not in the pool and without a spare model.
#[cfg(test)]
pub(super) fn fresh_cut(is: &mut super::Islands, m: &Model, bodies: &[usize]) -> Compiled {
    let mut model = empty_model(&is.params);
    let mut own = Numbering::default();
    is.cutter
        .cut_into(&is.params, m, &is.joint_coords, bodies, &mut model, &mut own);
    Compiled {
        model: Arc::new(model),
        numbering: own,
    }
}

/// The models cut for islands, by their keys, with the bodies each was cut for, and spare
/// models and numberings to cut into. Every one-body key's model is kept (a body alone again
/// shares it, however long after), the multi-body keys' up to [`MULTI_BODY_PARTS`], the
/// oldest put leaving first (those taken again mostly are within a few rounds): the models
/// that leave, and those dropped when the pool starts empty again, become spares once no
/// island holds them, up to [`SPARE_PARTS`], and the cuts reuse their buffers.
#[derive(Default)]
pub(super) struct Pool {
    models: HashMap<Key, (Arc<Model>, Vec<usize>)>,
    /// The multi-body keys held, oldest put first.
    multi: VecDeque<Key>,
    /// Models no island holds, to cut into, with their numbers of bodies.
    spares: Vec<(usize, Arc<Model>)>,
    /// Numberings of islands that ended, to write into.
    numberings: Vec<Numbering>,
    /// Scratch: the key of the island being formed.
    key: Key,
}

/// The pool keeps up to this many multi-body keys' models (measured on 1,000 spheres,
/// docs/benchmarks.md §16, when each island had a model of its own: 0, 16, 32, 64 and 128
/// formed the islands in 273.6, 271.7, 271.0, 273.1 and 274.1 M instructions: fewer pool
/// hits, or fewer spares).
const MULTI_BODY_PARTS: usize = 32;

/// The pool keeps up to this many spare models (16 and 256 instead of 64: 275.6 and 271.1 M
/// instructions instead of 271.0 M, measured as above).
const SPARE_PARTS: usize = 64;

/// The pool keeps up to this many numberings of islands that ended.
const SPARE_NUMBERINGS: usize = 4096;

impl Pool {
    /// The part of the island of the scene bodies `bodies` (sorted): the model of its key from
    /// the pool (`true`), or cut by `cutter` from the scene's model `m` into a spare model's
    /// buffers if there is one (else into new ones) and put in the pool; its numbering written
    /// into the buffers of an ended island's. Beyond `limit` models the pool starts empty
    /// again.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn part(
        &mut self,
        params: &Parameters,
        cutter: &mut ModelCutter,
        m: &Model,
        joint_coords: &[(usize, usize)],
        bodies: &[usize],
        limit: usize,
    ) -> (Compiled, bool) {
        let mut own = self.numberings.pop().unwrap_or_default();
        cutter.key_into(bodies, &mut self.key);
        if let Some((model, _)) = self.models.get(&self.key) {
            let model = Arc::clone(model);
            cutter.number_into(m, joint_coords, bodies, &model, &mut own);
            return (Compiled { model, numbering: own }, true);
        }
        let mut model = self
            .take_spare(bodies.len())
            .unwrap_or_else(|| Arc::new(empty_model(params)));
        // (a spare is held by no one: nothing is cloned)
        let out = Arc::make_mut(&mut model);
        cutter.cut_into(params, m, joint_coords, bodies, out, &mut own);
        self.keep(Arc::clone(&model), bodies, limit);
        (Compiled { model, numbering: own }, false)
    }

    /// Takes back the part of an island that ended: its numbering's buffers, and its model as
    /// a spare if the pool no longer holds it and no other island does.
    pub(super) fn put_back(&mut self, part: Compiled) {
        if self.numberings.len() < SPARE_NUMBERINGS {
            self.numberings.push(part.numbering);
        }
        self.spare(part.model);
    }

    /// The keys of the models the pool holds, with the bodies each was cut for.
    #[cfg(test)]
    pub(super) fn keys(&self) -> impl Iterator<Item = (&Key, &Vec<usize>)> {
        self.models.iter().map(|(k, (_, bodies))| (k, bodies))
    }

    /// The spare model of the fewest bodies from `n` on (whose buffers are most likely large
    /// enough), else of the most.
    fn take_spare(&mut self, n: usize) -> Option<Arc<Model>> {
        let fit = |&(m, _): &(usize, Arc<Model>)| if m >= n { m - n } else { usize::MAX - m };
        let (i, _) = self.spares.iter().enumerate().min_by_key(|(_, s)| fit(s))?;
        Some(self.spares.swap_remove(i).1)
    }

    /// Keeps `model` as a spare, if no one else holds it and there is room.
    fn spare(&mut self, model: Arc<Model>) {
        if Arc::strong_count(&model) == 1 && self.spares.len() < SPARE_PARTS {
            self.spares.push((model.bodies.len(), model));
        }
    }

    /// Puts `model`, cut for `bodies`, in the pool under the present key.
    fn keep(&mut self, model: Arc<Model>, bodies: &[usize], limit: usize) {
        if self.models.len() >= limit {
            self.multi.clear();
            for (_, (old, _)) in std::mem::take(&mut self.models) {
                self.spare(old);
            }
        }
        let key = self.key.clone();
        if key.len() > 1 {
            self.multi.push_back(key.clone());
            if self.multi.len() > MULTI_BODY_PARTS {
                if let Some((old, _)) = self.multi.pop_front().and_then(|k| self.models.remove(&k)) {
                    self.spare(old);
                }
            }
        }
        self.models.insert(key, (model, bodies.to_vec()));
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::tests::{on_64_spheres, snapshot};
    use super::Compiled;

    /// Every model the pool holds after islands merged and split is the one cutting gives
    /// for the bodies it was cut for (compared field by field through their debug form,
    /// which prints every number so that it reads back exactly), and every island's model is
    /// the one cut for its own bodies but for the names, with the same numbering against the
    /// scene.
    #[test]
    fn pooled_parts_are_those_compilation_gives() {
        on_64_spheres("pool test", |m, d, is| {
            is.advance(m, d, 0.02, false).unwrap();
            assert!(
                is.rebuilds > 0 && is.pooled > 0,
                "rebuilds {}, pooled {}",
                is.rebuilds,
                is.pooled
            );
            let pooled: Vec<_> = is.pool.models.values().cloned().collect();
            assert!(!pooled.is_empty());
            for (model, bodies) in &pooled {
                let fresh = super::fresh_cut(is, m, bodies);
                assert_eq!(format!("{model:?}"), format!("{:?}", fresh.model), "bodies {bodies:?}");
            }
            let (mut shared, mut own) = (0, 0);
            for k in 0..is.parts.len() {
                let bodies = d.partition.bodies(k).to_vec();
                let fresh = super::fresh_cut(is, m, &bodies);
                let island = &is.parts[k];
                let (model, unnamed_model) = (format!("{:?}", island.model), format!("{:?}", unnamed(&island.model)));
                assert_eq!(
                    unnamed_model,
                    format!("{:?}", unnamed(&fresh.model)),
                    "bodies {bodies:?}"
                );
                let numbering = &fresh.numbering;
                assert_eq!(island.numbering, *numbering);
                if model == format!("{:?}", fresh.model) {
                    own += 1;
                } else {
                    shared += 1;
                }
            }
            assert!(
                shared > 0 && own > 0,
                "{shared} islands with another's model, {own} with their own"
            );
        });
    }

    /// `model` with no names (those of its bodies, joints, loops, springs and contacts) and no
    /// initial coordinates of its joints (which an island does not read: its state is the
    /// scene's), what alike bodies differ in.
    pub(in super::super) fn unnamed(model: &crate::model::Model) -> crate::model::Model {
        let mut model = model.clone();
        model.bodies.iter_mut().for_each(|b| b.name.clear());
        model.joints.iter_mut().for_each(|j| {
            j.name.clear();
            j.q0 = [0.0; 7];
        });
        model.loops.iter_mut().for_each(|l| l.name.clear());
        model.springs.iter_mut().for_each(|s| s.name.clear());
        model.initial_contacts.iter_mut().for_each(|c| c.name.clear());
        model
    }

    /// Islands formed with the data (and integrators) of islands that ended take the same
    /// steps as islands formed with new data: on 64 grouped spheres that collide, every
    /// island's whole state (its integrator's included), the counters and the dissipated
    /// energy are the same bit for bit.
    #[test]
    fn reused_data_gives_the_trajectories_of_new_data() {
        let run = |spare_limit: usize| {
            on_64_spheres("reuse test", |m, d, is| {
                is.spare_limit = spare_limit;
                is.advance(m, d, 0.02, false).unwrap();
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

    /// Asserts that two parts of the island of `bodies` are the same: their models field by
    /// field through their debug form (which prints every number so that it reads back
    /// exactly, the sign of a zero too) and their numbering against the scene.
    pub(in super::super) fn assert_same_part(a: &Compiled, b: &Compiled, bodies: &[usize]) {
        assert_eq!(format!("{:?}", a.model), format!("{:?}", b.model), "bodies {bodies:?}");
        assert_eq!(a.numbering, b.numbering, "bodies {bodies:?}");
    }
}
