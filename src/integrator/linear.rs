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

use super::{OdeSystem, Stats};
use crate::linalg;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::sparse::linalg::lu::{factorize_symbolic_lu, LuRef, LuSymbolicParams, NumericLu, SymbolicLu};
pub use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par};
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

/// A Jacobian in compressed sparse columns with its column colouring. The diagonal is always
/// part of the pattern; rows are sorted within each column.
#[derive(Debug, Clone, Default)]
pub struct SparseJacobian {
    n: usize,
    /// Column pointers (n + 1), row indices and values.
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    pub val: Vec<f64>,
    /// Columns grouped by colour: those of colour `c` are `colour_cols[colour_ptr[c]..colour_ptr[c + 1]]`.
    colour_ptr: Vec<usize>,
    colour_cols: Vec<usize>,
    /// Rows with more than twice as many entries as the longest column (and more than 16): a
    /// quadrature state such as the dissipated energy, which depends on every velocity, and
    /// would force as many colours as it has entries. Left out of the colouring,
    /// their values stay those of the last probe (Newton converges for them whatever their
    /// row holds, since no other equation depends on them through it).
    dense_row: Vec<bool>,
    /// Largest |entry| of each row in the values held (the scale against which a change in a
    /// row outside the pattern counts as a grown pattern).
    row_scale: Vec<f64>,
    /// The pattern was probed (false: J = 0 on the diagonal; probe before use).
    pub valid: bool,
    /// The values come from a coloured evaluation (not from a probe).
    pub last_coloured: bool,
    /// Incremented with every new pattern (the factorisations re-analyse when it changes).
    pub generation: u64,
    /// Scratch: a stamp per row or column, and the increments of a coloured evaluation.
    mark: Vec<usize>,
    dy: Vec<f64>,
    /// Counters.
    pub probes: u64,
    pub coloured: u64,
}

impl SparseJacobian {
    /// No probed pattern yet (J = 0 on the diagonal pattern), for a system of size `n`.
    pub fn new(n: usize) -> SparseJacobian {
        let mut jac = SparseJacobian {
            n,
            mark: vec![usize::MAX; n],
            dy: vec![0.0; n],
            ..SparseJacobian::default()
        };
        jac.clear();
        jac
    }

    /// Stored entries.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Colours of the pattern.
    pub fn colours(&self) -> usize {
        if self.valid {
            self.colour_ptr.len().saturating_sub(1)
        } else {
            0
        }
    }

    /// Forgets the pattern: J = 0, stored on the diagonal.
    pub fn clear(&mut self) {
        self.col_ptr.clear();
        self.col_ptr.extend(0..=self.n);
        self.row_idx.clear();
        self.row_idx.extend(0..self.n);
        self.val.clear();
        self.val.resize(self.n, 0.0);
        self.colour_ptr.clear();
        self.colour_cols.clear();
        self.dense_row.clear();
        self.valid = false;
        self.last_coloured = false;
        self.generation += 1;
    }

    /// The forward-difference increment of component `y`.
    fn increment(y: f64) -> f64 {
        let dy = (f64::EPSILON * 1e-5_f64.max(y.abs())).sqrt();
        (y + dy) - y
    }

    /// The Jacobian at `(t, y)`: by colours when a pattern is held and still holds, else by a
    /// full probe (joined to the pattern held, if any). `f0 = f(t, y)` on entry; `y_pert` and
    /// `f1` are scratch. Counts the evaluations in `stats`.
    #[allow(clippy::too_many_arguments)]
    pub fn evaluate(
        &mut self,
        sys: &mut dyn OdeSystem,
        t: f64,
        y: &[f64],
        f0: &[f64],
        y_pert: &mut [f64],
        f1: &mut [f64],
        stats: &mut Stats,
    ) {
        if self.valid && self.coloured_evaluation(sys, t, y, f0, y_pert, f1, stats) {
            self.last_coloured = true;
            return;
        }
        self.probe(sys, t, y, f0, y_pert, f1, stats);
    }

