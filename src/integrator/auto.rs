//! `auto`: Dormand-Prince while the problem is not stiff, an implicit method while it is,
//! switched by a stiffness estimate, as LSODA does between Adams and BDF.
//!
//! - **Explicit → implicit.** Every accepted Dormand-Prince step estimates `h·ρ` from its last
//!   two stages ([`Dopri5::stiffness`], Hairer's estimate, free). From [`CHECK_TRIGGER`] on
//!   ([`CHECK_AFTER`] steps in a row), the estimate is checked by three power iterations of
//!   directional differences from the
//!   step's error estimate ([`Dopri5::stiffness_check`], three evaluations), which sees the
//!   stiff components that Hairer's estimate misses once the controller keeps them small.
//!   A checked `h·ρ` from [`STIFF_LIMIT`] on means the step size is bounded by stability (or
//!   about to be: the boundary is 3.31 on the negative real axis), not accuracy; it counts
//!   one stiff step, and [`UNSTABLE_WEIGHT`] from [`UNSTABLE_LIMIT`] on, where the step is
//!   beyond the boundary and the stiff components grow. At [`STIFF_STEPS`] (a run of
//!   [`CALM_STEPS`] steps below the limit forgets them) the next step switches: the implicit
//!   method starts at the current state with a fresh Jacobian.
//! - **Implicit → explicit.** After every accepted implicit step: the step is *non-stiff* when
//!   Newton converged without a Jacobian (functional iteration, as after a reset), or when
//!   the stiffness ρ times the next step is below [`CALM_LIMIT`]: Dormand-Prince would be
//!   stable at that step size with margin. ρ is the spectral radius of the Jacobian held
//!   (power iteration, computed once per Jacobian), and every [`RECHECK_STEPS`] steps with
//!   the same Jacobian the rate of change of `f` along its dominant direction at the current
//!   state (one evaluation): a Jacobian is kept for as long as Newton converges, so its own
//!   ρ may describe a stiffness that has faded since. After [`CALM_STEPS_IMPLICIT`] non-stiff
//!   steps in a row the next step switches back.
//! - **Cost.** Every [`COST_WINDOW`] accepted implicit steps, the evaluations the implicit
//!   method spent per unit of time since it was switched to (rejected steps, Newton failures
//!   and Jacobians included; on the sparse path each factorisation counts as many evaluations
//!   as the system has states: [`ImplicitMethod::factorisation_evaluations`]) are compared
//!   with what Dormand-Prince would spend at its stability limit,
//!   [`DOPRI5_EVALUATIONS`]` · ρ / `[`STABILITY_BOUNDARY`] (while no Jacobian is held, as after
//!   a reset: Dormand-Prince's own `6/h` before the stint). On the sparse path the stint is
//!   also judged after [`EARLY_COST_STEPS`] steps by its evaluations per step so far at the
//!   step size it goes on with. Beyond [`COST_RATIO`] times that, the implicit method is
//!   losing (its Newton iteration keeps failing: the rail vehicle at rtol 1e-3, whose wheel
//!   slip crosses the regularised friction law's band; or its steps are no longer than
//!   Dormand-Prince's: a rattling pile of balls) and the next step switches back, also across
//!   a reset or restart (which drop a switch that stiffness alone asked for). The cost is that
//!   of the whole stint, not of the last few steps: a burst of Newton failures where the slip
//!   crosses the band edge costs 4-10× Dormand-Prince for some ten steps, in a stint that
//!   costs an eighth of it (measured over the last ten steps, it sent the rail vehicle back to
//!   Dormand-Prince for seconds at a time: up to 11,887 evaluations at rtol near 1e-3, against
//!   2,215 and 8,326 with the stint's cost). The cost is remembered, and for the next
//!   [`COST_MEMORY_STEPS`] Dormand-Prince steps, doubled for each further loss in a row (up to
//!   [`MAX_HOLD_DOUBLINGS`] times; a stint that ends calm clears the count), a step whose own
//!   cost per unit of time (`6/h`) is below it runs no stiffness check; an island formed anew
//!   takes the hold over from the islands its bodies come from ([`Integrator::hold_explicit`]).
//! - A switch happens at the start of a step, so the dense output of the last step stays that
//!   of the method that took it. The counters carry over (one [`Stats`](super::Stats) for the run).
//! - Resets (after events) and restarts keep the active method and the switching memory.
//! - The implicit method is built at the first switch (its workspace: Jacobian, iteration
//!   matrices, LU factors), so a problem that is never stiff never allocates one, and kept
//!   for later switches. It brings its own linear algebra: dense for small systems, faer's
//!   sparse LU with a coloured Jacobian for large ones ([`super::linear`]); ρ(J) is computed
//!   from either form. (A caller may build `auto` without an implicit method: it is then
//!   Dormand-Prince alone.)
//! - Saved state: the tag, the switching memory, then the active method's own state; the other
//!   method is not saved since it starts afresh at a switch (a state with the implicit
//!   method active builds it when loaded).

