//! Hairer and Wanner's SDIRK4: a five-stage, L-stable, stiffly accurate singly diagonally
//! implicit Runge-Kutta method of order 4 with an embedded order-3 error estimate
//! (γ = 1/4; Hairer & Wanner, *Solving ODEs II*, Table IV.6.5). For stiff contact.
//!
//! - Stage equations `Yᵢ = y₀ + h Σⱼ<ᵢ aᵢⱼ kⱼ + hγ f(Yᵢ)` are solved by simplified Newton
//!   iterations with the matrix `I − hγJ`, `J` a forward-difference Jacobian kept across
//!   steps and refreshed only when Newton fails or converges slowly; the LU factors are kept
//!   while `h` and `J` do not change (a step-size change below 20 % is not made, to keep them).
//!   After a reset (a restart after a discontinuity) the iteration begins with `J = 0`
//!   (functional iteration), so that a non-stiff phase costs no Jacobian at all; a plain
//!   [`Integrator::restart`] keeps `J` and the controller memory, which
//!   [`Integrator::warm_state`] exports for saved states. Stage values are predicted by
//!   extrapolating the previous step's continuous extension.
//! - The error estimate `h Σ (bᵢ − b̂ᵢ) kᵢ` is filtered by `(I − hγJ)⁻¹` (as in RADAU5) so
//!   that stiff components, which the L-stable method damps, do not force tiny steps.
//! - Step sizes follow Gustafsson's predictive controller, as in RADAU5.
//! - Dense output is the method's own continuous extension of order 3 (cubic in θ, through
//!   both ends of the step), built from the stage derivatives.
//! - Nothing is allocated after construction.

use super::lu;
use super::{error_norm, Integrator, IntegratorError, OdeSystem, Stats, WarmMemory};

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

/// Most Newton iterations per stage.
const MAX_NEWTON: usize = 7;

/// Newton contraction rate above which the Jacobian is refreshed before the next step.
const SLOW_CONTRACTION: f64 = 0.5;
/// Safety factor of the step-size controller.
const SAFETY: f64 = 0.9;
/// Largest step-size increase and decrease factors.
const MAX_GROW: f64 = 8.0;
const MAX_SHRINK: f64 = 5.0;

/// Steps (and gaps to the end) below this multiple of |t| are rounding noise.
const ROUNDOFF_GAP: f64 = 16.0 * f64::EPSILON;
/// The SDIRK4 method (scene name `"sdirk"`).
pub struct Sdirk {
    rtol: f64,
    atol: f64,
    hmax: f64,
    /// Newton stopping tolerance in the weighted norm.
    newton_tol: f64,
    /// Most Newton iterations per stage.
    max_newton: usize,
    n: usize,
    t: f64,
    t_prev: f64,
    h: f64,
    /// Current state and `f(t, y)` (from the last stage of the previous step).
    y: Vec<f64>,
    f: Vec<f64>,
    /// State at the start of the last step and `h·Σᵢ DENSE[i][m] kᵢ` (dense output).
    y_prev: Vec<f64>,
    dense: [Vec<f64>; 3],
    /// Stage derivatives.
    k: [Vec<f64>; S],
    /// Row-major Jacobian ∂f/∂y (zero after a restart until Newton first needs one).
    jac: Vec<f64>,
    /// LU factors of `I − h_lu·γ·J` with row permutation.
    lu: Vec<f64>,
    perm: Vec<usize>,
    /// Step size the factors were computed for (0: none).
    lu_h: f64,
    /// The Jacobian was evaluated at the current state / it should be refreshed.
    jac_fresh: bool,
    jac_stale: bool,
    /// `jac` holds an evaluation (false: J = 0 after a reset).
    jac_valid: bool,
    /// Newton convergence-rate memory (η of Hairer & Wanner).
    eta: f64,
    /// Step and error of the last accepted step (predictive controller); 0: none yet.
    h_acc: f64,
    err_acc: f64,
    base: Vec<f64>,
    stage: Vec<f64>,
    delta: Vec<f64>,
    fz: Vec<f64>,
    err: Vec<f64>,
    work: Vec<f64>,
    stats: Stats,
}

