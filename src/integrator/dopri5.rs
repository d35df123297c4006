//! Dormand-Prince 5(4) with FSAL, PI step-size control and Hairer's 4th-order dense output.

use super::core::{core_accessors, restore_blocks, save_blocks, state_tag, StateReader, StepCore};
use super::{error_scale, largest_step, rms, Integrator, IntegratorError, OdeSystem};
use crate::scene::{Method, SolverSection};
use std::cell::{Cell, Ref, RefCell};

// The tableau (Dormand and Prince 1980; Hairer, Nørsett and Wanner, Table II.5.2), stage s
// in the constants numbered s; a coefficient k of a row multiplies the stage k + 1.

/// Nodes c₂ … c₅ (c₆ = c₇ = 1).
const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
/// Rows 2 … 6 of the Butcher matrix: stage s's coefficients of k₁ … k₍ₛ₋₁₎.
const A2: [f64; 1] = [1.0 / 5.0];
const A3: [f64; 2] = [3.0 / 40.0, 9.0 / 40.0];
const A4: [f64; 3] = [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0];
const A5: [f64; 4] = [19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0];
#[rustfmt::skip]
const A6: [f64; 5] = [9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0];
/// Weights of the order-5 solution, also row 7 (the stage at the step's end, the next
/// step's k₁: FSAL); b₂ = 0.
#[rustfmt::skip]
const B: [f64; 6] = [35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0];
/// Weights of the error estimate (order-5 minus order-4 solution) of k₁ … k₇; e₂ = 0.
#[rustfmt::skip]
const E: [f64; 7] = [
    71.0 / 57600.0, 0.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0, 22.0 / 525.0, -1.0 / 40.0,
];
/// Hairer's coefficients dᵢ of the dense output's 4th-order term, of k₁ … k₇; d₂ = 0.
#[rustfmt::skip]
const D: [f64; 7] = [
    -12715105075.0 / 11282082432.0, 0.0, 87487479700.0 / 32700410799.0, -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0, -1453857185.0 / 822651844.0, 69997945.0 / 29380423.0,
];

/// The Dormand-Prince 5(4) method.
pub struct Dopri5 {
    /// Step state; `core.f` is the FSAL stage `k₁`.
    core: StepCore,
    err_old: f64,
    y_new: Vec<f64>,
    /// Two sets of the stages `k₂ … k₇`: a step writes `k[work]`; the other set holds those of
    /// the last accepted step (with its `k₁` in place of `k₇`, which is `core.f`), from which
    /// its dense output is computed when it is first read.
    k: [[Vec<f64>; 6]; 2],
    /// The set of stages a step writes.
    work: usize,
    /// Size of the last accepted step (its dense output's scale).
    h_last: f64,
    tmp: Vec<f64>,
    err: Vec<f64>,
    /// Dense output coefficients after `core.y_prev`, valid when `cont_ready` (else computed
    /// from the last accepted step's stages at the first read: most steps are never
    /// interpolated).
    cont: RefCell<[Vec<f64>; 4]>,
    cont_ready: Cell<bool>,
    /// `h·ρ` of the last accepted step: its size times the local Lipschitz estimate
    /// `‖k₇ − k₆‖ / ‖y₁ − Y₆‖` of the two stages at its end (Hairer's stiffness test, in the
    /// error weights; the method is stable for `h·ρ` up to 3.31 on the negative real axis).
    stiffness: f64,
}

/// Power iterations of [`Dopri5::stiffness_check`] (one evaluation each): with two, the
/// rail vehicle at rtol 1e-4 read `h·ρ` 1.5-2.0 for 0.2 s while the wheels' spin modes put it
/// near 3.5, and `auto` switched at t = 0.195 s (1,800 evaluations against radau5's 778);
/// with three it switches at 0.018 s (787).
pub const CHECK_ITERATIONS: usize = 3;

