//! Radau IIA of order 5 (three stages, stage order 3, L-stable, stiffly accurate), after
//! Hairer & Wanner's RADAU5 (*Solving ODEs II*, IV.8), for stiff problems with a smooth slow
//! solution, where the stage order 1 of SDIRK4 costs it accuracy (order reduction).
//!
//! - The stage increments `Zᵢ = Yᵢ − y₀` are solved together by simplified Newton on the real
//!   3n × 3n matrix `I − h A⊗J` (an in-place LU on a preallocated buffer; no complex
//!   transformation — the systems here are small), `J` by forward differences.
//! - Jacobian and LU reuse, `J = 0` after a reset, `J` and controller memory kept across a
//!   plain restart (and saved through `warm_state`), and the step-size controller are those of
//!   [`super::sdirk`].
//! - Error estimate of order 3 filtered by `(I − hγ₀J)⁻¹` (IV.8.19), refined with one more
//!   evaluation after a rejected or first step, as RADAU5 does.
//! - Dense output: the collocation polynomial through `(0, y₀)` and `(cᵢ, Yᵢ)` (order 3).
//! - Nothing is allocated after construction.

use super::lu;
use super::{error_norm, Integrator, IntegratorError, OdeSystem, Stats, WarmMemory};

const SQ6: f64 = 2.449_489_742_783_178;
/// Nodes.
const C: [f64; 3] = [(4.0 - SQ6) / 10.0, (4.0 + SQ6) / 10.0, 1.0];
/// Butcher matrix.
const A: [[f64; 3]; 3] = [
    [
        (88.0 - 7.0 * SQ6) / 360.0,
        (296.0 - 169.0 * SQ6) / 1800.0,
        (-2.0 + 3.0 * SQ6) / 225.0,
    ],
    [
        (296.0 + 169.0 * SQ6) / 1800.0,
        (88.0 + 7.0 * SQ6) / 360.0,
        (-2.0 - 3.0 * SQ6) / 225.0,
    ],
    [(16.0 - SQ6) / 36.0, (16.0 + SQ6) / 36.0, 1.0 / 9.0],
];
/// Coefficients `(−13 − 7√6)/3, (−13 + 7√6)/3, −1/3` of the embedded error formula.
const DD: [f64; 3] = [(-13.0 - 7.0 * SQ6) / 3.0, (-13.0 + 7.0 * SQ6) / 3.0, -1.0 / 3.0];

/// γ₀ = 1/λ, λ the real eigenvalue of A⁻¹: `(6 + 81^{1/3} − 9^{1/3})/30`.
fn gamma0() -> f64 {
    (6.0 + 81f64.cbrt() - 9f64.cbrt()) / 30.0
}

const MAX_NEWTON: usize = 7;
const SLOW_CONTRACTION: f64 = 0.5;
const SAFETY: f64 = 0.9;
const MAX_GROW: f64 = 8.0;
const MAX_SHRINK: f64 = 5.0;
const ROUNDOFF_GAP: f64 = 16.0 * f64::EPSILON;

/// The Radau IIA 5 method (scene name `"radau5"`).
pub struct Radau5 {
    rtol: f64,
    atol: f64,
    hmax: f64,
    newton_tol: f64,
    max_newton: usize,
    n: usize,
    t: f64,
    t_prev: f64,
    h: f64,
    y: Vec<f64>,
    /// f(t, y).
    f: Vec<f64>,
    /// State at the start of the last step and its stage increments (dense output).
    y_prev: Vec<f64>,
    z_prev: [Vec<f64>; 3],
    /// Stage increments Z (3n, stage-major) and Newton correction.
    z: Vec<f64>,
    dz: Vec<f64>,
    /// Stage values and right-hand sides.
    stage: Vec<f64>,
    fz: [Vec<f64>; 3],
    jac: Vec<f64>,
    /// LU of `I − hA⊗J` (3n × 3n) and of `I − hγ₀J` (n × n).
    lu_big: Vec<f64>,
    perm_big: Vec<usize>,
    lu_err: Vec<f64>,
    perm_err: Vec<usize>,
    lu_h: f64,
    jac_fresh: bool,
    jac_stale: bool,
    /// `jac` holds an evaluation (false: J = 0 after a reset).
    jac_valid: bool,
    eta: f64,
    h_acc: f64,
    err_acc: f64,
    err: Vec<f64>,
    work: Vec<f64>,
    work_big: Vec<f64>,
    stats: Stats,
}

