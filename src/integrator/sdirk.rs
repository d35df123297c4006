//! An L-stable, stiffly accurate two-stage SDIRK method of order 2 (Alexander,
//! γ = 1 − 1/√2) with an embedded first-order error estimate, simplified Newton iterations
//! on a finite-difference Jacobian, and cubic Hermite dense output. For stiff contact.

use super::{error_norm, Integrator, IntegratorError, OdeSystem, Stats};
use nalgebra::{DMatrix, DVector};

const GAMMA: f64 = 1.0 - std::f64::consts::FRAC_1_SQRT_2;

/// The SDIRK2 method.
pub struct Sdirk {
    rtol: f64,
    atol: f64,
    hmax: f64,
    t: f64,
    t_prev: f64,
    h: f64,
    y: Vec<f64>,
    y_prev: Vec<f64>,
    f: Vec<f64>,
    f_prev: Vec<f64>,
    jac: DMatrix<f64>,
    lu: Option<nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>>,
    lu_h: f64,
    jac_fresh: bool,
    have_jac: bool,
    k1: Vec<f64>,
    k2: Vec<f64>,
    stage: Vec<f64>,
    base: Vec<f64>,
    fz: Vec<f64>,
    err: Vec<f64>,
    ynew: Vec<f64>,
    stats: Stats,
}

impl Sdirk {
    /// A method for systems of size `n`.
    pub fn new(n: usize, rtol: f64, atol: f64, hmax: f64) -> Sdirk {
        let v = || vec![0.0; n];
        Sdirk {
            rtol,
            atol,
            hmax,
            t: 0.0,
            t_prev: 0.0,
            h: 0.0,
            y: v(),
            y_prev: v(),
            f: v(),
            f_prev: v(),
            jac: DMatrix::zeros(n, n),
            lu: None,
            lu_h: 0.0,
            jac_fresh: false,
            have_jac: false,
            k1: v(),
            k2: v(),
            stage: v(),
            base: v(),
            fz: v(),
            err: v(),
            ynew: v(),
            stats: Stats::default(),
        }
    }

    fn jacobian(&mut self, sys: &mut dyn OdeSystem) {
        let n = self.y.len();
        let mut yp = self.y.clone();
        for j in 0..n {
            let dy = f64::EPSILON.sqrt() * self.y[j].abs().max(1e-5);
            yp[j] = self.y[j] + dy;
            sys.rhs(self.t, &yp, &mut self.fz);
            for i in 0..n {
                self.jac[(i, j)] = (self.fz[i] - self.f[i]) / dy;
            }
            yp[j] = self.y[j];
        }
        self.stats.rhs_evals += n as u64;
        self.stats.jac_evals += 1;
        self.jac_fresh = true;
        self.have_jac = true;
        self.lu = None;
    }

    /// Solves `Y = base + hγ f(t_s, Y)` by simplified Newton; returns f(t_s, Y) in `kout`.
    fn solve_stage(&mut self, sys: &mut dyn OdeSystem, ts: f64, h: f64, which: usize) -> bool {
        let n = self.y.len();
        if self.lu.is_none() || self.lu_h != h {
            let m = DMatrix::identity(n, n) - &self.jac * (h * GAMMA);
            self.lu = Some(m.lu());
            self.lu_h = h;
        }
        self.stage.copy_from_slice(&self.base);
        for i in 0..n {
            self.stage[i] += h * GAMMA * self.f[i];
        }
        let mut prev_norm = f64::INFINITY;
        for _ in 0..8 {
            sys.rhs(ts, &self.stage, &mut self.fz);
            self.stats.rhs_evals += 1;
            let mut r = DVector::from_fn(n, |i, _| self.base[i] + h * GAMMA * self.fz[i] - self.stage[i]);
            let Some(lu) = &self.lu else { return false };
            if !lu.solve_mut(&mut r) {
                return false;
            }
            let norm = error_norm(r.as_slice(), &self.stage, &self.stage, self.rtol, self.atol);
            for i in 0..n {
                self.stage[i] += r[i];
            }
            if !norm.is_finite() || norm > 2.0 * prev_norm {
                return false;
            }
            if norm < 1e-2 {
                sys.rhs(ts, &self.stage, &mut self.fz);
                self.stats.rhs_evals += 1;
                let k = if which == 1 { &mut self.k1 } else { &mut self.k2 };
                k.copy_from_slice(&self.fz);
                return true;
            }
            prev_norm = norm;
        }
        false
    }
}