impl Dopri5 {
    /// A method for systems of size `n`.
    pub fn new(n: usize, rtol: f64, atol: f64, hmax: f64) -> Dopri5 {
        let v = || vec![0.0; n];
        Dopri5 {
            core: StepCore::new(n, rtol, atol, hmax),
            err_old: 1e-4,
            y_new: v(),
            k: [[v(), v(), v(), v(), v(), v()], [v(), v(), v(), v(), v(), v()]],
            work: 0,
            h_last: 0.0,
            tmp: v(),
            err: v(),
            cont: RefCell::new([v(), v(), v(), v()]),
            cont_ready: Cell::new(true),
            stiffness: 0.0,
        }
    }

    /// Makes this method what [`Dopri5::new`]`(n, rtol, atol, hmax)` gives, in place (see
    /// [`Integrator::renew`]): every number that defines its future (what
    /// [`Integrator::save_state`] writes) and its flags; false, and nothing changed, for
    /// another size or other settings.
    pub fn renew_with(&mut self, n: usize, rtol: f64, atol: f64, hmax: f64) -> bool {
        if !self.core.renew(n, rtol, atol, hmax) {
            return false;
        }
        (self.err_old, self.work, self.h_last, self.stiffness) = (1e-4, 0, 0.0, 0.0);
        // (the stages, `y_new`, `tmp` and `err` are scratch that a step writes before it
        // reads them: they keep their numbers)
        self.clear_dense();
        true
    }

    /// `h·ρ` of the last accepted step (0 before one), Hairer's estimate from the two stages
    /// at its end, in the error weights: free, but only a hint — it measures the Lipschitz
    /// constant along `y₁ − Y₆`, which the stiff components hardly enter once the controller
    /// keeps them small (on the rail vehicle it read 0.05-3.07 while the step sat at the
    /// stability boundary, `h·ρ(J)` = 3.3). [`super::auto`] uses it to decide when to run
    /// [`Dopri5::stiffness_check`]. Not part of saved states: each step computes it afresh.
    pub fn stiffness(&self) -> f64 {
        self.stiffness
    }

    /// `h·ρ` of the last accepted step from [`CHECK_ITERATIONS`] power iterations of
    /// directional differences `J v ≈ (f(y + v) − f(y))`, started from the step's error
    /// estimate (the direction the step size is limited by: the stiff components when the
    /// step sits at the stability boundary) and measured in the error weights: a lower bound
    /// of `h·ρ(J)` that is close to it for a dominant real eigenvalue or cluster (on the rail
    /// vehicle 3.31 at the boundary 3.31). Each perturbation is scaled to the increments of
    /// the finite-difference Jacobians (`√ε·max(|yᵢ|, 10⁻⁵)` at most per component). Costs
    /// [`CHECK_ITERATIONS`] evaluations (counted); changes nothing the next step reads except
    /// the stage buffers, which each step writes before it reads them.
    pub fn stiffness_check(&mut self, sys: &mut dyn OdeSystem) -> f64 {
        let h = self.core.t - self.core.t_prev;
        // v (in k[1]): the error estimate, then J v; scratch in tmp and k[0] (of the stages a
        // step writes: the other set is the last step's)
        let [jv, v, ..] = &mut self.k[self.work];
        v.copy_from_slice(&self.err);
        let mut rho = 0.0;
        for _ in 0..CHECK_ITERATIONS {
            if h <= 0.0 {
                break;
            }
            match self.core.directional_rate(sys, v, &mut self.tmp, jv) {
                Some(r) => rho = r,
                None => break,
            }
        }
        h * rho
    }

    /// Dense output of a zero-length step (with `core.y_prev = y`).
    fn clear_dense(&mut self) {
        for c in self.cont.get_mut().iter_mut() {
            c.iter_mut().for_each(|x| *x = 0.0);
        }
        self.cont_ready.set(true);
    }

