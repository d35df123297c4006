//! What the implicit methods (SDIRK4 and Radau IIA) share: simplified Newton iterations with a
//! forward-difference Jacobian kept across steps ([`NewtonCore`]), the memory a warm restart
//! carries ([`WarmMemory`], in `warm.rs`, written into saved states), and the step driver with RADAU5's
//! step-size controller and Gustafsson's prediction ([`ImplicitMethod`], for which
//! [`Integrator`] is implemented here).
//!
//! - The Jacobian is refreshed only when Newton fails or converges slowly; the LU factors of
//!   the iteration matrices are kept while `h` and `J` do not change (a step-size change
//!   below 20 % is not made, to keep them).
//! - After a reset (a restart after a discontinuity) the iteration begins with `J = 0`
//!   (functional iteration), so that a non-stiff phase costs no Jacobian at all; a plain
//!   [`Integrator::restart`] keeps `J` and the controller memory.
//! - [`Integrator::save_state`] writes the step state, the dense output and all of the
//!   Newton state ([`NewtonCore::save_state`]); the LU factors are not written but factored
//!   again on load, from the same Jacobian and step size by the same code, hence to the same
//!   bits.

use super::core::{restore_blocks, save_blocks, StateReader, StepCore};
use super::linear::{EvalPoint, JacRef, LinearStats, SparseJacobian};
use super::second_order::SecondOrder;
use super::warm::{
    burst_counter, read_bound, saved_bound, WarmMemory, FAILURE_BURST_STEPS, FILTERED_START_STEPS, NEWTON_RELAX,
};
use super::{Integrator, IntegratorError, OdeSystem};
use crate::scene::Method;

/// Most Newton iterations per solve.
const MAX_NEWTON: usize = 7;
/// Newton stopping tolerance in the weighted norm of the error test (bounded below by
/// `10ε/rtol`). RADAU5's `max(10ε/rtol', min(0.03, √rtol'))` in its transformed tolerance
/// `rtol' = 0.1 rtol^{2/3}` is 0.03 (0.0316) in the user's tolerance for every rtol up to 1e-3;
/// the same rule applied to the user's rtol directly (`min(0.03, √rtol)`, as before) asked
/// for 3e-5 of the tolerance at rtol 1e-9, below the rounding noise of the right-hand side
/// on components near zero: Newton stalled there and radau5 thrashed its Jacobian on the rail
/// vehicle (330 Jacobians at rtol 1e-9, 23,530 at 1e-10; now 2 and 1, same errors).
const NEWTON_TOL: f64 = 0.03;
/// Newton contraction rate above which the Jacobian is refreshed before the next step.
const SLOW_CONTRACTION: f64 = 0.5;
/// The iteration matrices are factored again when the step size moved by more than this
/// fraction from the one they were factored for (as CVODE does). Within it the simplified
/// Newton iteration uses them as they are: for a stiff component (h|λ| ≫ 1) the correction
/// is then off by the ratio of the step sizes, a contraction of at most 0.3. RADAU5 factors
/// again whenever the step size changes (it keeps the step size instead for proposals within
/// [1, 1.2], as do these methods). On the rail vehicle (rtol 1e-4, 3e-6, 1e-8, 1e-10) this
/// took the factorisations from 112, 192, 564, 902 to 60, 102, 148, 102, for 3-12 % more
/// evaluations (a factorisation of its 38 × 38 matrices costs about 4.5 evaluations);
/// 0.2 gave 90, 138, 192, 152 for 0-4 % more: the same total work.
const LU_KEEP: f64 = 0.3;
/// Safety factor of the step-size controller.
const SAFETY: f64 = 0.9;
/// Largest step-size increase and decrease factors.
const MAX_GROW: f64 = 8.0;
const MAX_SHRINK: f64 = 5.0;

/// Numbers [`NewtonCore::save_state`] writes before the Jacobian: `h_acc`, `err_acc`, `eta`,
/// `jac_stale`, `jac_valid`, `jac_fresh`, the step size of the factorisation, the step-size
/// bound after a Newton failure (0: none), `since_failure`, `filtered_start`.
pub const SAVED_NEWTON_HEADER: usize = 10;

