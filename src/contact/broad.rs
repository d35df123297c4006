//! The broad phase: the pairs of a model's group shapes ([`crate::model::groups`]) within
//! reach (sweep and prune along x, or a uniform grid).
//!
//! The data holds the contacts of the group pairs as ordinary contact elements
//! (`Data::contacts[n_explicit..]`, the model's `initial_contacts` at the start), one per
//! *candidate*: a pair of shapes whose bounding boxes, each grown by half the margin, overlap
//! at the configuration where the list was made (the reference poses, `Data::broad_reference`).
//! A pair left out is farther apart than the margin there, so it cannot touch while every
//! body's shapes have moved less than half the margin: the engine bounds each step so that no
//! body's shapes move farther than that (`groups::time_to_margin`), stops once one has moved a
//! quarter of it (`groups::stale`), and the caller then makes the list again at the present
//! configuration, in the data, the model unchanged (`groups::find_candidates`, then
//! `elements::set_contact_list`, which carries each listed pair's memory over).

pub use crate::model::groups::{Bound, Candidate, GroupShape, Groups, STALE_FRACTION};
use crate::scene::BroadPhaseMethod;
use nalgebra::{Matrix3, Vector3};

impl Groups {
    /// The element (sphere, other, pair) for shapes `i` and `j` whose boxes overlap, if their
    /// groups touch and, for two balls, their bounds come within the margin.
    fn pair_of(&self, i: usize, j: usize, boxes: &[[Vector3<f64>; 2]]) -> Option<Candidate> {
        let (a, b) = (&self.shapes[i], &self.shapes[j]);
        if a.body == b.body {
            return None;
        }
        if let (Bound::Ball(ra), Bound::Ball(rb)) = (a.bound, b.bound) {
            // the box centres are the balls' centres
            let (ca, cb) = (boxes[i][0] + boxes[i][1], boxes[j][0] + boxes[j][1]);
            let reach = ra + rb + self.margin;
            if (ca - cb).norm_squared() > 4.0 * reach * reach {
                return None;
            }
        }
        let n = self.ngroups;
        if a.group == b.group {
            let pair = self.touch[a.group * n + a.group]?;
            return Some(Candidate {
                pair,
                sphere: i.min(j),
                other: i.max(j),
            });
        }
        if let Some(pair) = self.touch[a.group * n + b.group] {
            return Some(Candidate {
                pair,
                sphere: i,
                other: j,
            });
        }
        self.touch[b.group * n + a.group].map(|pair| Candidate {
            pair,
            sphere: j,
            other: i,
        })
    }

    /// World bounding box (min, max) of shape `s` at pose `(pos, rot)`, grown by `grow`.
    fn aabb(&self, s: &GroupShape, pos: &Vector3<f64>, rot: &Matrix3<f64>, grow: f64) -> [Vector3<f64>; 2] {
        let c = pos + rot * s.center;
        let half = match s.bound {
            Bound::Ball(r) => Vector3::repeat(r),
            Bound::Rectangle(u, v) => (rot * u).abs() + (rot * v).abs(),
        } + Vector3::repeat(grow);
        [c - half, c + half]
    }

    /// Every shape's bounding box at the body poses `pose(body)`, grown by half the margin.
    fn grown_boxes(&self, pose: &dyn Fn(Option<usize>) -> (Vector3<f64>, Matrix3<f64>)) -> Vec<[Vector3<f64>; 2]> {
        self.shapes
            .iter()
            .map(|s| {
                let (p, r) = pose(s.body);
                self.aabb(s, &p, &r, 0.5 * self.margin)
            })
            .collect()
    }

    /// The candidate pairs at the body poses `pose(body)` (position of the centre of mass,
    /// rotation), sorted (pair, sphere, other): every pair whose bounding boxes, grown by
    /// half the margin each, overlap (and, for two ball bounds, whose balls come within the
    /// margin).
    pub fn find(&self, pose: &dyn Fn(Option<usize>) -> (Vector3<f64>, Matrix3<f64>)) -> Vec<Candidate> {
        let boxes = self.grown_boxes(pose);
        let mut out = match self.method {
            BroadPhaseMethod::Sweep => self.sweep(&boxes),
            BroadPhaseMethod::Grid => self.grid(&boxes),
        };
        out.sort_unstable();
        out
    }

    /// Sweep and prune along x: boxes sorted by their lower x; each is tested against the
    /// boxes still open at its lower end.
    fn sweep(&self, boxes: &[[Vector3<f64>; 2]]) -> Vec<Candidate> {
        let mut order: Vec<usize> = (0..boxes.len()).collect();
        order.sort_unstable_by(|&a, &b| boxes[a][0].x.total_cmp(&boxes[b][0].x));
        let mut open: Vec<usize> = Vec::new();
        let mut out = Vec::new();
        for &i in &order {
            let lo = boxes[i][0].x;
            open.retain(|&j| boxes[j][1].x >= lo);
            for &j in &open {
                if overlap_yz(&boxes[i], &boxes[j]) {
                    if let Some(c) = self.pair_of(i, j, boxes) {
                        out.push(c);
                    }
                }
            }
            open.push(i);
        }
        out
    }