use super::core::{StateReader, StepCore};
use super::dopri5::Dopri5;
use super::linear::JacRef;
use super::newton::ImplicitMethod;
use super::second_order::SecondOrder;
use super::{largest_step, ExplicitHold, Integrator, IntegratorError, OdeSystem};
use crate::scene::{Method, SolverSection};

/// Hairer's estimate of `h·ρ` from which a Dormand-Prince step's stiffness is checked
/// ([`Dopri5::stiffness_check`]).
pub const CHECK_TRIGGER: f64 = 1.0;
/// Steps in a row whose estimate reaches [`CHECK_TRIGGER`] before the check runs (an estimate
/// above it on the first steps after a contact's touch, while they grow from the short first
/// step, is not checked: with two, the two spheres ran one check, three evaluations, at their
/// touch; with three the bundled scenes take the same or fewer evaluations).
pub const CHECK_AFTER: u32 = 3;
/// Checked `h·ρ` from which a Dormand-Prince step counts as limited by stability (the
/// stability region reaches 3.31 along the negative real axis; the check is a lower bound).
pub const STIFF_LIMIT: f64 = 2.5;
/// Checked `h·ρ` beyond the stability boundary: the stiff components grow.
pub const UNSTABLE_LIMIT: f64 = 4.0;
/// What a step beyond [`UNSTABLE_LIMIT`] counts toward [`STIFF_STEPS`].
pub const UNSTABLE_WEIGHT: u32 = 3;
/// Stiff steps (weighted) that switch to the implicit method.
pub const STIFF_STEPS: u32 = 5;
/// Dormand-Prince steps below [`STIFF_LIMIT`] in a row that forget the stiff ones (Hairer: 6).
pub const CALM_STEPS: u32 = 6;
/// `h·ρ(J)` of the implicit method's next step below which Dormand-Prince would be stable
/// with margin (about half of the stability boundary 3.31).
pub const CALM_LIMIT: f64 = 1.625;
/// Non-stiff implicit steps in a row that switch back to Dormand-Prince.
pub const CALM_STEPS_IMPLICIT: u32 = 10;
/// Implicit steps with the same Jacobian between two measurements of the stiffness along its
/// dominant direction at the current state.
pub const RECHECK_STEPS: u32 = 5;
/// Accepted implicit steps between two checks of its cost per unit of time.
pub const COST_WINDOW: u32 = 10;
/// Right-hand side evaluations of one Dormand-Prince step (first same as last).
pub const DOPRI5_EVALUATIONS: f64 = 6.0;
/// `h·ρ` at Dormand-Prince's stability limit (3.31 on the negative real axis).
pub const STABILITY_BOUNDARY: f64 = 3.3;
/// How many times Dormand-Prince's cost at its stability limit the implicit method may spend
/// per unit of time before it switches back.
pub const COST_RATIO: f64 = 4.0;
/// Accepted implicit steps after which a stint on the sparse path is judged by its cost so
/// far per step at the step size it goes on with (its start is dear there: a probe of n + 1
/// evaluations and factorisations of n each; where Radau's steps grow far beyond
/// Dormand-Prince's, they have grown by then).
pub const EARLY_COST_STEPS: u32 = 3;
/// Dormand-Prince steps after a switch back for cost during which the implicit method's
/// measured cost holds the next switch.
pub const COST_MEMORY_STEPS: u32 = 500;
/// Each losing stint in a row doubles the next hold, up to this many times (32,000 steps).
pub const MAX_HOLD_DOUBLINGS: u32 = 6;
/// Power iterations for ρ(J).
const POWER_ITERATIONS: usize = 16;
/// Numbers of the switching memory in saved states (after the tag).
pub const MEMORY_LEN: usize = 18;

