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
use crate::model::{nq_of, nv_of, Drive, Model, TreeJoint};
use rustc_hash::FxHashMap as HashMap;

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

/// The part of the island of the bodies `key`: its model cut from the
/// scene's model `m` (compiled from `src` with the parameter values `params`) by `cutter`,
/// `joint_coords`: per scene body the first position and velocity index of its joint in the
/// scene's state.
pub(super) fn compile(
    src: &Source,
    params: &Parameters,
    cutter: &mut ModelCutter,
    m: &Model,
    joint_coords: &[(usize, usize)],
    key: &Key,
) -> Compiled {
    cutter.cut(src.scene, params, m, joint_coords, key)
}

/// An island's [`Compiled::coords`], [`Compiled::inputs`] and [`Compiled::driven`].
pub(super) type Numbering = (Vec<(usize, usize)>, Vec<(usize, usize)>, Vec<(usize, usize)>);

/// The numbering against the scene's model `m` of the model of an island of `bodies` whose
/// tree joints are `joints` (with `nq` position coordinates) and drives `drives`, with the
/// scene's inputs `scene_inputs`.
pub(super) fn numbering(
    m: &Model,
    joints: &[TreeJoint],
    nq: usize,
    drives: &[Drive],
    joint_coords: &[(usize, usize)],
    bodies: &[usize],
    scene_inputs: &[usize],
) -> Numbering {
    let nv: usize = joints.iter().map(|j| nv_of(j.kind)).sum();
    let mut coords = Vec::with_capacity(nq + nv);
    for j in joints {
        let (qpos, qvel) = joint_coords[bodies[j.child]];
        coords.extend((0..nq_of(j.kind)).map(|k| (j.qpos + k, qpos + k)));
        coords.extend((0..nv_of(j.kind)).map(|k| (nq + j.qvel + k, qvel + k)));
    }
    let mut inputs = Vec::new();
    for &g in scene_inputs {
        for v in m.input_range(g) {
            inputs.push((inputs.len(), v));
        }
    }
    // a drive's coordinates: the scene's state index of the island's
    let scene_index = |l: usize| coords.iter().find(|&&(a, _)| a == l).map(|&(_, b)| b);
    let driven = drives
        .iter()
        .flat_map(|dr| [dr.qpos, nq + dr.qvel])
        .filter_map(|l| Some((l, scene_index(l)?)))
        .collect();
    (coords, inputs, driven)
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
    let (coords, inputs, driven) = numbering(
        m,
        &model.joints,
        model.nq,
        &model.drives,
        joint_coords,
        key,
        &cut.inputs,
    );
    Ok(Compiled {
        model,
        coords,
        explicit: cut.explicit,
        inputs,
        driven,
        shapes: cut.shapes,
    })
}

/// The compiled parts of islands that ended, by their bodies.
#[derive(Default)]
pub(super) struct Pool {
    parts: HashMap<Key, Compiled>,
}

impl Pool {
    /// The part compiled for `key`, taken out of the pool (with the key), if there is one.
    pub(super) fn take(&mut self, key: &Key) -> Option<(Key, Compiled)> {
        self.parts.remove_entry(key)
    }

    /// The keys of the parts the pool holds.
    #[cfg(test)]
    pub(super) fn keys(&self) -> impl Iterator<Item = &Key> {
        self.parts.keys()
    }

    /// Keeps the part of an island that ended, its model's largest step count set back to
    /// `max_steps` (the parameter values': the rounds set it before every advance). Beyond
    /// `limit` parts the pool starts empty again.
    pub(super) fn put(&mut self, key: Key, mut part: Compiled, max_steps: u64, limit: usize) {
        if self.parts.len() >= limit {
            self.parts.clear();
        }
        part.model.solver.max_steps = max_steps;
        self.parts.insert(key, part);
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
