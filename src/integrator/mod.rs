//! Time integration behind one trait, so that the engine can switch methods by name.
//!
//! An [`Integrator`] takes one accepted step at a time, never past a given limit, and offers
//! dense output over its last step; the engine uses that to locate events (contact touch and
//! separation) and restarts the method after each discontinuity with [`Integrator::reset`];
//! at a communication point without one it restarts with [`Integrator::restart`], which lets an
//! implicit method keep its Jacobian (that memory is part of saved states:
//! [`Integrator::warm_state`]).
//!
//! Every method embeds a [`StepCore`] (time, state, step size, counters and the bookkeeping of
//! a step); the implicit ones also share a [`newton::NewtonCore`] (Jacobian, simplified
//! Newton, warm memory) and the step-size controller of [`newton::ImplicitMethod`].

pub mod core;
pub mod dopri5;
pub mod newton;
pub mod radau;
pub mod rk4;
pub mod sdirk;

pub use self::core::StepCore;
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
    /// State at `t` in `[t_prev, t]` from the dense output of the last step.
    fn interpolate(&self, t: f64, out: &mut [f64]);
    /// The step state (time, state, step size, counters) that the accessors below read.
    fn core(&self) -> &StepCore;
    /// The step state, to change (for [`Integrator::set_stats`]).
    fn core_mut(&mut self) -> &mut StepCore;
    /// Current time.
    fn t(&self) -> f64 {
        self.core().t
    }
    /// Time at the start of the last step.
    fn t_prev(&self) -> f64 {
        self.core().t_prev
    }
    /// Current state.
    fn y(&self) -> &[f64] {
        &self.core().y
    }
    /// The step size the method would try next (saved in FMU states).
    fn next_step(&self) -> f64 {
        self.core().h
    }
    /// Counters since creation.
    fn stats(&self) -> Stats {
        self.core().stats
    }
    /// Sets the counters (restoring a saved state).
    fn set_stats(&mut self, s: Stats) {
        self.core_mut().stats = s;
    }
    /// Restarts at `(t, y)` where the right-hand side did not change (a communication point
    /// without an event). Like [`Integrator::reset`], but an implicit method keeps its memory
    /// (Jacobian, Newton and step-size controller history). What it keeps is exactly what
    /// [`Integrator::warm_state`] writes, so a state saved with it and restored by
    /// [`Integrator::set_warm_state`] continues bit for bit. Explicit methods just reset.
    fn restart(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.reset(sys, t, y, h);
    }
    /// Appends the memory that [`Integrator::restart`] carries over (nothing for explicit
    /// methods; see [`WARM_JACOBIAN_MAX`] for the implicit ones).
    fn warm_state(&self, _out: &mut Vec<f64>) {}
    /// Restores memory written by [`Integrator::warm_state`] of the same method and system
    /// size; an empty slice means none (as after [`Integrator::reset`]).
    fn set_warm_state(&mut self, v: &[f64]) -> Result<(), String> {
        if v.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "the integrator keeps no memory across restarts, the state holds {} numbers",
                v.len()
            ))
        }
    }
}

/// Largest Jacobian (in numbers, `n²`) an implicit method keeps across a warm restart and
/// writes into saved states; above it the Jacobian is recomputed after each restart, so that
/// the FMU states of big scenes stay small.
pub const WARM_JACOBIAN_MAX: usize = 40_000;

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
        Method::Radau5 => Box::new(radau::Radau5::new(n, s.rtol, s.atol, s.max_step)),
    }
}

/// A first step size from the initial slope (Hairer-Wanner II.4).
#[allow(clippy::too_many_arguments)]
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

/// Test problems with closed-form solutions, shared by the integrators' unit tests.
#[cfg(test)]
pub(crate) mod test_problems {
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

    /// Integrates from `(t0, y0)` to `t_end`; returns the final state.
    pub fn run(m: &mut dyn Integrator, sys: &mut dyn OdeSystem, t0: f64, y0: &[f64], t_end: f64) -> Vec<f64> {
        run_from(m, sys, t0, y0, t_end, 0.0)
    }