/// The switching memory of a new method.
const FRESH_MEMORY: Memory = Memory {
    count: 0,
    calm: 0,
    rho: 0.0,
    rho_jac: u64::MAX,
    switches: 0,
    rho_now: 0.0,
    since: 0,
    stint_t: 0.0,
    stint_rhs: 0,
    steps_since_check: 0,
    stint_steps: 0,
    stint_linear: 0.0,
    stint_explicit_rate: 0.0,
    implicit_cost: 0.0,
    cost_hold: 0,
    losses: 0,
};

/// Builds the implicit method for a system size with the tolerances and largest step
/// (`Radau5::new`).
pub type ImplicitBuilder<I> = fn(usize, f64, f64, f64) -> I;

/// The automatic method (scene name `"auto"`) over Dormand-Prince and the implicit method `I`.
pub struct Auto<I: ImplicitMethod + Integrator> {
    explicit: Dopri5,
    /// Builds the implicit method at the first switch (None: Dormand-Prince alone).
    build: Option<ImplicitBuilder<I>>,
    /// The implicit method, once built.
    implicit: Option<I>,
    /// The implicit method is the active one.
    stiff: bool,
    /// Switch to the other method at the start of the next step.
    switch_pending: bool,
    /// The rest of the switching memory.
    memory: Memory,
    /// Power-iteration vectors (`x`: J's dominant direction once `x_for` is `rho_jac`).
    x: Vec<f64>,
    jx: Vec<f64>,
    x_for: u64,
    /// Scratch of the directional differences.
    v: Vec<f64>,
    y_pert: Vec<f64>,
    jv: Vec<f64>,
    /// The system's second-order structure, handed to the implicit method when it is built.
    second_order: Option<SecondOrder>,
    /// The implicit method's own count of its factorisations in evaluations at the switch or
    /// the last load, up to which the stint's are in [`Memory::stint_linear`] (not saved: what
    /// the method counts before a load is in the saved `stint_linear`).
    linear_mark: f64,
}

/// The switching memory after its two flags, in the order of saved states.
#[derive(Debug, Clone, Copy)]
struct Memory {
    /// Explicit: stability-limited steps counted toward a switch; implicit: non-stiff steps in
    /// a row.
    count: u32,
    /// Explicit: steps below the limit in a row.
    calm: u32,
    /// ρ(J) of the implicit method's Jacobian, and the Jacobian count it was computed for
    /// (u64::MAX: none).
    rho: f64,
    rho_jac: u64,
    /// Switches made (both directions).
    switches: u64,
    /// The stiffness the implicit steps are measured against: ρ(J) when the Jacobian is new,
    /// then the rate along its dominant direction every [`RECHECK_STEPS`] steps.
    rho_now: f64,
    /// Implicit: steps since `rho_now` was measured; explicit: steps in a row whose estimate
    /// reached [`CHECK_TRIGGER`].
    since: u32,
    /// Start of the implicit method's stint (its last switch): time and evaluations so far;
    /// and its accepted steps since the cost was last checked.
    stint_t: f64,
    stint_rhs: u64,
    steps_since_check: u32,
    /// The stint's accepted steps.
    stint_steps: u32,
    /// The stint's factorisations in evaluations ([`ImplicitMethod::factorisation_evaluations`])
    /// up to [`Auto::linear_mark`].
    stint_linear: f64,
    /// Dormand-Prince's evaluations per unit of time in its last step before the stint
    /// (`6/h`, a step bounded by stability): what the stint is measured against while no
    /// Jacobian is held (after a reset Newton iterates without one, and ρ is not known).
    stint_explicit_rate: f64,
    /// The implicit method's evaluations per unit of time when it last switched back for
    /// cost, and the Dormand-Prince steps for which that still holds a switch (0: none).
    implicit_cost: f64,
    cost_hold: u32,
    /// Stints in a row that switched back for cost (a stint that ends calm clears it).
    losses: u32,
}