/// A [`NewtonCore`] as read back from a saved state (checked, not yet applied).
#[derive(Debug, Clone, Copy)]
pub struct SavedNewton<'a> {
    mem: WarmMemory,
    jac_fresh: bool,
    lu_h: f64,
    /// The Jacobian, when one is held (`mem.jac_valid`).
    jac: Option<&'a [f64]>,
}

/// Jacobian, Newton and controller state of an implicit method for a system of size `n`.
#[derive(Debug, Clone)]
pub struct NewtonCore {
    /// Newton stopping tolerance in the weighted norm.
    pub newton_tol: f64,
    /// Most Newton iterations per solve.
    pub max_newton: usize,
    /// Row-major Jacobian ∂f/∂y (zero after a reset until Newton first needs one); empty on
    /// the sparse path.
    pub jac: Vec<f64>,
    /// The Jacobian on the sparse path (see [`super::linear`]).
    pub sparse: Option<SparseJacobian>,
    /// What a warm restart keeps besides `jac`.
    pub mem: WarmMemory,
    /// The Jacobian was evaluated at the current state.
    pub jac_fresh: bool,
    /// Step size the iteration matrices were factored for (0: none).
    lu_h: f64,
    /// Factorisations of the iteration matrices by this instance (not saved: `auto`'s cost
    /// rule reads differences of it).
    pub factorisations: u64,
    /// Perturbed state and right-hand sides of the finite differences.
    y_pert: Vec<f64>,
    f0: Vec<f64>,
    f1: Vec<f64>,
}

impl NewtonCore {
    /// The state for a system of size `n` and relative tolerance `rtol`, as after a reset;
    /// the Jacobian dense or sparse.
    pub fn new(n: usize, rtol: f64, sparse: bool) -> NewtonCore {
        NewtonCore {
            newton_tol: (10.0 * f64::EPSILON / rtol.max(1e-300)).max(NEWTON_TOL),
            max_newton: MAX_NEWTON,
            jac: if sparse { Vec::new() } else { vec![0.0; n * n] },
            sparse: sparse.then(|| SparseJacobian::new(n)),
            mem: WarmMemory::cold(),
            jac_fresh: false,
            lu_h: 0.0,
            factorisations: 0,
            y_pert: vec![0.0; n],
            f0: vec![0.0; n],
            f1: vec![0.0; n],
        }
    }

    /// System size.
    fn n(&self) -> usize {
        self.f0.len()
    }

    /// Whether the Jacobian is kept across warm restarts (and written into warm states): a
    /// dense one of at most [`WARM_JACOBIAN_MAX`](super::WARM_JACOBIAN_MAX) numbers.
    pub fn keeps_jacobian(&self) -> bool {
        self.sparse.is_none() && WarmMemory::keeps_jacobian(self.n())
    }

