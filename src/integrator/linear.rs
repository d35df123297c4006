//! The linear algebra of the implicit methods' Newton iterations: the Jacobian, dense or
//! sparse ([`SparseJacobian`]), and the LU factorisations of the iteration matrices `I − cJ`
//! (SDIRK4, and RADAU5's error filter) and `I − h A⊗J` (RADAU5's stages) ([`Lu`]).
//!
//! - **Dense** (systems below [`SPARSE_MIN_N`] states): the row-major Jacobian by `n` forward
//!   differences and the in-place LU of [`crate::linalg`], as before this module existed
//!   (as fast as faer's dense LU at the bundled scenes' sizes, and bit for bit the results of
//!   before: docs/integrators.md).
//! - **Sparse** (from [`SPARSE_MIN_N`] states on): the Jacobian's pattern is probed once by
//!   `n` forward differences (the values of that probe are the first Jacobian), coloured
//!   greedily (Curtis-Powell-Reid: columns that share no row are perturbed together), and each
//!   later Jacobian costs one evaluation per colour. faer's sparse LU (supernodal) analyses
//!   the pattern of each iteration matrix once (fill-reducing ordering, symbolic
//!   factorisation) and factors numerically while the pattern holds. RADAU5's `I − h A⊗J` is factored as the real
//!   `3n × 3n` sparse matrix (nine copies of J's pattern).
//! - The pattern lives as long as the Jacobian: it is dropped with it (a reset, a restart that
//!   does not keep the Jacobian) and probed afresh when Newton next needs a Jacobian. A pattern
//!   that has grown since the probe (a contact that touched with zero stiffness at the probe,
//!   a rate that was zero) is caught in two ways: a coloured evaluation that changes a row no
//!   column of its colour touches (by more than second-order rounding), and a second Newton
//!   failure within one step with a fresh coloured Jacobian; both probe again and join the
//!   new pattern to the old.
//!
//! The sparse path allocates when it analyses a new pattern (probe, colouring, symbolic
//! factorisation) and in each numeric factorisation (faer's supernodal LU takes its
//! per-supernode work vectors afresh: a few dozen allocations); solves and coloured Jacobians
//! on an analysed pattern allocate nothing. The dense path allocates nothing after
//! construction.

mod sparse_jacobian;
mod sparse_lu;
#[cfg(test)]
mod tests;

pub use self::sparse_jacobian::{EvalPoint, SparseJacobian};
pub use self::sparse_lu::{SparseLu, SupernodalThreshold};
use crate::linalg;
use std::sync::atomic::{AtomicU8, Ordering};

/// Systems with at least this many states take the sparse path (under [`Policy::Auto`]).
/// `contact-fmu bench lu` on the multibody pattern: sparse and dense LU even around
/// n = 100-500, sparse solves faster from n ≈ 100, sparse 4× faster to factor at n = 1,000
/// (docs/integrators.md). Above the bundled scenes (n ≤ 60), whose results stay those of
/// the dense path.
pub const SPARSE_MIN_N: usize = 200;

/// Which linear algebra the implicit methods built by `new` use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Policy {
    /// Sparse from [`SPARSE_MIN_N`] states on, dense below.
    Auto = 0,
    /// Always dense.
    Dense = 1,
    /// Always sparse.
    Sparse = 2,
}

static POLICY: AtomicU8 = AtomicU8::new(Policy::Auto as u8);

/// Sets the process-wide [`Policy`] for methods created from now on (benchmarks compare the
/// two paths on the same scene with it; the default is [`Policy::Auto`]).
pub fn set_policy(p: Policy) {
    POLICY.store(p as u8, Ordering::Relaxed);
}

/// The process-wide [`Policy`].
pub fn policy() -> Policy {
    match POLICY.load(Ordering::Relaxed) {
        1 => Policy::Dense,
        2 => Policy::Sparse,
        _ => Policy::Auto,
    }
}

/// Whether a system of `n` states takes the sparse path under the current [`Policy`].
pub fn sparse_for(n: usize) -> bool {
    match policy() {
        Policy::Auto => n >= SPARSE_MIN_N,
        Policy::Dense => false,
        Policy::Sparse => true,
    }
}

