//! The step state that every method embeds ([`StepCore`]): time and state at both ends of the
//! last step, `f` at the current state, the step size to try next, the tolerances and the work
//! counters, with the bookkeeping that all methods do alike (start, step size toward a limit,
//! arrival within rounding, advance, the dense-output parameter), and the pieces of a saved
//! integrator state that all methods share ([`StepCore::save_state`], [`StateReader`]).

use super::{initial_step, IntegratorError, OdeSystem, Stats};
use crate::scene::Method;

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

/// Sets every number of the buffers `vs` to zero, as at a method's creation.
pub fn zeroed<const K: usize>(vs: [&mut Vec<f64>; K]) {
    for v in vs {
        v.fill(0.0);
    }
}

/// The accessors [`Integrator::core`](super::Integrator::core) and
/// [`Integrator::core_mut`](super::Integrator::core_mut) for a method whose step state is its
/// field `core`.
macro_rules! core_accessors {
    () => {
        fn core(&self) -> &StepCore {
            &self.core
        }

        fn core_mut(&mut self) -> &mut StepCore {
            &mut self.core
        }
    };
}
pub(crate) use core_accessors;

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

    /// Makes this step state what [`StepCore::new`]`(n, rtol, atol, hmax)` gives, in place
    /// (its buffers kept); false, and nothing changed, for another size or other settings
    /// (compared bit for bit).
    pub fn renew(&mut self, n: usize, rtol: f64, atol: f64, hmax: f64) -> bool {
        let settings = |c: [f64; 3]| c.map(f64::to_bits);
        if self.y.len() != n || settings([self.rtol, self.atol, self.hmax]) != settings([rtol, atol, hmax]) {
            return false;
        }
        (self.t, self.t_prev, self.h) = (0.0, 0.0, 0.0);
        zeroed([&mut self.y, &mut self.y_prev, &mut self.f]);
        self.stats = Stats::default();
        true
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
        if !(self.t + h).is_finite() {
            // a step to a time beyond the largest number (or from a non-finite one)
            return Err(IntegratorError::NotFinite(self.t));
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

    /// Numbers [`StepCore::save_state`] writes for a system of size `n`: `t`, `t_prev`, `h`,
    /// the four counters, then `y`, `y_prev` and `f`.
    pub fn saved_len(n: usize) -> usize {
        7 + 3 * n
    }

    /// Appends the step state (not the settings `rtol`, `atol`, `hmax`, which come from the
    /// construction): see [`StepCore::saved_len`].
    pub fn save_state(&self, out: &mut Vec<f64>) {
        let s = &self.stats;
        out.extend_from_slice(&[self.t, self.t_prev, self.h]);
        out.extend_from_slice(&[s.steps, s.rejected, s.rhs_evals, s.jac_evals].map(|c| c as f64));
        out.extend_from_slice(&self.y);
        out.extend_from_slice(&self.y_prev);
        out.extend_from_slice(&self.f);
    }

    /// Reads and checks what [`StepCore::save_state`] wrote, without changing anything; apply
    /// it with [`StepCore::restore`].
    pub fn read_state<'a>(&self, r: &mut StateReader<'a>) -> Result<SavedCore<'a>, String> {
        let n = self.y.len();
        let [t, t_prev] = [r.finite_value("the time")?, r.finite_value("the time")?];
        if t_prev > t {
            return Err(format!(
                "the method's last step ends at t = {t} before it begins, at {t_prev}"
            ));
        }
        let h = r.value()?;
        let stats = Stats {
            steps: r.count()?,
            rejected: r.count()?,
            rhs_evals: r.count()?,
            jac_evals: r.count()?,
        };
        Ok(SavedCore {
            t,
            t_prev,
            h,
            stats,
            // (not checked here: a method that failed holds what it failed on, and a saved
            // state with it restarts cold; `model::state::set` checks a continued step's state)
            y: r.take(n)?,
            y_prev: r.take(n)?,
            f: r.take(n)?,
        })
    }

    /// Sets the step state read by [`StepCore::read_state`].
    pub fn restore(&mut self, s: &SavedCore) {
        self.t = s.t;
        self.t_prev = s.t_prev;
        self.h = s.h;
        self.stats = s.stats;
        self.y.copy_from_slice(s.y);
        self.y_prev.copy_from_slice(s.y_prev);
        self.f.copy_from_slice(s.f);
    }

    /// The rate of change of `f` along `v` at the current state, `‖J v‖/‖v‖` in the error
    /// weights, from one directional difference `f(y + c v) − f(y)` (one evaluation,
    /// counted; `self.f` must be `f(t, y)`), with `c v` scaled to the increments of the
    /// finite-difference Jacobians (`√ε·max(|yᵢ|, 10⁻⁵)` at most per component). Leaves the
    /// difference `f(y + c v) − f(y)` in `v` (the next vector of a power iteration); `y_pert`
    /// and `jv` are scratch. None when `v` is zero or the difference is not finite.
    pub fn directional_rate(
        &mut self,
        sys: &mut dyn OdeSystem,
        v: &mut [f64],
        y_pert: &mut [f64],
        jv: &mut [f64],
    ) -> Option<f64> {
        let n = self.y.len();
        let scale = (0..n)
            .filter(|&i| v[i] != 0.0)
            .map(|i| (f64::EPSILON * 1e-5_f64.max(self.y[i].abs())).sqrt() / v[i].abs())
            .fold(f64::INFINITY, f64::min);
        if !scale.is_finite() {
            return None;
        }
        for i in 0..n {
            y_pert[i] = self.y[i] + scale * v[i];
        }
        sys.rhs(self.t, y_pert, jv);
        self.stats.rhs_evals += 1;
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..n {
            let w = 1.0 / (self.atol + self.rtol * self.y[i].abs().max(self.y_prev[i].abs()));
            let (dv, dj) = (w * (y_pert[i] - self.y[i]), w * (jv[i] - self.f[i]));
            num += dj * dj;
            den += dv * dv;
            v[i] = jv[i] - self.f[i];
        }
        (den > 0.0 && num.is_finite()).then(|| (num / den).sqrt())
    }

    /// Dense output at `t` in `[t_prev, t]`: `y` after a zero-length step, otherwise
    /// `dense(s, h, out)` with `h = t − t_prev` and `s = (t − t_prev)/h`.
    pub fn interpolate(&self, t: f64, out: &mut [f64], dense: impl FnOnce(f64, f64, &mut [f64])) {
        match self.dense_fraction(t) {
            Some((s, h)) => dense(s, h, out),
            None => out.copy_from_slice(&self.y),
        }
    }

    /// `(s, h)` of the dense output at `t` ([`StepCore::interpolate`]); None after a
    /// zero-length step (the state is `y`).
    #[inline]
    pub fn dense_fraction(&self, t: f64) -> Option<(f64, f64)> {
        let h = self.t - self.t_prev;
        (h > 0.0).then(|| ((t - self.t_prev) / h, h))
    }
}

