//! Test problems with closed-form solutions, shared by the integrators' unit tests, and the
//! helpers that run and measure them.

use super::newton::ImplicitMethod;
use super::{Integrator, OdeSystem};

/// `y₀' = y₀, y₁' = y₂, y₂' = −y₁` from `(1, 0, 1)`: `(eᵗ, sin t, cos t)`.
pub struct Growth;
impl OdeSystem for Growth {
    fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[0];
        dy[1] = y[2];
        dy[2] = -y[1];
    }
}
impl Growth {
    pub fn exact(t: f64) -> [f64; 3] {
        [t.exp(), t.sin(), t.cos()]
    }
}

/// Nonlinear and non-autonomous: `y₀' = −2t y₀²`, plus the oscillator of [`Growth`];
/// `y = (1/(1+t²), sin t, cos t)`.
pub struct Smooth;
impl OdeSystem for Smooth {
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = -2.0 * t * y[0] * y[0];
        dy[1] = y[2];
        dy[2] = -y[1];
    }
}
impl Smooth {
    pub fn exact(t: f64) -> [f64; 3] {
        [1.0 / (1.0 + t * t), t.sin(), t.cos()]
    }
}

/// Prothero-Robinson `y' = λ(y − sin t) + cos t`, `y(0) = 0`: `y = sin t` (stiff for λ ≪ 0).
pub struct ProtheroRobinson {
    pub lambda: f64,
}
impl OdeSystem for ProtheroRobinson {
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = self.lambda * (y[0] - t.sin()) + t.cos();
    }
}

/// A unit mass on a stiff, critically damped spring under gravity (a resting contact):
/// `x'' = −ω²x − 2ωx' − g`, from `x = 0`, `x' = v₀`.
pub struct SpringDamper {
    pub omega: f64,
    pub g: f64,
}
impl OdeSystem for SpringDamper {
    fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = -self.omega * self.omega * y[0] - 2.0 * self.omega * y[1] - self.g;
    }
}
impl SpringDamper {
    /// `x(t) = x_eq + (A + Bt) e^{−ωt}` with `x_eq = −g/ω²`.
    pub fn exact(&self, t: f64, v0: f64) -> [f64; 2] {
        let w = self.omega;
        let x_eq = -self.g / (w * w);
        let a = -x_eq;
        let b = v0 + w * a;
        let e = (-w * t).exp();
        [x_eq + (a + b * t) * e, (b - w * (a + b * t)) * e]
    }
}

/// Van der Pol in relaxation form `y₀' = y₁`, `y₁' = ((1 − y₀²) y₁ − y₀)/ε`: stiff for small
/// ε, and nonlinear, so that an implicit method's Jacobian goes stale (slow Newton
/// contraction near the fast jumps) and is refreshed.
pub struct VanDerPol {
    pub eps: f64,
}
impl OdeSystem for VanDerPol {
    fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = ((1.0 - y[0] * y[0]) * y[1] - y[0]) / self.eps;
    }
}

/// `y' = −λ (y + y³ − 2 sin t)`: stiff for λ ≫ 1, near the slow solution `y + y³ = 2 sin t`,
/// where the Jacobian `−λ(1 + 3y²)` drifts by a factor of up to 4 (so that an implicit
/// method's Newton iteration slows down and its Jacobian goes stale).
pub struct StiffCubic {
    pub lambda: f64,
}
impl OdeSystem for StiffCubic {
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = -self.lambda * (y[0] + y[0] * y[0] * y[0] - 2.0 * t.sin());
    }
}

/// Integrates from `(t0, y0)` to `t_end`; returns the final state.
pub fn run(m: &mut dyn Integrator, sys: &mut dyn OdeSystem, t0: f64, y0: &[f64], t_end: f64) -> Vec<f64> {
    run_from(m, sys, t0, y0, t_end, 0.0)
}

