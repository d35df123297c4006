//! The sparse Jacobian of the implicit methods: its pattern probed by forward differences,
//! coloured (Curtis-Powell-Reid), evaluated one colour at a time, checked for growth, and
//! written into and read from saved states.

use crate::integrator::{OdeSystem, Stats};

/// Where a Jacobian is evaluated: `sys` at `(t, y)` with `f0 = f(t, y)`; `y_pert` and `f1`
/// are scratch for the perturbed evaluations, which count in `stats`.
pub struct EvalPoint<'a> {
    pub sys: &'a mut dyn OdeSystem,
    pub t: f64,
    pub y: &'a [f64],
    pub f0: &'a [f64],
    pub y_pert: &'a mut [f64],
    pub f1: &'a mut [f64],
    pub stats: &'a mut Stats,
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

    /// The Jacobian at `at`: by colours when a pattern is held and still holds, else by a full
    /// probe (joined to the pattern held, if any).
    pub fn evaluate(&mut self, mut at: EvalPoint) {
        if self.valid && self.coloured_evaluation(&mut at) {
            self.last_coloured = true;
            return;
        }
        self.probe(at);
    }

    /// Probes every column (n evaluations), joins the nonzeros found to the pattern held (if
    /// any), colours the result and sets the values.
    pub fn probe(&mut self, at: EvalPoint) {
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
        at.y_pert.copy_from_slice(at.y);
        for j in 0..n {
            let dy = Self::increment(at.y[j]);
            at.y_pert[j] = at.y[j] + dy;
            at.sys.rhs(at.t, at.y_pert, at.f1);
            at.y_pert[j] = at.y[j];
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
                if self.mark[i] == j || at.f1[i] != at.f0[i] {
                    self.row_idx.push(i);
                    self.val.push((at.f1[i] - at.f0[i]) / dy);
                }
            }
            self.col_ptr.push(self.row_idx.len());
        }
        self.mark.iter_mut().for_each(|m| *m = usize::MAX);
        at.stats.rhs_evals += n as u64;
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
    fn coloured_evaluation(&mut self, at: &mut EvalPoint) -> bool {
        let n = self.n;
        at.y_pert.copy_from_slice(at.y);
        let colours = self.colours();
        for c in 0..colours {
            let cols = &self.colour_cols[self.colour_ptr[c]..self.colour_ptr[c + 1]];
            let mut dy_max = 0.0_f64;
            for &j in cols {
                self.dy[j] = Self::increment(at.y[j]);
                at.y_pert[j] = at.y[j] + self.dy[j];
                dy_max = dy_max.max(self.dy[j]);
            }
            at.sys.rhs(at.t, at.y_pert, at.f1);
            at.stats.rhs_evals += 1;
            for &j in cols {
                at.y_pert[j] = at.y[j];
                let dy = self.dy[j];
                for k in self.col_ptr[j]..self.col_ptr[j + 1] {
                    let i = self.row_idx[k];
                    if !self.dense_row[i] {
                        self.val[k] = (at.f1[i] - at.f0[i]) / dy;
                        self.mark[i] = c;
                    }
                }
            }
            for i in 0..n {
                if self.mark[i] != c
                    && !self.dense_row[i]
                    && (at.f1[i] - at.f0[i]).abs() > 1e-6 * self.row_scale[i].max(1.0) * dy_max
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
