//! Small dense factorisations that work in caller-owned buffers, so that a step allocates
//! nothing: the tree-sparse `LᵀDL` of the per-tree mass-matrix blocks, Cholesky with diagonal
//! pivoting for the loop-constraint and contact Schur complements (a few dozen rows at most),
//! and LU with partial pivoting for the implicit integrators' iteration matrices. faer's
//! allocation-free API would need a scratch arena for matrices this small and nalgebra's
//! decompositions take ownership.

/// Dot product.
#[inline]
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Marks "no parent" in a branch-induced sparsity pattern.
pub const NO_PARENT: usize = usize::MAX;

/// Sparse `H = Lᵀ D L` factorisation of a symmetric positive definite row-major `n × n`
/// matrix whose sparsity follows a tree: `parent[k] < k` is the previous degree of freedom on
/// the path of `k` to the root (or [`NO_PARENT`]), and `H[k][i] ≠ 0` only when `i` is `k` or an
/// ancestor of `k` (Featherstone's LTDL). Working from the leaves up creates no fill-in, so
/// the cost is O(n d²) for depth d instead of O(n³), and only the lower entries on ancestor
/// paths are read or written. L (unit, strictly lower) and D (diagonal) overwrite `h`.
/// Returns false if a pivot is not positive.
#[inline(always)]
pub fn ltdl_in_place(h: &mut [f64], n: usize, parent: &[usize]) -> bool {
    ltdl_rows(h, n, parent, |_| false)
}

/// [`ltdl_in_place`] over the rows that `skip` does not name (their rows of `h` are left as
/// they are; no other row may descend from them).
#[inline(always)]
fn ltdl_rows(h: &mut [f64], n: usize, parent: &[usize], skip: impl Fn(usize) -> bool) -> bool {
    let parent = &parent[..n];
    for k in (0..n).rev() {
        if skip(k) {
            continue;
        }
        // row k, and the rows before it (its ancestors' rows: parent[k] < k)
        let (head, tail) = h[..n * n].split_at_mut(k * n);
        let hk = &mut tail[..n];
        let hkk = hk[k];
        if hkk.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return false;
        }
        let mut i = parent[k];
        while i != NO_PARENT {
            let a = hk[i] / hkk;
            let hi = &mut head[i * n..i * n + n];
            let mut j = i;
            while j != NO_PARENT {
                hi[j] -= a * hk[j];
                j = parent[j];
            }
            hk[i] = a;
            i = parent[i];
        }
    }
    true
}

/// Solves `Lᵀ D L x = b` in place with a factor from [`ltdl_in_place`].
#[inline(always)]
pub fn ltdl_solve(l: &[f64], n: usize, parent: &[usize], x: &mut [f64]) {
    ltdl_solve_rows(l, n, parent, x, |_| false);
}

/// [`ltdl_solve`] with the off-diagonal entries of the rows that `skip` names left out (the
/// caller applies them: [`ltdl_solve_leaves`]).
#[inline(always)]
fn ltdl_solve_rows(l: &[f64], n: usize, parent: &[usize], x: &mut [f64], skip: impl Fn(usize) -> bool) {
    let (parent, x) = (&parent[..n], &mut x[..n]);
    for i in (0..n).rev() {
        if skip(i) {
            continue;
        }
        let (li, xi) = (&l[i * n..i * n + n], x[i]);
        let mut j = parent[i];
        while j != NO_PARENT {
            x[j] -= li[j] * xi;
            j = parent[j];
        }
    }
    for i in 0..n {
        x[i] /= l[i * n + i];
    }
    for i in 0..n {
        if skip(i) {
            continue;
        }
        let li = &l[i * n..i * n + n];
        let mut j = parent[i];
        let mut s = x[i];
        while j != NO_PARENT {
            s -= li[j] * x[j];
            j = parent[j];
        }
        x[i] = s;
    }
}