impl<I: ImplicitMethod + Integrator> Auto<I> {
    /// Hands the implicit method to `load` (which reads a saved state or warm memory into it),
    /// built first when there is none yet; `what` names the part in the error when none can be.
    fn load_implicit(&mut self, what: &str, load: impl FnOnce(&mut I) -> Result<(), String>) -> Result<(), String> {
        match (&mut self.implicit, self.build) {
            (Some(i), _) => load(i),
            (None, Some(build)) => {
                let mut fresh = self.build_with(build);
                load(&mut fresh)?;
                self.implicit = Some(fresh);
                self.size_stiff_scratch();
                Ok(())
            }
            (None, None) => Err(format!(
                "{what} is implicit, but this integrator has no implicit method"
            )),
        }
    }

    /// The method for systems of size `n`, with the explicit method's tolerances and largest
    /// step and the builder of an implicit method for the same (None: never stiff).
    pub fn new(n: usize, rtol: f64, atol: f64, hmax: f64, build: Option<ImplicitBuilder<I>>) -> Self {
        Auto {
            explicit: Dopri5::new(n, rtol, atol, hmax),
            build,
            implicit: None,
            stiff: false,
            switch_pending: false,
            memory: FRESH_MEMORY,
            x: Vec::new(),
            jx: Vec::new(),
            x_for: u64::MAX,
            v: Vec::new(),
            y_pert: Vec::new(),
            jv: Vec::new(),
            second_order: None,
            linear_mark: 0.0,
        }
    }

    /// [`Integrator::renew`] for the tolerances and largest step given (the settings of
    /// [`Auto::new`]): the explicit method renewed, the switching memory as at creation, a
    /// built implicit method dropped (the builder and the scratch of the stiff steps kept).
    fn renew_with(&mut self, n: usize, rtol: f64, atol: f64, hmax: f64) -> bool {
        if !self.explicit.renew_with(n, rtol, atol, hmax) {
            return false;
        }
        self.implicit = None;
        (self.stiff, self.switch_pending, self.memory) = (false, false, FRESH_MEMORY);
        // (the stiff steps' scratch is written before it is read: `x` once `x_for` is unset)
        (self.x_for, self.linear_mark) = (u64::MAX, 0.0);
        true
    }

    /// Sizes the scratch of the stiff steps (the power iteration and the directional
    /// differences) for the system, once an implicit method is built: Dormand-Prince alone
    /// needs none.
    fn size_stiff_scratch(&mut self) {
        let n = self.explicit.core().y.len();
        let Auto {
            x, jx, v, y_pert, jv, ..
        } = self;
        for w in [x, jx, v, y_pert, jv] {
            if w.len() != n {
                *w = vec![0.0; n];
            }
        }
    }

    /// The implicit method built for the explicit one's system, with the structure declared.
    fn build_with(&self, build: ImplicitBuilder<I>) -> I {
        let c = self.explicit.core();
        let mut fresh = build(c.y.len(), c.rtol, c.atol, c.hmax);
        if let Some(s) = &self.second_order {
            Integrator::use_second_order(&mut fresh, s);
        }
        fresh
    }

    /// Whether the implicit method has been built (at the first switch or a load).
    pub fn has_implicit(&self) -> bool {
        self.implicit.is_some()
    }

    /// The implicit method, built when it is not yet (None without a builder).
    fn implicit_built(&mut self) -> Option<&mut I> {
        if self.implicit.is_none() {
            let build = self.build?;
            self.implicit = Some(self.build_with(build));
            self.size_stiff_scratch();
        }
        self.implicit.as_mut()
    }

    /// The implicit method is active and its stint was found too costly (the hold is set at
    /// that check and counts down only on Dormand-Prince): the switch back stands across a
    /// reset or restart, which drops the switches that stiffness alone asked for (an event
    /// changes the stiffness; it does not make the stint's spending undone).
    fn losing(&self) -> bool {
        self.stiff && self.memory.cost_hold > 0
    }

    /// The implicit stint lost at `cost` evaluations per unit of time: switch back at the
    /// next step and hold Dormand-Prince (the hold doubled for each loss in a row before).
    fn lose(&mut self, cost: f64) {
        self.switch_pending = true;
        self.memory.implicit_cost = cost;
        self.memory.cost_hold = COST_MEMORY_STEPS << self.memory.losses.min(MAX_HOLD_DOUBLINGS);
        self.memory.losses = self.memory.losses.saturating_add(1);
    }

