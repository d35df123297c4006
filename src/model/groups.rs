//! The contact groups a model holds: the group shapes in their bodies' frames, which groups
//! touch, the broad phase's settings, what each shape and group pair brings to a contact
//! element, and the candidate pairs at the initial configuration. The data holds the current
//! candidate pairs (`Data::candidates`, behind `Data::contacts[n_explicit..]`); the broad
//! phase that finds them is in the contact module (`broad.rs`).

use crate::model::contact::{LawConstants, OtherSide, SphereSide};
use crate::scene::BroadPhaseMethod;
use nalgebra::Vector3;

/// The bounding geometry of a group shape in its body's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bound {
    /// A ball of this radius around the centre (spheres, cylinder patches).
    Ball(f64),
    /// A rectangle: its two half side vectors.
    Rectangle(Vector3<f64>, Vector3<f64>),
}

/// A group shape as the broad phase sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct GroupShape {
    /// Body (None = ground).
    pub body: Option<usize>,
    /// Group index.
    pub group: usize,
    /// Centre of the bound, body frame.
    pub center: Vector3<f64>,
    /// The bound around it.
    pub bound: Bound,
}

/// One candidate pair: the contact element `n_explicit + k` for the `k`-th candidate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Candidate {
    /// Group pair (index of the `[[contact_group]]`).
    pub pair: usize,
    /// The sphere shape.
    pub sphere: usize,
    /// The other shape.
    pub other: usize,
}

/// The contact groups of a model (empty without `[[shape]]`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Groups {
    /// Every group shape, in scene order.
    pub shapes: Vec<GroupShape>,
    /// Number of groups.
    pub ngroups: usize,
    /// `touch[a * ngroups + b]`: the group pair whose spheres are in group `a` and whose other
    /// shapes are in group `b`.
    pub touch: Vec<Option<usize>>,
    /// Per group pair: its name.
    pub pair_names: Vec<String>,
    /// Per group pair: its two groups (the spheres', the other shapes').
    pub pair_groups: Vec<(usize, usize)>,
    /// Contact elements before the group contacts (the scene's `[[contact]]` entries).
    pub n_explicit: usize,
    /// The candidate pairs at the initial configuration (found by the broad phase there, or
    /// given), in the order of their contact elements.
    pub initial_candidates: Vec<Candidate>,
    /// Broad-phase margin \[m\].
    pub margin: f64,
    /// Algorithm.
    pub method: BroadPhaseMethod,
    /// Per body: the largest distance of a point of its group shapes' bounds from its centre
    /// of mass (0: no group shape).
    pub reach: Vec<f64>,
    /// Per body: carries a group shape.
    pub has_shape: Vec<bool>,
    /// The candidate list is made again once a body's shapes moved this fraction of the
    /// margin ([`STALE_FRACTION`]; more for an island, see [`crate::islands`]).
    pub stale_fraction: f64,
    /// Per shape: what it brings to a contact element as the sphere of a pair.
    pub sphere_sides: Vec<SphereSide>,
    /// Per shape: what it brings as the other shape.
    pub other_sides: Vec<OtherSide>,
    /// Per group pair: its law constants.
    pub laws: Vec<LawConstants>,
}

/// The fraction of the margin a body's shapes may move before the candidate list is made
/// again (the steps are bounded so that none moves half of it).
pub const STALE_FRACTION: f64 = 0.25;

impl Groups {
    /// True when the model has group shapes.
    pub fn is_active(&self) -> bool {
        !self.initial_candidates.is_empty() || !self.shapes.is_empty()
    }

    /// True when `c` is a pair the broad phase may list: one of the group pairs, a shape of
    /// each of its two groups, on two bodies (or a body and the ground), the lower shape first
    /// where both groups are one (a saved state's pairs are checked by it).
    pub fn is_candidate(&self, c: &Candidate) -> bool {
        let (Some(a), Some(b)) = (self.shapes.get(c.sphere), self.shapes.get(c.other)) else {
            return false;
        };
        self.pair_groups.get(c.pair) == Some(&(a.group, b.group))
            && a.body != b.body
            && (a.group != b.group || c.sphere < c.other)
    }

    /// The name of candidate pair `c`'s contact: `<group pair>[<sphere>:<other>]` (1-based
    /// shape numbers).
    pub fn element_name(&self, c: &Candidate) -> String {
        format!("{}[{}:{}]", self.pair_names[c.pair], c.sphere + 1, c.other + 1)
    }
}