    /// Uniform grid: cells of twice the size of the largest box of a ball bound (at least
    /// the margin). Each box is entered into the cells it covers (one sorted list of (cell, box)),
    /// and a pair is reported by the first cell the two share; a box that would cover more
    /// than [`GRID_LARGE`] cells (a wall much larger than the spheres) is tested against every
    /// other box instead.
    fn grid(&self, boxes: &[[Vector3<f64>; 2]]) -> Vec<Candidate> {
        let mut cell = self.margin;
        for (s, b) in self.shapes.iter().zip(boxes) {
            if matches!(s.bound, Bound::Ball(_)) {
                cell = cell.max((b[1] - b[0]).max());
            }
        }
        // (a box as large as its cell covers two cells along each axis, eight in all; one of
        // half its cell covers 1.5³ ≈ 3.4 on average: a shorter list to sort for more pairs
        // tested per cell; the list of pairs is the same at any size)
        cell *= GRID_CELL_FACTOR;
        let lo: Vector3<f64> = boxes.iter().fold(Vector3::repeat(f64::INFINITY), |a, b| a.inf(&b[0]));
        let index = |x: &Vector3<f64>| -> [u64; 3] {
            let r = (x - lo) / cell;
            [r.x as u64, r.y as u64, r.z as u64]
        };
        let key = |c: [u64; 3]| (c[0] << 42) | (c[1] << 21) | c[2];
        // the boxes' cell ranges (None: tested against every other box)
        let ranges: Vec<Option<([u64; 3], [u64; 3])>> = boxes
            .iter()
            .map(|b| {
                let (a, z) = (index(&b[0]), index(&b[1]));
                let cells = (z[0] - a[0] + 1) * (z[1] - a[1] + 1) * (z[2] - a[2] + 1);
                (cells <= GRID_LARGE && z.iter().all(|&c| c < 1 << 21)).then_some((a, z))
            })
            .collect();
        let large: Vec<usize> = (0..boxes.len()).filter(|&i| ranges[i].is_none()).collect();
        let entries = sorted_cell_entries(&ranges, key, GRID_COUNTING_CELLS);
        let mut out = Vec::new();
        let mut start = 0;
        while start < entries.len() {
            let k = entries[start].0;
            let mut end = start + 1;
            while end < entries.len() && entries[end].0 == k {
                end += 1;
            }
            for (n, &(_, i)) in entries[start..end].iter().enumerate() {
                for &(_, j) in &entries[start + n + 1..end] {
                    let (bi, bj) = (&boxes[i], &boxes[j]);
                    // (every comparison made, without an early exit: whether two boxes of a cell
                    // overlap is as likely as not, and a mispredicted branch costs more than
                    // the comparisons)
                    if (bi[0].x > bj[1].x) | (bj[0].x > bi[1].x) | !overlap_yz(bi, bj) {
                        continue;
                    }
                    // report once: in the cell of the lower corner of the boxes' common part
                    if key(index(&bi[0].sup(&bj[0]))) != k {
                        continue;
                    }
                    if let Some(c) = self.pair_of(i, j, boxes) {
                        out.push(c);
                    }
                }
            }
            start = end;
        }
        for (n, &l) in large.iter().enumerate() {
            for j in 0..boxes.len() {
                // a large box against the others, each pair of large boxes once
                if j == l || (large.contains(&j) && large[..=n].contains(&j)) {
                    continue;
                }
                let (bi, bj) = (&boxes[l], &boxes[j]);
                if bi[0].x <= bj[1].x && bj[0].x <= bi[1].x && overlap_yz(bi, bj) {
                    if let Some(c) = self.pair_of(l, j, boxes) {
                        out.push(c);
                    }
                }
            }
        }
        out
    }

    /// Every pair whose grown boxes overlap, by testing all pairs (for tests and as a
    /// reference).
    pub fn find_all_pairs(&self, pose: &dyn Fn(Option<usize>) -> (Vector3<f64>, Matrix3<f64>)) -> Vec<Candidate> {
        let boxes = self.grown_boxes(pose);
        let mut out = Vec::new();
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                let (bi, bj) = (&boxes[i], &boxes[j]);
                if bi[0].x <= bj[1].x && bj[0].x <= bi[1].x && overlap_yz(bi, bj) {
                    if let Some(c) = self.pair_of(i, j, &boxes) {
                        out.push(c);
                    }
                }
            }
        }
        out.sort_unstable();
        out
    }
}

