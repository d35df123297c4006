//! Classical fixed-step Runge-Kutta 4, a baseline. Dense output is the cubic Hermite
//! interpolant through both ends of the step.

use super::{Integrator, IntegratorError, OdeSystem, Stats};

/// Fixed-step RK4 with step `h`.
pub struct Rk4 {
    h: f64,
    t: f64,
    t_prev: f64,
    y: Vec<f64>,
    y_prev: Vec<f64>,
    f_prev: Vec<f64>,
    k: [Vec<f64>; 4],
    tmp: Vec<f64>,
    stats: Stats,
}

impl Rk4 {
    /// A method for systems of size `n` with step `h`.
    pub fn new(n: usize, h: f64) -> Rk4 {
        let v = || vec![0.0; n];
        Rk4 {
            h,
            t: 0.0,
            t_prev: 0.0,
            y: v(),
            y_prev: v(),
            f_prev: v(),
            k: [v(), v(), v(), v()],
            tmp: v(),
            stats: Stats::default(),
        }
    }
}

impl Integrator for Rk4 {
    fn reset(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], _h: f64) {
        self.t = t;
        self.t_prev = t;
        self.y.copy_from_slice(y);
        self.y_prev.copy_from_slice(y);
        sys.rhs(t, y, &mut self.k[0]);
        self.f_prev.copy_from_slice(&self.k[0]);
        self.stats.rhs_evals += 1;
    }

    fn step(&mut self, sys: &mut dyn OdeSystem, t_max: f64) -> Result<(), IntegratorError> {
        let n = self.y.len();
        // stretch the last step by up to 1 % rather than leave a sliver before t_max
        let last = self.t + 1.01 * self.h >= t_max;
        let h = if last { t_max - self.t } else { self.h };
        if h <= 0.0 {
            return Err(IntegratorError::StepSizeUnderflow(self.t));
        }
        let t = self.t;
        let [k1, k2, k3, k4] = &mut self.k;
        let tmp = &mut self.tmp;
        for i in 0..n {
            tmp[i] = self.y[i] + 0.5 * h * k1[i];
        }
        sys.rhs(t + 0.5 * h, tmp, k2);
        for i in 0..n {
            tmp[i] = self.y[i] + 0.5 * h * k2[i];
        }
        sys.rhs(t + 0.5 * h, tmp, k3);
        for i in 0..n {
            tmp[i] = self.y[i] + h * k3[i];
        }
        let t_new = if last { t_max } else { t + h };
        sys.rhs(t_new, tmp, k4);
        self.y_prev.copy_from_slice(&self.y);
        self.f_prev.copy_from_slice(k1);
        for i in 0..n {
            self.y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        if !self.y.iter().all(|v| v.is_finite()) {
            return Err(IntegratorError::NotFinite(t));
        }
        sys.rhs(t_new, &self.y, k1);
        self.stats.rhs_evals += 4;
        self.stats.steps += 1;
        self.t_prev = t;
        self.t = t_new;
        Ok(())
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
            *o = h00 * self.y_prev[i] + h10 * h * self.f_prev[i] + h01 * self.y[i] + h11 * h * self.k[0][i];
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
        let (e1, e2, e3) = (err(20), err(40), err(80));
        let (p1, p2) = (order(e1, e2), order(e2, e3));
        assert!(
            (p1 - 4.0).abs() < 0.3 && (p2 - 4.0).abs() < 0.3,
            "orders {p1} {p2} (errors {e1:e} {e2:e} {e3:e})"
        );
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
        let (e1, e2, e3) = (err(0.1), err(0.05), err(0.025));
        let (p1, p2) = (order(e1, e2), order(e2, e3));
        assert!(
            (p1 - 4.0).abs() < 0.3 && (p2 - 4.0).abs() < 0.3,
            "orders {p1} {p2} (errors {e1:e} {e2:e} {e3:e})"
        );
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