    /// The dense output coefficients of the last step (Hairer's), computed from its stages
    /// at the first read after it.
    fn dense(&self) -> Ref<'_, [Vec<f64>; 4]> {
        if !self.cont_ready.get() {
            let mut cont = self.cont.borrow_mut();
            let n = self.core.y.len();
            let h = self.h_last;
            let [_, k3, k4, k5, k6, k1] = &self.k[1 - self.work];
            let (k1, k3, k4, k5, k6) = (&k1[..n], &k3[..n], &k4[..n], &k5[..n], &k6[..n]);
            let (y, y_new, k7) = (&self.core.y_prev[..n], &self.core.y[..n], &self.core.f[..n]);
            let [c0, c1, c2, c3] = &mut *cont;
            let (c0, c1, c2, c3) = (&mut c0[..n], &mut c1[..n], &mut c2[..n], &mut c3[..n]);
            for i in 0..n {
                let dy = y_new[i] - y[i];
                let bspl = h * k1[i] - dy;
                c0[i] = dy;
                c1[i] = bspl;
                c2[i] = dy - h * k7[i] - bspl;
                c3[i] = h * (D[0] * k1[i] + D[2] * k3[i] + D[3] * k4[i] + D[4] * k5[i] + D[5] * k6[i] + D[6] * k7[i]);
            }
            self.cont_ready.set(true);
        }
        self.cont.borrow()
    }
}

impl Integrator for Dopri5 {
    core_accessors!();

    fn renew(&mut self, s: &SolverSection, n: usize) -> bool {
        s.method == Method::Dopri5 && self.renew_with(n, s.rtol, s.atol, largest_step(s))
    }

    fn reset(&mut self, sys: &mut dyn OdeSystem, t: f64, y: &[f64], h: f64) {
        self.core.start(sys, t, y);
        self.err_old = 1e-4;
        self.stiffness = 0.0;
        self.core
            .first_step(sys, h, 5, &mut self.tmp, &mut self.k[self.work][0]);
        self.clear_dense();
    }