impl Radau5 {
    /// A method for systems of size `n` with tolerances `rtol`, `atol` and largest step `hmax`.
    pub fn new(n: usize, rtol: f64, atol: f64, hmax: f64) -> Radau5 {
        let v = |k: usize| vec![0.0; k];
        Radau5 {
            rtol,
            atol,
            hmax: if hmax > 0.0 { hmax } else { f64::INFINITY },
            newton_tol: (10.0 * f64::EPSILON / rtol.max(1e-300)).max(0.03_f64.min(rtol.sqrt())),
            max_newton: MAX_NEWTON,
            n,
            t: 0.0,
            t_prev: 0.0,
            h: 0.0,
            y: v(n),
            f: v(n),
            y_prev: v(n),
            z_prev: [v(n), v(n), v(n)],
            z: v(3 * n),
            dz: v(3 * n),
            stage: v(n),
            fz: [v(n), v(n), v(n)],
            jac: v(n * n),
            lu_big: v(9 * n * n),
            perm_big: vec![0; 3 * n],
            lu_err: v(n * n),
            perm_err: vec![0; n],
            lu_h: 0.0,
            jac_fresh: false,
            jac_stale: false,
            jac_valid: false,
            eta: 1.0,
            h_acc: 0.0,
            err_acc: 0.0,
            err: v(n),
            work: v(n),
            work_big: v(3 * n),
            stats: Stats::default(),
        }
    }

