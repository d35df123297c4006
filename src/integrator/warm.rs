//! The memory an implicit method carries across a warm restart ([`WarmMemory`]: the last
//! accepted step, the Newton rate, the Jacobian's flags, the step-size bound after a Newton
//! failure and the failure bursts), as the implicit methods write it into saved states.

use super::WARM_JACOBIAN_MAX;

/// Size of the controller memory of the implicit methods in their warm state: accepted step,
/// its error, Newton rate memory η, Jacobian-stale flag, Jacobian-present flag, the step-size
/// bound after a Newton failure (0: none), the two counters of Newton failure bursts.
pub(crate) const WARM_HEADER: usize = 8;

/// A Newton failure within this many accepted steps of the step of the previous one makes a
/// burst (see [`WarmMemory::filtered_start`]); failures in the same step (the retries of a
/// step) do not.
pub const FAILURE_BURST_STEPS: u32 = 3;
/// Accepted steps after a failure in a burst for which Radau IIA filters its starting values
/// (see [`WarmMemory::filtered_start`]).
pub const FILTERED_START_STEPS: u32 = 10;

/// Growth per accepted step of the bound on the step size after a Newton failure with a
/// fresh Jacobian (see [`WarmMemory::h_newton`]).
pub const NEWTON_RELAX: f64 = 1.2;

/// The step-size bound as saved: 0 for none (infinite), as the factorisation's step size.
pub(crate) fn saved_bound(h: f64) -> f64 {
    if h.is_finite() {
        h
    } else {
        0.0
    }
}

/// The step-size bound from its saved step size (0: none).
pub(crate) fn read_bound(x: f64) -> f64 {
    if x == 0.0 {
        f64::INFINITY
    } else {
        x
    }
}

/// Memory an implicit method carries across a warm restart (see [`Integrator::restart`](super::Integrator::restart)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WarmMemory {
    /// Step size and error norm of the last accepted step (0: none).
    pub h_acc: f64,
    pub err_acc: f64,
    /// Newton convergence-rate memory.
    pub eta: f64,
    /// The Jacobian is to be refreshed before the next step.
    pub jac_stale: bool,
    /// The Jacobian holds an evaluation (false: J = 0, functional iteration).
    pub jac_valid: bool,
    /// Bound on the step size after a Newton failure with a fresh Jacobian: the halved step,
    /// grown by [`NEWTON_RELAX`] at every accepted step (infinite: none). Where a step's
    /// iterates cross a steep band of the right-hand side (the rail vehicle's friction law at
    /// rtol 1e-3), the accuracy-based controller would grow the step straight back into the
    /// failure.
    pub h_newton: f64,
    /// Accepted steps since the last step with a Newton failure, up to
    /// [`FAILURE_BURST_STEPS`] + 1 (that value: none within the burst window).
    pub since_failure: u32,
    /// Accepted steps left for which Radau IIA filters the starting values of its Newton
    /// iteration (0: the previous step's collocation polynomial, extrapolated, as is). Set to
    /// [`FILTERED_START_STEPS`] by a Newton failure in a burst
    /// ([`WarmMemory::note_newton_failure`]). The extrapolation assumes a solution smooth on
    /// the scale of the step; where the right-hand side is not (the rail vehicle at rtol 1e-3,
    /// whose wheel slip crosses the friction law's 2 cm/s regularisation band by more than
    /// the tolerance's 2.2 cm/s), its stiff components put the stages' slip outside the band
    /// while the Jacobian has the band's slope, and Newton fails in bursts. The filtered start
    /// takes the stiff components from the stage equations linearised at the step's state
    /// instead (see `Radau5::filter_start`). Filtering every step cost the rail vehicle's
    /// defaults 1,424 evaluations instead of 1,143 and the track's 6,381 instead of 3,316;
    /// starting from the state itself (Z = 0) after a burst cost up to 1.8× at rtol 1e-5 …
    /// 1e-7 on both.
    pub filtered_start: u32,
}

