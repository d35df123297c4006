//! What the data counts and logs: the work counters since initialisation and the watch of the
//! energy balance (both saved with the state), and the located contact events (a diagnostic
//! log, not saved).

/// Work counters since initialisation.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Accepted steps.
    pub steps: u64,
    /// Rejected steps.
    pub rejected: u64,
    /// Right-hand-side evaluations.
    pub rhs_evals: u64,
    /// Jacobian evaluations (implicit methods).
    pub jac_evals: u64,
    /// Events located: the instants the integration stopped (touch, separation, impact,
    /// rest, release, a damping force cut at zero or its end, stick, slip).
    pub events: u64,
}

impl std::ops::Add for Counters {
    type Output = Counters;

    /// The counters of two runs together (islands).
    fn add(self, b: Counters) -> Counters {
        Counters {
            steps: self.steps + b.steps,
            rejected: self.rejected + b.rejected,
            rhs_evals: self.rhs_evals + b.rhs_evals,
            jac_evals: self.jac_evals + b.jac_evals,
            events: self.events + b.events,
        }
    }
}

/// The watch of the energy balance `energy.total + energy.dissipated − energy.input_work` at
/// communication points (kept by the facade, `simulation/energy.rs`): its value at the first
/// step, relative to the larger of `|energy.total|` there and the largest kinetic energy seen
/// (the scale of the command line's energy error). Saved with the state
/// ([`super::state::StatePart::EnergyWatch`]), so that a restored run checks, warns and refuses
/// a blow-up where the uninterrupted one does.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EnergyWatch {
    /// The reference was taken.
    pub started: bool,
    /// The balance at the start \[J\].
    pub reference: f64,
    /// The scale of the relative drift \[J\].
    pub scale: f64,
    /// RHS evaluations (since initialisation) at the last check.
    pub checked_at: u64,
    /// The warning was given (once per run).
    pub warned: bool,
}

/// What happened at a contact event (see [`ContactEvent`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactEventKind {
    /// A continuous-law contact starts (δ becomes positive inside the patch).
    Touch,
    /// A continuous-law contact ends (δ returns to zero or the sphere leaves the patch).
    Separation,
    /// An impulse-law impact (a velocity jump); `delta_dot` is the approach rate before it.
    Impact,
    /// An impulse-law contact comes to rest (resting constraint on).
    Rest,
    /// A resting contact lets go (its normal force would pull, or the sphere left the patch).
    Release,
    /// The damping term cuts the force at zero before δ does (the law would pull).
    Clamp,
    /// The cut ends (the law's force is positive again).
    Unclamp,
    /// Largest penetration of a continuous-law contact (δ̇ = 0), located on the dense output
    /// without interrupting the integration.
    Peak,
    /// The slip speed of a contact with friction falls below the stiction velocity (the
    /// friction force leaves its Coulomb value: sticking, rolling).
    Stick,
    /// The slip speed rises above the stiction velocity (sliding at the Coulomb value).
    Slip,
}

impl ContactEventKind {
    /// True for the kinds that change a contact's mode: touch, separation, impact, rest,
    /// release.
    pub fn changes_mode(self) -> bool {
        use ContactEventKind::*;
        matches!(self, Touch | Separation | Impact | Rest | Release)
    }
}

/// One located contact event, with the contact's state at that instant. A diagnostic log
/// ([`Data::event_log`](super::Data::event_log)); not part of the saved state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactEvent {
    /// Time \[s\].
    pub time: f64,
    /// Contact index (scene order).
    pub contact: usize,
    /// What happened.
    pub kind: ContactEventKind,
    /// Penetration δ \[m\] (signed).
    pub delta: f64,
    /// Penetration rate δ̇ \[m/s\] (for an impact: before it).
    pub delta_dot: f64,
    /// Normal force \[N\] (continuous laws; resting contacts: the constraint force); for an
    /// impact, the normal impulse \[N s\].
    pub force: f64,
}

/// Oldest entries are dropped beyond this many logged contact events.
pub const EVENT_LOG_CAPACITY: usize = 4096;