    /// The Jacobian as the factorisations read it.
    pub fn jac_ref(&self) -> JacRef<'_> {
        match &self.sparse {
            Some(s) => JacRef::Sparse(s),
            None => JacRef::Dense(&self.jac),
        }
    }

    /// What the sparse Jacobian did (the factorisation counts are the method's).
    pub fn linear_stats(&self) -> LinearStats {
        match &self.sparse {
            Some(s) => LinearStats {
                sparse: true,
                probes: s.probes,
                coloured: s.coloured,
                colours: s.colours(),
                nnz: s.nnz(),
                ..LinearStats::default()
            },
            None => LinearStats::default(),
        }
    }

    /// Appends the Newton state: the [`SAVED_NEWTON_HEADER`] numbers, then the row-major
    /// Jacobian (n²) when one is held (on the sparse path its pattern and values instead:
    /// [`SparseJacobian::save`]). Without one (`jac_valid` = 0) the Jacobian is all
    /// zeros (functional iteration: [`NewtonCore::new`], `drop_jacobian`, a cold warm state)
    /// and is not written. The settings `newton_tol` and `max_newton` come from the
    /// construction; the LU factors are left to the method (they are a function of the
    /// Jacobian and the step size written here: see [`ImplicitMethod::factor`]).
    pub fn save_state(&self, out: &mut Vec<f64>) {
        let m = &self.mem;
        let flag = |b: bool| b as u8 as f64;
        out.extend_from_slice(&[
            m.h_acc,
            m.err_acc,
            m.eta,
            flag(m.jac_stale),
            flag(m.jac_valid),
            flag(self.jac_fresh),
            self.lu_h,
            saved_bound(m.h_newton),
            m.since_failure as f64,
            m.filtered_start as f64,
        ]);
        if m.jac_valid {
            match &self.sparse {
                Some(s) => s.save(out),
                None => out.extend_from_slice(&self.jac),
            }
        }
    }

    /// Reads and checks what [`NewtonCore::save_state`] wrote, without changing anything;
    /// apply it with [`NewtonCore::restore`].
    pub fn read_state<'a>(&self, r: &mut StateReader<'a>) -> Result<SavedNewton<'a>, String> {
        let n = self.n();
        let [h_acc, err_acc, eta] = [r.value()?, r.value()?, r.value()?];
        let [jac_stale, jac_valid, jac_fresh] = [r.flag()?, r.flag()?, r.flag()?];
        let lu_h = r.step_size()?;
        let h_newton = read_bound(r.step_size()?);
        let counter = |r: &mut StateReader, max: u32| -> Result<u32, String> {
            let x = r.value()?;
            burst_counter(x, max)
                .ok_or_else(|| format!("Newton failure counter {x} in the state is not a count up to {max}"))
        };
        let since_failure = counter(r, FAILURE_BURST_STEPS + 1)?;
        let filtered_start = counter(r, FILTERED_START_STEPS)?;
        let jac = match (jac_valid, &self.sparse) {
            (false, _) => None,
            (true, None) => Some(r.take(n * n)?),
            (true, Some(_)) => {
                let len = r
                    .peek()
                    .and_then(|first| SparseJacobian::saved_len(first, n))
                    .ok_or("sparse Jacobian in the state: no entry count")?;
                let block = r.take(len)?;
                SparseJacobian::check(block, n)?;
                Some(block)
            }
        };
        Ok(SavedNewton {
            mem: WarmMemory {
                h_acc,
                err_acc,
                eta,
                jac_stale,
                jac_valid,
                h_newton,
                since_failure,
                filtered_start,
            },
            jac_fresh,
            lu_h,
            jac,
        })
    }

    /// Sets the Newton state read by [`NewtonCore::read_state`], with no factorisation
    /// (`lu_h` = 0); returns the step size the saved factorisation was for (0: none), for
    /// [`ImplicitMethod::factor`].
    pub fn restore(&mut self, s: &SavedNewton) -> f64 {
        match (s.jac, &mut self.sparse) {
            (Some(j), None) => self.jac.copy_from_slice(j),
            (None, None) => self.jac.iter_mut().for_each(|x| *x = 0.0),
            (Some(j), Some(sp)) => sp.load(j),
            (None, Some(sp)) => sp.clear(),
        }
        self.mem = s.mem;
        self.jac_fresh = s.jac_fresh;
        self.lu_h = 0.0;
        s.lu_h
    }

    /// Forward-difference Jacobian at `(core.t, core.y)` (n + 1 evaluations: `f(t, y)` is
    /// evaluated afresh, since `core.f` may satisfy a stage equation only to the Newton
    /// tolerance). On the sparse path one evaluation per colour plus one, or n + 1 when the
    /// pattern is probed ([`SparseJacobian::evaluate`]; `probe` forces a probe).
    pub fn jacobian(&mut self, sys: &mut dyn OdeSystem, core: &mut StepCore) {
        self.jacobian_with(sys, core, false);
    }

    fn jacobian_with(&mut self, sys: &mut dyn OdeSystem, core: &mut StepCore, probe: bool) {
        let n = self.n();
        sys.rhs(core.t, &core.y, &mut self.f0);
        if let Some(s) = &mut self.sparse {
            let at = EvalPoint {
                sys,
                t: core.t,
                y: &core.y,
                f0: &self.f0,
                y_pert: &mut self.y_pert,
                f1: &mut self.f1,
                stats: &mut core.stats,
            };
            if probe {
                s.probe(at);
            } else {
                s.evaluate(at);
            }
            core.stats.rhs_evals += 1;
            core.stats.jac_evals += 1;
            self.jac_fresh = true;
            self.mem.jac_stale = false;
            self.mem.jac_valid = true;
            self.lu_h = 0.0;
            return;
        }
        self.y_pert.copy_from_slice(&core.y);
        for j in 0..n {
            let yj = core.y[j];
            let dy = (f64::EPSILON * 1e-5_f64.max(yj.abs())).sqrt();
            self.y_pert[j] = yj + dy;
            let dy = self.y_pert[j] - yj; // exactly representable increment
            sys.rhs(core.t, &self.y_pert, &mut self.f1);
            for i in 0..n {
                self.jac[i * n + j] = (self.f1[i] - self.f0[i]) / dy;
            }
            self.y_pert[j] = yj;
        }
        core.stats.rhs_evals += n as u64 + 1;
        core.stats.jac_evals += 1;
        self.jac_fresh = true;
        self.mem.jac_stale = false;
        self.mem.jac_valid = true;
        self.lu_h = 0.0;
    }

    /// Factors the iteration matrices for step `h` with `factor(jac)` unless they are
    /// factored for the current Jacobian and a step size within `LU_KEEP` of `h`. False if
    /// singular.
    pub fn factor(&mut self, h: f64, factor: impl FnOnce(JacRef) -> bool) -> bool {
        if self.lu_h == h {
            return true;
        }
        if self.lu_h > 0.0 && (h / self.lu_h - 1.0).abs() <= LU_KEEP {
            // factored for a step size within 30 %: an approximate iteration matrix, which
            // slows the iteration of the stiff components by at most that ratio
            return true;
        }
        let ok = factor(self.jac_ref());
        self.factorisations += 1;
        self.lu_h = if ok { h } else { 0.0 };
        ok
    }

    /// Drops iteration matrices factored for a step size other than `h` (within `LU_KEEP`,
    /// so that they were used as they were); true if there were such.
    pub fn drop_approximate_factors(&mut self, h: f64) -> bool {
        let approximate = self.lu_h != 0.0 && self.lu_h != h;
        if approximate {
            self.lu_h = 0.0;
        }
        approximate
    }

    /// Simplified Newton iterations: each call of `correct` applies one correction and returns
    /// its weighted norm and whether it is at rounding level. Returns the largest contraction
    /// rate once converged, or None when the iteration diverges, would not converge within
    /// the iterations left, or is not finite.
    pub fn iterate(&mut self, mut correct: impl FnMut() -> (f64, bool)) -> Option<f64> {
        let mut norm_old = 0.0;
        let mut theta_max: f64 = 0.0;
        let mut eta = crate::math::powf(self.mem.eta.max(f64::EPSILON), 0.8);
        for iter in 0..self.max_newton {
            let (norm, at_roundoff) = correct();
            if !norm.is_finite() {
                return None;
            }
            // corrections at rounding level: converged, whatever their ratio says
            if !at_roundoff && iter > 0 {
                let theta = norm / norm_old;
                theta_max = theta_max.max(theta);
                if theta >= 0.99 {
                    return None;
                }
                // predicted error after the remaining iterations is too large: give up early
                let left = (self.max_newton - 1 - iter) as i32;
                if crate::math::powi(theta, left) / (1.0 - theta) * norm > self.newton_tol {
                    return None;
                }
                eta = theta / (1.0 - theta);
            }
            if at_roundoff || eta * norm <= self.newton_tol {
                self.mem.eta = eta;
                return Some(theta_max);
            }
            norm_old = norm;
        }
        None
    }

    /// Forgets the Jacobian (and a sparse one's pattern): J = 0 (functional iteration) until
    /// Newton needs one.
    fn drop_jacobian(&mut self) {
        self.jac.iter_mut().for_each(|x| *x = 0.0);
        if let Some(s) = &mut self.sparse {
            s.clear();
        }
        self.mem.jac_valid = false;
        self.lu_h = 0.0;
    }

    /// Sets the memory that warm restarts carry (the Jacobian is in `jac` already).
    fn set_memory(&mut self, m: WarmMemory) {
        self.mem = m;
        self.jac_fresh = false;
        self.lu_h = 0.0;
    }
}