/// A [`StepCore`] as read back from a saved state (checked, not yet applied).
#[derive(Debug, Clone, Copy)]
pub struct SavedCore<'a> {
    t: f64,
    t_prev: f64,
    h: f64,
    stats: Stats,
    y: &'a [f64],
    y_prev: &'a [f64],
    f: &'a [f64],
}

/// Largest counter value that an `f64` holds exactly (2⁵³).
const MAX_EXACT_COUNT: f64 = 9_007_199_254_740_992.0;

/// What a [`StateReader`] reads, as its messages name it.
#[derive(Debug, Clone, Copy)]
pub enum Subject {
    /// A method's saved state (`the dopri5 integrator state`).
    Method(Method),
    /// Another part of a saved state, by its name (`the saved islands`).
    Part(&'static str),
}

impl std::fmt::Display for Subject {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Subject::Method(m) => write!(f, "the {} integrator state", m.name()),
            Subject::Part(name) => f.write_str(name),
        }
    }
}

/// Reads a saved state front to back (see [`super::Integrator::load_state`]; also the other
/// positional parts of a saved state), so that everything is checked before anything changes:
/// each part takes its numbers in the order they were written, and [`StateReader::finish`]
/// refuses numbers left over. A method's state begins with the method's enumeration value
/// (`solver.method`), checked by [`StateReader::new`].
#[derive(Debug)]
pub struct StateReader<'a> {
    v: &'a [f64],
    pos: usize,
    subject: Subject,
}