/// What the linear algebra of an implicit method did (for tests and benchmarks; not part of
/// saved states).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LinearStats {
    /// The method takes the sparse path.
    pub sparse: bool,
    /// Sparse numeric factorisations.
    pub sparse_factorisations: u64,
    /// Symbolic analyses of a sparse pattern (every iteration matrix counts).
    pub analyses: u64,
    /// Full probes of the Jacobian's pattern (n + 1 evaluations each).
    pub probes: u64,
    /// Coloured Jacobian evaluations.
    pub coloured: u64,
    /// Colours of the current pattern (0: none).
    pub colours: usize,
    /// Stored entries of the current Jacobian pattern.
    pub nnz: usize,
}

/// A Jacobian as the factorisations read it.
#[derive(Debug, Clone, Copy)]
pub enum JacRef<'a> {
    /// Row-major `n × n`.
    Dense(&'a [f64]),
    /// Compressed sparse columns.
    Sparse(&'a SparseJacobian),
}

/// The LU factors of one iteration matrix, dense or sparse.
pub enum Lu {
    /// Row-major factors of [`linalg::lu_in_place`] with their permutation and solve scratch.
    Dense {
        lu: Vec<f64>,
        perm: Vec<usize>,
        work: Vec<f64>,
    },
    /// faer's sparse LU.
    Sparse(Box<SparseLu>),
}

impl Lu {
    /// Factors for a matrix of size `m`, dense or sparse.
    pub fn new(m: usize, sparse: bool) -> Lu {
        if sparse {
            Lu::Sparse(Box::new(SparseLu::new(m)))
        } else {
            Lu::Dense {
                lu: vec![0.0; m * m],
                perm: vec![0; m],
                work: vec![0.0; m],
            }
        }
    }

    /// Factors `I − c·J`. False if singular.
    pub fn factor_shifted(&mut self, jac: JacRef, c: f64) -> bool {
        match (self, jac) {
            (Lu::Dense { lu, perm, .. }, JacRef::Dense(jac)) => {
                let n = perm.len();
                for (l, j) in lu.iter_mut().zip(jac) {
                    *l = -c * j;
                }
                for i in 0..n {
                    lu[i * n + i] += 1.0;
                }
                linalg::lu_in_place(lu, n, perm)
            }
            (Lu::Sparse(s), JacRef::Sparse(jac)) => s.factor_shifted(jac, c),
            _ => unreachable!("dense and sparse parts mixed"),
        }
    }

    /// Factors `I − h A⊗J` (`3n × 3n`, stage-major). False if singular.
    pub fn factor_kron(&mut self, jac: JacRef, h: f64, a: &[[f64; 3]; 3]) -> bool {
        match (self, jac) {
            (Lu::Dense { lu, perm, .. }, JacRef::Dense(jac)) => {
                let m = perm.len();
                let n = m / 3;
                for (bi, a_row) in a.iter().enumerate() {
                    for (bj, aij) in a_row.iter().enumerate() {
                        let ha = h * aij;
                        for i in 0..n {
                            let row = (bi * n + i) * m + bj * n;
                            let (dst, src) = (&mut lu[row..row + n], &jac[i * n..(i + 1) * n]);
                            for (d, j) in dst.iter_mut().zip(src) {
                                *d = -ha * j;
                            }
                        }
                    }
                }
                for i in 0..m {
                    lu[i * m + i] += 1.0;
                }
                linalg::lu_in_place(lu, m, perm)
            }
            (Lu::Sparse(s), JacRef::Sparse(jac)) => s.factor_kron(jac, h, a),
            _ => unreachable!("dense and sparse parts mixed"),
        }
    }

    /// Solves with the factors in place (`x` holds the right-hand side on entry).
    pub fn solve(&mut self, x: &mut [f64]) {
        match self {
            Lu::Dense { lu, perm, work } => linalg::lu_solve(lu, perm.len(), perm, x, work),
            Lu::Sparse(s) => s.solve(x),
        }
    }

    /// Sparse numeric factorisations and symbolic analyses so far (0 for dense factors).
    pub fn sparse_counts(&self) -> (u64, u64) {
        match self {
            Lu::Dense { .. } => (0, 0),
            Lu::Sparse(s) => (s.factorisations, s.analyses),
        }
    }
}