    /// Forward-difference Jacobian at `(t, y)` (n + 1 evaluations).
    fn jacobian(&mut self, sys: &mut dyn OdeSystem) {
        let n = self.n;
        sys.rhs(self.t, &self.y, &mut self.err);
        self.stage.copy_from_slice(&self.y);
        for j in 0..n {
            let yj = self.y[j];
            let dy = (f64::EPSILON * 1e-5_f64.max(yj.abs())).sqrt();
            self.stage[j] = yj + dy;
            let dy = self.stage[j] - yj;
            sys.rhs(self.t, &self.stage, &mut self.work);
            for i in 0..n {
                self.jac[i * n + j] = (self.work[i] - self.err[i]) / dy;
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

    /// Factors both iteration matrices for step `h` unless done. False if singular.
    fn factor(&mut self, h: f64) -> bool {
        if self.lu_h == h {
            return true;
        }
        let n = self.n;
        let m = 3 * n;
        for (bi, a_row) in A.iter().enumerate() {
            for (bj, aij) in a_row.iter().enumerate() {
                let a = h * aij;
                for i in 0..n {
                    let row = (bi * n + i) * m + bj * n;
                    for j in 0..n {
                        self.lu_big[row + j] = -a * self.jac[i * n + j];
                    }
                }
            }
        }
        for i in 0..m {
            self.lu_big[i * m + i] += 1.0;
        }
        let hg = h * gamma0();
        for (l, j) in self.lu_err.iter_mut().zip(&self.jac) {
            *l = -hg * j;
        }
        for i in 0..n {
            self.lu_err[i * n + i] += 1.0;
        }
        let ok = lu::factor_in_place(&mut self.lu_big, m, &mut self.perm_big)
            && lu::factor_in_place(&mut self.lu_err, n, &mut self.perm_err);
        self.lu_h = if ok { h } else { 0.0 };
        ok
    }

    /// Lagrange basis on the nodes (0, c₁, c₂, c₃) for node `i` (1..=3) at θ.
    fn basis(i: usize, th: f64) -> f64 {
        let nodes = [0.0, C[0], C[1], C[2]];
        let mut l = 1.0;
        for (k, ck) in nodes.iter().enumerate() {
            if k != i {
                l *= (th - ck) / (nodes[i] - ck);
            }
        }
        l
    }

    /// Solves the stage equations for step `h`; returns the largest contraction rate.
    fn newton(&mut self, sys: &mut dyn OdeSystem, h: f64) -> Option<f64> {
        let n = self.n;
        // starting values: the previous collocation polynomial, extrapolated
        let h_prev = self.t - self.t_prev;
        if self.h_acc > 0.0 && h_prev > 0.0 {
            for (s, cs) in C.iter().enumerate() {
                let th = 1.0 + cs * h / h_prev;
                let l = [Self::basis(1, th), Self::basis(2, th), Self::basis(3, th)];
                for m in 0..n {
                    let u =
                        self.y_prev[m] + l[0] * self.z_prev[0][m] + l[1] * self.z_prev[1][m] + l[2] * self.z_prev[2][m];
                    self.z[s * n + m] = u - self.y[m];
                }
            }
        } else {
            self.z.iter_mut().for_each(|x| *x = 0.0);
        }
        let mut norm_old = 0.0;
        let mut theta_max: f64 = 0.0;
        let mut eta = self.eta.max(f64::EPSILON).powf(0.8);
        for iter in 0..self.max_newton {
            for (s, cs) in C.iter().enumerate() {
                for m in 0..n {
                    self.stage[m] = self.y[m] + self.z[s * n + m];
                }
                sys.rhs(self.t + cs * h, &self.stage, &mut self.fz[s]);
            }
            self.stats.rhs_evals += 3;
            // residual −Z + h (A⊗I) F
            for (s, a_row) in A.iter().enumerate() {
                for m in 0..n {
                    let hf = h * (a_row[0] * self.fz[0][m] + a_row[1] * self.fz[1][m] + a_row[2] * self.fz[2][m]);
                    self.dz[s * n + m] = hf - self.z[s * n + m];
                }
            }
            lu::solve_in_place(&self.lu_big, 3 * n, &self.perm_big, &mut self.dz, &mut self.work_big);
            let mut sum = 0.0;
            let mut at_roundoff = true;
            for s in 0..3 {
                for m in 0..n {
                    let d = self.dz[s * n + m];
                    let sc = self.atol + self.rtol * self.y[m].abs();
                    sum += (d / sc) * (d / sc);
                    let zi = self.z[s * n + m] + d;
                    at_roundoff &= d.abs() <= 8.0 * f64::EPSILON * (self.y[m] + zi).abs();
                    self.z[s * n + m] = zi;
                }
            }
            let norm = (sum / (3 * n).max(1) as f64).sqrt();
            if !norm.is_finite() {
                return None;
            }
            if !at_roundoff && iter > 0 {
                let theta = norm / norm_old;
                theta_max = theta_max.max(theta);
                if theta >= 0.99 {
                    return None;
                }
                let left = (self.max_newton - 1 - iter) as i32;
                if theta.powi(left) / (1.0 - theta) * norm > self.newton_tol {
                    return None;
                }
                eta = theta / (1.0 - theta);
            }
            if at_roundoff || eta * norm <= self.newton_tol {
                self.eta = eta;
                return Some(theta_max);
            }
            norm_old = norm;
        }
        None
    }

    /// Filtered error estimate (IV.8.19) in `self.err`; its weighted norm.
    fn error_estimate(&mut self, sys: &mut dyn OdeSystem, h: f64, refine: bool) -> f64 {
        let n = self.n;
        let g0 = gamma0();
        // work = γ₀ Σ ddᵢ Zᵢ (the h·f₀ term added below)
        for m in 0..n {
            self.work[m] = g0 * (DD[0] * self.z[m] + DD[1] * self.z[n + m] + DD[2] * self.z[2 * n + m]);
            self.err[m] = self.work[m] + g0 * h * self.f[m];
        }
        lu::solve_in_place(&self.lu_err, n, &self.perm_err, &mut self.err, &mut self.stage);
        for m in 0..n {
            self.stage[m] = self.y[m] + self.z[2 * n + m];
        }
        let mut e = error_norm(&self.err, &self.y, &self.stage, self.rtol, self.atol);
        if refine && e >= 1.0 {
            // RADAU5: replace f(y₀) by f(y₀ + err) and filter again
            for m in 0..n {
                self.stage[m] = self.y[m] + self.err[m];
            }
            sys.rhs(self.t, &self.stage, &mut self.fz[0]);
            self.stats.rhs_evals += 1;
            for m in 0..n {
                self.err[m] = self.work[m] + g0 * h * self.fz[0][m];
            }
            lu::solve_in_place(&self.lu_err, n, &self.perm_err, &mut self.err, &mut self.stage);
            for m in 0..n {
                self.stage[m] = self.y[m] + self.z[2 * n + m];
            }
            e = error_norm(&self.err, &self.y, &self.stage, self.rtol, self.atol);
        }
        e
    }

    /// One attempt of a step of size `h`: (error norm, contraction), or None if Newton failed.
    fn attempt(&mut self, sys: &mut dyn OdeSystem, h: f64, refine: bool) -> Option<(f64, f64)> {
        if !self.factor(h) {
            return None;
        }
        let theta = self.newton(sys, h)?;
        // fz[2] = f(Y₃) = f at the new state (before the refinement may overwrite fz[0])
        let err = self.error_estimate(sys, h, refine);
        Some((err, theta))
    }

    /// Accepts the attempted step of size `h` ending at `t_new`.
    fn accept(&mut self, sys: &mut dyn OdeSystem, t_new: f64) {
        let n = self.n;
        self.y_prev.copy_from_slice(&self.y);
        for s in 0..3 {
            self.z_prev[s].copy_from_slice(&self.z[s * n..(s + 1) * n]);
        }
        for m in 0..n {
            self.y[m] += self.z[2 * n + m];
        }
        self.t_prev = self.t;
        self.t = t_new;
        // f at the new state (the last stage's f is only converged to the Newton tolerance)
        sys.rhs(self.t, &self.y, &mut self.f);
        self.stats.rhs_evals += 1;
        self.stats.steps += 1;
        self.jac_fresh = false;
    }
}

impl Radau5 {
    /// Starts at `(t, y)` with first step `h` (0: choose one); the memory is left alone.
    fn start(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.t = t;
        self.t_prev = t;
        self.y.copy_from_slice(y);
        self.y_prev.copy_from_slice(y);
        for z in self.z_prev.iter_mut() {
            z.iter_mut().for_each(|x| *x = 0.0);
        }
        sys.rhs(t, y, &mut self.f);
        self.stats.rhs_evals += 1;
        self.h = if h > 0.0 {
            h.min(self.hmax)
        } else {
            let [k0, k1, _] = &mut self.fz;
            k0.copy_from_slice(&self.f);
            self.stats.rhs_evals += 1;
            super::initial_step(sys, t, y, k0, self.rtol, self.atol, 5, &mut self.work, k1, self.hmax)
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

    /// Forgets the Jacobian: J = 0 until Newton needs one.
    fn drop_jacobian(&mut self) {
        self.jac.iter_mut().for_each(|x| *x = 0.0);
        self.jac_valid = false;
        self.lu_h = 0.0;
    }
}

impl Integrator for Radau5 {
    fn reset(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.start(sys, t, y, h);
        // as in SDIRK4: nothing survives a restart after a discontinuity; J = 0 until Newton
        // needs a Jacobian
        self.drop_jacobian();
        self.set_memory(WarmMemory::cold());
    }

    fn restart(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.start(sys, t, y, h);
        // keep J, the LU factors (a function of J and h), Newton and controller memory; all
        // of it is in `warm_state`, except a Jacobian too big to save, which is dropped here
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
        if t_max - self.t <= ROUNDOFF_GAP * self.t.abs() {
            self.y_prev.copy_from_slice(&self.y);
            for z in self.z_prev.iter_mut() {
                z.iter_mut().for_each(|x| *x = 0.0);
            }
            self.t_prev = self.t;
            self.t = self.t.max(t_max);
            return Ok(());
        }
        let mut rejected_before = false;
        loop {
            let mut h = self.h.min(self.hmax);
            let last = self.t + 1.01 * h >= t_max;
            if last {
                h = t_max - self.t;
            }
            if h <= ROUNDOFF_GAP * self.t.abs().max(1e-300) {
                return Err(IntegratorError::StepSizeUnderflow(self.t));
            }
            let refine = rejected_before || self.h_acc == 0.0;
            let Some((err, theta)) = self.attempt(sys, h, refine) else {
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
            let mut quot = (err.powf(0.25) / SAFETY).clamp(1.0 / MAX_GROW, MAX_SHRINK);
            if err <= 1.0 {
                if self.h_acc > 0.0 {
                    let gus = (self.h_acc / h) * (err * err / self.err_acc).powf(0.25) / SAFETY;
                    quot = quot.max(gus.clamp(1.0 / MAX_GROW, MAX_SHRINK));
                }
                self.h_acc = h;
                self.err_acc = err.max(1e-2);
                let t_new = if last { t_max } else { self.t + h };
                self.accept(sys, t_new);
                if theta > SLOW_CONTRACTION {
                    self.jac_stale = true;
                }
                let mut h_new = h / quot;
                if rejected_before {
                    h_new = h_new.min(h);
                }
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
        let th = (t - self.t_prev) / h;
        let l = [Self::basis(1, th), Self::basis(2, th), Self::basis(3, th)];
        for (m, o) in out.iter_mut().enumerate() {
            *o = self.y_prev[m] + l[0] * self.z_prev[0][m] + l[1] * self.z_prev[1][m] + l[2] * self.z_prev[2][m];
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
    use super::super::sdirk::Sdirk;
    use super::super::test_problems::*;
    use super::*;

    /// One step of exactly `h` (tight Newton, fresh Jacobian, no error control).
    fn fixed_step(m: &mut Radau5, sys: &mut dyn OdeSystem, h: f64) -> f64 {
        m.max_newton = 40;
        m.jacobian(sys);
        let (err, _) = m.attempt(sys, h, false).expect("Newton failed");
        let t_new = m.t + h;
        m.accept(sys, t_new);
        err
    }

    #[test]
    fn tableau_is_radau_iia() {
        // B(5): Σ bᵢ cᵢ^{k−1} = 1/k; C(3): Σⱼ aᵢⱼ cⱼ^{k−1} = cᵢᵏ/k
        for k in 1..=5 {
            let s: f64 = (0..3).map(|i| A[2][i] * C[i].powi(k - 1)).sum();
            assert!((s - 1.0 / k as f64).abs() < 1e-14, "B({k}): {s}");
        }
        for i in 0..3 {
            for k in 1..=3 {
                let s: f64 = (0..3).map(|j| A[i][j] * C[j].powi(k - 1)).sum();
                assert!((s - C[i].powi(k) / k as f64).abs() < 1e-14, "C({k}) row {i}");
            }
        }
        // γ₀ is the inverse of a real eigenvalue of A⁻¹, i.e. an eigenvalue of A: det(A − γ₀I) = 0
        let g = gamma0();
        let m = |i: usize, j: usize| A[i][j] - if i == j { g } else { 0.0 };
        let det = m(0, 0) * (m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1)) - m(0, 1) * (m(1, 0) * m(2, 2) - m(1, 2) * m(2, 0))
            + m(0, 2) * (m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0));
        assert!(det.abs() < 1e-14, "det {det}");
        // the embedded formula is consistent: γ₀(1 + Σ ddᵢ cᵢ) = 0
        let s: f64 = (0..3).map(|i| DD[i] * C[i]).sum();
        assert!((1.0 + s).abs() < 1e-14);
    }

    #[test]
    fn converges_with_order_five() {
        let y0 = Smooth::exact(0.0);
        let err = |steps: usize| {
            let h = 2.0 / steps as f64;
            let mut m = Radau5::new(3, 1e-13, 1e-13, f64::INFINITY);
            m.reset(&mut Smooth, 0.0, &y0, h);
            for _ in 0..steps {
                fixed_step(&mut m, &mut Smooth, h);
            }
            max_diff(m.y(), &Smooth::exact(2.0))
        };
        let (e1, e2, e3) = (err(10), err(20), err(40));
        let (p1, p2) = (order(e1, e2), order(e2, e3));
        assert!(
            (p1 - 5.0).abs() < 0.3 && (p2 - 5.0).abs() < 0.3,
            "orders {p1} {p2} (errors {e1:e} {e2:e} {e3:e})"
        );
    }

    #[test]
    fn dense_output_and_error_estimate_have_the_expected_local_orders() {
        // collocation polynomial: O(h⁴) over the step; error estimate of an order-3 method: O(h⁴)
        let y0 = Smooth::exact(1.0);
        let run = |h: f64| {
            let mut m = Radau5::new(3, 1e-13, 1e-13, f64::INFINITY);
            m.reset(&mut Smooth, 1.0, &y0, h);
            let est = fixed_step(&mut m, &mut Smooth, h);
            (dense_error(&m, |t| Smooth::exact(t).to_vec()), est)
        };
        let ((d1, s1), (d2, s2), (d3, s3)) = (run(0.1), run(0.05), run(0.025));
        let (p1, p2) = (order(d1, d2), order(d2, d3));
        assert!(
            (p1 - 4.0).abs() < 0.3 && (p2 - 4.0).abs() < 0.3,
            "dense {p1} {p2} ({d1:e} {d2:e} {d3:e})"
        );
        let (q1, q2) = (order(s1, s2), order(s2, s3));
        assert!(
            (q1 - 4.0).abs() < 0.3 && (q2 - 4.0).abs() < 0.3,
            "estimate {q1} {q2} ({s1:e} {s2:e} {s3:e})"
        );
    }

    #[test]
    fn adaptive_run_meets_the_tolerance() {
        let y0 = Growth::exact(0.0);
        for tol in [1e-5, 1e-8] {
            let mut m = Radau5::new(3, tol, tol, f64::INFINITY);
            let y = run(&mut m, &mut Growth, 0.0, &y0, 2.0);
            let e = max_diff(&y, &Growth::exact(2.0)) / 2f64.exp();
            assert!(e < 100.0 * tol, "tol {tol:e}: relative error {e:e}");
        }
    }

    #[test]
    fn stiff_problems_take_far_fewer_steps_than_dopri5_and_sdirk4() {
        let lambda = -1e5;
        let tol = 1e-6;
        let mut imp = Radau5::new(1, tol, tol, f64::INFINITY);
        let y = run(&mut imp, &mut ProtheroRobinson { lambda }, 0.0, &[0.0], 10.0);
        assert!((y[0] - 10f64.sin()).abs() < 10.0 * tol);
        let mut exp = Dopri5::new(1, tol, tol, f64::INFINITY);
        run(&mut exp, &mut ProtheroRobinson { lambda }, 0.0, &[0.0], 10.0);
        assert!(
            exp.stats().steps > 1000 * imp.stats().steps,
            "{:?} {:?}",
            imp.stats(),
            exp.stats()
        );
        // a stiff spring on a moving support: stage order 3 avoids SDIRK4's order reduction
        struct Support;
        impl OdeSystem for Support {
            fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
                let (w, om) = (2.0 * std::f64::consts::PI * 5.0, 1e4);
                let (s, sd) = (1e-3 * (w * t).sin(), 1e-3 * w * (w * t).cos());
                dy[0] = y[1];
                dy[1] = -om * om * (y[0] - s) - 2.0 * om * (y[1] - sd) - 9.81;
            }
        }
        let tol = 1e-8;
        let mut reference = Radau5::new(2, 1e-12, 1e-12, f64::INFINITY);
        let y_ref = run(&mut reference, &mut Support, 0.0, &[0.0, -1.0], 1.0);
        let mut check = Dopri5::new(2, 1e-12, 1e-12, f64::INFINITY);
        let y_chk = run(&mut check, &mut Support, 0.0, &[0.0, -1.0], 1.0);
        assert!(max_diff(&y_ref, &y_chk) < 1e-9, "{y_ref:?} vs {y_chk:?}");
        let mut ra = Radau5::new(2, tol, tol, f64::INFINITY);
        let y_ra = run(&mut ra, &mut Support, 0.0, &[0.0, -1.0], 1.0);
        let mut sd = Sdirk::new(2, tol, tol, f64::INFINITY);
        run(&mut sd, &mut Support, 0.0, &[0.0, -1.0], 1.0);
        assert!(
            max_diff(&y_ra, &y_ref) < 10.0 * tol,
            "error {:e}",
            max_diff(&y_ra, &y_ref)
        );
        assert!(
            sd.stats().rhs_evals > 5 * ra.stats().rhs_evals,
            "radau5 {:?} sdirk4 {:?}",
            ra.stats(),
            sd.stats()
        );
    }
}
