//! The step state that every method embeds ([`StepCore`]): time and state at both ends of the
//! last step, `f` at the current state, the step size to try next, the tolerances and the work
//! counters, with the bookkeeping that all methods do alike (start, step size toward a limit,
//! arrival within rounding, advance, the dense-output parameter).

use super::{initial_step, IntegratorError, OdeSystem, Stats};

/// Steps (and gaps to the end) below this multiple of |t| are rounding noise.
pub const ROUNDOFF_GAP: f64 = 16.0 * f64::EPSILON;

/// State and counters of a one-step method over its last step `[t_prev, t]`.
#[derive(Debug, Clone)]
pub struct StepCore {
    /// Relative and absolute error tolerances (unused by fixed-step RK4).
    pub rtol: f64,
    pub atol: f64,
    /// Largest step (RK4: its fixed step).
    pub hmax: f64,
    /// Current time and the start of the last step (equal after a start).
    pub t: f64,
    pub t_prev: f64,
    /// Step size to try next (RK4: its fixed step).
    pub h: f64,
    /// State at `t` and at `t_prev`.
    pub y: Vec<f64>,
    pub y_prev: Vec<f64>,
    /// `f(t, y)` (for SDIRK4 the last stage's, converged to the Newton tolerance).
    pub f: Vec<f64>,
    /// Work counters.
    pub stats: Stats,
}

impl StepCore {
    /// The state of a method for systems of size `n`, before any start.
    pub fn new(n: usize, rtol: f64, atol: f64, hmax: f64) -> StepCore {
        StepCore {
            rtol,
            atol,
            hmax,
            t: 0.0,
            t_prev: 0.0,
            h: 0.0,
            y: vec![0.0; n],
            y_prev: vec![0.0; n],
            f: vec![0.0; n],
            stats: Stats::default(),
        }
    }

    /// Starts at `(t, y)` with a zero-length last step and evaluates `f(t, y)`.
    pub fn start(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64]) {
        self.t = t;
        self.t_prev = t;
        self.y.copy_from_slice(y);
        self.y_prev.copy_from_slice(y);
        sys.rhs(t, y, &mut self.f);
        self.stats.rhs_evals += 1;
    }

    /// Sets the first step after [`StepCore::start`]: `h` up to `hmax`, or for `h = 0` an
    /// estimate for a method of order `order` from the slope `f` (one more evaluation;
    /// `work` and `f1` are scratch of length `n`).
    pub fn first_step(&mut self, sys: &mut dyn OdeSystem, h: f64, order: i32, work: &mut [f64], f1: &mut [f64]) {
        self.h = if h > 0.0 {
            h.min(self.hmax)
        } else {
            self.stats.rhs_evals += 1;
            initial_step(
                sys, self.t, &self.y, &self.f, self.rtol, self.atol, order, work, f1, self.hmax,
            )
        };
    }

    /// When `t_max` is within rounding of `t`, arrives there with a zero-length step
    /// (`y_prev = y`; the method clears the rest of its dense output) and returns true.
    pub fn arrive_within_roundoff(&mut self, t_max: f64) -> bool {
        if t_max - self.t <= ROUNDOFF_GAP * self.t.abs() {
            self.y_prev.copy_from_slice(&self.y);
            self.t_prev = self.t;
            self.t = self.t.max(t_max);
            true
        } else {
            false
        }
    }

    /// The step to attempt toward `t_max` and whether it is the last: `h` up to `hmax`,
    /// stretched by up to 1 % rather than leave a sliver before `t_max` (Hairer). Fails when
    /// the step is rounding noise.
    pub fn trial_step(&self, t_max: f64) -> Result<(f64, bool), IntegratorError> {
        let mut h = self.h.min(self.hmax);
        let last = self.t + 1.01 * h >= t_max;
        if last {
            h = t_max - self.t;
        }
        if h <= ROUNDOFF_GAP * self.t.abs().max(1e-300) {
            return Err(IntegratorError::StepSizeUnderflow(self.t));
        }
        Ok((h, last))
    }

    /// End of a step of size `h` from `t`: exactly `t_max` for the last one.
    pub fn step_end(&self, h: f64, last: bool, t_max: f64) -> f64 {
        if last {
            t_max
        } else {
            self.t + h
        }
    }

    /// Counts an accepted step ending at `t_new` (the method sets `y` and `y_prev`).
    pub fn advance(&mut self, t_new: f64) {
        self.t_prev = self.t;
        self.t = t_new;
        self.stats.steps += 1;
    }

    /// Sets the step to try next from the proposal `h_new`: after a `last` step cut short by
    /// `t_max`, not below the step proposed before it; at most `hmax`.
    pub fn set_next_step(&mut self, h_new: f64, last: bool) {
        let h = if last { h_new.max(self.h) } else { h_new };
        self.h = h.min(self.hmax);
    }

    /// Dense output at `t` in `[t_prev, t]`: `y` after a zero-length step, otherwise
    /// `dense(s, h, out)` with `h = t − t_prev` and `s = (t − t_prev)/h`.
    pub fn interpolate(&self, t: f64, out: &mut [f64], dense: impl FnOnce(f64, f64, &mut [f64])) {
        let h = self.t - self.t_prev;
        if h <= 0.0 {
            out.copy_from_slice(&self.y);
            return;
        }
        dense((t - self.t_prev) / h, h, out);
    }
}