impl Sdirk {
    /// A method for systems of size `n` with tolerances `rtol`, `atol` and largest step `hmax`.
    pub fn new(n: usize, rtol: f64, atol: f64, hmax: f64) -> Sdirk {
        let v = || vec![0.0; n];
        let newton_tol = (10.0 * f64::EPSILON / rtol.max(1e-300)).max(0.03_f64.min(rtol.sqrt()));
        Sdirk {
            rtol,
            atol,
            hmax: if hmax > 0.0 { hmax } else { f64::INFINITY },
            newton_tol,
            max_newton: MAX_NEWTON,
            n,
            t: 0.0,
            t_prev: 0.0,
            h: 0.0,
            y: v(),
            f: v(),
            y_prev: v(),
            dense: [v(), v(), v()],
            k: [v(), v(), v(), v(), v()],
            jac: vec![0.0; n * n],
            lu: vec![0.0; n * n],
            perm: vec![0; n],
            lu_h: 0.0,
            jac_fresh: false,
            jac_stale: false,
            jac_valid: false,
            eta: 1.0,
            h_acc: 0.0,
            err_acc: 0.0,
            base: v(),
            stage: v(),
            delta: v(),
            fz: v(),
            err: v(),
            work: v(),
            stats: Stats::default(),
        }
    }

    /// Forward-difference Jacobian at `(t, y)` (n + 1 evaluations: `f(t, y)` is evaluated
    /// afresh, since `self.f` satisfies the stage equation only to the Newton tolerance).
    fn jacobian(&mut self, sys: &mut dyn OdeSystem) {
        let n = self.n;
        sys.rhs(self.t, &self.y, &mut self.fz);
        self.stage.copy_from_slice(&self.y);
        for j in 0..n {
            let yj = self.y[j];
            let dy = (f64::EPSILON * 1e-5_f64.max(yj.abs())).sqrt();
            self.stage[j] = yj + dy;
            let dy = self.stage[j] - yj; // exactly representable increment
            sys.rhs(self.t, &self.stage, &mut self.delta);
            for i in 0..n {
                self.jac[i * n + j] = (self.delta[i] - self.fz[i]) / dy;
            }
            self.stage[j] = yj;
        }
        self.stats.rhs_evals += n as u64 + 1;
        self.stats.jac_evals += 1;
        self.jac_fresh = true;
        self.jac_stale = false;
        self.jac_valid = true;
        self.lu_h = 0.0;
    }

    /// Factors `I − hγJ` unless the factors for this `h` exist. False if singular.
    fn factor(&mut self, h: f64) -> bool {
        if self.lu_h == h {
            return true;
        }
        let n = self.n;
        let hg = h * GAMMA;
        for (l, j) in self.lu.iter_mut().zip(&self.jac) {
            *l = -hg * j;
        }
        for i in 0..n {
            self.lu[i * n + i] += 1.0;
        }
        if lu::factor_in_place(&mut self.lu, n, &mut self.perm) {
            self.lu_h = h;
            true
        } else {
            self.lu_h = 0.0;
            false
        }
    }