impl WarmMemory {
    /// Whether a system of size `n` keeps its Jacobian across warm restarts.
    pub fn keeps_jacobian(n: usize) -> bool {
        n.saturating_mul(n) <= WARM_JACOBIAN_MAX
    }

    /// Writes the memory and, when present and kept (`keep`: see
    /// [`NewtonCore::keeps_jacobian`](super::newton::NewtonCore::keeps_jacobian)), the row-major Jacobian `jac`.
    pub fn write(&self, jac: &[f64], keep: bool, out: &mut Vec<f64>) {
        let with_jac = self.jac_valid && keep;
        out.extend_from_slice(&[
            self.h_acc,
            self.err_acc,
            self.eta,
            self.jac_stale as u8 as f64,
            with_jac as u8 as f64,
            saved_bound(self.h_newton),
            self.since_failure as f64,
            self.filtered_start as f64,
        ]);
        if with_jac {
            out.extend_from_slice(jac);
        }
    }

    /// Parses what [`WarmMemory::write`] wrote (empty: the memory after a reset) and copies
    /// the Jacobian into `jac` (zeros when absent); `keep` as for the write.
    pub fn read(v: &[f64], jac: &mut [f64], n: usize, keep: bool) -> Result<WarmMemory, String> {
        if v.is_empty() {
            jac.iter_mut().for_each(|x| *x = 0.0);
            return Ok(WarmMemory::cold());
        }
        let bad = || {
            format!(
                "integrator memory has {} numbers, not a state of this method and model",
                v.len()
            )
        };
        if v.len() < WARM_HEADER {
            return Err(bad());
        }
        let with_jac = v[4] != 0.0;
        let len = WARM_HEADER + if with_jac { n * n } else { 0 };
        if v.len() != len || (with_jac && !keep) {
            return Err(bad());
        }
        if with_jac {
            jac.copy_from_slice(&v[WARM_HEADER..]);
        } else {
            jac.iter_mut().for_each(|x| *x = 0.0);
        }
        Ok(WarmMemory {
            h_acc: v[0],
            err_acc: v[1],
            eta: v[2],
            jac_stale: v[3] != 0.0,
            jac_valid: with_jac,
            h_newton: match v[5] {
                x if x.is_finite() && x >= 0.0 => read_bound(x),
                _ => return Err(bad()),
            },
            since_failure: burst_counter(v[6], FAILURE_BURST_STEPS + 1).ok_or_else(bad)?,
            filtered_start: burst_counter(v[7], FILTERED_START_STEPS).ok_or_else(bad)?,
        })
    }

    /// The memory after a reset: none.
    pub fn cold() -> WarmMemory {
        WarmMemory {
            h_acc: 0.0,
            err_acc: 0.0,
            eta: 1.0,
            jac_stale: false,
            jac_valid: false,
            h_newton: f64::INFINITY,
            since_failure: FAILURE_BURST_STEPS + 1,
            filtered_start: 0,
        }
    }

    /// Records a Newton failure: one in a burst (within [`FAILURE_BURST_STEPS`] accepted steps
    /// of the step of the previous one, or while the start is filtered already) makes the next
    /// [`FILTERED_START_STEPS`] accepted steps filter their starting values.
    pub fn note_newton_failure(&mut self) {
        if (1..=FAILURE_BURST_STEPS).contains(&self.since_failure) || self.filtered_start > 0 {
            self.filtered_start = FILTERED_START_STEPS;
        }
        self.since_failure = 0;
    }

    /// Records an accepted step (for the burst counters).
    pub fn note_accepted_step(&mut self) {
        self.since_failure = (self.since_failure + 1).min(FAILURE_BURST_STEPS + 1);
        self.filtered_start = self.filtered_start.saturating_sub(1);
    }
}

/// A burst counter as saved: a whole number in [0, `max`].
pub(crate) fn burst_counter(x: f64, max: u32) -> Option<u32> {
    ((0.0..=max as f64).contains(&x) && x.fract() == 0.0).then_some(x as u32)
}