    /// [`run`] with first step `h0`.
    pub fn run_from(
        m: &mut dyn Integrator,
        sys: &mut dyn OdeSystem,
        t0: f64,
        y0: &[f64],
        t_end: f64,
        h0: f64,
    ) -> Vec<f64> {
        m.reset(sys, t0, y0, h0);
        while m.t() < t_end {
            m.step(sys, t_end).expect("step failed");
        }
        m.y().to_vec()
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
}

/// Counts heap allocations made by the current thread (to check that stepping allocates
/// nothing).
#[cfg(test)]
pub(crate) mod alloc_counter {
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::cell::Cell;

    thread_local! {
        static COUNT: Cell<u64> = const { Cell::new(0) };
    }

    /// The system allocator, counting.
    pub struct Counting;

    unsafe impl GlobalAlloc for Counting {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            let _ = COUNT.try_with(|c| c.set(c.get() + 1));
            // SAFETY: the caller's contract of `GlobalAlloc::alloc`, passed on.
            unsafe { System.alloc(layout) }
        }
        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            // SAFETY: `ptr` came from this allocator, i.e. from `System`, with `layout`.
            unsafe { System.dealloc(ptr, layout) }
        }
        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            let _ = COUNT.try_with(|c| c.set(c.get() + 1));
            // SAFETY: as `dealloc`, and the caller's contract of `GlobalAlloc::realloc`.
            unsafe { System.realloc(ptr, layout, new_size) }
        }
    }

    #[global_allocator]
    static GLOBAL: Counting = Counting;

    /// Allocations made by this thread so far.
    pub fn count() -> u64 {
        COUNT.try_with(|c| c.get()).unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::newton::WARM_HEADER;
    use super::test_problems::*;
    use super::*;

    /// Solver settings for `method` with largest step 0.01.
    fn settings(method: Method, rtol: f64, atol: f64) -> SolverSection {
        SolverSection {
            method,
            rtol,
            atol,
            max_step: 1e-2,
        }
    }

    /// After construction and reset, stepping allocates nothing (every method).
    #[test]
    fn stepping_does_not_allocate() {
        for method in Method::ALL {
            let mut m = create(&settings(method, 1e-8, 1e-10), 2);
            let mut sys = SpringDamper { omega: 10.0, g: 9.81 };
            m.reset(&mut sys, 0.0, &[0.0, -1.0], 0.0);
            m.step(&mut sys, 1.0).unwrap();
            let before = alloc_counter::count();
            let mut out = [0.0; 2];
            while m.t() < 0.5 {
                m.step(&mut sys, 0.5).unwrap();
                m.interpolate(0.5 * (m.t() + m.t_prev()), &mut out);
            }
            m.reset(&mut sys, 0.5, &[0.0, 1.0], m.next_step());
            m.step(&mut sys, 1.0).unwrap();
            let (t1, y1) = (m.t(), [m.y()[0], m.y()[1]]);
            m.restart(&mut sys, t1, &y1, m.next_step());
            m.step(&mut sys, 1.0).unwrap();
            assert_eq!(
                alloc_counter::count() - before,
                0,
                "{method:?} allocated while stepping"
            );
        }
    }

    /// Steps `m` to `t_end`.
    fn run_to(m: &mut dyn Integrator, sys: &mut dyn OdeSystem, t_end: f64) {
        while m.t() < t_end {
            m.step(sys, t_end).unwrap();
        }
    }

    /// A warm restart keeps the implicit methods' Jacobian (a cold one must evaluate a new
    /// one on a stiff problem), and it depends only on `(t, y, h)` and the warm state: another
    /// integrator with other history, given that warm state, continues bit for bit.
    #[test]
    fn warm_restart_keeps_the_jacobian_and_is_reproduced_from_the_warm_state() {
        for method in [Method::Sdirk, Method::Radau5] {
            let s = settings(method, 1e-6, 1e-8);
            let mut sys = SpringDamper { omega: 1e4, g: 9.81 };
            let mut a = create(&s, 2);
            a.reset(&mut sys, 0.0, &[0.0, -1.0], 0.0);
            run_to(a.as_mut(), &mut sys, 0.01);
            let mut w = Vec::new();
            a.warm_state(&mut w);
            assert_eq!(w.len(), WARM_HEADER + 4, "{method:?}: memory and a 2×2 Jacobian");
            let (t, y, h) = (a.t(), a.y().to_vec(), a.next_step());
            let mut b = create(&s, 2);
            b.reset(&mut sys, 0.0, &[0.3, 2.0], 0.0);
            run_to(b.as_mut(), &mut sys, 0.2);
            b.set_warm_state(&w).unwrap();
            let mut cold = create(&s, 2);
            cold.reset(&mut sys, t, &y, h);
            let jac0 = a.stats().jac_evals;
            a.restart(&mut sys, t, &y, h);
            b.restart(&mut sys, t, &y, h);
            while a.t() < 0.05 {
                a.step(&mut sys, 0.05).unwrap();
                b.step(&mut sys, 0.05).unwrap();
                assert_eq!(a.t().to_bits(), b.t().to_bits(), "{method:?}");
                assert_eq!(a.y(), b.y(), "{method:?} at t = {}", a.t());
            }
            run_to(cold.as_mut(), &mut sys, 0.05);
            assert_eq!(a.stats().jac_evals, jac0, "{method:?}: the warm restart re-evaluated J");
            assert!(
                cold.stats().jac_evals >= 1,
                "{method:?}: a cold start needs a Jacobian here"
            );
            let exact = sys.exact(0.05, -1.0);
            assert!(
                test_problems::max_diff(a.y(), &exact) < 1e-6,
                "{method:?}: {:?} vs {exact:?}",
                a.y()
            );
        }
    }

    /// Explicit methods keep nothing; malformed memory is refused; a Jacobian above
    /// [`WARM_JACOBIAN_MAX`] numbers is neither saved nor kept.
    #[test]
    fn warm_state_sizes_and_checks() {
        for method in [Method::Dopri5, Method::Rk4] {
            let mut m = create(&settings(method, 1e-6, 1e-8), 2);
            let mut w = vec![7.0];
            m.warm_state(&mut w);
            assert_eq!(w, [7.0], "{method:?}");
            assert!(m.set_warm_state(&[]).is_ok());
            assert!(m.set_warm_state(&[1.0]).is_err());
        }
        for method in [Method::Sdirk, Method::Radau5] {
            let mut m = create(&settings(method, 1e-6, 1e-8), 2);
            let mut w = Vec::new();
            m.warm_state(&mut w);
            assert_eq!(w.len(), WARM_HEADER, "{method:?}: no Jacobian before one is evaluated");
            assert!(m.set_warm_state(&[]).is_ok());
            assert!(
                m.set_warm_state(&[0.0, 0.0, 1.0, 0.0, 1.0, 1.0]).is_err(),
                "{method:?}: short Jacobian"
            );
            assert!(m.set_warm_state(&[0.0; 3]).is_err(), "{method:?}");
            assert!(m.set_warm_state(&[0.0, 0.0, 1.0, 0.0, 0.0]).is_ok(), "{method:?}");
        }
        // n = 201: n² > WARM_JACOBIAN_MAX
        struct Decay;
        impl OdeSystem for Decay {
            fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
                for (d, v) in dy.iter_mut().zip(y) {
                    *d = -1e4 * (v - 1.0);
                }
            }
        }
        let n = 201;
        assert!(n * n > WARM_JACOBIAN_MAX);
        let mut m = create(&settings(Method::Sdirk, 1e-6, 1e-8), n);
        m.reset(&mut Decay, 0.0, &vec![0.0; n], 0.0);
        run_to(m.as_mut(), &mut Decay, 0.01);
        assert!(m.stats().jac_evals >= 1);
        let mut w = Vec::new();
        m.warm_state(&mut w);
        assert_eq!(w.len(), WARM_HEADER, "a big Jacobian is not saved");
        let (t, y, h, j0) = (m.t(), m.y().to_vec(), m.next_step(), m.stats().jac_evals);
        m.restart(&mut Decay, t, &y, h);
        run_to(m.as_mut(), &mut Decay, 0.02);
        assert!(
            m.stats().jac_evals > j0,
            "a big Jacobian is recomputed after a warm restart"
        );
    }
}