    /// Whether the implicit method is active.
    pub fn is_stiff(&self) -> bool {
        self.stiff
    }

    /// Switches made since construction.
    pub fn switches(&self) -> u64 {
        self.memory.switches
    }

    fn active(&self) -> &dyn Integrator {
        match &self.implicit {
            Some(i) if self.stiff => i,
            _ => &self.explicit,
        }
    }

    fn active_mut(&mut self) -> &mut dyn Integrator {
        match &mut self.implicit {
            Some(i) if self.stiff => i,
            _ => &mut self.explicit,
        }
    }

    /// Makes the other method the active one at the current state: it starts there with the
    /// counters so far (the implicit one with a fresh Jacobian).
    fn switch(&mut self, sys: &mut dyn OdeSystem) {
        let (t, stats, h) = (self.active().t(), self.active().stats(), self.active().next_step());
        if self.implicit_built().is_none() {
            self.switch_pending = false;
            return;
        }
        self.stiff = !self.stiff;
        self.switch_pending = false;
        self.memory.count = 0;
        self.memory.calm = 0;
        self.memory.since = 0;
        self.memory.switches += 1;
        let Auto { explicit, implicit, .. } = self;
        let Some(implicit) = implicit else {
            return;
        };
        if self.stiff {
            implicit.set_stats(stats);
            implicit.reset(sys, t, explicit.y(), h);
            implicit.jacobian(sys);
            // (the stint starts before the first Jacobian: it is part of the cost)
            self.memory.stint_t = t;
            self.memory.stint_rhs = stats.rhs_evals;
            self.memory.stint_steps = 0;
            // (a hold that a switch overrode ends: in a stint a hold marks a loss)
            self.memory.cost_hold = 0;
            self.memory.steps_since_check = 0;
            self.memory.stint_linear = 0.0;
            self.linear_mark = linear_work(implicit);
            // (the step the controller asked for: the last one may have been cut short to
            // reach the end of an advance)
            let h_explicit = (explicit.t() - explicit.t_prev()).max(explicit.next_step());
            self.memory.stint_explicit_rate = if h_explicit > 0.0 {
                DOPRI5_EVALUATIONS / h_explicit
            } else {
                f64::INFINITY
            };
        } else {
            if self.memory.cost_hold == 0 {
                // (the stint ended calm: it did not lose)
                self.memory.losses = 0;
            }
            explicit.set_stats(stats);
            explicit.reset(sys, t, implicit.y(), h);
        }
    }

