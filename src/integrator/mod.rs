//! Time integration behind one trait, so that the engine can switch methods by name.
//!
//! An [`Integrator`] takes one accepted step at a time, never past a given limit, and offers
//! dense output over its last step; the engine uses that to locate events (contact touch and
//! separation) and restarts the method after each discontinuity with [`Integrator::reset`].

pub mod dopri5;
pub mod rk4;
pub mod sdirk;

use crate::scene::{Method, SolverSection};

/// A first-order system `y' = f(t, y)`.
pub trait OdeSystem {
    /// Evaluates `dy = f(t, y)`.
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]);
}

/// Work counters of an integrator.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Accepted steps.
    pub steps: u64,
    /// Rejected steps.
    pub rejected: u64,
    /// Right-hand-side evaluations.
    pub rhs_evals: u64,
    /// Jacobian evaluations.
    pub jac_evals: u64,
}

/// Why a step failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IntegratorError {
    /// The step size fell below the smallest representable increment.
    #[error("step size underflow at t = {0} (the problem is too stiff for this method or the state is not finite)")]
    StepSizeUnderflow(f64),
    /// The right-hand side returned a non-finite value.
    #[error("the right-hand side is not finite at t = {0}")]
    NotFinite(f64),
    /// Newton iterations did not converge (implicit methods).
    #[error("Newton iteration failed to converge at t = {0}")]
    NewtonFailure(f64),
}

/// A one-step method with dense output.
pub trait Integrator {
    /// Starts (or restarts after a discontinuity) at `(t, y)`. `h` is the first step to try
    /// (0: choose one).
    fn reset(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64);
    /// Takes one accepted step that ends at or before `t_max`.
    fn step(&mut self, sys: &mut dyn OdeSystem, t_max: f64) -> Result<(), IntegratorError>;
    /// Current time.
    fn t(&self) -> f64;
    /// Time at the start of the last step.
    fn t_prev(&self) -> f64;
    /// Current state.
    fn y(&self) -> &[f64];
    /// State at `t` in `[t_prev, t]` from the dense output of the last step.
    fn interpolate(&self, t: f64, out: &mut [f64]);
    /// The step size the method would try next (saved in FMU states).
    fn next_step(&self) -> f64;
    /// Counters since creation.
    fn stats(&self) -> Stats;
    /// Sets the counters (restoring a saved state).
    fn set_stats(&mut self, s: Stats);
}

/// Weighted RMS norm of an error estimate (Hairer's): `sqrt(mean((err/(atol+rtol·max|y|))²))`.
pub fn error_norm(err: &[f64], y0: &[f64], y1: &[f64], rtol: f64, atol: f64) -> f64 {
    let n = err.len().max(1) as f64;
    let s: f64 = err
        .iter()
        .zip(y0.iter().zip(y1))
        .map(|(e, (a, b))| {
            let sc = atol + rtol * a.abs().max(b.abs());
            (e / sc) * (e / sc)
        })
        .sum();
    (s / n).sqrt()
}

/// Creates the integrator named by the solver settings for a system of size `n`.
pub fn create(s: &SolverSection, n: usize) -> Box<dyn Integrator + Send> {
    match s.method {
        Method::Dopri5 => Box::new(dopri5::Dopri5::new(n, s.rtol, s.atol, s.max_step)),
        Method::Rk4 => Box::new(rk4::Rk4::new(n, s.max_step)),
        Method::Sdirk => Box::new(sdirk::Sdirk::new(n, s.rtol, s.atol, s.max_step)),
    }
}

/// A first step size from the initial slope (Hairer-Wanner II.4).
pub fn initial_step(
    sys: &mut dyn OdeSystem,
    t: f64,
    y: &[f64],
    f0: &[f64],
    rtol: f64,
    atol: f64,
    order: i32,
    work: &mut [f64],
    f1: &mut [f64],
    hmax: f64,
) -> f64 {
    let sc = |v: f64| atol + rtol * v.abs();
    let n = y.len().max(1) as f64;
    let d0 = (y.iter().map(|v| (v / sc(*v)).powi(2)).sum::<f64>() / n).sqrt();
    let d1 = (f0.iter().zip(y).map(|(f, v)| (f / sc(*v)).powi(2)).sum::<f64>() / n).sqrt();
    let mut h0 = if d0 < 1e-5 || d1 < 1e-5 { 1e-6 } else { 0.01 * d0 / d1 };
    h0 = h0.min(hmax);
    for i in 0..y.len() {
        work[i] = y[i] + h0 * f0[i];
    }
    sys.rhs(t + h0, work, f1);
    let d2 = (f1
        .iter()
        .zip(f0)
        .zip(y)
        .map(|((a, b), v)| ((a - b) / sc(*v)).powi(2))
        .sum::<f64>()
        / n)
        .sqrt()
        / h0;
    let h1 = if d1.max(d2) <= 1e-15 {
        (h0 * 1e-3).max(1e-6)
    } else {
        (0.01 / d1.max(d2)).powf(1.0 / (order as f64 + 1.0))
    };
    (100.0 * h0).min(h1).min(hmax)
}