/// The accessors of [`ImplicitMethod`] for a method whose step state, Newton state and dense
/// output are its fields `core`, `newton` and `dense`, with its `METHOD` and its
/// `first_step` for a method of order `order`, which takes `work` and row 1 of its field
/// `scratch` as the estimate's scratch.
macro_rules! implicit_parts {
    ($method:expr, order $order:expr, scratch $scratch:ident) => {
        const METHOD: Method = $method;

        fn first_step(&mut self, sys: &mut dyn OdeSystem, h: f64) {
            self.core
                .first_step(sys, h, $order, &mut self.work, &mut self.$scratch[1]);
        }

        fn parts(&self) -> (&StepCore, &NewtonCore) {
            (&self.core, &self.newton)
        }

        fn parts_mut(&mut self) -> (&mut StepCore, &mut NewtonCore) {
            (&mut self.core, &mut self.newton)
        }

        fn dense_coefficients(&self) -> &[Vec<f64>] {
            &self.dense
        }

        fn dense_coefficients_mut(&mut self) -> &mut [Vec<f64>] {
            &mut self.dense
        }
    };
}
pub(crate) use implicit_parts;

/// An implicit Runge-Kutta method on a [`StepCore`] and a [`NewtonCore`]: what differs between
/// SDIRK4 and Radau IIA. [`Integrator`] is implemented for it below.
pub trait ImplicitMethod {
    /// The step state and the Newton state.
    fn parts(&self) -> (&StepCore, &NewtonCore);
    /// The same, to change.
    fn parts_mut(&mut self) -> (&mut StepCore, &mut NewtonCore);
    /// Clears the method's dense output to that of a zero-length step (`y_prev = y` is set).
    fn clear_dense(&mut self) {
        for c in self.dense_coefficients_mut() {
            c.iter_mut().for_each(|x| *x = 0.0);
        }
    }
    /// Calls [`StepCore::first_step`] with the method's order and scratch.
    fn first_step(&mut self, sys: &mut dyn OdeSystem, h: f64);
    /// One attempt of a step of size `h`: (error norm, largest Newton contraction), or None
    /// if Newton failed. `refine`: after a rejection or before the first accepted step.
    fn attempt(&mut self, sys: &mut dyn OdeSystem, h: f64, refine: bool) -> Option<(f64, f64)>;
    /// Accepts the attempted step of size `h` ending at `t_new`: state, dense output, `t`.
    fn accept(&mut self, sys: &mut dyn OdeSystem, h: f64, t_new: f64);
    /// Dense output at `t` (see [`Integrator::interpolate`]).
    fn dense_output(&self, t: f64, out: &mut [f64]);
    /// The method, whose enumeration value tags its saved states.
    const METHOD: Method;
    /// The vectors (each of length n) that, with `core.y_prev`, hold the dense output of the
    /// last step.
    fn dense_coefficients(&self) -> &[Vec<f64>];
    /// The same, to change.
    fn dense_coefficients_mut(&mut self) -> &mut [Vec<f64>];
    /// Factors the iteration matrices for step `h` from the Jacobian with
    /// [`NewtonCore::factor`] (nothing when they are factored for `h` already). False if
    /// singular. The factors depend on nothing but the Jacobian and `h`.
    fn factor(&mut self, h: f64) -> bool;
    /// What the linear algebra did (see [`LinearStats`]).
    fn linear_stats(&self) -> LinearStats;
    /// What one call of [`ImplicitMethod::factor`] that factors costs, in right-hand-side
    /// evaluations, as `auto`'s cost rule counts it (0: left out; see the method's own).
    fn factorisation_evaluations(&self) -> f64 {
        0.0
    }
    /// See [`Integrator::use_second_order`] (nothing by default).
    fn use_second_order(&mut self, _s: &SecondOrder) {}