    fn step(&mut self, sys: &mut dyn OdeSystem, t_max: f64) -> Result<(), IntegratorError> {
        let n = self.core.y.len();
        let mut rejected_before = false;
        if self.core.arrive_within_roundoff(t_max) {
            // the end is within rounding of the current time: arrived without a step
            self.clear_dense();
            return Ok(());
        }
        loop {
            let (h, last) = self.core.trial_step(t_max)?;
            let t_new = self.core.step_end(h, last, t_max);
            let core = &mut self.core;
            let t = core.t;
            let [k2, k3, k4, k5, k6, k7] = &mut self.k[self.work];
            // (the vectors as slices of length n, so that the loops need no bounds checks)
            let (y, k1) = (&core.y[..n], &core.f[..n]);
            let (tmp, y_new, e) = (&mut self.tmp[..n], &mut self.y_new[..n], &mut self.err[..n]);
            for i in 0..n {
                tmp[i] = y[i] + h * A2[0] * k1[i];
            }
            sys.rhs(t + C2 * h, tmp, k2);
            let k2 = &k2[..n];
            for i in 0..n {
                tmp[i] = y[i] + h * (A3[0] * k1[i] + A3[1] * k2[i]);
            }
            sys.rhs(t + C3 * h, tmp, k3);
            let k3 = &k3[..n];
            for i in 0..n {
                tmp[i] = y[i] + h * (A4[0] * k1[i] + A4[1] * k2[i] + A4[2] * k3[i]);
            }
            sys.rhs(t + C4 * h, tmp, k4);
            let k4 = &k4[..n];
            for i in 0..n {
                tmp[i] = y[i] + h * (A5[0] * k1[i] + A5[1] * k2[i] + A5[2] * k3[i] + A5[3] * k4[i]);
            }
            sys.rhs(t + C5 * h, tmp, k5);
            let k5 = &k5[..n];
            for i in 0..n {
                tmp[i] = y[i] + h * (A6[0] * k1[i] + A6[1] * k2[i] + A6[2] * k3[i] + A6[3] * k4[i] + A6[4] * k5[i]);
            }
            sys.rhs(t_new, tmp, k6);
            let k6 = &k6[..n];
            for i in 0..n {
                y_new[i] = y[i] + h * (B[0] * k1[i] + B[2] * k3[i] + B[3] * k4[i] + B[4] * k5[i] + B[5] * k6[i]);
            }
            sys.rhs(t_new, y_new, k7);
            core.stats.rhs_evals += 6;
            // The error estimate and its norm ([`error_norm`]), and the stiffness estimate's
            // sums (Hairer's: k6 and k7 are f at the stage state `tmp` and at y_new, both at
            // t_new, weighted as the error), in one pass; the sums in the order of
            // [`error_norm`]'s.
            let (mut sum, mut num, mut den) = (0.0, 0.0, 0.0);
            {
                let k7 = &k7[..n];
                for i in 0..n {
                    e[i] =
                        h * (E[0] * k1[i] + E[2] * k3[i] + E[3] * k4[i] + E[4] * k5[i] + E[5] * k6[i] + E[6] * k7[i]);
                    let sc = error_scale(y[i], y_new[i], core.rtol, core.atol);
                    sum += (e[i] / sc) * (e[i] / sc);
                    let w = 1.0 / sc;
                    num += (w * (k7[i] - k6[i])).powi(2);
                    den += (w * (y_new[i] - tmp[i])).powi(2);
                }
            }
            let err = rms(sum, n);
            if !err.is_finite() {
                core.stats.rejected += 1;
                core.h = h * 0.1;
                if !y_new.iter().all(|v| v.is_finite()) && h < 1e-14 {
                    return Err(IntegratorError::NotFinite(t));
                }
                continue;
            }
            // PI controller (Hairer's dopri5: beta = 0.04)
            let fac11 = crate::math::powf(err, 0.2 - 0.04 * 0.75);
            let fac = (fac11 / crate::math::powf(self.err_old, 0.04) / 0.9).clamp(0.1, 5.0);
            // no increase right after a rejection (Hairer)
            let h_new = if rejected_before { (h / fac).min(h) } else { h / fac };
            if err <= 1.0 {
                self.err_old = err.max(1e-4);
                self.stiffness = if den > 0.0 { h * (num / den).sqrt() } else { 0.0 };
                // the stages stay for the dense output: k₇ becomes the next step's k₁ and
                // this step's k₁ takes its place; the next step writes the other set
                std::mem::swap(&mut core.f, k7);
                self.h_last = h;
                self.cont_ready.set(false);
                self.work = 1 - self.work;
                std::mem::swap(&mut core.y_prev, &mut core.y);
                std::mem::swap(&mut core.y, &mut self.y_new);
                core.advance(t_new);
                // keep the unclipped proposal when the step was cut short by t_max
                core.set_next_step(h_new, last);
                return Ok(());
            }
            core.stats.rejected += 1;
            rejected_before = true;
            core.h = h / (fac11 / 0.9).min(5.0);
        }
    }

    /// Tag, [`StepCore::save_state`], the PI controller's last error, the four dense-output
    /// coefficient vectors: `9 + 7n` numbers. The stages are not written: each step computes
    /// them afresh before it reads them (the FSAL stage `k₁` is `core.f`).
    fn save_state(&self, out: &mut Vec<f64>) {
        out.push(state_tag(Method::Dopri5));
        self.core.save_state(out);
        out.push(self.err_old);
        save_blocks(&*self.dense(), out);
    }

    fn load_state(&mut self, v: &[f64]) -> Result<(), String> {
        let n = self.core.y.len();
        let mut r = StateReader::new(v, Method::Dopri5)?;
        let core = self.core.read_state(&mut r)?;
        let err_old = r.finite_value("the last error norm")?;
        if err_old <= 0.0 {
            return Err(format!(
                "the dopri5 integrator state holds the error norm {err_old}, not above 0"
            ));
        }
        let cont = r.take(4 * n)?;
        r.finish()?;
        self.core.restore(&core);
        self.err_old = err_old;
        restore_blocks(self.cont.get_mut(), cont);
        self.cont_ready.set(true);
        Ok(())
    }

