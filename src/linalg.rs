//! Small dense factorisations that work in caller-owned buffers, so that the step allocates
//! nothing. They serve the per-tree mass-matrix blocks and the loop-constraint Schur
//! complement, which are a few dozen rows at most; faer's allocation-free API would need a
//! scratch arena for matrices this small and nalgebra's decompositions take ownership.

/// Dot product.
#[inline]
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Cholesky factorisation `A = L Lᵀ` of a symmetric positive definite row-major `n × n`
/// matrix, in place (L in the lower triangle). Returns false if a pivot is not positive.
pub fn cholesky_in_place(a: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        let mut s = a[j * n + j];
        for k in 0..j {
            s -= a[j * n + k] * a[j * n + k];
        }
        if s.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return false;
        }
        let l = s.sqrt();
        a[j * n + j] = l;
        for i in j + 1..n {
            let mut t = a[i * n + j];
            for k in 0..j {
                t -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = t / l;
        }
    }
    true
}

/// Solves `L Lᵀ x = b` in place with a factor from [`cholesky_in_place`].
pub fn cholesky_solve(l: &[f64], n: usize, x: &mut [f64]) {
    for i in 0..n {
        let mut s = x[i];
        for k in 0..i {
            s -= l[i * n + k] * x[k];
        }
        x[i] = s / l[i * n + i];
    }
    for i in (0..n).rev() {
        let mut s = x[i];
        for k in i + 1..n {
            s -= l[k * n + i] * x[k];
        }
        x[i] = s / l[i * n + i];
    }
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
pub fn ltdl_in_place(h: &mut [f64], n: usize, parent: &[usize]) -> bool {
    for k in (0..n).rev() {
        let hkk = h[k * n + k];
        if hkk.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return false;
        }
        let mut i = parent[k];
        while i != NO_PARENT {
            let a = h[k * n + i] / hkk;
            let mut j = i;
            while j != NO_PARENT {
                h[i * n + j] -= a * h[k * n + j];
                j = parent[j];
            }
            h[k * n + i] = a;
            i = parent[i];
        }
    }
    true
}

/// Solves `Lᵀ D L x = b` in place with a factor from [`ltdl_in_place`].
pub fn ltdl_solve(l: &[f64], n: usize, parent: &[usize], x: &mut [f64]) {
    for i in (0..n).rev() {
        let xi = x[i];
        let mut j = parent[i];
        while j != NO_PARENT {
            x[j] -= l[i * n + j] * xi;
            j = parent[j];
        }
    }
    for i in 0..n {
        x[i] /= l[i * n + i];
    }
    for i in 0..n {
        let mut j = parent[i];
        let mut s = x[i];
        while j != NO_PARENT {
            s -= l[i * n + j] * x[j];
            j = parent[j];
        }
        x[i] = s;
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
    for i in 0..n {
        work[i] = x[perm[i]];
    }
    for i in 0..rank {
        let mut s = work[i];
        for k in 0..i {
            s -= l[i * n + k] * work[k];
        }
        work[i] = s / l[i * n + i];
    }
    for i in (0..rank).rev() {
        let mut s = work[i];
        for k in i + 1..rank {
            s -= l[k * n + i] * work[k];
        }
        work[i] = s / l[i * n + i];
    }
    for w in work.iter_mut().take(n).skip(rank) {
        *w = 0.0;
    }
    for i in 0..n {
        x[perm[i]] = work[i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_solves_spd_system() {
        let a = [4.0, 2.0, 0.4, 2.0, 5.0, 1.0, 0.4, 1.0, 3.0];
        let mut f = a;
        assert!(cholesky_in_place(&mut f, 3));
        let b = [1.0, 2.0, 3.0];
        let mut x = b;
        cholesky_solve(&f, 3, &mut x);
        for i in 0..3 {
            let r: f64 = (0..3).map(|k| a[i * 3 + k] * x[k]).sum();
            assert!((r - b[i]).abs() < 1e-14);
        }
    }

    #[test]
    fn ltdl_solves_a_branched_tree_system_like_dense_cholesky() {
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
        assert!(cholesky_in_place(&mut dense, n));
        let mut x1 = b;
        cholesky_solve(&dense, n, &mut x1);
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
        let x0 = [0.3, -0.2, 0.5];
        let mut b = [0.0; 3];
        for i in 0..3 {
            b[i] = (0..3).map(|k| orig[i * 3 + k] * x0[k]).sum();
        }
        let mut x = b;
        let mut work = [0.0; 3];
        pivoted_cholesky_solve(&a, 3, &perm, rank, &mut x, &mut work);
        for i in 0..3 {
            let r: f64 = (0..3).map(|k| orig[i * 3 + k] * x[k]).sum();
            assert!((r - b[i]).abs() < 1e-12, "row {i}: {r} vs {}", b[i]);
        }
    }
}