impl Integrator for Sdirk {
    fn reset(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.t = t;
        self.t_prev = t;
        self.y.copy_from_slice(y);
        self.y_prev.copy_from_slice(y);
        sys.rhs(t, y, &mut self.f);
        self.f_prev.copy_from_slice(&self.f);
        self.stats.rhs_evals += 1;
        self.h = if h > 0.0 {
            h.min(self.hmax)
        } else {
            (1e-4_f64).min(self.hmax)
        };
        self.jac_fresh = false;
        self.have_jac = false;
        self.lu = None;
    }

    fn step(&mut self, sys: &mut dyn OdeSystem, t_max: f64) -> Result<(), IntegratorError> {
        let n = self.y.len();
        if !self.have_jac {
            self.jacobian(sys);
        }
        loop {
            let mut h = self.h.min(self.hmax);
            let last = self.t + h >= t_max;
            if last {
                h = t_max - self.t;
            }
            if h <= 16.0 * f64::EPSILON * self.t.abs().max(1e-300) {
                return Err(IntegratorError::StepSizeUnderflow(self.t));
            }
            self.base.copy_from_slice(&self.y);
            if !self.solve_stage(sys, self.t + GAMMA * h, h, 1) {
                self.stats.rejected += 1;
                if !self.jac_fresh {
                    self.jacobian(sys);
                } else {
                    self.h = h * 0.25;
                }
                continue;
            }
            for i in 0..n {
                self.base[i] = self.y[i] + h * (1.0 - GAMMA) * self.k1[i];
            }
            let t_new = if last { t_max } else { self.t + h };
            if !self.solve_stage(sys, t_new, h, 2) {
                self.stats.rejected += 1;
                if !self.jac_fresh {
                    self.jacobian(sys);
                } else {
                    self.h = h * 0.25;
                }
                continue;
            }
            for i in 0..n {
                self.ynew[i] = self.stage[i];
                self.err[i] = h * GAMMA * (self.k2[i] - self.k1[i]);
            }
            let err = error_norm(&self.err, &self.y, &self.ynew, self.rtol, self.atol);
            let fac = (0.9 * err.max(1e-10).powf(-0.5)).clamp(0.2, 5.0);
            if err <= 1.0 {
                self.y_prev.copy_from_slice(&self.y);
                self.f_prev.copy_from_slice(&self.f);
                self.y.copy_from_slice(&self.ynew);
                self.f.copy_from_slice(&self.k2);
                self.t_prev = self.t;
                self.t = t_new;
                self.stats.steps += 1;
                let proposal = h * fac;
                self.h = if last { proposal.max(self.h) } else { proposal }.min(self.hmax);
                self.jac_fresh = false;
                return Ok(());
            }
            self.stats.rejected += 1;
            self.h = h * fac.min(0.9);
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
        let (h00, h10, h01, h11) = (
            (1.0 + 2.0 * s) * (1.0 - s) * (1.0 - s),
            s * (1.0 - s) * (1.0 - s),
            s * s * (3.0 - 2.0 * s),
            s * s * (s - 1.0),
        );
        for (i, o) in out.iter_mut().enumerate() {
            *o = h00 * self.y_prev[i] + h10 * h * self.f_prev[i] + h01 * self.y[i] + h11 * h * self.f[i];
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
