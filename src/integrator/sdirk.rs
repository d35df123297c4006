//! Hairer and Wanner's SDIRK4: a five-stage, L-stable, stiffly accurate singly diagonally
//! implicit Runge-Kutta method of order 4 with an embedded order-3 error estimate
//! (γ = 1/4; Hairer & Wanner, *Solving ODEs II*, Table IV.6.5). For stiff contact.
//!
//! - Stage equations `Yᵢ = y₀ + h Σⱼ<ᵢ aᵢⱼ kⱼ + hγ f(Yᵢ)` are solved by simplified Newton
//!   iterations with the matrix `I − hγJ` (the Jacobian, its reuse, `J = 0` after a reset and
//!   the memory kept across a plain restart are those of [`super::newton`]). Stage values are
//!   predicted by extrapolating the previous step's continuous extension.
//! - The error estimate `h Σ (bᵢ − b̂ᵢ) kᵢ` is filtered by `(I − hγJ)⁻¹` (as in RADAU5) so
//!   that stiff components, which the L-stable method damps, do not force tiny steps.
//! - Step sizes follow Gustafsson's predictive controller, as in RADAU5 ([`super::newton`]).
//! - Dense output is the method's own continuous extension of order 3 (cubic in θ, through
//!   both ends of the step), built from the stage derivatives.
//! - Nothing is allocated after construction.

use super::core::StepCore;
use super::linear::{self, LinearStats, Lu};
use super::newton::{implicit_parts, ImplicitMethod, NewtonCore};
use super::{error_norm, OdeSystem};
use crate::scene::Method;

/// Number of stages.
const S: usize = 5;
/// Diagonal coefficient γ.
const GAMMA: f64 = 0.25;
/// Nodes cᵢ.
const C: [f64; S] = [0.25, 0.75, 11.0 / 20.0, 0.5, 1.0];
/// Strictly lower part of the Butcher matrix (row i, columns j < i).
const A: [[f64; S]; S] = [
    [0.0; S],
    [0.5, 0.0, 0.0, 0.0, 0.0],
    [17.0 / 50.0, -1.0 / 25.0, 0.0, 0.0, 0.0],
    [371.0 / 1360.0, -137.0 / 2720.0, 15.0 / 544.0, 0.0, 0.0],
    [25.0 / 24.0, -49.0 / 48.0, 125.0 / 16.0, -85.0 / 12.0, 0.0],
];
/// Weights of the order-4 solution (the last row of the Butcher matrix: stiffly accurate).
const B: [f64; S] = [25.0 / 24.0, -49.0 / 48.0, 125.0 / 16.0, -85.0 / 12.0, 0.25];
/// Weights of the embedded order-3 solution.
const B_HAT: [f64; S] = [59.0 / 48.0, -17.0 / 96.0, 225.0 / 32.0, -85.0 / 12.0, 0.0];
/// Continuous extension `bᵢ(θ) = Σₘ DENSE[i][m−1] θᵐ` (m = 1..3): satisfies the order-3
/// conditions for every θ and `bᵢ(1) = bᵢ` (derived for this tableau; checked in the tests).
const DENSE: [[f64; 3]; S] = [
    [41.0 / 16.0, -41.0 / 16.0, 25.0 / 24.0],
    [17.0 / 32.0, -213.0 / 32.0, 245.0 / 48.0],
    [-75.0 / 32.0, 975.0 / 32.0, -325.0 / 16.0],
    [0.0, -85.0 / 4.0, 85.0 / 6.0],
    [0.25, 0.0, 0.0],
];

/// The SDIRK4 method (scene name `"sdirk"`).
pub struct Sdirk {
    core: StepCore,
    newton: NewtonCore,
    /// `h·Σᵢ DENSE[i][m] kᵢ` (dense output, with `core.y_prev`).
    dense: [Vec<f64>; 3],
    /// Stage derivatives.
    k: [Vec<f64>; S],
    /// LU factors of `I − hγJ`.
    lu: Lu,
    base: Vec<f64>,
    stage: Vec<f64>,
    delta: Vec<f64>,
    fz: Vec<f64>,
    err: Vec<f64>,
    work: Vec<f64>,
}

impl Sdirk {
    /// A method for systems of size `n` with tolerances `rtol`, `atol` and largest step `hmax`;
    /// dense or sparse linear algebra by [`linear::sparse_for`].
    pub fn new(n: usize, rtol: f64, atol: f64, hmax: f64) -> Sdirk {
        Self::with_linear(n, rtol, atol, hmax, linear::sparse_for(n))
    }