    /// Updates the switching memory after an accepted step of positive length (the
    /// explicit method's stiffness check evaluates `sys`).
    fn observe(&mut self, sys: &mut dyn OdeSystem) {
        if !self.stiff {
            if self.memory.cost_hold > 0 {
                self.memory.cost_hold -= 1;
                let h = self.explicit.t() - self.explicit.t_prev();
                if DOPRI5_EVALUATIONS / h <= self.memory.implicit_cost {
                    // cheaper than the implicit method measured: no check, no switch
                    return;
                }
                // (a step that costs more, as near an event, is checked; the hold stays for
                // the steps after it)
            }
            // (explicit: `since` counts the steps in a row whose estimate is at the trigger)
            self.memory.since = if self.explicit.stiffness() >= CHECK_TRIGGER {
                (self.memory.since + 1).min(CHECK_AFTER)
            } else {
                0
            };
            let h_rho = if self.memory.since >= CHECK_AFTER {
                self.explicit.stiffness_check(sys)
            } else {
                0.0
            };
            // (the counts saturate: without an implicit method they would grow forever)
            if h_rho >= STIFF_LIMIT {
                let weight = if h_rho >= UNSTABLE_LIMIT { UNSTABLE_WEIGHT } else { 1 };
                self.memory.count = (self.memory.count + weight).min(STIFF_STEPS);
                self.memory.calm = 0;
            } else {
                self.memory.calm = (self.memory.calm + 1).min(CALM_STEPS);
                if self.memory.calm >= CALM_STEPS {
                    self.memory.count = 0;
                }
            }
            if self.memory.count >= STIFF_STEPS && self.build.is_some() {
                self.switch_pending = true;
            }
            return;
        }
        let Auto {
            implicit: Some(implicit),
            ..
        } = self
        else {
            return;
        };
        let (_, newton) = implicit.parts();
        let jac_valid = newton.mem.jac_valid;
        let calm = if !jac_valid {
            true
        } else {
            let jac_evals = implicit.stats().jac_evals;
            if self.memory.rho_jac != jac_evals || self.x_for != jac_evals {
                // a new Jacobian (or its direction not known since a load: the same numbers)
                self.memory.rho = spectral_radius(newton.jac_ref(), &mut self.x, &mut self.jx);
                self.x_for = jac_evals;
                if self.memory.rho_jac != jac_evals {
                    self.memory.rho_jac = jac_evals;
                    self.memory.rho_now = self.memory.rho;
                    self.memory.since = 0;
                }
            }
            self.memory.since += 1;
            if self.memory.since >= RECHECK_STEPS {
                self.memory.since = 0;
                self.v.copy_from_slice(&self.x);
                let core = implicit.parts_mut().0;
                if let Some(r) = core.directional_rate(sys, &mut self.v, &mut self.y_pert, &mut self.jv) {
                    self.memory.rho_now = r;
                }
            }
            implicit.next_step() * self.memory.rho_now < CALM_LIMIT
        };
        self.memory.count = if calm {
            (self.memory.count + 1).min(CALM_STEPS_IMPLICIT)
        } else {
            0
        };
        if self.memory.count >= CALM_STEPS_IMPLICIT {
            self.switch_pending = true;
        }
        self.memory.steps_since_check += 1;
        self.memory.stint_steps = self.memory.stint_steps.saturating_add(1);
        // the stint's evaluations so far, and what Dormand-Prince would spend per unit of time
        let spent = implicit.stats().rhs_evals.saturating_sub(self.memory.stint_rhs) as f64
            + self.memory.stint_linear
            + (linear_work(implicit) - self.linear_mark);
        let explicit_cost = if jac_valid {
            DOPRI5_EVALUATIONS * self.memory.rho_now / STABILITY_BOUNDARY
        } else {
            self.memory.stint_explicit_rate
        };
        if self.memory.stint_steps == EARLY_COST_STEPS && implicit.factorisation_evaluations() > 0.0 {
            // per step so far, at the step size it goes on with
            let predicted = spent / self.memory.stint_steps as f64 / implicit.next_step();
            if predicted.is_finite() && predicted > COST_RATIO * explicit_cost {
                self.lose(predicted);
                return;
            }
        }
        if self.memory.steps_since_check >= COST_WINDOW {
            let cost = spent / (implicit.t() - self.memory.stint_t);
            if cost.is_finite() && cost > COST_RATIO * explicit_cost {
                self.lose(cost);
            }
            self.memory.steps_since_check = 0;
        }
    }
}

/// The implicit method's factorisations so far, in evaluations (whole multiples of its
/// [`ImplicitMethod::factorisation_evaluations`]: sums of them are exact, so a stint's cost
/// is the same number whether or not it was saved and loaded on the way).
fn linear_work<I: ImplicitMethod>(implicit: &I) -> f64 {
    implicit.parts().1.factorisations as f64 * implicit.factorisation_evaluations()
}

/// Spectral radius of the n×n Jacobian `jac` (dense row-major or sparse) by power iteration
/// from a fixed start (deterministic): `sqrt(‖J²x‖/‖x‖)` after `POWER_ITERATIONS`
/// iterations, which is exact for a dominant real eigenvalue and for a dominant complex pair
/// `±iω` of an oscillation.
pub fn spectral_radius(jac: JacRef, x: &mut [f64], jx: &mut [f64]) -> f64 {
    let n = x.len();
    if n == 0 {
        return 0.0;
    }
    for (i, v) in x.iter_mut().enumerate() {
        *v = 1.0 + (0.618_033_988_749_895 * i as f64).fract();
    }
    let norm = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>().sqrt();
    let scale = norm(x);
    x.iter_mut().for_each(|v| *v /= scale);
    let mut norms = [0.0; 2];
    for k in 0..POWER_ITERATIONS {
        match jac {
            JacRef::Dense(jac) => {
                for (i, out) in jx.iter_mut().enumerate() {
                    let row = &jac[i * n..(i + 1) * n];
                    *out = row.iter().zip(x.iter()).map(|(a, b)| a * b).sum();
                }
            }
            JacRef::Sparse(jac) => {
                jx.iter_mut().for_each(|v| *v = 0.0);
                for (j, xj) in x.iter().enumerate() {
                    for k in jac.col_ptr[j]..jac.col_ptr[j + 1] {
                        jx[jac.row_idx[k]] += jac.val[k] * xj;
                    }
                }
            }
        }
        let nj = norm(jx);
        if !(nj > 0.0 && nj.is_finite()) {
            return if nj == 0.0 { 0.0 } else { f64::INFINITY };
        }
        norms[k % 2] = nj;
        for (a, b) in x.iter_mut().zip(jx.iter()) {
            *a = b / nj;
        }
    }
    (norms[0] * norms[1]).sqrt()
}