    /// Starts at `(t, y)` with first step `h` (0: choose one); the memory is left alone.
    fn start(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.parts_mut().0.start(sys, t, y);
        self.clear_dense();
        self.first_step(sys, h);
        self.parts_mut().1.jac_fresh = false;
    }

    /// A fresh Jacobian at the current state.
    fn jacobian(&mut self, sys: &mut dyn OdeSystem) {
        let (core, newton) = self.parts_mut();
        newton.jacobian(sys, core);
    }
}

impl<M: ImplicitMethod> Integrator for M {
    fn reset(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.start(sys, t, y, h);
        // everything from before a restart after a discontinuity is discarded; the iteration
        // starts with J = 0 (functional iteration, enough while the problem is not stiff) and
        // a Jacobian is evaluated only when that fails to converge or converges slowly
        let newton = self.parts_mut().1;
        newton.drop_jacobian();
        newton.set_memory(WarmMemory::cold());
    }

    fn restart(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.start(sys, t, y, h);
        // keep J (and the LU factors, which are a function of J and h and are recomputed
        // identically after a restore), Newton and controller memory: all of it is in
        // `warm_state`, except a Jacobian too big to save, which is dropped here
        let newton = self.parts_mut().1;
        if !newton.keeps_jacobian() {
            newton.drop_jacobian();
        }
    }