    /// [`Sdirk::new`] with the linear algebra chosen: sparse or dense.
    pub fn with_linear(n: usize, rtol: f64, atol: f64, hmax: f64, sparse: bool) -> Sdirk {
        let v = || vec![0.0; n];
        let hmax = if hmax > 0.0 { hmax } else { f64::INFINITY };
        Sdirk {
            core: StepCore::new(n, rtol, atol, hmax),
            newton: NewtonCore::new(n, rtol, sparse),
            dense: [v(), v(), v()],
            k: [v(), v(), v(), v(), v()],
            lu: Lu::new(n, sparse),
            base: v(),
            stage: v(),
            delta: v(),
            fz: v(),
            err: v(),
            work: v(),
        }
    }

    /// Solves stage `i` by simplified Newton; on success `k[i]` holds its derivative and
    /// `stage` its value. Returns the largest contraction rate, or None on failure.
    fn solve_stage(&mut self, sys: &mut dyn OdeSystem, i: usize, h: f64) -> Option<f64> {
        let core = &mut self.core;
        let n = core.y.len();
        let hg = h * GAMMA;
        // base = y + h Σⱼ<ᵢ aᵢⱼ kⱼ
        self.base.copy_from_slice(&core.y);
        for (aij, kj) in A[i].iter().zip(&self.k).take(i) {
            let a = h * aij;
            if a != 0.0 {
                for (b, kjm) in self.base.iter_mut().zip(kj) {
                    *b += a * kjm;
                }
            }
        }
        let h_prev = core.t - core.t_prev;
        if self.newton.mem.h_acc > 0.0 && h_prev > 0.0 {
            // predictor: the previous step's continuous extension, extrapolated to t + cᵢh
            let th = 1.0 + C[i] * h / h_prev;
            let [d0, d1, d2] = &self.dense;
            for m in 0..n {
                self.stage[m] = core.y_prev[m] + th * (d0[m] + th * (d1[m] + th * d2[m]));
            }
        } else {
            // predictor: Y⁰ = base + hγ k_{i−1} (f(y) for the first stage)
            let prev = if i == 0 { &core.f } else { &self.k[i - 1] };
            for ((st, b), p) in self.stage.iter_mut().zip(&self.base).zip(prev) {
                *st = b + hg * p;
            }
        }
        let ts = core.t + C[i] * h;
        let (base, stage, delta, fz) = (&self.base, &mut self.stage, &mut self.delta, &mut self.fz);
        let theta_max = self.newton.iterate(|| {
            sys.rhs(ts, stage, fz);
            core.stats.rhs_evals += 1;
            for m in 0..n {
                delta[m] = base[m] + hg * fz[m] - stage[m];
            }
            self.lu.solve(delta);
            let norm = error_norm(delta, &core.y, &core.y, core.rtol, core.atol);
            if !norm.is_finite() {
                return (norm, false);
            }
            let mut at_roundoff = true;
            for m in 0..n {
                at_roundoff &= delta[m].abs() <= 8.0 * f64::EPSILON * stage[m].abs();
                stage[m] += delta[m];
            }
            (norm, at_roundoff)
        })?;
        let inv = 1.0 / hg;
        for m in 0..n {
            self.k[i][m] = (self.stage[m] - self.base[m]) * inv;
        }
        Some(theta_max)
    }
}

impl ImplicitMethod for Sdirk {
    implicit_parts!(Method::Sdirk, order 4, scratch k);

    /// `I − hγJ`.
    fn factor(&mut self, h: f64) -> bool {
        let hg = h * GAMMA;
        let lu = &mut self.lu;
        self.newton.factor(h, |jac| lu.factor_shifted(jac, hg))
    }

    fn linear_stats(&self) -> LinearStats {
        let (f, a) = self.lu.sparse_counts();
        LinearStats {
            sparse_factorisations: f,
            analyses: a,
            ..self.newton.linear_stats()
        }
    }

    fn attempt(&mut self, sys: &mut dyn OdeSystem, h: f64, _refine: bool) -> Option<(f64, f64)> {
        if !self.factor(h) {
            return None;
        }
        let mut theta = 0.0_f64;
        for i in 0..S {
            theta = theta.max(self.solve_stage(sys, i, h)?);
        }
        let n = self.core.y.len();
        for m in 0..n {
            let mut e = 0.0;
            for i in 0..S {
                e += (B[i] - B_HAT[i]) * self.k[i][m];
            }
            self.err[m] = h * e;
        }
        self.lu.solve(&mut self.err);
        // the last stage is the new solution (stiffly accurate)
        let err = error_norm(&self.err, &self.core.y, &self.stage, self.core.rtol, self.core.atol);
        Some((err, theta))
    }

