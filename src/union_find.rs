//! Union-find over indices 0..n (path halving, the smaller root wins, so a set's root is its
//! first member): which bodies move together, for the islands and for the outputs a motion
//! input moves.

/// Disjoint sets of `0..n`.
pub struct UnionFind(Vec<usize>);

impl UnionFind {
    /// `n` sets of one element each.
    pub fn new(n: usize) -> UnionFind {
        UnionFind((0..n).collect())
    }

    /// The root of `a`'s set (its smallest member).
    pub fn root(&mut self, mut a: usize) -> usize {
        while self.0[a] != a {
            self.0[a] = self.0[self.0[a]];
            a = self.0[a];
        }
        a
    }

    /// Joins the sets of `a` and `b` (nothing when either is None: the ground).
    pub fn join(&mut self, a: Option<usize>, b: Option<usize>) {
        if let (Some(a), Some(b)) = (a, b) {
            let (ra, rb) = (self.root(a), self.root(b));
            if ra != rb {
                self.0[ra.max(rb)] = ra.min(rb);
            }
        }
    }
}
