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

pub mod auto;
pub mod core;
pub mod dopri5;
pub mod linear;
pub mod newton;
pub mod radau;
pub mod rk4;
pub mod sdirk;
pub mod second_order;
pub mod warm;

#[cfg(test)]
pub(crate) mod alloc_counter;
#[cfg(test)]
pub(crate) mod test_problems;
#[cfg(test)]
mod tests;

pub use self::core::{StateReader, StepCore};
use crate::scene::{Method, SolverSection, RK4_DEFAULT_STEP};

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
    #[error("step size underflow at t = {} (the problem is too stiff for this method or the state is not finite)", crate::scene::Num(*.0))]
    StepSizeUnderflow(f64),
    /// The right-hand side returned a non-finite value.
    #[error("the right-hand side is not finite at t = {}", crate::scene::Num(*.0))]
    NotFinite(f64),
    /// Newton iterations did not converge (implicit methods).
    #[error("Newton iteration failed to converge at t = {}", crate::scene::Num(*.0))]
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
    /// The components `slots` of [`Integrator::interpolate`]`(t)` into `out` (the same
    /// numbers); false when the method does not interpolate single components (nothing
    /// written).
    fn interpolate_slots(&self, _t: f64, _slots: &[usize], _out: &mut [f64]) -> bool {
        false
    }
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
    /// Appends everything the method needs to go on exactly as it would have: its last step
    /// (t_prev, t, states, f, dense-output coefficients), the step size to try, controller and
    /// Newton memory (Jacobian, the factorisation's step size, rate memory, flags...), counters.
    ///
    /// Layout: the method's enumeration value (`solver.method`) as a tag,
    /// [`StepCore::save_state`], then the method's own part (see each method and
    /// docs/integrators.md). Settings given at construction (tolerances, largest step) are not
    /// written: the state is for an integrator created with the same settings.
    fn save_state(&self, out: &mut Vec<f64>);
    /// Restores what `save_state` wrote, for the same method and system size. Checks the length
    /// (and that flags are 0/1 etc.) before changing anything; on an error nothing changed.
    fn load_state(&mut self, v: &[f64]) -> Result<(), String>;
    /// Restarts at `(t, y)` where the right-hand side did not change (a communication point
    /// without an event). Like [`Integrator::reset`], but an implicit method keeps its memory
    /// (Jacobian, Newton and step-size controller history). What it keeps is exactly what
    /// [`Integrator::warm_state`] writes, so a state saved with it and restored by
    /// [`Integrator::set_warm_state`] continues bit for bit. Explicit methods just reset.
    fn restart(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.reset(sys, t, y, h);
    }
    /// Declares the system's second-order structure (positions, velocities, integrals): an
    /// implicit method with dense linear algebra then factors its iteration matrices reduced
    /// to the velocities ([`second_order`]). Explicit methods ignore it.
    fn use_second_order(&mut self, _s: &second_order::SecondOrder) {}
    /// Makes this integrator what [`create`]`(s, n)` gives, in place and without allocating:
    /// what defines its future and its reports as at creation (everything
    /// [`Integrator::save_state`] writes, its flags; the scratch that a step writes before it
    /// reads keeps its numbers), a built implicit method dropped; false,
    /// and nothing changed, where it cannot: another method, size or settings (compared bit
    /// for bit), or a method that does not renew (the implicit ones). Its second-order
    /// structure is set by the caller, as after creation
    /// ([`Integrator::use_second_order`]).
    fn renew(&mut self, _s: &SolverSection, _n: usize) -> bool {
        false
    }
    /// What the implicit methods' linear algebra did (None for explicit methods).
    fn linear_stats(&self) -> Option<linear::LinearStats> {
        None
    }
    /// `auto`'s memory of implicit stints that lost to Dormand-Prince (None: none, or
    /// another method). An island formed anew takes it over from the islands its bodies came
    /// from ([`Integrator::hold_explicit`]).
    fn explicit_hold(&self) -> Option<ExplicitHold> {
        None
    }
    /// Takes over such a memory (nothing for other methods, while `auto`'s implicit method is
    /// active, or where it holds a longer one already).
    fn hold_explicit(&mut self, _hold: ExplicitHold) {}
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