/// [`run`] with first step `h0`.
pub fn run_from(m: &mut dyn Integrator, sys: &mut dyn OdeSystem, t0: f64, y0: &[f64], t_end: f64, h0: f64) -> Vec<f64> {
    m.reset(sys, t0, y0, h0);
    while m.t() < t_end {
        m.step(sys, t_end).expect("step failed");
    }
    m.y().to_vec()
}

/// One step of an implicit method of exactly `h` (tight Newton, fresh Jacobian, no error
/// control), to measure the order of the formula itself; returns the step's error estimate.
pub fn implicit_fixed_step<M: ImplicitMethod>(m: &mut M, sys: &mut dyn OdeSystem, h: f64) -> f64 {
    m.parts_mut().1.max_newton = 40;
    m.jacobian(sys);
    let (err, _) = m.attempt(sys, h, false).expect("Newton failed");
    let t_new = m.parts().0.t + h;
    m.accept(sys, h, t_new);
    err
}

/// The method that `new` makes for [`Smooth`] with tolerances of 1e-13 (its Newton iterations
/// converge to rounding), started at the exact state at `t0`, after `steps` steps of exactly
/// `h` ([`implicit_fixed_step`]); and the last step's error estimate.
pub fn smooth_fixed_steps<M: ImplicitMethod>(
    new: fn(usize, f64, f64, f64) -> M,
    t0: f64,
    h: f64,
    steps: usize,
) -> (M, f64) {
    let mut m = new(3, 1e-13, 1e-13, f64::INFINITY);
    m.reset(&mut Smooth, t0, &Smooth::exact(t0), h);
    let mut estimate = 0.0;
    for _ in 0..steps {
        estimate = implicit_fixed_step(&mut m, &mut Smooth, h);
    }
    (m, estimate)
}

/// Asserts that the implicit method `new` makes converges with order `p` at fixed steps: its
/// errors at t = 2 after 10, 20 and 40 steps from the exact state of [`Smooth`] at 0.
pub fn assert_fixed_step_order<M: ImplicitMethod>(name: &str, new: fn(usize, f64, f64, f64) -> M, p: f64) {
    let err = |steps: usize| {
        let (m, _) = smooth_fixed_steps(new, 0.0, 2.0 / steps as f64, steps);
        max_diff(m.y(), &Smooth::exact(2.0))
    };
    assert_order(name, p, [err(10), err(20), err(40)]);
}

/// One step of exactly `h` from the exact state of [`Smooth`] at `t0` ([`smooth_fixed_steps`]):
/// the largest error of its dense output and its error estimate.
pub fn smooth_one_step<M: ImplicitMethod>(new: fn(usize, f64, f64, f64) -> M, t0: f64, h: f64) -> (f64, f64) {
    let (m, estimate) = smooth_fixed_steps(new, t0, h, 1);
    (dense_error(&m, |t| Smooth::exact(t).to_vec()), estimate)
}

/// Largest absolute difference.
pub fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
}

/// Largest error of the dense output over the last step against `exact`.
pub fn dense_error(m: &dyn Integrator, exact: impl Fn(f64) -> Vec<f64>) -> f64 {
    let (t0, t1) = (m.t_prev(), m.t());
    let mut out = vec![0.0; m.y().len()];
    let mut worst = 0.0_f64;
    for i in 1..40 {
        let t = t0 + (t1 - t0) * i as f64 / 40.0;
        m.interpolate(t, &mut out);
        worst = worst.max(max_diff(&out, &exact(t)));
    }
    worst
}

/// Observed order `log2(e(h)/e(h/2))`.
pub fn order(e_h: f64, e_half: f64) -> f64 {
    (e_h / e_half).log2()
}

/// Asserts that `errors` at step sizes that halve from one to the next fall with order `p`:
/// both observed orders within 0.3 of it.
pub fn assert_order(what: &str, p: f64, errors: [f64; 3]) {
    let [e1, e2, e3] = errors;
    let (p1, p2) = (order(e1, e2), order(e2, e3));
    assert!(
        (p1 - p).abs() < 0.3 && (p2 - p).abs() < 0.3,
        "{what}: orders {p1} {p2} (errors {e1:e} {e2:e} {e3:e})"
    );
}
