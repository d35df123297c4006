//! Classical fixed-step Runge-Kutta 4, a baseline. Dense output is the cubic Hermite
//! interpolant through both ends of the step.

use super::core::{core_accessors, state_tag, zeroed, StateReader, StepCore};
use super::{rk4_step, Integrator, IntegratorError, OdeSystem};
use crate::scene::{Method, SolverSection};

/// Fixed-step RK4 with step `h` (`core.h`).
pub struct Rk4 {
    /// Step state; `core.f` is `f(t, y)`, the first stage of the next step.
    core: StepCore,
    /// `f(t_prev, y_prev)` (dense output).
    f_prev: Vec<f64>,
    /// Stages `k₂ … k₄`.
    k: [Vec<f64>; 3],
    tmp: Vec<f64>,
}

impl Rk4 {
    /// A method for systems of size `n` with step `h`.
    pub fn new(n: usize, h: f64) -> Rk4 {
        let v = || vec![0.0; n];
        let mut core = StepCore::new(n, 0.0, 0.0, h);
        core.h = h;
        Rk4 {
            core,
            f_prev: v(),
            k: [v(), v(), v()],
            tmp: v(),
        }
    }
}

impl Integrator for Rk4 {
    core_accessors!();

    /// (as [`Rk4::new`]: the step is the core's largest step and its step to try)
    fn renew(&mut self, s: &SolverSection, n: usize) -> bool {
        let h = rk4_step(s);
        if s.method != Method::Rk4 || !self.core.renew(n, 0.0, 0.0, h) {
            return false;
        }
        self.core.h = h;
        let [k0, k1, k2] = &mut self.k;
        zeroed([&mut self.f_prev, k0, k1, k2, &mut self.tmp]);
        true
    }

    fn reset(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], _h: f64) {
        self.core.start(sys, t, y);
        self.f_prev.copy_from_slice(&self.core.f);
    }

    fn step(&mut self, sys: &mut dyn OdeSystem, t_max: f64) -> Result<(), IntegratorError> {
        let core = &mut self.core;
        let n = core.y.len();
        // stretch the last step by up to 1 % rather than leave a sliver before t_max
        let last = core.t + 1.01 * core.h >= t_max;
        let h = if last { t_max - core.t } else { core.h };
        if h <= 0.0 {
            return Err(IntegratorError::StepSizeUnderflow(core.t));
        }
        let t = core.t;
        let t_new = core.step_end(h, last, t_max);
        let k1 = &mut core.f;
        let [k2, k3, k4] = &mut self.k;
        let tmp = &mut self.tmp;
        for i in 0..n {
            tmp[i] = core.y[i] + 0.5 * h * k1[i];
        }
        sys.rhs(t + 0.5 * h, tmp, k2);
        for i in 0..n {
            tmp[i] = core.y[i] + 0.5 * h * k2[i];
        }
        sys.rhs(t + 0.5 * h, tmp, k3);
        for i in 0..n {
            tmp[i] = core.y[i] + h * k3[i];
        }
        sys.rhs(t_new, tmp, k4);
        core.y_prev.copy_from_slice(&core.y);
        self.f_prev.copy_from_slice(k1);
        for i in 0..n {
            core.y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        if !core.y.iter().all(|v| v.is_finite()) {
            return Err(IntegratorError::NotFinite(t));
        }
        sys.rhs(t_new, &core.y, k1);
        core.stats.rhs_evals += 4;
        core.advance(t_new);
        Ok(())
    }

    /// Tag, [`StepCore::save_state`] (its `h` is the fixed step), `f(t_prev, y_prev)` for the
    /// dense output: `8 + 4n` numbers.
    fn save_state(&self, out: &mut Vec<f64>) {
        out.push(state_tag(Method::Rk4));
        self.core.save_state(out);
        out.extend_from_slice(&self.f_prev);
    }

    fn load_state(&mut self, v: &[f64]) -> Result<(), String> {
        let n = self.core.y.len();
        let mut r = StateReader::new(v, Method::Rk4)?;
        let core = self.core.read_state(&mut r)?;
        let f_prev = r.take(n)?;
        r.finish()?;
        self.core.restore(&core);
        self.f_prev.copy_from_slice(f_prev);
        Ok(())
    }

    fn interpolate(&self, t: f64, out: &mut [f64]) {
        let (core, f_prev) = (&self.core, &self.f_prev);
        core.interpolate(t, out, |s, h, out| {
            let (h00, h10, h01, h11) = (
                (1.0 + 2.0 * s) * (1.0 - s) * (1.0 - s),
                s * (1.0 - s) * (1.0 - s),
                s * s * (3.0 - 2.0 * s),
                s * s * (s - 1.0),
            );
            for (i, o) in out.iter_mut().enumerate() {
                *o = h00 * core.y_prev[i] + h10 * h * f_prev[i] + h01 * core.y[i] + h11 * h * core.f[i];
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_problems::*;
    use super::*;

    #[test]
    fn converges_with_order_four() {
        let y0 = Smooth::exact(0.0);
        let err = |steps: usize| {
            let mut m = Rk4::new(3, 2.0 / steps as f64);
            let y = run(&mut m, &mut Smooth, 0.0, &y0, 2.0);
            assert_eq!(m.stats().steps as usize, steps);
            max_diff(&y, &Smooth::exact(2.0))
        };
        assert_order("rk4", 4.0, [err(20), err(40), err(80)]);
    }

    #[test]
    fn hermite_dense_output_has_local_order_four() {
        // from t = 1 (near t = 0.325 the fourth derivative of 1/(1+t²), which sets the
        // interpolation error, changes sign)
        let y0 = Smooth::exact(1.0);
        let err = |h: f64| {
            let mut m = Rk4::new(3, h);
            m.reset(&mut Smooth, 1.0, &y0, h);
            m.step(&mut Smooth, 10.0).unwrap();
            dense_error(&m, |t| Smooth::exact(t).to_vec())
        };
        assert_order("rk4", 4.0, [err(0.1), err(0.05), err(0.025)]);
    }

    #[test]
    fn stability_ends_at_the_real_axis_bound() {
        // RK4 is stable on the negative real axis for h|λ| ≤ 2.785
        let lambda = -1e3;
        let decay = |h: f64| {
            let mut m = Rk4::new(1, h);
            let y = run(&mut m, &mut ProtheroRobinson { lambda }, 0.0, &[1.0], 1.0);
            (y[0] - 1f64.sin()).abs()
        };
        // stable: the error stays at the truncation error of the forced solution
        assert!(decay(2.70e-3) < 1e-4, "stable side: {:e}", decay(2.70e-3));
        assert!(decay(2.85e-3) > 1.0, "unstable side: {:e}", decay(2.85e-3));
    }
}
