//! The energy balance watched at communication points: `energy.total + energy.dissipated −
//! energy.input_work` against its value at the start, a warning (once) beyond
//! [`ENERGY_DRIFT_WARNING`] of its scale, a refused step beyond [`ENERGY_BLOW_UP`].

use super::{SimError, Simulation};
use crate::engine;
use crate::model::EnergyWatch;

/// The energy balance found drifted at a communication point.
#[derive(Debug, Clone, Copy)]
pub(super) struct Drift {
    /// Time \[s\].
    time: f64,
    /// `energy.total + energy.dissipated − energy.input_work` then \[J\].
    balance: f64,
    /// Its reference \[J\].
    reference: f64,
    /// The drift relative to `scale`.
    drift: f64,
    /// The scale \[J\].
    scale: f64,
}

impl std::fmt::Display for Drift {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "at t = {}: the energy balance energy.total + energy.dissipated - energy.input_work = {:.6e} J has drifted from {:.6e} J \
             by {:.2} % of the energy scale {:.6e} J (more than {} %): the integration is inaccurate; tighten \
             solver.rtol and solver.atol or, with rk4, shorten solver.max_step (warned once per run)",
            self.time,
            self.balance,
            self.reference,
            100.0 * self.drift,
            self.scale,
            100.0 * ENERGY_DRIFT_WARNING
        )
    }
}

/// Relative drift of the energy balance beyond which the run warns (once).
pub const ENERGY_DRIFT_WARNING: f64 = 0.01;

/// Relative drift of the energy balance beyond which the step is refused as a blow-up (no
/// physical run gets near it: the balance counts dissipation and the inputs' work).
pub const ENERGY_BLOW_UP: f64 = 10.0;

/// The energy balance is checked at a communication point when at least this many RHS
/// evaluations were made since the last check, per island when the scene runs as islands (a
/// check costs one evaluation of the whole scene, as many as there are islands of theirs: at
/// most 1 % more work).
const ENERGY_CHECK_EVALS: u64 = 100;

impl Simulation {
    /// The energy balance `energy.total + energy.dissipated − energy.input_work` at the
    /// current state.
    pub(super) fn balance(&mut self) -> Result<f64, SimError> {
        Ok(self.energies()?.balance())
    }

    /// The energy watch (in the data: saved with the state; unstarted before initialisation).
    pub(super) fn watch(&self) -> EnergyWatch {
        match (&self.compiled, self.initialized) {
            (Some(c), true) => c.data.energy_watch,
            _ => EnergyWatch::default(),
        }
    }

    /// Starts watching the energy balance from the current state (at the first step after
    /// initialisation; a restored state carries the watch it was saved with).
    pub(super) fn start_watch(&mut self) -> Result<(), SimError> {
        let e = self.energies()?;
        let evals = self.counters().rhs_evals;
        self.running()?.data.energy_watch = EnergyWatch {
            started: true,
            reference: e.balance(),
            scale: e.total().abs().max(e.kinetic),
            checked_at: evals,
            warned: false,
        };
        Ok(())
    }

    /// At a communication point: when enough work was done since the last check, compares the
    /// energy balance with its reference and warns, once, when it drifted by more than
    /// [`ENERGY_DRIFT_WARNING`] of its scale.
    #[inline]
    pub(super) fn watch_energy(&mut self) -> Result<(), SimError> {
        let evals = self.counters().rhs_evals;
        let islands = self.compiled.as_ref().and_then(|c| c.islands.as_ref());
        let every = ENERGY_CHECK_EVALS.saturating_mul(islands.map_or(1, |is| is.parts.len().max(1)) as u64);
        // (checked on after the warning too: a drift beyond ENERGY_BLOW_UP stops the run)
        if evals < self.watch().checked_at.saturating_add(every) {
            return Ok(());
        }
        self.check_energy(evals)
    }

    /// [`Simulation::watch_energy`]'s check, after `evals` RHS evaluations.
    fn check_energy(&mut self, evals: u64) -> Result<(), SimError> {
        let e = self.energies()?;
        let time = self.time();
        let w = &mut self.running()?.data.energy_watch;
        w.checked_at = evals;
        w.scale = w.scale.max(e.kinetic);
        let balance = e.balance();
        let drift = (balance - w.reference).abs() / w.scale.max(f64::MIN_POSITIVE);
        if drift > ENERGY_DRIFT_WARNING && !w.warned {
            w.warned = true;
            // kept as numbers: a step allocates nothing; the text is made when it is taken
            self.drift = Some(Drift {
                time,
                balance,
                reference: w.reference,
                drift,
                scale: w.scale,
            });
        }
        if drift > ENERGY_BLOW_UP {
            let w = self.watch();
            let what = format!(
                "the energy balance drifted by {:.0} times its scale {:.6e} J",
                drift, w.scale
            );
            let c = self.running()?;
            let message = engine::blow_up(&c.model, time, &what);
            return Err(SimError::Step { time, message });
        }
        Ok(())
    }

    /// True when the energy balance drifted beyond [`ENERGY_DRIFT_WARNING`] in this run (the
    /// warning was given, or is waiting in [`Simulation::take_warnings`]).
    pub fn energy_drifted(&self) -> bool {
        self.watch().warned
    }

    /// The warnings of the run since the last call (the energy-balance drift), oldest first.
    pub fn take_warnings(&mut self) -> Vec<String> {
        self.drift.take().map(|d| d.to_string()).into_iter().collect()
    }
}