/// Leaves of a tree-sparse matrix (rows no other row descends from, see [`ltdl_in_place`])
/// whose rows are constant: their rows of the `LᵀDL` factor are then constant too, and so is
/// what their elimination subtracts from their ancestors' rows (`D L[k][i] L[k][j]`, summed over
/// the leaves). [`ltdl_in_place_leaves`] skips them and subtracts that sum instead;
/// [`ltdl_solve_leaves`] runs through their nonzero entries only. Their factor rows are written
/// into the matrix once ([`ConstantLeaves::write`]) and left alone afterwards.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ConstantLeaves {
    /// Per row: whether it is such a leaf (empty when there is none).
    pub is_leaf: Vec<bool>,
    /// The leaves and their pivots: (row, D).
    pub pivots: Vec<(usize, f64)>,
    /// The leaves' nonzero entries of L below the diagonal: (row, column, L[row][column]).
    pub factor: Vec<(usize, usize, f64)>,
    /// What their elimination subtracts from the lower entries of the other rows: (row,
    /// column, Σ D L\[k\]\[row\] L\[k\]\[column\]).
    pub update: Vec<(usize, usize, f64)>,
}

/// A constant leaf for [`ConstantLeaves::new`]: its row, its pivot `D` and the nonzero entries
/// `(column, L)` of its factor row.
pub type LeafRow = (usize, f64, Vec<(usize, f64)>);

impl ConstantLeaves {
    /// The leaves of an `n × n` tree-sparse matrix, each as its row, pivot `D` and the nonzero
    /// entries `(column, L)` of its factor row (columns: its ancestors). The caller guarantees
    /// that each is a leaf whose matrix row is `D` on the diagonal and `D L` at the columns
    /// given, zero elsewhere.
    pub fn new(n: usize, leaves: &[LeafRow]) -> ConstantLeaves {
        let mut c = ConstantLeaves::default();
        if leaves.is_empty() {
            return c;
        }
        c.is_leaf = vec![false; n];
        let mut update = vec![0.0; n * n];
        for (k, dk, row) in leaves {
            c.is_leaf[*k] = true;
            c.pivots.push((*k, *dk));
            for &(i, li) in row {
                c.factor.push((*k, i, li));
                for &(j, lj) in row {
                    if j <= i {
                        update[i * n + j] += dk * li * lj;
                    }
                }
            }
        }
        c.update = (0..n * n)
            .filter(|&e| update[e] != 0.0)
            .map(|e| (e / n, e % n, update[e]))
            .collect();
        c
    }
    /// True when there are no constant leaves.
    pub fn is_empty(&self) -> bool {
        self.pivots.is_empty()
    }
    /// Writes the leaves' factor rows (D on the diagonal, L below it, zero elsewhere) into the
    /// row-major `n × n` block `h`.
    pub fn write(&self, h: &mut [f64], n: usize) {
        for &(k, dk) in &self.pivots {
            h[k * n..(k + 1) * n].iter_mut().for_each(|x| *x = 0.0);
            h[k * n + k] = dk;
        }
        for &(k, i, l) in &self.factor {
            h[k * n + i] = l;
        }
    }
}

/// [`ltdl_in_place`] with constant leaves: their rows of `h` must already hold their factor
/// rows ([`ConstantLeaves::write`]), which are left as they are; the other rows are those of
/// the matrix. The factor equals [`ltdl_in_place`]'s to rounding.
#[inline(always)]
pub fn ltdl_in_place_leaves(h: &mut [f64], n: usize, parent: &[usize], leaves: &ConstantLeaves) -> bool {
    if leaves.is_empty() {
        return ltdl_in_place(h, n, parent);
    }
    for &(i, j, u) in &leaves.update {
        h[i * n + j] -= u;
    }
    let is_leaf = &leaves.is_leaf[..n];
    ltdl_rows(h, n, parent, |k| is_leaf[k])
}

/// [`ltdl_solve`] with a factor from [`ltdl_in_place_leaves`]: the leaves' rows through their
/// nonzero entries (a leaf's value is final before its ancestors' in the first pass, and
/// depends on them in the last).
#[inline(always)]
pub fn ltdl_solve_leaves(l: &[f64], n: usize, parent: &[usize], leaves: &ConstantLeaves, x: &mut [f64]) {
    if leaves.is_empty() {
        return ltdl_solve(l, n, parent, x);
    }
    for &(k, i, lki) in &leaves.factor {
        x[i] -= lki * x[k];
    }
    let is_leaf = &leaves.is_leaf[..n];
    ltdl_solve_rows(l, n, parent, x, |i| is_leaf[i]);
    for &(k, i, lki) in &leaves.factor {
        x[k] -= lki * x[i];
    }
}