/// `auto`'s memory of implicit stints that cost more than Dormand-Prince would have
/// ([`auto`]'s cost rule).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExplicitHold {
    /// The last losing stint's evaluations per unit of time.
    pub implicit_cost: f64,
    /// Dormand-Prince steps for which a switch still waits for Dormand-Prince to cost more.
    pub steps: u32,
    /// Losing stints in a row (each doubles the next hold).
    pub losses: u32,
}

impl ExplicitHold {
    /// The highest cost, the longest hold and the most losses of both (an island formed
    /// from several holds what its costliest part did).
    pub fn join(self, other: ExplicitHold) -> ExplicitHold {
        ExplicitHold {
            implicit_cost: self.implicit_cost.max(other.implicit_cost),
            steps: self.steps.max(other.steps),
            losses: self.losses.max(other.losses),
        }
    }
}

/// Largest Jacobian (in numbers, `n²`) an implicit method keeps across a warm restart and
/// writes into saved states; above it the Jacobian is recomputed after each restart, so that
/// the FMU states of big scenes stay small.
pub const WARM_JACOBIAN_MAX: usize = 40_000;

/// Weighted RMS norm of an error estimate (Hairer's): `sqrt(mean((err/(atol+rtol·max|y|))²))`.
pub fn error_norm(err: &[f64], y0: &[f64], y1: &[f64], rtol: f64, atol: f64) -> f64 {
    let s: f64 = err
        .iter()
        .zip(y0.iter().zip(y1))
        .map(|(e, (a, b))| {
            let sc = error_scale(*a, *b, rtol, atol);
            (e / sc) * (e / sc)
        })
        .sum();
    rms(s, err.len())
}

/// The scale of a component's error in [`error_norm`]: `atol + rtol·max(|y₀|, |y₁|)`.
#[inline]
pub fn error_scale(y0: f64, y1: f64, rtol: f64, atol: f64) -> f64 {
    atol + rtol * y0.abs().max(y1.abs())
}

/// The root mean square of `n` numbers whose squares sum to `sum_of_squares` (of one number
/// when there are none), as [`error_norm`] takes it.
#[inline]
pub fn rms(sum_of_squares: f64, n: usize) -> f64 {
    (sum_of_squares / n.max(1) as f64).sqrt()
}

/// Creates the integrator named by the solver settings for a system of size `n`.
/// `solver.max_step` 0 means no largest step.
pub fn create(s: &SolverSection, n: usize) -> Box<dyn Integrator + Send> {
    let hmax = largest_step(s);
    match s.method {
        Method::Dopri5 => Box::new(dopri5::Dopri5::new(n, s.rtol, s.atol, hmax)),
        Method::Rk4 => Box::new(rk4::Rk4::new(n, rk4_step(s))),
        Method::Sdirk => Box::new(sdirk::Sdirk::new(n, s.rtol, s.atol, hmax)),
        Method::Radau5 => Box::new(radau::Radau5::new(n, s.rtol, s.atol, hmax)),
        Method::Auto => Box::new(auto::Auto::new(n, s.rtol, s.atol, hmax, Some(radau::Radau5::new))),
    }
}

/// The largest step [`create`] gives an adaptive method: `solver.max_step`, none (infinite)
/// for 0.
pub fn largest_step(s: &SolverSection) -> f64 {
    if s.max_step > 0.0 {
        s.max_step
    } else {
        f64::INFINITY
    }
}

/// The fixed step [`create`] gives RK4: `solver.max_step`, [`RK4_DEFAULT_STEP`] for 0.
pub fn rk4_step(s: &SolverSection) -> f64 {
    if s.max_step > 0.0 {
        s.max_step
    } else {
        RK4_DEFAULT_STEP
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
        crate::math::powf(0.01 / d1.max(d2), 1.0 / (order as f64 + 1.0))
    };
    (100.0 * h0).min(h1).min(hmax)
}
