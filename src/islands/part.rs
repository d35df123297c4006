//! The compiled part of an island: its model, cut from the scene's (`cut_model.rs`), and how
//! its coordinates, inputs, contacts and shapes map onto the scene's.

use crate::compile::Parameters;
use crate::model::{nq_of, nv_of, Model};

/// An island's model and its numbering against the scene's.
pub(super) struct Compiled {
    /// The island's model (boxed: the pool, its spares and the islands move a pointer).
    pub(super) model: Box<Model>,
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
            model: Box::new(Model {
                solver: params.solver.clone(),
                ..Model::default()
            }),
            coords: Vec::new(),
            explicit: Vec::new(),
            inputs: Vec::new(),
            driven: Vec::new(),
            shapes: Vec::new(),
        }
    }
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

/// The part a cut gives (the tests' `pool::fresh_cut`), made the former way: the island's part of the scene cut
/// (`cut.rs`) and compiled (the oracle of the tests).
#[cfg(test)]
pub(super) fn compile_cut_scene(
    src: &super::Source,
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
        model: Box::new(model),
        coords: Vec::new(),
        explicit: cut.explicit,
        inputs: Vec::new(),
        driven: Vec::new(),
        shapes: cut.shapes,
    };
    numbering(m, joint_coords, key, &cut.inputs, &mut part);
    Ok(part)
}