    fn interpolate_slots(&self, t: f64, slots: &[usize], out: &mut [f64]) -> bool {
        let Some((s, _)) = self.core.dense_fraction(t) else {
            for (x, &i) in out.iter_mut().zip(slots) {
                *x = self.core.y[i];
            }
            return true;
        };
        let cont = self.dense();
        let (y0, [c0, c1, c2, c3]) = (&self.core.y_prev[..], &*cont);
        // (slices of one length: one bounds check per slot)
        let n = y0.len();
        let (c0, c1, c2, c3) = (&c0[..n], &c1[..n], &c2[..n], &c3[..n]);
        for (x, &i) in out.iter_mut().zip(slots) {
            *x = dense_value(s, y0[i], c0[i], c1[i], c2[i], c3[i]);
        }
        true
    }

    fn interpolate(&self, t: f64, out: &mut [f64]) {
        let cont = self.dense();
        let (y0, [c0, c1, c2, c3]) = (&self.core.y_prev, &*cont);
        self.core.interpolate(t, out, |s, _, out| {
            let n = out.len();
            let (y0, c0, c1, c2, c3) = (&y0[..n], &c0[..n], &c1[..n], &c2[..n], &c3[..n]);
            for i in 0..n {
                out[i] = dense_value(s, y0[i], c0[i], c1[i], c2[i], c3[i]);
            }
        });
    }
}

/// One component of the dense output at the step fraction `s` (Hairer's DOPRI5 form), for
/// both the whole state and the slots of a batch: the same operations, so the same bits.
#[inline(always)]
fn dense_value(s: f64, y0: f64, c0: f64, c1: f64, c2: f64, c3: f64) -> f64 {
    let s1 = 1.0 - s;
    y0 + s * (c0 + s1 * (c1 + s * (c2 + s1 * c3)))
}

#[cfg(test)]
mod tests {
    use super::super::test_problems::*;
    use super::*;

    /// Tolerances so loose that every step of `h` is accepted: the formula alone.
    fn fixed(n: usize, h: f64) -> Dopri5 {
        Dopri5::new(n, 1e6, 1e6, h)
    }

    #[test]
    fn tableau_satisfies_the_order_conditions() {
        // rows by stage (row 7 the weights b, with b₇ = 0) and the nodes
        let rows: [&[f64]; 7] = [&[], &A2, &A3, &A4, &A5, &A6, &B];
        let c = [0.0, C2, C3, C4, C5, 1.0, 1.0];
        let b = |i: usize| B.get(i).copied().unwrap_or(0.0);
        for (s, row) in rows.iter().enumerate() {
            assert!(
                (row.iter().sum::<f64>() - c[s]).abs() < 1e-14,
                "row {} sums to c",
                s + 1
            );
        }
        // quadrature: Σ bᵢ cᵢ^{k−1} = 1/k up to k = 5; the order-4 solution's weights b − e
        // up to k = 4, so Σ eᵢ cᵢ^{k−1} = 0 there
        for k in 1..=5 {
            let bc: f64 = (0..7).map(|i| b(i) * c[i].powi(k - 1)).sum();
            assert!((bc - 1.0 / k as f64).abs() < 1e-14, "Σ b c^{}: {bc}", k - 1);
        }
        for k in 1..=4 {
            let ec: f64 = (0..7).map(|i| E[i] * c[i].powi(k - 1)).sum();
            assert!(ec.abs() < 1e-14, "Σ e c^{}: {ec}", k - 1);
        }
        // D(1): Σᵢ bᵢ aᵢⱼ = bⱼ (1 − cⱼ)
        for j in 0..6 {
            let ba: f64 = (j + 1..7).map(|i| b(i) * rows[i][j]).sum();
            assert!((ba - b(j) * (1.0 - c[j])).abs() < 1e-14, "D(1) column {}", j + 1);
        }
    }