impl<I: ImplicitMethod + Integrator> Integrator for Auto<I> {
    fn reset(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.switch_pending = self.losing();
        self.active_mut().reset(sys, t, y, h);
    }

    fn restart(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.switch_pending = self.losing();
        self.active_mut().restart(sys, t, y, h);
    }

    fn step(&mut self, sys: &mut dyn OdeSystem, t_max: f64) -> Result<(), IntegratorError> {
        if self.switch_pending {
            self.switch(sys);
        }
        self.active_mut().step(sys, t_max)?;
        if self.active().t() > self.active().t_prev() {
            self.observe(sys);
        }
        Ok(())
    }

    fn interpolate(&self, t: f64, out: &mut [f64]) {
        self.active().interpolate(t, out);
    }

    fn interpolate_slots(&self, t: f64, slots: &[usize], out: &mut [f64]) -> bool {
        self.active().interpolate_slots(t, slots, out)
    }

    fn explicit_hold(&self) -> Option<ExplicitHold> {
        (self.memory.cost_hold > 0).then_some(ExplicitHold {
            implicit_cost: self.memory.implicit_cost,
            steps: self.memory.cost_hold,
            losses: self.memory.losses,
        })
    }

    fn hold_explicit(&mut self, hold: ExplicitHold) {
        if !self.stiff && hold.steps > self.memory.cost_hold {
            self.memory.implicit_cost = hold.implicit_cost;
            self.memory.cost_hold = hold.steps;
            self.memory.losses = self.memory.losses.max(hold.losses);
        }
    }

    fn use_second_order(&mut self, s: &SecondOrder) {
        if let Some(i) = &mut self.implicit {
            Integrator::use_second_order(i, s);
        }
        // (in the buffer held, as after a renewal; every field named, so that a new one is not
        // left out)
        let held = self.second_order.get_or_insert_with(SecondOrder::default);
        let SecondOrder { nq, nv, blocks } = s;
        (held.nq, held.nv) = (*nq, *nv);
        held.blocks.clone_from(blocks);
    }

    /// (the auto method over Radau IIA, with its builder, as [`super::create`] makes it)
    fn renew(&mut self, s: &SolverSection, n: usize) -> bool {
        s.method == Method::Auto
            && I::METHOD == Method::Radau5
            && self.build.is_some()
            && self.renew_with(n, s.rtol, s.atol, largest_step(s))
    }

    /// The implicit method's, whichever is active (None without one).
    fn linear_stats(&self) -> Option<super::linear::LinearStats> {
        self.implicit.as_ref().and_then(|i| Integrator::linear_stats(i))
    }

    fn core(&self) -> &StepCore {
        self.active().core()
    }

    fn core_mut(&mut self) -> &mut StepCore {
        self.active_mut().core_mut()
    }