/// Cholesky with diagonal pivoting of a symmetric positive semi-definite row-major matrix,
/// in place: `P A Pᵀ = L Lᵀ` for the leading `rank` pivots. Factorisation stops when the
/// largest remaining diagonal falls below `rel_tol` times the largest initial diagonal; the
/// rows left over are (numerically) dependent on the others. Returns the rank.
pub fn pivoted_cholesky_in_place(a: &mut [f64], n: usize, perm: &mut [usize], rel_tol: f64) -> usize {
    for (i, p) in perm.iter_mut().enumerate().take(n) {
        *p = i;
    }
    let max0 = (0..n).map(|i| a[i * n + i]).fold(0.0_f64, f64::max);
    if max0 <= 0.0 {
        return 0;
    }
    let tol = rel_tol * max0;
    for j in 0..n {
        // pick the largest remaining diagonal
        let (mut best, mut bv) = (j, f64::NEG_INFINITY);
        for i in j..n {
            let v = a[i * n + i];
            if v > bv {
                best = i;
                bv = v;
            }
        }
        if bv <= tol {
            return j;
        }
        if best != j {
            perm.swap(j, best);
            for k in 0..n {
                a.swap(j * n + k, best * n + k);
            }
            for k in 0..n {
                a.swap(k * n + j, k * n + best);
            }
        }
        let l = a[j * n + j].sqrt();
        a[j * n + j] = l;
        for i in j + 1..n {
            a[i * n + j] /= l;
        }
        for i in j + 1..n {
            let lij = a[i * n + j];
            for k in j + 1..=i {
                a[i * n + k] -= lij * a[k * n + j];
            }
            for k in j + 1..i {
                a[k * n + i] = a[i * n + k];
            }
        }
    }
    n
}

/// Solves with the leading `rank` pivots of [`pivoted_cholesky_in_place`]; the unknowns of
/// dropped (dependent) rows are set to zero. `work` has length `n`.
pub fn pivoted_cholesky_solve(l: &[f64], n: usize, perm: &[usize], rank: usize, x: &mut [f64], work: &mut [f64]) {
    gather(perm, n, x, work);
    forward_substitute::<false>(l, n, rank, work);
    back_substitute::<true>(l, n, rank, work);
    for w in work.iter_mut().take(n).skip(rank) {
        *w = 0.0;
    }
    for i in 0..n {
        x[perm[i]] = work[i];
    }
}

/// The row of `k..n` whose `magnitude` is largest (the first of equals): the pivot of column
/// `k`; None when that magnitude is zero or not finite (singular to working precision).
#[inline(always)]
fn pivot_row(k: usize, n: usize, magnitude: impl Fn(usize) -> f64) -> Option<usize> {
    let mut piv = k;
    let mut best = magnitude(k);
    for i in k + 1..n {
        let v = magnitude(i);
        if v > best {
            best = v;
            piv = i;
        }
    }
    (best > 0.0 && best.is_finite()).then_some(piv)
}

/// Factors the row-major `n × n` matrix `a` in place as `P·A = L·U` (unit lower `L` below the
/// diagonal, `U` on and above it); `perm[i]` is the original row now in row `i`. Returns
/// false when a pivot is zero or not finite (the matrix is singular to working precision).
pub fn lu_in_place(a: &mut [f64], n: usize, perm: &mut [usize]) -> bool {
    debug_assert!(a.len() >= n * n && perm.len() >= n);
    for (i, p) in perm.iter_mut().enumerate().take(n) {
        *p = i;
    }
    for k in 0..n {
        let Some(piv) = pivot_row(k, n, |i| a[i * n + k].abs()) else {
            return false;
        };
        if piv != k {
            for j in 0..n {
                a.swap(k * n + j, piv * n + j);
            }
            perm.swap(k, piv);
        }
        let d = a[k * n + k];
        let (top, rest) = a[..n * n].split_at_mut((k + 1) * n);
        let uk = &top[k * n + k + 1..];
        for ri in rest.chunks_exact_mut(n) {
            let l = ri[k] / d;
            ri[k] = l;
            if l != 0.0 {
                for (x, u) in ri[k + 1..].iter_mut().zip(uk) {
                    *x -= l * u;
                }
            }
        }
    }
    true
}