    /// Probes every column (n evaluations), joins the nonzeros found to the pattern held (if
    /// any), colours the result and sets the values.
    #[allow(clippy::too_many_arguments)]
    pub fn probe(
        &mut self,
        sys: &mut dyn OdeSystem,
        t: f64,
        y: &[f64],
        f0: &[f64],
        y_pert: &mut [f64],
        f1: &mut [f64],
        stats: &mut Stats,
    ) {
        let n = self.n;
        let old = if self.valid {
            Some((std::mem::take(&mut self.col_ptr), std::mem::take(&mut self.row_idx)))
        } else {
            None
        };
        self.col_ptr.clear();
        self.row_idx.clear();
        self.val.clear();
        self.col_ptr.push(0);
        y_pert.copy_from_slice(y);
        for j in 0..n {
            let dy = Self::increment(y[j]);
            y_pert[j] = y[j] + dy;
            sys.rhs(t, y_pert, f1);
            y_pert[j] = y[j];
            // rows: the nonzero differences, the diagonal, and the old pattern's rows
            for i in 0..n {
                self.mark[i] = usize::MAX;
            }
            if let Some((cp, ri)) = &old {
                for &i in &ri[cp[j]..cp[j + 1]] {
                    self.mark[i] = j;
                }
            }
            self.mark[j] = j;
            for i in 0..n {
                if self.mark[i] == j || f1[i] != f0[i] {
                    self.row_idx.push(i);
                    self.val.push((f1[i] - f0[i]) / dy);
                }
            }
            self.col_ptr.push(self.row_idx.len());
        }
        self.mark.iter_mut().for_each(|m| *m = usize::MAX);
        stats.rhs_evals += n as u64;
        self.probes += 1;
        self.colour();
        self.valid = true;
        self.last_coloured = false;
        self.generation += 1;
    }

    /// Sets `row_scale` from the values.
    fn scale_rows(&mut self) {
        self.row_scale.clear();
        self.row_scale.resize(self.n, 0.0);
        for (&i, v) in self.row_idx.iter().zip(&self.val) {
            self.row_scale[i] = self.row_scale[i].max(v.abs());
        }
    }

    /// Greedy colouring of the columns in their natural order: a column takes the smallest
    /// colour no column sharing a row (other than a dense row) with it has.
    fn colour(&mut self) {
        self.scale_rows();
        let n = self.n;
        // rows → columns (CSR of the pattern)
        let nnz = self.row_idx.len();
        let mut row_ptr = vec![0usize; n + 1];
        for &i in &self.row_idx {
            row_ptr[i + 1] += 1;
        }
        let longest_col = (0..n).map(|j| self.col_ptr[j + 1] - self.col_ptr[j]).max().unwrap_or(0);
        let dense_min = (2 * longest_col).max(16);
        self.dense_row.clear();
        self.dense_row.extend((0..n).map(|i| row_ptr[i + 1] > dense_min));
        for i in 0..n {
            row_ptr[i + 1] += row_ptr[i];
        }
        let mut fill = row_ptr.clone();
        let mut col_idx = vec![0usize; nnz];
        for j in 0..n {
            for &i in &self.row_idx[self.col_ptr[j]..self.col_ptr[j + 1]] {
                col_idx[fill[i]] = j;
                fill[i] += 1;
            }
        }
        let mut colour = vec![usize::MAX; n];
        // forbidden[c] == j: colour c is taken by a neighbour of column j
        let mut forbidden: Vec<usize> = Vec::new();
        let mut count = 0;
        for j in 0..n {
            for &i in &self.row_idx[self.col_ptr[j]..self.col_ptr[j + 1]] {
                if self.dense_row[i] {
                    continue;
                }
                for &k in &col_idx[row_ptr[i]..row_ptr[i + 1]] {
                    if colour[k] != usize::MAX {
                        forbidden[colour[k]] = j;
                    }
                }
            }
            let c = (0..count).find(|&c| forbidden[c] != j).unwrap_or(count);
            if c == count {
                count += 1;
                forbidden.push(usize::MAX);
            }
            colour[j] = c;
        }
        self.colour_ptr = vec![0; count + 1];
        for &c in &colour {
            self.colour_ptr[c + 1] += 1;
        }
        for c in 0..count {
            self.colour_ptr[c + 1] += self.colour_ptr[c];
        }
        let mut fill = self.colour_ptr.clone();
        self.colour_cols = vec![0; n];
        for (j, &c) in colour.iter().enumerate() {
            self.colour_cols[fill[c]] = j;
            fill[c] += 1;
        }
    }