impl<'a> StateReader<'a> {
    /// Starts reading a state of `method`: checks the leading tag.
    pub fn new(v: &'a [f64], method: Method) -> Result<StateReader<'a>, String> {
        let tag = state_tag(method);
        match v.first() {
            Some(&x) if x == tag => Ok(StateReader {
                v,
                pos: 1,
                subject: Subject::Method(method),
            }),
            Some(&x) => Err(format!(
                "the integrator state is not one of {} (it begins with {x}, not {tag})",
                method.name()
            )),
            None => Err(format!("the {} integrator state is empty", method.name())),
        }
    }

    /// Starts reading the part `name` (no tag).
    pub fn part(v: &'a [f64], name: &'static str) -> StateReader<'a> {
        StateReader {
            v,
            pos: 0,
            subject: Subject::Part(name),
        }
    }

    /// The next number, not taken.
    pub fn peek(&self) -> Option<f64> {
        self.v.get(self.pos).copied()
    }

    /// The numbers not yet taken.
    pub fn left(&self) -> usize {
        self.v.len() - self.pos
    }

    /// The next `k` numbers.
    pub fn take(&mut self, k: usize) -> Result<&'a [f64], String> {
        let end = self.pos.checked_add(k).filter(|&e| e <= self.v.len()).ok_or_else(|| {
            format!(
                "{} ends early: {} numbers, not a state of {}",
                self.subject,
                self.v.len(),
                self.owner()
            )
        })?;
        let s = &self.v[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    /// The next number, finite (`what` it is, for the message).
    pub fn finite_value(&mut self, what: &str) -> Result<f64, String> {
        let x = self.value()?;
        if x.is_finite() {
            Ok(x)
        } else {
            Err(self.misplaced(x, &format!("a finite number ({what})")))
        }
    }

    /// The next number.
    pub fn value(&mut self) -> Result<f64, String> {
        Ok(self.take(1)?[0])
    }

    /// The next number as a flag: 0 or 1.
    pub fn flag(&mut self) -> Result<bool, String> {
        match self.value()? {
            0.0 => Ok(false),
            1.0 => Ok(true),
            x => Err(self.misplaced(x, "a flag (0 or 1)")),
        }
    }

    /// The next number as a counter: a whole number in [0, 2⁵³].
    pub fn count(&mut self) -> Result<u64, String> {
        let x = self.value()?;
        if (0.0..=MAX_EXACT_COUNT).contains(&x) && x.fract() == 0.0 {
            Ok(x as u64)
        } else {
            Err(self.misplaced(x, "a counter"))
        }
    }

    /// The next number as a count up to `max`.
    pub fn count_to(&mut self, max: u64) -> Result<u64, String> {
        let c = self.count()?;
        if c <= max {
            Ok(c)
        } else {
            Err(self.misplaced(c as f64, &format!("a count up to {max}")))
        }
    }

    /// The next number as a step size: finite and not negative.
    pub fn step_size(&mut self) -> Result<f64, String> {
        let x = self.value()?;
        if x.is_finite() && x >= 0.0 {
            Ok(x)
        } else {
            Err(self.misplaced(x, "a step size"))
        }
    }

    /// Whose state it would have been.
    fn owner(&self) -> &'static str {
        match self.subject {
            Subject::Method(_) => "this method and model",
            Subject::Part(_) => "this model",
        }
    }

    /// The message for the number `x` just read where `what` belongs.
    fn misplaced(&self, x: f64, what: &str) -> String {
        format!("{} holds {x} at {} where {what} belongs", self.subject, self.pos - 1)
    }

    /// Ends reading: the whole state was read.
    pub fn finish(self) -> Result<(), String> {
        if self.pos == self.v.len() {
            Ok(())
        } else {
            Err(format!(
                "{} has {} numbers, {} more than a state of {}",
                self.subject,
                self.v.len(),
                self.v.len() - self.pos,
                self.owner()
            ))
        }
    }
}

/// The first number of a saved state of `method`: its enumeration value (`solver.method`).
pub fn state_tag(method: Method) -> f64 {
    method as i64 as f64
}

/// Appends vectors one after the other (dense-output coefficients).
pub fn save_blocks(blocks: &[Vec<f64>], out: &mut Vec<f64>) {
    for b in blocks {
        out.extend_from_slice(b);
    }
}

/// Copies `v`, as written by [`save_blocks`], back into vectors of the same lengths.
pub fn restore_blocks(blocks: &mut [Vec<f64>], v: &[f64]) {
    let mut pos = 0;
    for b in blocks {
        let end = pos + b.len();
        b.copy_from_slice(&v[pos..end]);
        pos = end;
    }
}