    /// Tag, the switching memory (implicit active, switch pending, the two step counts, ρ(J)
    /// and the Jacobian count it is for (−1: none), switches made, the stiffness measured
    /// since and the implicit steps since that measurement, the cost window's start time,
    /// evaluations and steps, its steps, its factorisations in evaluations, Dormand-Prince's rate before
    /// it, the remembered implicit cost, its hold and the losing stints in a row), then the active method's state
    /// with its own tag.
    fn save_state(&self, out: &mut Vec<f64>) {
        out.push(super::core::state_tag(Method::Auto));
        let flag = |b: bool| b as u8 as f64;
        let m = &self.memory;
        let rho_jac = if m.rho_jac == u64::MAX { -1.0 } else { m.rho_jac as f64 };
        out.extend_from_slice(&[
            flag(self.stiff),
            flag(self.switch_pending),
            m.count as f64,
            m.calm as f64,
            m.rho,
            rho_jac,
            m.switches as f64,
            m.rho_now,
            m.since as f64,
            m.stint_t,
            m.stint_rhs as f64,
            m.steps_since_check as f64,
            m.stint_steps as f64,
            m.stint_linear
                + self
                    .implicit
                    .as_ref()
                    .map_or(0.0, |i| linear_work(i) - self.linear_mark),
            m.stint_explicit_rate,
            m.implicit_cost,
            m.cost_hold as f64,
            m.losses as f64,
        ]);
        self.active().save_state(out);
    }

    fn load_state(&mut self, v: &[f64]) -> Result<(), String> {
        let mut r = StateReader::new(v, Method::Auto)?;
        let stiff = r.flag()?;
        let pending = r.flag()?;
        let max_u32 = u32::MAX as u64;
        let m = Memory {
            count: r.count_to(max_u32)? as u32,
            calm: r.count_to(max_u32)? as u32,
            rho: r.value()?,
            rho_jac: match r.value()? {
                -1.0 => u64::MAX,
                x if x >= 0.0 && x.fract() == 0.0 && x < 9.0e15 => x as u64,
                x => {
                    return Err(format!(
                        "the auto integrator state holds {x} where a Jacobian count belongs"
                    ))
                }
            },
            switches: r.count()?,
            rho_now: r.value()?,
            since: r.count_to(max_u32)? as u32,
            stint_t: r.value()?,
            stint_rhs: r.count()?,
            steps_since_check: r.count_to(max_u32)? as u32,
            stint_steps: r.count_to(max_u32)? as u32,
            stint_linear: r.value()?,
            stint_explicit_rate: r.value()?,
            implicit_cost: r.value()?,
            cost_hold: r.count_to((COST_MEMORY_STEPS << MAX_HOLD_DOUBLINGS) as u64)? as u32,
            losses: r.count_to(max_u32)? as u32,
        };
        let own = r.take(v.len().saturating_sub(1 + MEMORY_LEN))?;
        r.finish()?;
        let bad_rate = |x: f64| x.is_nan() || x < 0.0;
        if bad_rate(m.rho)
            || bad_rate(m.rho_now)
            || bad_rate(m.implicit_cost)
            || !m.implicit_cost.is_finite()
            || (stiff && m.cost_hold > 0 && !pending)
            || bad_rate(m.stint_explicit_rate)
            || !(0.0..9.0e15).contains(&m.stint_linear)
            || !m.stint_t.is_finite()
        {
            return Err("the auto integrator state holds an out-of-range switching memory".into());
        }
        if stiff {
            self.load_implicit("the auto integrator state", |i| i.load_state(own))?;
        } else {
            self.explicit.load_state(own)?;
        }
        self.stiff = stiff;
        self.switch_pending = pending;
        self.memory = m;
        self.linear_mark = self.implicit.as_ref().map_or(0.0, linear_work);
        // the Jacobian's direction is computed again from the loaded Jacobian when needed
        self.x_for = u64::MAX;
        Ok(())
    }

    /// The active method (a flag) and its warm memory.
    fn warm_state(&self, out: &mut Vec<f64>) {
        out.push(self.stiff as u8 as f64);
        self.active().warm_state(out);
    }

    fn set_warm_state(&mut self, v: &[f64]) -> Result<(), String> {
        match v.split_first() {
            None => self.active_mut().set_warm_state(&[]),
            Some((&flag, rest)) if flag == 0.0 || flag == 1.0 => {
                if flag == 1.0 {
                    self.load_implicit("the auto integrator's memory", |i| i.set_warm_state(rest))?;
                } else {
                    self.explicit.set_warm_state(rest)?;
                }
                self.stiff = flag == 1.0;
                self.x_for = u64::MAX;
                Ok(())
            }
            Some((&flag, _)) => Err(format!(
                "the auto integrator's memory begins with {flag}, not a flag (0 or 1)"
            )),
        }
    }
}

#[cfg(test)]
mod tests;