    /// Solves stage `i` by simplified Newton; on success `k[i]` holds its derivative and
    /// `stage` its value. Returns the largest contraction rate, or None on failure.
    fn solve_stage(&mut self, sys: &mut dyn OdeSystem, i: usize, h: f64) -> Option<f64> {
        let n = self.n;
        let hg = h * GAMMA;
        // base = y + h Σⱼ<ᵢ aᵢⱼ kⱼ
        self.base.copy_from_slice(&self.y);
        for (aij, kj) in A[i].iter().zip(&self.k).take(i) {
            let a = h * aij;
            if a != 0.0 {
                for (b, kjm) in self.base.iter_mut().zip(kj) {
                    *b += a * kjm;
                }
            }
        }
        let h_prev = self.t - self.t_prev;
        if self.h_acc > 0.0 && h_prev > 0.0 {
            // predictor: the previous step's continuous extension, extrapolated to t + cᵢh
            let th = 1.0 + C[i] * h / h_prev;
            let [d0, d1, d2] = &self.dense;
            for m in 0..n {
                self.stage[m] = self.y_prev[m] + th * (d0[m] + th * (d1[m] + th * d2[m]));
            }
        } else {
            // predictor: Y⁰ = base + hγ k_{i−1} (f(y) for the first stage)
            let prev = if i == 0 { &self.f } else { &self.k[i - 1] };
            for ((st, b), p) in self.stage.iter_mut().zip(&self.base).zip(prev) {
                *st = b + hg * p;
            }
        }
        let ts = self.t + C[i] * h;
        let mut norm_old = 0.0;
        let mut theta_max: f64 = 0.0;
        let mut eta = self.eta.max(f64::EPSILON).powf(0.8);
        for iter in 0..self.max_newton {
            sys.rhs(ts, &self.stage, &mut self.fz);
            self.stats.rhs_evals += 1;
            for m in 0..n {
                self.delta[m] = self.base[m] + hg * self.fz[m] - self.stage[m];
            }
            lu::solve_in_place(&self.lu, n, &self.perm, &mut self.delta, &mut self.work);
            let norm = error_norm(&self.delta, &self.y, &self.y, self.rtol, self.atol);
            if !norm.is_finite() {
                return None;
            }
            let mut at_roundoff = true;
            for m in 0..n {
                at_roundoff &= self.delta[m].abs() <= 8.0 * f64::EPSILON * self.stage[m].abs();
                self.stage[m] += self.delta[m];
            }
            // corrections at rounding level: converged, whatever their ratio says
            if !at_roundoff && iter > 0 {
                let theta = norm / norm_old;
                theta_max = theta_max.max(theta);
                if theta >= 0.99 {
                    return None;
                }
                // predicted error after the remaining iterations is too large: give up early
                let left = (self.max_newton - 1 - iter) as i32;
                if theta.powi(left) / (1.0 - theta) * norm > self.newton_tol {
                    return None;
                }
                eta = theta / (1.0 - theta);
            }
            if at_roundoff || eta * norm <= self.newton_tol {
                self.eta = eta;
                let inv = 1.0 / hg;
                for m in 0..n {
                    self.k[i][m] = (self.stage[m] - self.base[m]) * inv;
                }
                return Some(theta_max);
            }
            norm_old = norm;
        }
        None
    }

    /// One attempt of a step of size `h`; returns the error norm, or None if Newton failed.
    fn attempt(&mut self, sys: &mut dyn OdeSystem, h: f64) -> Option<(f64, f64)> {
        if !self.factor(h) {
            return None;
        }
        let mut theta = 0.0_f64;
        for i in 0..S {
            theta = theta.max(self.solve_stage(sys, i, h)?);
        }
        let n = self.n;
        for m in 0..n {
            let mut e = 0.0;
            for i in 0..S {
                e += (B[i] - B_HAT[i]) * self.k[i][m];
            }
            self.err[m] = h * e;
        }
        lu::solve_in_place(&self.lu, n, &self.perm, &mut self.err, &mut self.work);
        // the last stage is the new solution (stiffly accurate)
        let err = error_norm(&self.err, &self.y, &self.stage, self.rtol, self.atol);
        Some((err, theta))
    }

    /// Accepts the attempted step of size `h` ending at `t_new`: dense output, new state.
    fn accept(&mut self, h: f64, t_new: f64) {
        for (m, d) in self.dense.iter_mut().enumerate() {
            for (x, out) in d.iter_mut().enumerate() {
                let s: f64 = DENSE.iter().zip(&self.k).map(|(row, k)| row[m] * k[x]).sum();
                *out = h * s;
            }
        }
        std::mem::swap(&mut self.y_prev, &mut self.y);
        self.y.copy_from_slice(&self.stage);
        self.f.copy_from_slice(&self.k[S - 1]);
        self.t_prev = self.t;
        self.t = t_new;
        self.stats.steps += 1;
        self.jac_fresh = false;
    }
}

impl Sdirk {
    /// Starts at `(t, y)` with first step `h` (0: choose one); the memory is left alone.
    fn start(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.t = t;
        self.t_prev = t;
        self.y.copy_from_slice(y);
        self.y_prev.copy_from_slice(y);
        sys.rhs(t, y, &mut self.f);
        self.stats.rhs_evals += 1;
        for d in self.dense.iter_mut() {
            d.iter_mut().for_each(|x| *x = 0.0);
        }
        self.h = if h > 0.0 {
            h.min(self.hmax)
        } else {
            let [k0, k1, ..] = &mut self.k;
            k0.copy_from_slice(&self.f);
            self.stats.rhs_evals += 1;
            super::initial_step(sys, t, y, k0, self.rtol, self.atol, 4, &mut self.work, k1, self.hmax)
        };
        self.jac_fresh = false;
    }