    #[test]
    fn converges_with_order_five() {
        let y0 = Smooth::exact(0.0);
        let err = |steps: usize| {
            let h = 2.0 / steps as f64;
            let mut m = fixed(3, h);
            let y = run_from(&mut m, &mut Smooth, 0.0, &y0, 2.0, h);
            assert_eq!(m.stats().steps as usize, steps);
            max_diff(&y, &Smooth::exact(2.0))
        };
        // h = 1/30..1/80: larger steps are not yet asymptotic (observed ratio above 2⁵),
        // smaller ones meet rounding (errors near 1e-14)
        let (e1, e2, e3, e4) = (err(60), err(120), err(80), err(160));
        let (p1, p2) = (order(e1, e2), order(e3, e4));
        assert!(
            (p1 - 5.0).abs() < 0.3 && (p2 - 5.0).abs() < 0.3,
            "orders {p1} {p2} (errors {e1:e} {e2:e} {e3:e} {e4:e})"
        );
    }

    #[test]
    fn dense_output_has_local_order_five() {
        // one step from the exact state: the order-4 interpolant errs by O(h⁵)
        for (name, exact) in [
            ("growth", Growth::exact as fn(f64) -> [f64; 3]),
            ("smooth", Smooth::exact as fn(f64) -> [f64; 3]),
        ] {
            let err = |h: f64| {
                let mut m = fixed(3, h);
                if name == "growth" {
                    m.reset(&mut Growth, 0.3, &exact(0.3), h);
                    m.step(&mut Growth, 10.0).unwrap();
                } else {
                    m.reset(&mut Smooth, 0.3, &exact(0.3), h);
                    m.step(&mut Smooth, 10.0).unwrap();
                }
                assert!((m.t() - 0.3 - h).abs() < 1e-15);
                dense_error(&m, |t| exact(t).to_vec())
            };
            assert_order(name, 5.0, [err(0.1), err(0.05), err(0.025)]);
        }
    }

    #[test]
    fn global_error_is_proportional_to_the_tolerance() {
        // y' = y and y'' = −y over [0, 4]
        let y0 = Growth::exact(0.0);
        let mut errs = Vec::new();
        for tol in [1e-5, 1e-7, 1e-9, 1e-11] {
            let mut m = Dopri5::new(3, tol, tol, f64::INFINITY);
            let y = run(&mut m, &mut Growth, 0.0, &y0, 4.0);
            let exact = Growth::exact(4.0);
            let e = (0..3)
                .map(|i| (y[i] - exact[i]).abs() / (1.0 + exact[i].abs()))
                .fold(0.0, f64::max);
            assert!(e < 100.0 * tol, "tol {tol:e}: relative error {e:e}");
            errs.push(e);
        }
        // slope of log(error) against log(tol) over six decades
        let slope = (errs[0] / errs[3]).log10() / 6.0;
        assert!(slope > 0.7 && slope < 1.3, "error ∝ tol^{slope}: {errs:?}");
    }

    #[test]
    fn rejected_steps_are_retried_smaller_and_counted() {
        // a first step far too large must be rejected, then the run must still be accurate
        let y0 = Smooth::exact(0.0);
        let mut m = Dopri5::new(3, 1e-9, 1e-9, f64::INFINITY);
        m.reset(&mut Smooth, 0.0, &y0, 1.5);
        while m.t() < 2.0 {
            m.step(&mut Smooth, 2.0).unwrap();
        }
        let s = m.stats();
        assert!(s.rejected >= 1, "{s:?}");
        assert_eq!(s.rhs_evals, 1 + 6 * (s.steps + s.rejected));
        assert!(max_diff(m.y(), &Smooth::exact(2.0)) < 1e-7);
    }
}
