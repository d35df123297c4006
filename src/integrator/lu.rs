//! Dense LU factorisation with partial pivoting, in place on a caller-owned buffer, so that
//! the implicit integrator can refactor its iteration matrix without allocating.

/// Factors the row-major `n × n` matrix `a` in place as `P·A = L·U` (unit lower `L` below the
/// diagonal, `U` on and above it); `perm[i]` is the original row now in row `i`. Returns
/// false when a pivot is zero or not finite (the matrix is singular to working precision).
pub fn factor_in_place(a: &mut [f64], n: usize, perm: &mut [usize]) -> bool {
    debug_assert!(a.len() >= n * n && perm.len() >= n);
    for (i, p) in perm.iter_mut().enumerate().take(n) {
        *p = i;
    }
    for k in 0..n {
        let mut piv = k;
        let mut best = a[k * n + k].abs();
        for i in k + 1..n {
            let v = a[i * n + k].abs();
            if v > best {
                best = v;
                piv = i;
            }
        }
        if !(best > 0.0 && best.is_finite()) {
            return false;
        }
        if piv != k {
            for j in 0..n {
                a.swap(k * n + j, piv * n + j);
            }
            perm.swap(k, piv);
        }
        let d = a[k * n + k];
        for i in k + 1..n {
            let l = a[i * n + k] / d;
            a[i * n + k] = l;
            if l != 0.0 {
                for j in k + 1..n {
                    a[i * n + j] -= l * a[k * n + j];
                }
            }
        }
    }
    true
}

/// Solves `A·x = b` with the factors from [`factor_in_place`]; `x` holds `b` on entry and the
/// solution on return, `work` is scratch of length `n`.
pub fn solve_in_place(lu: &[f64], n: usize, perm: &[usize], x: &mut [f64], work: &mut [f64]) {
    for i in 0..n {
        work[i] = x[perm[i]];
    }
    for i in 0..n {
        let mut s = work[i];
        for j in 0..i {
            s -= lu[i * n + j] * work[j];
        }
        work[i] = s;
    }
    for i in (0..n).rev() {
        let mut s = work[i];
        for j in i + 1..n {
            s -= lu[i * n + j] * work[j];
        }
        work[i] = s / lu[i * n + i];
    }
    x[..n].copy_from_slice(&work[..n]);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_system_that_needs_pivoting() {
        // zero leading pivot: fails without row exchanges
        let a0 = [0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
        let x_true = [1.0, -2.0, 0.5];
        let mut b = [0.0; 3];
        for i in 0..3 {
            b[i] = (0..3).map(|j| a0[i * 3 + j] * x_true[j]).sum();
        }
        let mut a = a0;
        let mut perm = [0; 3];
        assert!(factor_in_place(&mut a, 3, &mut perm));
        let mut work = [0.0; 3];
        solve_in_place(&a, 3, &perm, &mut b, &mut work);
        for i in 0..3 {
            assert!((b[i] - x_true[i]).abs() < 1e-14, "{b:?}");
        }
    }

    #[test]
    fn reports_a_singular_matrix() {
        let mut a = [1.0, 2.0, 2.0, 4.0];
        let mut perm = [0; 2];
        assert!(!factor_in_place(&mut a, 2, &mut perm));
    }
}