    /// Sets the memory that warm restarts carry (the Jacobian is in `self.jac` already).
    fn set_memory(&mut self, m: WarmMemory) {
        self.h_acc = m.h_acc;
        self.err_acc = m.err_acc;
        self.eta = m.eta;
        self.jac_stale = m.jac_stale;
        self.jac_valid = m.jac_valid;
        self.jac_fresh = false;
        self.lu_h = 0.0;
    }

    /// Forgets the Jacobian: J = 0 (functional iteration) until Newton needs one.
    fn drop_jacobian(&mut self) {
        self.jac.iter_mut().for_each(|x| *x = 0.0);
        self.jac_valid = false;
        self.lu_h = 0.0;
    }
}

impl Integrator for Sdirk {
    fn reset(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.start(sys, t, y, h);
        // everything from before a restart after a discontinuity is discarded; the iteration
        // starts with J = 0 (functional iteration, enough while the problem is not stiff) and
        // a Jacobian is evaluated only when that fails to converge or converges slowly
        self.drop_jacobian();
        self.set_memory(WarmMemory::cold());
    }

    fn restart(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.start(sys, t, y, h);
        // keep J (and the LU factors, which are a function of J and h and are recomputed
        // identically after a restore), Newton and controller memory: all of it is in
        // `warm_state`, except a Jacobian too big to save, which is dropped here
        if !WarmMemory::keeps_jacobian(self.n) {
            self.drop_jacobian();
        }
    }

    fn warm_state(&self, out: &mut Vec<f64>) {
        let m = WarmMemory {
            h_acc: self.h_acc,
            err_acc: self.err_acc,
            eta: self.eta,
            jac_stale: self.jac_stale,
            jac_valid: self.jac_valid,
        };
        m.write(&self.jac, self.n, out);
    }

    fn set_warm_state(&mut self, v: &[f64]) -> Result<(), String> {
        let m = WarmMemory::read(v, &mut self.jac, self.n)?;
        self.set_memory(m);
        Ok(())
    }

    fn step(&mut self, sys: &mut dyn OdeSystem, t_max: f64) -> Result<(), IntegratorError> {
        if self.jac_stale {
            self.jacobian(sys);
        }
        let mut rejected_before = false;
        if t_max - self.t <= ROUNDOFF_GAP * self.t.abs() {
            // the end is within rounding of the current time: arrive without a step
            self.y_prev.copy_from_slice(&self.y);
            for d in self.dense.iter_mut() {
                d.iter_mut().for_each(|x| *x = 0.0);
            }
            self.t_prev = self.t;
            self.t = self.t.max(t_max);
            return Ok(());
        }
        loop {
            let mut h = self.h.min(self.hmax);
            // stretch a step by up to 1 % rather than leave a sliver before t_max (Hairer)
            let last = self.t + 1.01 * h >= t_max;
            if last {
                h = t_max - self.t;
            }
            if h <= ROUNDOFF_GAP * self.t.abs().max(1e-300) {
                return Err(IntegratorError::StepSizeUnderflow(self.t));
            }
            let Some((err, theta)) = self.attempt(sys, h) else {
                // Newton failed: a fresh Jacobian first, then a smaller step
                self.stats.rejected += 1;
                rejected_before = true;
                if !self.jac_fresh {
                    self.jacobian(sys);
                } else {
                    self.h = h * 0.5;
                }
                continue;
            };
            if !err.is_finite() {
                self.stats.rejected += 1;
                rejected_before = true;
                self.h = h * 0.2;
                continue;
            }
            // step-size proposal (RADAU5's controller with Gustafsson's prediction)
            let mut quot = (err.powf(0.25) / SAFETY).clamp(1.0 / MAX_GROW, MAX_SHRINK);
            if err <= 1.0 {
                if self.h_acc > 0.0 {
                    let gus = (self.h_acc / h) * (err * err / self.err_acc).powf(0.25) / SAFETY;
                    quot = quot.max(gus.clamp(1.0 / MAX_GROW, MAX_SHRINK));
                }
                self.h_acc = h;
                self.err_acc = err.max(1e-2);
                let t_new = if last { t_max } else { self.t + h };
                self.accept(h, t_new);
                if theta > SLOW_CONTRACTION {
                    self.jac_stale = true;
                }
                let mut h_new = h / quot;
                if rejected_before {
                    h_new = h_new.min(h);
                }
                // keep h (and the LU factors) for changes below 20 %
                let ratio = h_new / h;
                if (1.0..=1.2).contains(&ratio) && !self.jac_stale {
                    h_new = h;
                }
                if last {
                    h_new = h_new.max(self.h);
                }
                self.h = h_new.min(self.hmax);
                return Ok(());
            }
            self.stats.rejected += 1;
            rejected_before = true;
            self.h = if self.h_acc == 0.0 { h * 0.1 } else { h / quot };
        }
    }

