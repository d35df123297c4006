//! The compiled part of an island (its model and how it maps onto the scene), and the pool
//! that keeps it when the island ends: an island formed again from the same bodies — a
//! sphere alone again after a collision, a pair that meets again, whatever its candidate
//! pairs — takes its model from there instead of cutting it from the scene's model anew. A
//! model depends on nothing else (the scene and the parameter values are the islands' own),
//! so a pooled model is the one cutting would give, and the results do not depend on the
//! pool.

use super::cut_model::ModelCutter;
use super::Source;
use crate::compile::Parameters;
use crate::model::groups::Groups;
use crate::model::{nq_of, nv_of, Model, Plan};
use nalgebra::Vector3;
use rustc_hash::FxHashMap as HashMap;
use std::collections::VecDeque;

/// An island's model and its numbering against the scene's.
pub(super) struct Compiled {
    /// The island's model.
    pub(super) model: Model,
    /// (island, scene) index pairs of the position and velocity coordinates.
    pub(super) coords: Vec<(usize, usize)>,
    /// The scene's index of each of the island's declared contacts.
    pub(super) explicit: Vec<usize>,
    /// (island, scene) index pairs of the input values.
    pub(super) inputs: Vec<(usize, usize)>,
    /// (island, scene) index pairs of the driven joints' coordinates and rates.
    pub(super) driven: Vec<(usize, usize)>,
    /// The scene's index of each of the island's group shapes (sorted).
    pub(super) shapes: Vec<usize>,
}

/// An island's bodies (scene numbering, sorted): what its model is cut from.
pub(super) type Key = Vec<usize>;

impl Compiled {
    /// A part with nothing in it (to cut into).
    pub(super) fn empty(params: &Parameters) -> Compiled {
        Compiled {
            model: Model {
                name: String::new(),
                gravity: Vector3::zeros(),
                bodies: Vec::new(),
                joints: Vec::new(),
                scene_joint: Vec::new(),
                loops: Vec::new(),
                drives: Vec::new(),
                springs: Vec::new(),
                initial_contacts: Vec::new(),
                groups: Groups::default(),
                inputs: Vec::new(),
                input_value: Vec::new(),
                input_start: Vec::new(),
                nq: 0,
                nv: 0,
                quaternions: Vec::new(),
                trees: Vec::new(),
                tree_block: Vec::new(),
                dof_joint: Vec::new(),
                dof_parent: Vec::new(),
                plan: Plan::default(),
                solver: params.solver.clone(),
                baumgarte: 0.0,
                warnings: Vec::new(),
            },
            coords: Vec::new(),
            explicit: Vec::new(),
            inputs: Vec::new(),
            driven: Vec::new(),
            shapes: Vec::new(),
        }
    }
}

/// The part of the island of the bodies `key`: its model cut from the
/// scene's model `m` (compiled from `src` with the parameter values `params`) by `cutter`,
/// `joint_coords`: per scene body the first position and velocity index of its joint in the
/// scene's state.
#[cfg(test)]
pub(super) fn compile(
    src: &Source,
    params: &Parameters,
    cutter: &mut ModelCutter,
    m: &Model,
    joint_coords: &[(usize, usize)],
    key: &Key,
) -> Compiled {
    let mut part = Compiled::empty(params);
    cutter.cut_into(src.scene, params, m, joint_coords, key, &mut part);
    part
}

/// Writes into `part` (its buffers kept) the numbering against the scene's model `m` of its
/// model, that of an island of `bodies` with the scene's inputs `scene_inputs`
/// ([`Compiled::coords`], [`Compiled::inputs`] and [`Compiled::driven`]).
pub(super) fn numbering(
    m: &Model,
    joint_coords: &[(usize, usize)],
    bodies: &[usize],
    scene_inputs: &[usize],
    part: &mut Compiled,
) {
    let Compiled {
        model,
        coords,
        inputs,
        driven,
        ..
    } = part;
    let nq = model.nq;
    coords.clear();
    coords.reserve(nq + model.nv);
    for j in &model.joints {
        let (qpos, qvel) = joint_coords[bodies[j.child]];
        coords.extend((0..nq_of(j.kind)).map(|k| (j.qpos + k, qpos + k)));
        coords.extend((0..nv_of(j.kind)).map(|k| (nq + j.qvel + k, qvel + k)));
    }
    inputs.clear();
    for &g in scene_inputs {
        for v in m.input_range(g) {
            inputs.push((inputs.len(), v));
        }
    }
    // a drive's coordinates: the scene's state index of the island's
    let scene_index = |l: usize| coords.iter().find(|&&(a, _)| a == l).map(|&(_, b)| b);
    driven.clear();
    driven.extend(
        model
            .drives
            .iter()
            .flat_map(|dr| [dr.qpos, nq + dr.qvel])
            .filter_map(|l| Some((l, scene_index(l)?))),
    );
}

/// The part [`compile`] gives, made the former way: the island's part of the scene cut
/// (`cut.rs`) and compiled (the oracle of the tests).
#[cfg(test)]
pub(super) fn compile_cut_scene(
    src: &Source,
    params: &Parameters,
    index: &super::cut::SceneIndex,
    m: &Model,
    joint_coords: &[(usize, usize)],
    key: &Key,
) -> Result<Compiled, String> {
    let cut = super::cut::cut(src.scene, params, index, key, &[]);
    let mut model = crate::compile::compile_model(&cut.scene, &cut.params, src.origin, Some(&[]))
        .map_err(|e| format!("an island could not be compiled: {e}"))?;
    model.groups.stale_fraction = super::ISLAND_STALE_FRACTION;
    let mut part = Compiled {
        model,
        coords: Vec::new(),
        explicit: cut.explicit,
        inputs: Vec::new(),
        driven: Vec::new(),
        shapes: cut.shapes,
    };
    numbering(m, joint_coords, key, &cut.inputs, &mut part);
    Ok(part)
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

    /// The part of the island of the bodies `key` cut by `cutter` (as [`compile`] does, from
    /// the same arguments) into a spare part's buffers, if there is one.
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
            for (key, part) in &is.pool.parts {
                let fresh = super::compile(src, &is.params, &mut is.cutter, m, &is.joint_coords, key);
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