    /// One evaluation per colour. False (values half written) if a row outside the pattern of
    /// a colour's columns changed by more than 1e-6 of what its largest entry (at least 1)
    /// would change it by: the pattern has grown (an entry below that changes `I − hγJ` by
    /// less than 1e-6 for steps hγ ≤ 1). (Smaller changes are second-order terms of two columns
    /// perturbed together where each derivative is zero, e.g. `ω × Iω` at `ω = 0`.)
    #[allow(clippy::too_many_arguments)]
    fn coloured_evaluation(
        &mut self,
        sys: &mut dyn OdeSystem,
        t: f64,
        y: &[f64],
        f0: &[f64],
        y_pert: &mut [f64],
        f1: &mut [f64],
        stats: &mut Stats,
    ) -> bool {
        let n = self.n;
        y_pert.copy_from_slice(y);
        let colours = self.colours();
        for c in 0..colours {
            let cols = &self.colour_cols[self.colour_ptr[c]..self.colour_ptr[c + 1]];
            let mut dy_max = 0.0_f64;
            for &j in cols {
                self.dy[j] = Self::increment(y[j]);
                y_pert[j] = y[j] + self.dy[j];
                dy_max = dy_max.max(self.dy[j]);
            }
            sys.rhs(t, y_pert, f1);
            stats.rhs_evals += 1;
            for &j in cols {
                y_pert[j] = y[j];
                let dy = self.dy[j];
                for k in self.col_ptr[j]..self.col_ptr[j + 1] {
                    let i = self.row_idx[k];
                    if !self.dense_row[i] {
                        self.val[k] = (f1[i] - f0[i]) / dy;
                        self.mark[i] = c;
                    }
                }
            }
            for i in 0..n {
                if self.mark[i] != c
                    && !self.dense_row[i]
                    && (f1[i] - f0[i]).abs() > 1e-6 * self.row_scale[i].max(1.0) * dy_max
                {
                    return false;
                }
            }
            // clear the stamps, so that no later evaluation of the same colour sees them
            for &j in cols {
                for &i in &self.row_idx[self.col_ptr[j]..self.col_ptr[j + 1]] {
                    self.mark[i] = usize::MAX;
                }
            }
        }
        self.scale_rows();
        self.coloured += 1;
        true
    }

    /// Appends the pattern and values: `nnz`, whether the values are from a coloured
    /// evaluation, the column pointers (n + 1), the row indices, the values (nothing derived:
    /// the colouring and factorisations are recomputed on load).
    pub fn save(&self, out: &mut Vec<f64>) {
        out.push(self.row_idx.len() as f64);
        out.push(self.last_coloured as u8 as f64);
        out.extend(self.col_ptr.iter().map(|&p| p as f64));
        out.extend(self.row_idx.iter().map(|&i| i as f64));
        out.extend_from_slice(&self.val);
    }

    /// Length of what [`SparseJacobian::save`] wrote, from its first number, for size `n`;
    /// None if that is no count.
    pub fn saved_len(first: f64, n: usize) -> Option<usize> {
        let ok = first >= 0.0 && first.fract() == 0.0 && first <= (n as f64) * (n as f64);
        ok.then(|| 2 + n + 1 + 2 * first as usize)
    }

    /// Checks a block written by [`SparseJacobian::save`] for size `n`.
    pub fn check(v: &[f64], n: usize) -> Result<(), String> {
        let bad = |what: &str| Err(format!("sparse Jacobian in the state: {what}"));
        let Some(len) = v.first().and_then(|&f| Self::saved_len(f, n)) else {
            return bad("no entry count");
        };
        if v.len() != len {
            return bad("wrong length");
        }
        let nnz = v[0] as usize;
        if v[1] != 0.0 && v[1] != 1.0 {
            return bad("the coloured flag is not 0 or 1");
        }
        let cp = &v[2..n + 3];
        let ri = &v[n + 3..n + 3 + nnz];
        if cp[0] != 0.0 || cp[n] != nnz as f64 {
            return bad("column pointers do not span the entries");
        }
        for j in 0..n {
            let (a, b) = (cp[j], cp[j + 1]);
            if a.fract() != 0.0 || b < a {
                return bad("column pointers not increasing integers");
            }
            let rows = &ri[a as usize..b as usize];
            let mut has_diag = false;
            for (k, &r) in rows.iter().enumerate() {
                if r.fract() != 0.0 || r < 0.0 || r >= n as f64 || (k > 0 && r <= rows[k - 1]) {
                    return bad("row indices not sorted integers in range");
                }
                has_diag |= r == j as f64;
            }
            if !has_diag {
                return bad("a diagonal entry is missing");
            }
        }
        Ok(())
    }