    fn t(&self) -> f64 {
        self.t
    }
    fn t_prev(&self) -> f64 {
        self.t_prev
    }
    fn y(&self) -> &[f64] {
        &self.y
    }
    fn interpolate(&self, t: f64, out: &mut [f64]) {
        let h = self.t - self.t_prev;
        if h <= 0.0 {
            out.copy_from_slice(&self.y);
            return;
        }
        let s = (t - self.t_prev) / h;
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.y_prev[i] + s * (self.dense[0][i] + s * (self.dense[1][i] + s * self.dense[2][i]));
        }
    }
    fn next_step(&self) -> f64 {
        self.h
    }
    fn stats(&self) -> Stats {
        self.stats
    }
    fn set_stats(&mut self, s: Stats) {
        self.stats = s;
    }
}

#[cfg(test)]
mod tests {
    use super::super::dopri5::Dopri5;
    use super::super::test_problems::*;
    use super::*;

    /// Takes one step of exactly `h` (tight Newton tolerance, fresh Jacobian, no error
    /// control), to measure the order of the formula itself.
    fn fixed_step(m: &mut Sdirk, sys: &mut dyn OdeSystem, h: f64) {
        m.max_newton = 40;
        m.jacobian(sys);
        m.attempt(sys, h).expect("Newton failed");
        let t_new = m.t + h;
        m.accept(h, t_new);
    }

    fn fixed_run(sys: &mut dyn OdeSystem, y0: &[f64], h: f64, steps: usize) -> Sdirk {
        let mut m = Sdirk::new(y0.len(), 1e-13, 1e-13, f64::INFINITY);
        m.reset(sys, 0.0, y0, h);
        for _ in 0..steps {
            fixed_step(&mut m, sys, h);
        }
        m
    }

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
        let y0 = Smooth::exact(0.0);
        let err = |n: usize| {
            let m = fixed_run(&mut Smooth, &y0, 2.0 / n as f64, n);
            max_diff(m.y(), &Smooth::exact(2.0))
        };
        let (e1, e2, e3) = (err(10), err(20), err(40));
        let (p1, p2) = (order(e1, e2), order(e2, e3));
        assert!(
            (p1 - 4.0).abs() < 0.3 && (p2 - 4.0).abs() < 0.3,
            "orders {p1} {p2} (errors {e1:e} {e2:e} {e3:e})"
        );
    }

    #[test]
    fn dense_output_has_local_order_four() {
        // one step from the exact state: the order-3 interpolant errs by O(h⁴)
        let y0 = Smooth::exact(0.3);
        let err = |h: f64| {
            let mut m = Sdirk::new(3, 1e-13, 1e-13, f64::INFINITY);
            m.reset(&mut Smooth, 0.3, &y0, h);
            fixed_step(&mut m, &mut Smooth, h);
            dense_error(&m, |t| Smooth::exact(t).to_vec())
        };
        let (e1, e2, e3) = (err(0.2), err(0.1), err(0.05));
        let (p1, p2) = (order(e1, e2), order(e2, e3));
        assert!(
            (p1 - 4.0).abs() < 0.3 && (p2 - 4.0).abs() < 0.3,
            "orders {p1} {p2} (errors {e1:e} {e2:e} {e3:e})"
        );
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