    fn warm_state(&self, out: &mut Vec<f64>) {
        let newton = self.parts().1;
        newton.mem.write(&newton.jac, newton.keeps_jacobian(), out);
    }

    fn set_warm_state(&mut self, v: &[f64]) -> Result<(), String> {
        let newton = self.parts_mut().1;
        let (n, keep) = (newton.n(), newton.keeps_jacobian());
        let m = WarmMemory::read(v, &mut newton.jac, n, keep)?;
        if let Some(s) = &mut newton.sparse {
            s.clear();
        }
        newton.set_memory(m);
        Ok(())
    }

    /// Tag, [`StepCore::save_state`], the dense-output coefficients (3n for both methods),
    /// [`NewtonCore::save_state`].
    fn save_state(&self, out: &mut Vec<f64>) {
        out.push(super::core::state_tag(Self::METHOD));
        let (core, newton) = self.parts();
        core.save_state(out);
        save_blocks(self.dense_coefficients(), out);
        newton.save_state(out);
    }

    /// Everything is checked first; then the LU factors are computed again when the saved
    /// state had them (for the saved step size, from the saved Jacobian: the inputs and
    /// operations of the original factorisation, so the same bits).
    fn load_state(&mut self, v: &[f64]) -> Result<(), String> {
        let mut r = StateReader::new(v, Self::METHOD)?;
        let (core, newton) = self.parts();
        let saved_core = core.read_state(&mut r)?;
        let dense_len = self.dense_coefficients().iter().map(Vec::len).sum();
        let dense = r.take(dense_len)?;
        let saved_newton = newton.read_state(&mut r)?;
        r.finish()?;
        let (core, newton) = self.parts_mut();
        core.restore(&saved_core);
        let lu_h = newton.restore(&saved_newton);
        restore_blocks(self.dense_coefficients_mut(), dense);
        if lu_h != 0.0 {
            // it succeeded with these inputs before, so it succeeds again and sets lu_h
            self.factor(lu_h);
        }
        Ok(())
    }