/// Solves `A·x = b` with the factors from [`lu_in_place`]; `x` holds `b` on entry and the
/// solution on return, `work` is scratch of length `n`.
pub fn lu_solve(lu: &[f64], n: usize, perm: &[usize], x: &mut [f64], work: &mut [f64]) {
    gather(perm, n, x, work);
    forward_substitute::<true>(lu, n, n, work);
    back_substitute::<false>(lu, n, n, work);
    x[..n].copy_from_slice(&work[..n]);
}

/// `work[i] = x[perm[i]]` for `i < n`.
fn gather(perm: &[usize], n: usize, x: &[f64], work: &mut [f64]) {
    for i in 0..n {
        work[i] = x[perm[i]];
    }
}

/// Solves `L w' = w` in place with the lower triangle of the leading `m × m` block of the
/// row-major `n × n` matrix `l`; its diagonal is taken as 1 when `UNIT`.
fn forward_substitute<const UNIT: bool>(l: &[f64], n: usize, m: usize, w: &mut [f64]) {
    for i in 0..m {
        let row = &l[i * n..i * n + i + 1];
        let (done, rest) = w.split_at_mut(i);
        let mut s = rest[0];
        for (a, x) in row[..i].iter().zip(done.iter()) {
            s -= a * x;
        }
        rest[0] = if UNIT { s } else { s / row[i] };
    }
}

/// Solves `U w' = w` in place with `U` the upper triangle of the leading `m × m` block of the
/// row-major `n × n` matrix `a`, or, when `TRANSPOSED`, the transpose of its lower triangle.
fn back_substitute<const TRANSPOSED: bool>(a: &[f64], n: usize, m: usize, w: &mut [f64]) {
    for i in (0..m).rev() {
        let (head, done) = w[..m].split_at_mut(i + 1);
        let mut s = head[i];
        if TRANSPOSED {
            for (k, x) in (i + 1..m).zip(done.iter()) {
                s -= a[k * n + i] * x;
            }
        } else {
            for (u, x) in a[i * n + i + 1..i * n + m].iter().zip(done.iter()) {
                s -= u * x;
            }
        }
        head[i] = s / a[i * n + i];
    }
}

/// Factors the row-major complex `n × n` matrix `a` in place as `P·A = L·U` (as
/// [`lu_in_place`]), stored split: entry `(i, j)` is `a[i n + j] + i·a[n² + i n + j]` (the
/// real parts, then the imaginary parts, so that the row updates run over contiguous real
/// arrays). Pivots by the largest squared modulus. Returns false when a pivot is zero or
/// not finite.
pub fn lu_in_place_complex(a: &mut [f64], n: usize, perm: &mut [usize]) -> bool {
    debug_assert!(a.len() >= 2 * n * n && perm.len() >= n);
    for (i, p) in perm.iter_mut().enumerate().take(n) {
        *p = i;
    }
    let (re, im) = a[..2 * n * n].split_at_mut(n * n);
    for k in 0..n {
        let modulus2 = |i: usize| re[i * n + k] * re[i * n + k] + im[i * n + k] * im[i * n + k];
        let Some(piv) = pivot_row(k, n, modulus2) else {
            return false;
        };
        if piv != k {
            for j in 0..n {
                re.swap(k * n + j, piv * n + j);
                im.swap(k * n + j, piv * n + j);
            }
            perm.swap(k, piv);
        }
        // 1/d
        let (dr, di) = (re[k * n + k], im[k * n + k]);
        let d2 = dr * dr + di * di;
        let (ir, ii) = (dr / d2, -di / d2);
        let (re_top, re_rest) = re.split_at_mut((k + 1) * n);
        let (im_top, im_rest) = im.split_at_mut((k + 1) * n);
        let (uk_re, uk_im) = (&re_top[k * n + k + 1..], &im_top[k * n + k + 1..]);
        for (ri_re, ri_im) in re_rest.chunks_exact_mut(n).zip(im_rest.chunks_exact_mut(n)) {
            let (xr, xi) = (ri_re[k], ri_im[k]);
            let (lr, li) = (xr * ir - xi * ii, xr * ii + xi * ir);
            ri_re[k] = lr;
            ri_im[k] = li;
            if lr != 0.0 || li != 0.0 {
                let rows = ri_re[k + 1..].iter_mut().zip(&mut ri_im[k + 1..]);
                for ((xr, xi), (ur, ui)) in rows.zip(uk_re.iter().zip(uk_im)) {
                    *xr -= lr * ur - li * ui;
                    *xi -= lr * ui + li * ur;
                }
            }
        }
    }
    true
}