    fn accept(&mut self, _sys: &mut dyn OdeSystem, h: f64, t_new: f64) {
        for (m, d) in self.dense.iter_mut().enumerate() {
            for (x, out) in d.iter_mut().enumerate() {
                let s: f64 = DENSE.iter().zip(&self.k).map(|(row, k)| row[m] * k[x]).sum();
                *out = h * s;
            }
        }
        let core = &mut self.core;
        std::mem::swap(&mut core.y_prev, &mut core.y);
        core.y.copy_from_slice(&self.stage);
        core.f.copy_from_slice(&self.k[S - 1]);
        core.advance(t_new);
    }

    fn dense_output(&self, t: f64, out: &mut [f64]) {
        let (y0, [d0, d1, d2]) = (&self.core.y_prev, &self.dense);
        self.core.interpolate(t, out, |s, _, out| {
            for (i, o) in out.iter_mut().enumerate() {
                *o = y0[i] + s * (d0[i] + s * (d1[i] + s * d2[i]));
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::super::dopri5::Dopri5;
    use super::super::test_problems::*;
    use super::super::Integrator;
    use super::*;

    #[test]
    fn tableau_satisfies_the_order_conditions() {
        let ac: Vec<f64> = (0..S)
            .map(|i| (0..S).map(|j| A[i][j] * C[j]).sum::<f64>() + GAMMA * C[i])
            .collect();
        let ac2: Vec<f64> = (0..S)
            .map(|i| (0..S).map(|j| A[i][j] * C[j] * C[j]).sum::<f64>() + GAMMA * C[i] * C[i])
            .collect();
        let aac: Vec<f64> = (0..S)
            .map(|i| (0..S).map(|j| A[i][j] * ac[j]).sum::<f64>() + GAMMA * ac[i])
            .collect();
        for i in 0..S {
            let row: f64 = A[i].iter().sum::<f64>() + GAMMA;
            assert!((row - C[i]).abs() < 1e-15, "row sum {i}");
            if i == S - 1 {
                assert_eq!(A[i][..S - 1], B[..S - 1], "stiffly accurate");
            }
        }
        let dot = |b: &[f64], v: &dyn Fn(usize) -> f64| (0..S).map(|i| b[i] * v(i)).sum::<f64>();
        let conditions = |b: &[f64]| -> [f64; 8] {
            [
                dot(b, &|_| 1.0) - 1.0,
                dot(b, &|i| C[i]) - 0.5,
                dot(b, &|i| C[i] * C[i]) - 1.0 / 3.0,
                dot(b, &|i| ac[i]) - 1.0 / 6.0,
                dot(b, &|i| C[i].powi(3)) - 0.25,
                dot(b, &|i| C[i] * ac[i]) - 1.0 / 8.0,
                dot(b, &|i| ac2[i]) - 1.0 / 12.0,
                dot(b, &|i| aac[i]) - 1.0 / 24.0,
            ]
        };
        for r in conditions(&B) {
            assert!(r.abs() < 1e-13, "order 4: {:?}", conditions(&B));
        }
        let hat = conditions(&B_HAT);
        assert!(hat[..4].iter().all(|r| r.abs() < 1e-13), "order 3: {hat:?}");
        assert!(
            hat[4..].iter().any(|r| r.abs() > 1e-3),
            "the embedded method is of order 3 exactly"
        );
        // continuous extension: order 3 for every θ, and bᵢ(1) = bᵢ
        for k in 0..=10 {
            let th = k as f64 / 10.0;
            let bt: Vec<f64> = (0..S)
                .map(|i| (0..3).map(|m| DENSE[i][m] * th.powi(m as i32 + 1)).sum())
                .collect();
            let r = [
                dot(&bt, &|_| 1.0) - th,
                dot(&bt, &|i| C[i]) - th * th / 2.0,
                dot(&bt, &|i| C[i] * C[i]) - th.powi(3) / 3.0,
                dot(&bt, &|i| ac[i]) - th.powi(3) / 6.0,
            ];
            assert!(r.iter().all(|x| x.abs() < 1e-13), "θ = {th}: {r:?}");
        }
        for i in 0..S {
            assert!((DENSE[i].iter().sum::<f64>() - B[i]).abs() < 1e-14);
        }
    }

    #[test]
    fn converges_with_order_four() {
        assert_fixed_step_order("sdirk", Sdirk::new, 4.0);
    }

    #[test]
    fn dense_output_has_local_order_four() {
        // one step from the exact state: the order-3 interpolant errs by O(h⁴)
        let err = |h: f64| smooth_one_step(Sdirk::new, 0.3, h).0;
        assert_order("sdirk", 4.0, [err(0.2), err(0.1), err(0.05)]);
    }

    #[test]
    fn adaptive_run_meets_the_tolerance_and_tightens_with_it() {
        let y0 = Growth::exact(0.0);
        let mut errs = Vec::new();
        for tol in [1e-5, 1e-8] {
            let mut m = Sdirk::new(3, tol, tol, f64::INFINITY);
            let y = run(&mut m, &mut Growth, 0.0, &y0, 2.0);
            let e = max_diff(&y, &Growth::exact(2.0)) / 2f64.exp();
            errs.push((tol, e, m.stats()));
        }
        for &(tol, e, _) in &errs {
            assert!(e < 100.0 * tol, "tol {tol:e}: relative error {e:e}");
        }
        let slope = (errs[0].1 / errs[1].1).log10() / 3.0;
        assert!(slope > 0.7 && slope < 1.3, "error ∝ tol^{slope}: {errs:?}");
    }

    #[test]
    fn stiff_prothero_robinson_takes_far_fewer_steps_than_dopri5() {
        let lambda = -1e5;
        let t_end = 10.0;
        let tol = 1e-6;
        let mut imp = Sdirk::new(1, tol, tol, f64::INFINITY);
        let y_imp = run(&mut imp, &mut ProtheroRobinson { lambda }, 0.0, &[0.0], t_end);
        let mut exp = Dopri5::new(1, tol, tol, f64::INFINITY);
        let y_exp = run(&mut exp, &mut ProtheroRobinson { lambda }, 0.0, &[0.0], t_end);
        let exact = t_end.sin();
        assert!(
            (y_imp[0] - exact).abs() < 10.0 * tol,
            "sdirk error {:e}",
            y_imp[0] - exact
        );
        assert!(
            (y_exp[0] - exact).abs() < 10.0 * tol,
            "dopri5 error {:e}",
            y_exp[0] - exact
        );
        let (si, se) = (imp.stats(), exp.stats());
        assert!(
            se.steps > 100 * si.steps && se.rhs_evals > 20 * si.rhs_evals,
            "sdirk {si:?} dopri5 {se:?}"
        );
    }

    #[test]
    fn stiff_spring_damper_is_accurate_and_cheap() {
        let mut sys = SpringDamper { omega: 1e4, g: 9.81 };
        let v0 = -1.0;
        let tol = 1e-8;
        let mut imp = Sdirk::new(2, tol, tol, f64::INFINITY);
        let y_imp = run(&mut imp, &mut sys, 0.0, &[0.0, v0], 1.0);
        let mut exp = Dopri5::new(2, tol, tol, f64::INFINITY);
        let y_exp = run(&mut exp, &mut sys, 0.0, &[0.0, v0], 1.0);
        let exact = sys.exact(1.0, v0);
        assert!(max_diff(&y_imp, &exact) < tol, "{y_imp:?} vs {exact:?}");
        assert!(max_diff(&y_exp, &exact) < tol, "{y_exp:?} vs {exact:?}");
        let (si, se) = (imp.stats(), exp.stats());
        // the Jacobian of a linear problem is reused for the whole run
        assert!(si.jac_evals <= 3, "{si:?}");
        assert!(se.steps > 10 * si.steps, "sdirk {si:?} dopri5 {se:?}");
    }

    #[test]
    fn restart_from_the_same_state_repeats_bit_for_bit() {
        let mut sys = SpringDamper { omega: 1e4, g: 9.81 };
        let mut m = Sdirk::new(2, 1e-8, 1e-10, 1e-2);
        let y1 = run(&mut m, &mut sys, 0.0, &[0.0, -1.0], 0.01);
        let h = m.next_step();
        let mut a = Sdirk::new(2, 1e-8, 1e-10, 1e-2);
        a.reset(&mut sys, 0.01, &y1, h);
        let mut b = Sdirk::new(2, 1e-8, 1e-10, 1e-2);
        // b has history (a Jacobian, a step size memory) before its restart
        run(&mut b, &mut sys, 0.0, &[0.1, 3.0], 0.2);
        b.reset(&mut sys, 0.01, &y1, h);
        while a.t() < 0.05 {
            a.step(&mut sys, 0.05).unwrap();
            b.step(&mut sys, 0.05).unwrap();
            assert_eq!(a.t(), b.t());
            assert_eq!(a.y(), b.y());
        }
    }
}