    /// A Jacobian given in compressed sparse columns (sorted rows, diagonal included), as if
    /// probed (for benchmarks and tests).
    pub fn from_csc(n: usize, col_ptr: Vec<usize>, row_idx: Vec<usize>, val: Vec<f64>) -> SparseJacobian {
        let mut jac = SparseJacobian::new(n);
        jac.col_ptr = col_ptr;
        jac.row_idx = row_idx;
        jac.val = val;
        jac.colour();
        jac.valid = true;
        jac.generation += 1;
        jac
    }

    /// Sets pattern and values from a block that [`SparseJacobian::check`] accepted.
    pub fn load(&mut self, v: &[f64]) {
        let n = self.n;
        let nnz = v[0] as usize;
        self.last_coloured = v[1] != 0.0;
        self.col_ptr = v[2..n + 3].iter().map(|&p| p as usize).collect();
        self.row_idx = v[n + 3..n + 3 + nnz].iter().map(|&i| i as usize).collect();
        self.val = v[n + 3 + nnz..].to_vec();
        self.colour();
        self.mark.iter_mut().for_each(|m| *m = usize::MAX);
        self.valid = true;
        self.generation += 1;
    }
}

/// A Jacobian as the factorisations read it.
#[derive(Debug, Clone, Copy)]
pub enum JacRef<'a> {
    /// Row-major `n × n`.
    Dense(&'a [f64]),
    /// Compressed sparse columns.
    Sparse(&'a SparseJacobian),
}

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

#[cfg(test)]
mod tests {
    use super::*;

    /// A small nonlinear system with a banded, partly zero Jacobian.
    struct Band;
    impl OdeSystem for Band {
        fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
            let n = y.len();
            for i in 0..n {
                let l = if i > 0 { y[i - 1] } else { 0.0 };
                let r = if i + 1 < n { y[i + 1] * y[i + 1] } else { 0.0 };
                dy[i] = -1e3 * y[i] + l + 0.5 * r + if i % 3 == 0 { y[(i + 5) % n] } else { 0.0 };
            }
        }
    }

    #[test]
    fn coloured_jacobian_matches_the_probe_and_sparse_lu_solves_like_dense() {
        let n = 40;
        let y: Vec<f64> = (0..n).map(|i| 0.1 + 0.01 * i as f64).collect();
        let mut f0 = vec![0.0; n];
        Band.rhs(0.0, &y, &mut f0);
        let (mut yp, mut f1, mut st) = (vec![0.0; n], vec![0.0; n], Stats::default());
        let mut jac = SparseJacobian::new(n);
        jac.evaluate(&mut Band, 0.0, &y, &f0, &mut yp, &mut f1, &mut st);
        assert_eq!((jac.probes, st.rhs_evals), (1, n as u64));
        let probed = jac.val.clone();
        assert!(jac.colours() <= 6, "{} colours", jac.colours());
        jac.evaluate(&mut Band, 0.0, &y, &f0, &mut yp, &mut f1, &mut st);
        assert_eq!(jac.coloured, 1);
        assert_eq!(st.rhs_evals, (n + jac.colours()) as u64);
        for (a, b) in probed.iter().zip(&jac.val) {
            assert!((a - b).abs() <= 1e-6 * a.abs().max(1.0), "{a} vs {b}");
        }
        // the dense Jacobian with the same values, and both LUs of I − cJ and I − h A⊗J
        let mut dense = vec![0.0; n * n];
        for j in 0..n {
            for k in jac.col_ptr[j]..jac.col_ptr[j + 1] {
                dense[jac.row_idx[k] * n + j] = jac.val[k];
            }
        }
        let b: Vec<f64> = (0..3 * n).map(|i| (i as f64).sin()).collect();
        let a = [[0.2, -0.05, 0.01], [0.4, 0.3, -0.02], [0.37, 0.5, 0.11]];
        for kron in [false, true] {
            let m = if kron { 3 * n } else { n };
            let (mut d, mut s) = (Lu::new(m, false), Lu::new(m, true));
            let (jd, js) = (JacRef::Dense(&dense), JacRef::Sparse(&jac));
            if kron {
                assert!(d.factor_kron(jd, 1e-2, &a) && s.factor_kron(js, 1e-2, &a));
            } else {
                assert!(d.factor_shifted(jd, 1e-2) && s.factor_shifted(js, 1e-2));
            }
            let (mut xd, mut xs) = (b[..m].to_vec(), b[..m].to_vec());
            d.solve(&mut xd);
            s.solve(&mut xs);
            for (p, q) in xd.iter().zip(&xs) {
                assert!((p - q).abs() < 1e-12, "kron {kron}: {p} vs {q}");
            }
            assert_eq!(s.sparse_counts(), (1, 1));
        }
    }

    #[test]
    fn solves_and_coloured_jacobians_on_an_analysed_pattern_do_not_allocate() {
        let n = 60;
        let y: Vec<f64> = (0..n).map(|i| 0.1 + 0.01 * i as f64).collect();
        let mut f0 = vec![0.0; n];
        Band.rhs(0.0, &y, &mut f0);
        let (mut yp, mut f1, mut st) = (vec![0.0; n], vec![0.0; n], Stats::default());
        let mut jac = SparseJacobian::new(n);
        jac.evaluate(&mut Band, 0.0, &y, &f0, &mut yp, &mut f1, &mut st);
        let a = [[0.2, -0.05, 0.01], [0.4, 0.3, -0.02], [0.37, 0.5, 0.11]];
        let (mut s1, mut s3) = (Lu::new(n, true), Lu::new(3 * n, true));
        assert!(s1.factor_shifted(JacRef::Sparse(&jac), 1e-2) && s3.factor_kron(JacRef::Sparse(&jac), 1e-2, &a));
        let (mut x1, mut x3) = (vec![1.0; n], vec![1.0; 3 * n]);
        let count = super::super::alloc_counter::count;
        let mut allocs = [0; 4];
        for k in 0..5 {
            let c = 1e-2 * (1.0 + k as f64);
            let t0 = count();
            assert!(s1.factor_shifted(JacRef::Sparse(&jac), c));
            let t1 = count();
            assert!(s3.factor_kron(JacRef::Sparse(&jac), c, &a));
            let t2 = count();
            s1.solve(&mut x1);
            s3.solve(&mut x3);
            let t3 = count();
            jac.evaluate(&mut Band, 0.0, &y, &f0, &mut yp, &mut f1, &mut st);
            let t4 = count();
            for (a, d) in allocs.iter_mut().zip([t1 - t0, t2 - t1, t3 - t2, t4 - t3]) {
                *a += d;
            }
        }
        // faer's supernodal numeric factorisation allocates its per-supernode work each time
        // (10 and 37 allocations per factorisation here); the rest allocates nothing
        assert_eq!(allocs[2..], [0, 0], "solves, coloured Jacobian: {allocs:?}");
        assert!(allocs[0] <= 5 * 20 && allocs[1] <= 5 * 60, "factorisations: {allocs:?}");
        assert_eq!(jac.coloured, 5);
    }

    #[test]
    fn a_grown_pattern_is_probed_again_and_saved_patterns_load() {
        // f₁ depends on y₂ and y₃ only once y₂ > 0: zero at the probe
        struct Grow;
        impl OdeSystem for Grow {
            fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
                dy[0] = -y[0] + y[1];
                dy[1] = -y[1] + y[2].max(0.0) * y[3];
                dy[2] = 1.0;
                dy[3] = -y[3];
            }
        }
        let (mut yp, mut f1, mut f0, mut st) = (vec![0.0; 4], vec![0.0; 4], vec![0.0; 4], Stats::default());
        let mut jac = SparseJacobian::new(4);
        let y = [1.0, 1.0, -1.0, 1.0];
        Grow.rhs(0.0, &y, &mut f0);
        jac.evaluate(&mut Grow, 0.0, &y, &f0, &mut yp, &mut f1, &mut st);
        assert_eq!((jac.nnz(), jac.colours()), (5, 2), "the diagonal and (0, 1)");
        let y = [1.0, 1.0, 1.0, 1.0];
        Grow.rhs(0.0, &y, &mut f0);
        jac.evaluate(&mut Grow, 0.0, &y, &f0, &mut yp, &mut f1, &mut st);
        assert_eq!(jac.probes, 2, "the new entries of row 1 were noticed");
        assert_eq!(jac.nnz(), 7, "diagonal, (0, 1), (1, 2), (1, 3)");
        let mut v = Vec::new();
        jac.save(&mut v);
        assert!(SparseJacobian::check(&v, 4).is_ok());
        let mut back = SparseJacobian::new(4);
        back.load(&v);
        assert_eq!(
            (back.col_ptr.clone(), back.row_idx.clone()),
            (jac.col_ptr.clone(), jac.row_idx.clone())
        );
        assert_eq!(back.colours(), jac.colours());
        let mut bad = v.clone();
        bad[2 + 5 + 1] = 3.0; // a row index out of order
        assert!(SparseJacobian::check(&bad, 4).is_err());
        assert!(SparseJacobian::check(&v[..v.len() - 1], 4).is_err());
    }
}