/// Solves `A·x = b` with the factors from [`lu_in_place_complex`]: `re` and `im` hold the real
/// and imaginary parts of `b` on entry and of `x` on return; `work` is scratch of length `2n`.
pub fn lu_solve_complex(lu: &[f64], n: usize, perm: &[usize], re: &mut [f64], im: &mut [f64], work: &mut [f64]) {
    let (lu_re, lu_im) = lu[..2 * n * n].split_at(n * n);
    let (wr, wi) = work[..2 * n].split_at_mut(n);
    for i in 0..n {
        wr[i] = re[perm[i]];
        wi[i] = im[perm[i]];
    }
    // L (unit lower)
    for i in 0..n {
        let (row_re, row_im) = (&lu_re[i * n..i * n + i], &lu_im[i * n..i * n + i]);
        let (mut sr, mut si) = (wr[i], wi[i]);
        for ((lr, li), (xr, xi)) in row_re.iter().zip(row_im).zip(wr[..i].iter().zip(&wi[..i])) {
            sr -= lr * xr - li * xi;
            si -= lr * xi + li * xr;
        }
        wr[i] = sr;
        wi[i] = si;
    }
    // U
    for i in (0..n).rev() {
        let (row_re, row_im) = (&lu_re[i * n..(i + 1) * n], &lu_im[i * n..(i + 1) * n]);
        let (mut sr, mut si) = (wr[i], wi[i]);
        let upper = row_re[i + 1..].iter().zip(&row_im[i + 1..]);
        for ((ur, ui), (xr, xi)) in upper.zip(wr[i + 1..].iter().zip(&wi[i + 1..])) {
            sr -= ur * xr - ui * xi;
            si -= ur * xi + ui * xr;
        }
        let (dr, di) = (row_re[i], row_im[i]);
        let d2 = dr * dr + di * di;
        wr[i] = (sr * dr + si * di) / d2;
        wi[i] = (si * dr - sr * di) / d2;
    }
    re[..n].copy_from_slice(wr);
    im[..n].copy_from_slice(wi);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ltdl_solves_a_branched_tree_system_like_dense_lu() {
        // dofs: 0 root, 1 child of 0, 2 child of 1, 3 child of 0 (a sibling branch), 4 child of 3
        let parent = [NO_PARENT, 0, 1, 0, 3];
        let n = 5;
        let anc = |k: usize, i: usize| {
            let mut j = k;
            loop {
                if j == i {
                    return true;
                }
                if parent[j] == NO_PARENT {
                    return false;
                }
                j = parent[j];
            }
        };
        let mut a = [0.0; 25];
        for k in 0..n {
            for i in 0..n {
                if anc(k, i) || anc(i, k) {
                    a[k * n + i] = if k == i {
                        4.0 + k as f64
                    } else {
                        0.3 + 0.1 * (k + i) as f64
                    };
                }
            }
        }
        let b = [1.0, -2.0, 0.5, 3.0, -1.0];
        let mut dense = a;
        let mut perm = [0; 5];
        assert!(lu_in_place(&mut dense, n, &mut perm));
        let mut x1 = b;
        lu_solve(&dense, n, &perm, &mut x1, &mut [0.0; 5]);
        // garbage in the entries between sibling branches must not matter
        let mut sparse = a;
        sparse[2 * n + 3] = 123.0;
        sparse[4 * n + 2] = -7.0;
        assert!(ltdl_in_place(&mut sparse, n, &parent));
        let mut x2 = b;
        ltdl_solve(&sparse, n, &parent, &mut x2);
        for i in 0..n {
            assert!((x1[i] - x2[i]).abs() < 1e-14, "{i}: {} vs {}", x1[i], x2[i]);
        }
    }

    #[test]
    fn constant_leaves_give_the_factor_and_solve_of_the_whole_matrix() {
        // dofs: 0 root, 1 and 2 a chain on it, 3 and 5 leaves on 2 and 0, 4 a leaf on 1;
        // leaves 3 and 5 constant (4 is not: it takes the general way)
        let parent = [NO_PARENT, 0, 1, 2, 1, 0];
        let n = 6;
        let mut a = [0.0; 36];
        let (l3, l5) = ([(0, 0.25), (2, -1.5)], [(0, 0.75)]);
        let (d3, d5) = (2.0, 3.0);
        for k in 0..3 {
            a[k * n + k] = 9.0 + k as f64;
        }
        a[n] = 0.5;
        a[2 * n] = -0.3;
        a[2 * n + 1] = 0.2;
        a[4 * n + 4] = 1.5;
        a[4 * n + 1] = 0.4;
        a[4 * n] = -0.1;
        a[3 * n + 3] = d3;
        a[5 * n + 5] = d5;
        for &(i, l) in &l3 {
            a[3 * n + i] = d3 * l;
        }
        for &(i, l) in &l5 {
            a[5 * n + i] = d5 * l;
        }
        let leaves = ConstantLeaves::new(n, &[(3, d3, l3.to_vec()), (5, d5, l5.to_vec())]);
        assert_eq!(leaves.is_leaf, [false, false, false, true, false, true]);
        let mut whole = a;
        assert!(ltdl_in_place(&mut whole, n, &parent));
        let mut with_leaves = a;
        // the leaves' rows hold their factor rows, whatever the rest of the matrix is
        with_leaves[3 * n..4 * n].fill(f64::NAN);
        leaves.write(&mut with_leaves, n);
        assert!(ltdl_in_place_leaves(&mut with_leaves, n, &parent, &leaves));
        for k in 0..n {
            let mut i = Some(k);
            while let Some(j) = i {
                let (x, y) = (whole[k * n + j], with_leaves[k * n + j]);
                assert!((x - y).abs() <= 1e-15 * x.abs().max(1.0), "L[{k}][{j}]: {x} vs {y}");
                i = (parent[j] != NO_PARENT).then_some(parent[j]);
            }
        }
        let b = [1.0, -2.0, 0.5, 3.0, -1.0, 0.25];
        let (mut x1, mut x2) = (b, b);
        ltdl_solve(&whole, n, &parent, &mut x1);
        ltdl_solve_leaves(&with_leaves, n, &parent, &leaves, &mut x2);
        let ax = mat_vec_symmetric(&a, n, &x2);
        for i in 0..n {
            assert!((x1[i] - x2[i]).abs() < 1e-14, "{i}: {} vs {}", x1[i], x2[i]);
            assert!((ax[i] - b[i]).abs() < 1e-13, "residual {i}: {}", ax[i] - b[i]);
        }
        // a matrix that is not positive definite is refused as before
        let mut bad = a;
        bad[0] = -1.0;
        leaves.write(&mut bad, n);
        assert!(!ltdl_in_place_leaves(&mut bad, n, &parent, &leaves));
    }

    /// `A x` for a symmetric matrix of which the lower triangle is stored.
    fn mat_vec_symmetric(a: &[f64], n: usize, x: &[f64]) -> Vec<f64> {
        let at = |i: usize, j: usize| if j <= i { a[i * n + j] } else { a[j * n + i] };
        (0..n).map(|i| (0..n).map(|k| at(i, k) * x[k]).sum()).collect()
    }

    /// `A x` for the row-major square matrix `a`.
    fn mat_vec(a: &[f64], x: &[f64]) -> Vec<f64> {
        let n = x.len();
        (0..n).map(|i| (0..n).map(|k| a[i * n + k] * x[k]).sum()).collect()
    }

    #[test]
    fn pivoted_cholesky_drops_dependent_rows() {
        // rows: r0, r1, r0 + r1 of a rank-2 Gram matrix
        let v = [[1.0, 0.0, 2.0], [0.0, 1.0, 1.0], [1.0, 1.0, 3.0]];
        let mut a = [0.0; 9];
        for i in 0..3 {
            for j in 0..3 {
                a[i * 3 + j] = (0..3).map(|k| v[i][k] * v[j][k]).sum();
            }
        }
        let orig = a;
        let mut perm = [0; 3];
        let rank = pivoted_cholesky_in_place(&mut a, 3, &mut perm, 1e-10);
        assert_eq!(rank, 2);
        // a consistent right-hand side: b = A x0
        let b = mat_vec(&orig, &[0.3, -0.2, 0.5]);
        let mut x = b.clone();
        let mut work = [0.0; 3];
        pivoted_cholesky_solve(&a, 3, &perm, rank, &mut x, &mut work);
        for (i, r) in mat_vec(&orig, &x).into_iter().enumerate() {
            assert!((r - b[i]).abs() < 1e-12, "row {i}: {r} vs {}", b[i]);
        }
    }

    /// The complex LU solves a system that needs pivoting: the residual of `A x = b`, in
    /// complex arithmetic, is at rounding level, and a singular matrix is refused.
    #[test]
    fn complex_lu_solves_a_system_that_needs_pivoting() {
        let n = 3;
        // (re, im) row-major, stored split; a zero leading pivot forces a row exchange
        let a: [(f64, f64); 9] = [
            (0.0, 0.0),
            (2.0, -1.0),
            (1.0, 0.5),
            (3.0, 1.0),
            (-1.0, 0.0),
            (0.0, 2.0),
            (1.0, -2.0),
            (0.5, 0.5),
            (4.0, 0.0),
        ];
        let mut m: Vec<f64> = a.iter().map(|z| z.0).chain(a.iter().map(|z| z.1)).collect();
        let mut perm = [0; 3];
        assert!(lu_in_place_complex(&mut m, n, &mut perm));
        let (b_re, b_im) = ([1.0, -2.0, 0.5], [0.0, 1.0, -1.0]);
        let (mut re, mut im) = (b_re, b_im);
        lu_solve_complex(&m, n, &perm, &mut re, &mut im, &mut [0.0; 6]);
        for i in 0..n {
            let (mut sr, mut si) = (0.0, 0.0);
            for j in 0..n {
                let (ar, ai) = a[i * n + j];
                sr += ar * re[j] - ai * im[j];
                si += ar * im[j] + ai * re[j];
            }
            assert!((sr - b_re[i]).abs() < 1e-14 && (si - b_im[i]).abs() < 1e-14, "row {i}");
        }
        // [[1 + i, 2 + 2i], [1 + i, 2 + 2i]]
        let mut singular = vec![1.0, 2.0, 1.0, 2.0, 1.0, 2.0, 1.0, 2.0];
        assert!(!lu_in_place_complex(&mut singular, 2, &mut [0; 2]));
    }

    #[test]
    fn lu_solves_a_system_that_needs_pivoting() {
        // zero leading pivot: fails without row exchanges
        let a0 = [0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
        let x_true = [1.0, -2.0, 0.5];
        let mut b = mat_vec(&a0, &x_true);
        let mut a = a0;
        let mut perm = [0; 3];
        assert!(lu_in_place(&mut a, 3, &mut perm));
        let mut work = [0.0; 3];
        lu_solve(&a, 3, &perm, &mut b, &mut work);
        for i in 0..3 {
            assert!((b[i] - x_true[i]).abs() < 1e-14, "{b:?}");
        }
    }

    #[test]
    fn lu_reports_a_singular_matrix() {
        let mut a = [1.0, 2.0, 2.0, 4.0];
        let mut perm = [0; 2];
        assert!(!lu_in_place(&mut a, 2, &mut perm));
    }
}