    fn step(&mut self, sys: &mut dyn OdeSystem, t_max: f64) -> Result<(), IntegratorError> {
        if self.parts().1.mem.jac_stale {
            self.jacobian(sys);
        }
        if self.parts_mut().0.arrive_within_roundoff(t_max) {
            self.clear_dense();
            return Ok(());
        }
        let mut rejected_before = false;
        // Newton failures with a fresh coloured Jacobian in this step (sparse path)
        let mut coloured_failures = 0;
        loop {
            let (h, last) = self.parts().0.trial_step(t_max)?;
            let refine = rejected_before || self.parts().1.mem.h_acc == 0.0;
            let attempt = self.attempt(sys, h, refine);
            let (core, newton) = self.parts_mut();
            let Some((err, theta)) = attempt else {
                // Newton failed: a smaller step, with a fresh Jacobian when it is not (as
                // RADAU5; retrying the same step with a fresh Jacobian first thrashed where the
                // rail vehicle's wheel slip crosses the edge of the regularised friction law at
                // rtol 1e-3: 245 Jacobians and 17,010 evaluations, against 6 and 638)
                core.stats.rejected += 1;
                rejected_before = true;
                newton.mem.note_newton_failure();
                if newton.drop_approximate_factors(h) {
                    // factored for another step size: factor for this one before anything else
                } else if !newton.jac_fresh {
                    // (functional iteration, J = 0 after a reset, failing says the problem is
                    // stiff, not that the step is too long: the same step with a Jacobian)
                    let held = newton.mem.jac_valid;
                    newton.jacobian(sys, core);
                    if held {
                        core.h = h * 0.5;
                    }
                } else if newton.sparse.as_ref().is_some_and(|s| s.last_coloured) && coloured_failures == 1 {
                    // twice: a coloured Jacobian may miss entries the pattern has gained, so
                    // probe it (a first failure halves the step, as a dense Jacobian does)
                    newton.jacobian_with(sys, core, true);
                } else {
                    if newton.sparse.as_ref().is_some_and(|s| s.last_coloured) {
                        coloured_failures += 1;
                    }
                    core.h = h * 0.5;
                    newton.mem.h_newton = core.h;
                }
                continue;
            };
            if !err.is_finite() {
                core.stats.rejected += 1;
                rejected_before = true;
                core.h = h * 0.2;
                continue;
            }
            // step-size proposal (RADAU5's controller with Gustafsson's prediction)
            let mut quot = (crate::math::powf(err, 0.25) / SAFETY).clamp(1.0 / MAX_GROW, MAX_SHRINK);
            if err <= 1.0 {
                let mem = &mut newton.mem;
                if mem.h_acc > 0.0 {
                    let gus = (mem.h_acc / h) * crate::math::powf(err * err / mem.err_acc, 0.25) / SAFETY;
                    quot = quot.max(gus.clamp(1.0 / MAX_GROW, MAX_SHRINK));
                }
                mem.h_acc = h;
                mem.err_acc = err.max(1e-2);
                let t_new = core.step_end(h, last, t_max);
                self.accept(sys, h, t_new);
                let (core, newton) = self.parts_mut();
                newton.mem.note_accepted_step();
                newton.jac_fresh = false;
                if theta > SLOW_CONTRACTION {
                    newton.mem.jac_stale = true;
                }
                let mut h_new = (h / quot).min(newton.mem.h_newton);
                newton.mem.h_newton *= NEWTON_RELAX;
                if rejected_before {
                    h_new = h_new.min(h);
                }
                // keep h (and the LU factors) for changes below 20 %
                let ratio = h_new / h;
                if (1.0..=1.2).contains(&ratio) && !newton.mem.jac_stale {
                    h_new = h;
                }
                core.set_next_step(h_new, last);
                return Ok(());
            }
            core.stats.rejected += 1;
            rejected_before = true;
            core.h = if newton.mem.h_acc == 0.0 { h * 0.1 } else { h / quot };
        }
    }

    fn interpolate(&self, t: f64, out: &mut [f64]) {
        self.dense_output(t, out);
    }

    fn linear_stats(&self) -> Option<LinearStats> {
        Some(ImplicitMethod::linear_stats(self))
    }

    fn use_second_order(&mut self, s: &SecondOrder) {
        ImplicitMethod::use_second_order(self, s);
    }

    fn core(&self) -> &StepCore {
        self.parts().0
    }

    fn core_mut(&mut self) -> &mut StepCore {
        self.parts_mut().0
    }
}
