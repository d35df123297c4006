//! faer's sparse LU of the iteration matrices `I − cJ` and `I − h A⊗J` on the pattern of a
//! [`SparseJacobian`]: symbolic analysis once per pattern, numeric factorisations and solves
//! in preallocated scratch.

use super::sparse_jacobian::SparseJacobian;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::sparse::linalg::lu::{factorize_symbolic_lu, LuRef, LuSymbolicParams, NumericLu, SymbolicLu};
pub use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par};

/// faer's sparse LU of a matrix whose pattern follows a [`SparseJacobian`]'s: symbolic
/// analysis once per pattern, numeric factorisations and solves in preallocated scratch.
pub struct SparseLu {
    m: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    val: Vec<f64>,
    symbolic: Option<SymbolicLu<usize>>,
    numeric: NumericLu<usize, f64>,
    mem: MemBuffer,
    /// faer's choice between its simplicial and supernodal factorisations: supernodal
    /// (faer's own rule picks the simplicial one for the smaller multibody matrices, 2-7×
    /// slower there: `contact-fmu bench lu`).
    pub threshold: SupernodalThreshold,
    /// The Jacobian pattern generation analysed (u64::MAX: none).
    generation: u64,
    /// Numeric factorisations and symbolic analyses so far.
    pub factorisations: u64,
    pub analyses: u64,
}

impl SparseLu {
    /// Nothing analysed yet, for a matrix of size `m`.
    pub fn new(m: usize) -> SparseLu {
        SparseLu {
            m,
            col_ptr: Vec::new(),
            row_idx: Vec::new(),
            val: Vec::new(),
            symbolic: None,
            numeric: NumericLu::new(),
            mem: MemBuffer::new(StackReq::EMPTY),
            threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            generation: u64::MAX,
            factorisations: 0,
            analyses: 0,
        }
    }

    /// Analyses the pattern in `col_ptr`, `row_idx` (sorted rows; `val` of the same length).
    fn analyse(&mut self) -> bool {
        let a = SymbolicSparseColMatRef::new_checked(self.m, self.m, &self.col_ptr, None, &self.row_idx);
        let params = LuSymbolicParams {
            supernodal_flop_ratio_threshold: self.threshold,
            ..LuSymbolicParams::default()
        };
        let Ok(symbolic) = factorize_symbolic_lu(a, params) else {
            return false;
        };
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        self.mem = MemBuffer::new(req);
        self.symbolic = Some(symbolic);
        self.numeric = NumericLu::new();
        self.analyses += 1;
        true
    }

    /// Factors the matrix whose values are in `val` (pattern analysed). False if singular.
    fn factor_values(&mut self) -> bool {
        let Some(symbolic) = &self.symbolic else {
            return false;
        };
        if !self.val.iter().all(|v| v.is_finite()) {
            return false;
        }
        let a = SparseColMatRef::new(
            SymbolicSparseColMatRef::new_checked(self.m, self.m, &self.col_ptr, None, &self.row_idx),
            &self.val,
        );
        let stack = MemStack::new(&mut self.mem);
        let ok = symbolic
            .factorize_numeric_lu(&mut self.numeric, a, Par::Seq, stack, Default::default())
            .is_ok();
        self.factorisations += 1;
        ok
    }

    /// Solves `A x = b` in place (`x` holds `b` on entry).
    pub fn solve(&mut self, x: &mut [f64]) {
        let symbolic = self.symbolic.as_ref().expect("factored");
        let lu = LuRef::new_unchecked(symbolic, &self.numeric);
        let stack = MemStack::new(&mut self.mem);
        lu.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut x[..self.m], self.m, 1),
            Par::Seq,
            stack,
        );
    }

    /// Factors `I − c·J` (same pattern as `J`).
    pub fn factor_shifted(&mut self, jac: &SparseJacobian, c: f64) -> bool {
        if self.generation != jac.generation {
            self.col_ptr.clone_from(&jac.col_ptr);
            self.row_idx.clone_from(&jac.row_idx);
            self.val.clone_from(&jac.val);
            if !self.analyse() {
                return false;
            }
            self.generation = jac.generation;
        }
        for j in 0..self.m {
            for k in jac.col_ptr[j]..jac.col_ptr[j + 1] {
                let d = if jac.row_idx[k] == j { 1.0 } else { 0.0 };
                self.val[k] = d - c * jac.val[k];
            }
        }
        self.factor_values()
    }

    /// Factors `I − h A⊗J` (`3n × 3n`, stage-major: block `(s, r)` is `δ_sr I − h a_sr J`).
    pub fn factor_kron(&mut self, jac: &SparseJacobian, h: f64, a: &[[f64; 3]; 3]) -> bool {
        let n = self.m / 3;
        if self.generation != jac.generation {
            let nnz = jac.row_idx.len();
            self.col_ptr.clear();
            self.row_idx.clear();
            self.col_ptr.push(0);
            for _bj in 0..3 {
                for j in 0..n {
                    for bi in 0..3 {
                        for &i in &jac.row_idx[jac.col_ptr[j]..jac.col_ptr[j + 1]] {
                            self.row_idx.push(bi * n + i);
                        }
                    }
                    self.col_ptr.push(self.row_idx.len());
                }
            }
            self.val.clear();
            self.val.resize(9 * nnz, 0.0);
            if !self.analyse() {
                return false;
            }
            self.generation = jac.generation;
        }
        let mut p = 0;
        for (bj, _) in a.iter().enumerate() {
            for j in 0..n {
                let col = jac.col_ptr[j]..jac.col_ptr[j + 1];
                for (bi, a_row) in a.iter().enumerate() {
                    let ha = h * a_row[bj];
                    for k in col.clone() {
                        let d = if bi == bj && jac.row_idx[k] == j { 1.0 } else { 0.0 };
                        self.val[p] = d - ha * jac.val[k];
                        p += 1;
                    }
                }
            }
        }
        self.factor_values()
    }
}