/// The (cell key, box) entries of the boxes' cell ranges (`ranges`, in box order; None: left
/// out), sorted by cell key and box: by counting the entries per cell where the cells the
/// boxes span are at most `counting_cells` per entry (each box entered in order, so each
/// cell's boxes stay in ascending order), by a sort otherwise. `key` gives the key of a cell,
/// ascending with (x, y, z) in that order.
fn sorted_cell_entries(
    ranges: &[Option<([u64; 3], [u64; 3])>],
    key: impl Fn([u64; 3]) -> u64,
    counting_cells: u64,
) -> Vec<(u64, usize)> {
    let mut extent = [0u64; 3];
    let mut n = 0u64;
    for (a, z) in ranges.iter().flatten() {
        for k in 0..3 {
            extent[k] = extent[k].max(z[k] + 1);
        }
        n += (z[0] - a[0] + 1) * (z[1] - a[1] + 1) * (z[2] - a[2] + 1);
    }
    let cells = extent[0].saturating_mul(extent[1]).saturating_mul(extent[2]);
    let mut entries: Vec<(u64, usize)> = Vec::with_capacity(n as usize);
    if cells > counting_cells.saturating_mul(n.max(1)) {
        each_entry(ranges, |c, i| entries.push((key(c), i)));
        entries.sort_unstable();
        return entries;
    }
    let dense = |c: [u64; 3]| ((c[0] * extent[1] + c[1]) * extent[2] + c[2]) as usize;
    let mut start = vec![0usize; cells as usize + 1];
    each_entry(ranges, |c, _| start[dense(c) + 1] += 1);
    for k in 1..start.len() {
        start[k] += start[k - 1];
    }
    entries.resize(n as usize, (0, 0));
    each_entry(ranges, |c, i| {
        let slot = &mut start[dense(c)];
        entries[*slot] = (key(c), i);
        *slot += 1;
    });
    entries
}

/// `f(cell, box)` for each cell of each box's range (`ranges`, in box order; None: none).
fn each_entry(ranges: &[Option<([u64; 3], [u64; 3])>], mut f: impl FnMut([u64; 3], usize)) {
    for (i, r) in ranges.iter().enumerate() {
        if let Some((a, z)) = r {
            for x in a[0]..=z[0] {
                for y in a[1]..=z[1] {
                    for w in a[2]..=z[2] {
                        f([x, y, w], i);
                    }
                }
            }
        }
    }
}

/// The grid's entries are sorted by counting when the cells spanned number at most this many
/// per entry (a sparser grid than that is sorted). Counting took 183 M instructions instead of
/// the sort's 234 M in the broad phase of `bench islands --n 1000` (callgrind), and 290
/// instead of 330 µs (N = 1,000) and 948 instead of 1,151 µs (N = 3,000) a pass on the
/// lattice of `bench groups`.
const GRID_COUNTING_CELLS: u64 = 8;

/// The grid's cell over the largest sphere box. On 1,000 spheres in a box (`bench islands
/// --n 1000`, callgrind) the broad phase took 393 M instructions with 1 and 233 M with 2; on
/// the dense lattice of `bench groups` 382 → 338 µs at N = 1,000 and 1,540 → 1,180 µs at
/// N = 3,000 (both sorted by a sort, before [`sorted_cell_entries`] counted).
const GRID_CELL_FACTOR: f64 = 2.0;

/// Most grid cells a box may cover before the grid tests it against every box instead.
const GRID_LARGE: u64 = 64;

fn overlap_yz(a: &[Vector3<f64>; 2], b: &[Vector3<f64>; 2]) -> bool {
    // (without an early exit, see `Groups::grid`)
    (a[0].y <= b[1].y) & (b[0].y <= a[1].y) & (a[0].z <= b[1].z) & (b[0].z <= a[1].z)
}

#[cfg(test)]
mod tests {
    use super::sorted_cell_entries;

    /// Counting the entries per cell gives the order of sorting them by (cell key, box): on
    /// 300 random sets of cell ranges (some boxes left out), dense and sparse.
    #[test]
    fn counted_cell_entries_are_the_sorted_ones() {
        let mut x: u64 = 0x2545_f491_4f6c_dd1d;
        let mut next = |n: u64| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x % n
        };
        let key = |c: [u64; 3]| (c[0] << 42) | (c[1] << 21) | c[2];
        for case in 0..300 {
            let (boxes, span) = (1 + next(60), 1 + next(40));
            let ranges: Vec<_> = (0..boxes)
                .map(|_| {
                    (next(5) > 0).then(|| {
                        let a = [next(span), next(span), next(span)];
                        (a, a.map(|c| c + next(3)))
                    })
                })
                .collect();
            let counted = sorted_cell_entries(&ranges, key, u64::MAX);
            let sorted = sorted_cell_entries(&ranges, key, 0);
            assert!(sorted.windows(2).all(|w| w[0] < w[1]), "case {case}");
            assert_eq!(counted, sorted, "case {case}");
        }
    }
}
