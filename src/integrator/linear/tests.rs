//! Tests of the sparse path: coloured Jacobians against the probe, sparse LU against dense,
//! no allocation on an analysed pattern, grown patterns and saved patterns.

use super::*;
use crate::integrator::{OdeSystem, Stats};

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

/// A stage matrix for the `I − h A⊗J` factorisations.
const STAGES: [[f64; 3]; 3] = [[0.2, -0.05, 0.01], [0.4, 0.3, -0.02], [0.37, 0.5, 0.11]];

/// [`Band`] of size `n` at a fixed state: the state, `f` there, the scratch of a Jacobian
/// evaluation and the counters of those evaluations.
struct BandPoint {
    y: Vec<f64>,
    f0: Vec<f64>,
    y_pert: Vec<f64>,
    f1: Vec<f64>,
    stats: Stats,
}

impl BandPoint {
    fn new(n: usize) -> BandPoint {
        let y: Vec<f64> = (0..n).map(|i| 0.1 + 0.01 * i as f64).collect();
        let mut f0 = vec![0.0; n];
        Band.rhs(0.0, &y, &mut f0);
        let (y_pert, f1, stats) = (vec![0.0; n], vec![0.0; n], Stats::default());
        BandPoint {
            y,
            f0,
            y_pert,
            f1,
            stats,
        }
    }

    /// The point of size `n` and a Jacobian evaluated there (a probe).
    fn probed(n: usize) -> (BandPoint, SparseJacobian) {
        let (mut at, mut jac) = (BandPoint::new(n), SparseJacobian::new(n));
        at.evaluate(&mut jac);
        (at, jac)
    }

    /// Evaluates `jac` at the point.
    fn evaluate(&mut self, jac: &mut SparseJacobian) {
        jac.evaluate(EvalPoint {
            sys: &mut Band,
            t: 0.0,
            y: &self.y,
            f0: &self.f0,
            y_pert: &mut self.y_pert,
            f1: &mut self.f1,
            stats: &mut self.stats,
        });
    }
}

#[test]
fn coloured_jacobian_matches_the_probe_and_sparse_lu_solves_like_dense() {
    let n = 40;
    let (mut at, mut jac) = BandPoint::probed(n);
    assert_eq!((jac.probes, at.stats.rhs_evals), (1, n as u64));
    let probed = jac.val.clone();
    assert!(jac.colours() <= 6, "{} colours", jac.colours());
    at.evaluate(&mut jac);
    assert_eq!(jac.coloured, 1);
    assert_eq!(at.stats.rhs_evals, (n + jac.colours()) as u64);
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
    let a = STAGES;
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
    let (mut at, mut jac) = BandPoint::probed(n);
    let a = STAGES;
    let (mut s1, mut s3) = (Lu::new(n, true), Lu::new(3 * n, true));
    assert!(s1.factor_shifted(JacRef::Sparse(&jac), 1e-2) && s3.factor_kron(JacRef::Sparse(&jac), 1e-2, &a));
    let (mut x1, mut x3) = (vec![1.0; n], vec![1.0; 3 * n]);
    let count = crate::integrator::alloc_counter::count;
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
        at.evaluate(&mut jac);
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
    let mut st = Stats::default();
    // the Jacobian at y (f there evaluated first)
    let mut evaluate_at = |jac: &mut SparseJacobian, y: [f64; 4]| {
        let (mut f0, mut y_pert, mut f1) = ([0.0; 4], [0.0; 4], [0.0; 4]);
        Grow.rhs(0.0, &y, &mut f0);
        jac.evaluate(EvalPoint {
            sys: &mut Grow,
            t: 0.0,
            y: &y,
            f0: &f0,
            y_pert: &mut y_pert,
            f1: &mut f1,
            stats: &mut st,
        });
    };
    let mut jac = SparseJacobian::new(4);
    evaluate_at(&mut jac, [1.0, 1.0, -1.0, 1.0]);
    assert_eq!((jac.nnz(), jac.colours()), (5, 2), "the diagonal and (0, 1)");
    evaluate_at(&mut jac, [1.0, 1.0, 1.0, 1.0]);
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
