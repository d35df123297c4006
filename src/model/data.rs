//! [`Data`]: everything about a simulation that changes — the state, the integrator with its
//! memory, and every work buffer — sized once at compilation so that a step allocates
//! nothing. The part that defines the future (what a saved state holds) is declared in
//! [`super::state`]; the rest is workspace, recomputed from it.

use super::compiled::Model;
use super::log::{ContactEvent, ContactEventKind, Counters, EnergyWatch, EVENT_LOG_CAPACITY};
use crate::integrator::second_order::SecondOrder;
use crate::integrator::{self, Integrator, Stats};
use crate::model::contact::{ContactElement, ContactMemory, ContactOutput};
use crate::model::groups::Candidate;
use crate::model::island_state::IslandsState;
use crate::model::partition::Partition;
use crate::model::work::{emptied, filled, ImpulseWork};
use crate::scene::{Law, SolverSection};
use crate::spatial::{Inertia, Spatial};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// The integrator with the buffer a restart starts from. While it steps it is taken out of
/// the [`Data`] (so that the right-hand side can borrow the data) and put back after.
pub struct Stepper {
    /// The method with its memory.
    pub method: Box<dyn Integrator + Send>,
    /// The state a restart starts from (a copy of `Data::state`).
    pub start: Vec<f64>,
}

/// Makes used integrators fresh again in place, without allocating ([`Data::refit`],
/// [`Integrator::renew`]), with a buffer for the second-order structure handed to them.
#[derive(Default)]
pub struct FreshIntegrators {
    second_order: SecondOrder,
}

impl FreshIntegrators {
    /// `method` made the integrator [`integrator::create`]`(solver, n)` gives, in place
    /// ([`Integrator::renew`]: it goes on exactly as a new one). None (and `method` dropped) when
    /// it cannot be: another method, size or settings, or an implicit method. Its
    /// second-order structure is set by the caller, as after creation.
    pub fn renew(
        &mut self,
        mut method: Box<dyn Integrator + Send>,
        solver: &SolverSection,
        n: usize,
    ) -> Option<Box<dyn Integrator + Send>> {
        method.renew(solver, n).then_some(method)
    }

    /// The model's second-order structure ([`Model::second_order_into`]), in the buffer held.
    fn second_order(&mut self, model: &Model) -> &SecondOrder {
        model.second_order_into(&mut self.second_order);
        &self.second_order
    }
}

impl std::fmt::Debug for Stepper {
    /// The method by its saved state, warm memory and counters (what defines its future and
    /// its reports), and the restart buffer.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (mut saved, mut warm) = (Vec::new(), Vec::new());
        self.method.save_state(&mut saved);
        self.method.warm_state(&mut warm);
        f.debug_struct("Stepper")
            .field("method", &saved)
            .field("warm", &warm)
            .field("stats", &self.method.stats())
            .field("start", &self.start)
            .finish()
    }
}

/// The integrator and what the driver keeps about it.
#[derive(Debug)]
pub struct Solver {
    /// The integrator; `None` only while it steps, or if a panic interrupted a step (the next
    /// advance then reports an error).
    pub stepper: Option<Stepper>,
    /// True when the method's last step `[t_prev, t]` contains the current time: the next
    /// advance continues it (no restart). Its end may lie ahead of `Data::time`: the state
    /// at a communication point inside a step comes from the dense output.
    pub started: bool,
    /// The earliest located event inside the method's last step after `Data::time`
    /// (infinite: none). Handled once the simulation reaches it.
    pub pending_event: f64,
    /// Step size to try at the next restart when the method has not run since a restore.
    pub next_h: f64,
    /// The method's counters at initialisation (the reported counters are since then).
    pub base: Stats,
}

impl Solver {
    /// True when the method's last step reaches past `time` (a continuation is pending).
    pub fn ahead_of(&self, time: f64) -> bool {
        self.started && self.method().is_some_and(|m| m.t() > time)
    }

    /// The method, unless it was lost to an internal error.
    pub fn method(&self) -> Option<&(dyn Integrator + Send)> {
        self.stepper.as_ref().map(|s| &*s.method)
    }

    /// The step size the next restart will try.
    pub fn pending_step(&self) -> f64 {
        match (self.method(), self.started) {
            (Some(m), true) => m.next_step(),
            _ => self.next_h,
        }
    }
}

/// Event functions at the current state and at the end of the step being checked.
#[derive(Debug, Clone, Default)]
pub struct EventWork {
    /// Event functions at the current state: per contact its mode function (touch /
    /// separation / release), then per contact its clamp function (the force law's sign).
    pub g: Vec<f64>,
    /// The same at the end of the step being checked.
    pub g_new: Vec<f64>,
    /// Per contact (δ, δ̇) at the current state (when the broad phase skipped the exact
    /// detection: minus the clearance of the bounding spheres and the rate at which it closes).
    pub aux: Vec<(f64, f64)>,
    /// The same at the end of the step being checked.
    pub aux_new: Vec<(f64, f64)>,
    /// The continuous contacts whose mode the last event's handling changed (touch,
    /// separation), in the order it changed them (capacity: the number of contacts).
    pub changed: Vec<usize>,
    /// Per contact (δ, δ̇, margin) of the exact gap at the last evaluation of the contact
    /// forces, written for the active continuous contacts (those whose forces it computes):
    /// while `Data::planned_kinematics` holds, those of the right-hand side's evaluation at
    /// `eval_state`, which the event values at a step's end take instead of detecting again.
    pub stage_gaps: Vec<(f64, f64, f64)>,
    /// The contact groups' entry of `aux_new` is not yet that of the present reference poses:
    /// they changed while the method's last step reached past the data's time, and the entry
    /// is evaluated at the step's end when the step is accepted
    /// ([`crate::engine::resync_margins`]); whatever writes the entry clears it.
    pub margin_pending: bool,
}

/// Preallocated buffers of the impulse law's mode changes, sized at compilation by the
/// number of impulse-law contacts: resolving impacts and settling resting contacts allocate
/// nothing.
#[derive(Debug, Clone, Default)]
pub struct ImpactWork {
    /// Work arrays of the impulse solve.
    pub solve: ImpulseWork,
    /// Contacts of the current round of impacts.
    pub set: Vec<usize>,
    /// Their restitution.
    pub restitution: Vec<f64>,
    /// Their (δ, δ̇) before the round.
    pub approach: Vec<(f64, f64)>,
    /// Per contact: active before the resting set was rebuilt.
    pub was: Vec<bool>,
    /// Resting candidates.
    pub candidates: Vec<usize>,
}

/// Mutable simulation data: the state, the integrator, contact memory, work buffers and
/// counters. Sized at compilation; nothing here is allocated during a step. (Its debug form
/// prints every number so that it reads back exactly, the integrator by its saved state.)
#[derive(Debug)]
pub struct Data {
    // --- the state (see `state::StatePart`) ---
    /// Time \[s\]: the one clock of the simulation.
    pub time: f64,
    /// State: `[qpos (nq), qvel (nv), dissipated energy]`.
    pub state: Vec<f64>,
    /// Input values.
    pub inputs: Vec<f64>,
    /// Contact memory: active flags, δ̇⁻, impact counts.
    pub contact_memory: Vec<ContactMemory>,
    /// Counters.
    pub counters: Counters,
    /// The facade's watch of the energy balance (its reference, scale and checks): saved with
    /// the state, so that a restored run warns and refuses where the uninterrupted one does.
    pub energy_watch: EnergyWatch,
    /// The integrator with its memory.
    pub solver: Solver,
    /// The islands' own state, gathered when a scene that runs as islands saves its state,
    /// read when it restores one (empty otherwise: the islands hold it in their own data).
    pub islands: IslandsState,
    // --- the contact list (the model's at compilation; the broad phase's stage makes it anew) ---
    /// Contact elements: the declared contacts, then one per candidate pair of the contact
    /// groups.
    pub contacts: Vec<ContactElement>,
    /// The candidate pairs behind `contacts[m.groups.n_explicit..]`, in their order.
    pub candidates: Vec<Candidate>,
    /// The islands' partition of the bodies and of the broad phase's candidate pairs (of the
    /// islands last formed; empty for one integrator).
    pub partition: Partition,
    /// Per contact, `solver.rtol` to its [`ContactElement::touch_power`] and
    /// [`ContactElement::separation_power`] (see [`crate::model::step_rtol_powers`]).
    pub step_rtol_powers: Vec<[f64; 2]>,
    /// Total constraint rows: the model's fixed rows, then one row per impulse-law contact
    /// (its resting mode; zero while the contact does not rest).
    pub nc: usize,
    // --- options ---
    /// Locate the instants a damped law's force is cut at zero (and restart there).
    pub clamp_events: bool,
    /// Log the largest penetration of each continuous contact (a diagnostic: it costs event
    /// location work and changes no result).
    pub log_peaks: bool,
    /// The most steps one advance may take, in place of the model's `solver.max_steps`
    /// (`None`: the model's). The islands set it before every advance: the steps left of
    /// their budget, while their models, shared by islands alike, stay as compiled.
    pub max_steps: Option<u64>,
    // --- diagnostics ---
    /// Located contact events, oldest first (at most [`EVENT_LOG_CAPACITY`]).
    pub event_log: Vec<ContactEvent>,
    // --- workspace ---
    /// The state at which the kinematics and dynamics below were evaluated.
    pub eval_state: Vec<f64>,
    /// True when the kinematics below are the plan's at `eval_state` and the contact forces
    /// were evaluated on them (set by the right-hand side's lean path; cleared by every other
    /// kinematics: the full one, the plan's alone, a probe's of two bodies, and by a new
    /// contact list): the event check at a step's end then takes them, and the active
    /// contacts' gaps (`EventWork::stage_gaps`), as they are.
    pub planned_kinematics: bool,
    /// True when `state` awaits the method's dense output at `time` (a communication point
    /// inside the method's step whose state nothing has read yet: `engine::settle` takes it;
    /// the facade reads a batch of free bodies' positions and velocities from the dense output
    /// directly).
    pub dense_pending: bool,
    /// True when the workspace (outputs) was evaluated at `state`.
    pub outputs_valid: bool,
    /// True when the bodies' kinematics (positions, orientations, velocities) were evaluated
    /// at `state` (implied by `outputs_valid`; cleared with it).
    pub kinematics_valid: bool,
    /// Event location.
    pub events: EventWork,
    /// Impulse-law mode changes.
    pub impacts: ImpactWork,
    // --- kinematics (per body, scene order) ---
    /// Centre-of-mass positions \[m\].
    pub body_pos: Vec<Vector3<f64>>,
    /// Rotation matrices body → world.
    pub body_rot: Vec<Matrix3<f64>>,
    /// Orientation quaternions.
    pub body_quat: Vec<UnitQuaternion<f64>>,
    /// Spatial velocities.
    pub body_vel: Vec<Spatial>,
    /// Spatial accelerations with q̈ = 0 (velocity-product terms).
    pub body_acc_bias: Vec<Spatial>,
    /// Spatial inertia about the origin.
    pub body_inertia: Vec<Inertia>,
    /// External forces on each body (gravity, springs, contacts, inputs).
    pub body_force: Vec<Spatial>,
    /// Motion subspace column of each degree of freedom.
    pub dof_s: Vec<Spatial>,
    /// Its time derivative.
    pub dof_sdot: Vec<Spatial>,
    /// Tree joints on one body's path to the ground (capacity: all joints), for
    /// [`crate::kinematics::kinematics_path`].
    pub path_joints: Vec<usize>,
    // --- dynamics ---
    /// Composite inertias (work).
    pub composite: Vec<Inertia>,
    /// Back-propagated forces (work).
    pub body_wrench: Vec<Spatial>,
    /// Packed mass-matrix blocks; factorised in place.
    pub mass_blocks: Vec<f64>,
    /// Generalised forces minus bias: right-hand side, then q̈.
    pub qacc: Vec<f64>,
    /// Generalised applied forces (joint inputs).
    pub tau: Vec<f64>,
    /// Constraint values Φ.
    pub phi: Vec<f64>,
    /// Constraint rates Φ_q q̇.
    pub phi_dot: Vec<f64>,
    /// Constraint Jacobian, row-major nc × nv.
    pub phi_q: Vec<f64>,
    /// γ (with stabilisation).
    pub gamma: Vec<f64>,
    /// M̄⁻¹ Φ_qᵀ, column-major nv × nc (work).
    pub minv_phit: Vec<f64>,
    /// Φ_q M̄⁻¹ Φ_qᵀ (work), nc × nc.
    pub schur: Vec<f64>,
    /// Pivot order of the Schur factorisation.
    pub schur_perm: Vec<usize>,
    /// Rank of the Schur complement (independent constraint rows).
    pub schur_rank: usize,
    /// Lagrange multipliers.
    pub lambda: Vec<f64>,
    /// Work vector of size max(nv, nc).
    pub work: Vec<f64>,
    /// Work vector of size nv.
    pub work2: Vec<f64>,
    /// Friction of resting impulse-law contacts: the generalised friction force applied so
    /// far (nv), the next correction (nv) and its change of the multipliers (nc); empty
    /// without impulse-law contacts.
    pub friction_applied: Vec<f64>,
    pub friction_step: Vec<f64>,
    pub friction_dlambda: Vec<f64>,
    /// Dissipated power at the last RHS evaluation \[W\].
    pub dissipation: f64,
    /// The power of the inputs on the system at the last evaluation \[W\] (forces, torques,
    /// joint forces, drives): the rate of the input-work state.
    pub input_power: f64,
    /// Per-contact outputs of the last evaluation.
    pub contact_out: Vec<ContactOutput>,
    /// The contacts whose forces the right-hand side computes (the active continuous ones),
    /// listed by the engine for one integrator step (`contact::list_force_contacts`);
    /// capacity: the number of contacts.
    pub force_contacts: Vec<usize>,
    /// True while `force_contacts` holds the list for the present modes (during an
    /// integrator step, when no impulse-law contact rests): the right-hand side's lean path
    /// then reads it.
    pub force_contacts_listed: bool,
    /// Contact groups: per body, the pose (centre of mass, orientation) where the candidate
    /// pairs were found.
    pub broad_reference: Vec<(Vector3<f64>, UnitQuaternion<f64>)>,
    /// Contact groups: per body the total contact force and torque of the last output
    /// evaluation (world frame; torque about the centre of mass).
    pub body_contact: Vec<[f64; 6]>,
    /// Contact groups: per group pair, contacts in contact and their largest penetration.
    pub group_out: Vec<(f64, f64)>,
}

impl Data {
    /// Allocates every buffer for `model`, creates its integrator and sets the initial
    /// positions (velocities zero; [`crate::compile`] sets them).
    pub fn new(model: &Model) -> Data {
        Data::with_event_log(model, EVENT_LOG_CAPACITY)
    }

    /// [`Data::new`] with room for `log_capacity` contact events reserved (an island's data
    /// holds the events of one advance: a full log's buffer would cost more than the island).
    pub fn with_event_log(model: &Model, log_capacity: usize) -> Data {
        let mut data = Data::empty();
        data.refit(model, log_capacity, &mut FreshIntegrators::default());
        data
    }

    /// A data of no buffers and no integrator, for [`Data::refit`].
    fn empty() -> Data {
        Data {
            time: 0.0,
            state: Vec::new(),
            inputs: Vec::new(),
            contact_memory: Vec::new(),
            contacts: Vec::new(),
            candidates: Vec::new(),
            step_rtol_powers: Vec::new(),
            nc: 0,
            counters: Counters::default(),
            energy_watch: EnergyWatch::default(),
            solver: Solver {
                stepper: None,
                started: false,
                pending_event: f64::INFINITY,
                next_h: 0.0,
                base: Stats::default(),
            },
            islands: IslandsState::default(),
            partition: Partition::default(),
            clamp_events: true,
            log_peaks: false,
            max_steps: None,
            event_log: Vec::new(),
            eval_state: Vec::new(),
            planned_kinematics: false,
            dense_pending: false,
            outputs_valid: false,
            kinematics_valid: false,
            events: EventWork::default(),
            impacts: ImpactWork::default(),
            body_pos: Vec::new(),
            body_rot: Vec::new(),
            body_quat: Vec::new(),
            body_vel: Vec::new(),
            body_acc_bias: Vec::new(),
            body_inertia: Vec::new(),
            body_force: Vec::new(),
            dof_s: Vec::new(),
            dof_sdot: Vec::new(),
            path_joints: Vec::new(),
            composite: Vec::new(),
            body_wrench: Vec::new(),
            mass_blocks: Vec::new(),
            qacc: Vec::new(),
            tau: Vec::new(),
            phi: Vec::new(),
            phi_dot: Vec::new(),
            phi_q: Vec::new(),
            gamma: Vec::new(),
            minv_phit: Vec::new(),
            schur: Vec::new(),
            schur_perm: Vec::new(),
            schur_rank: 0,
            lambda: Vec::new(),
            work: Vec::new(),
            work2: Vec::new(),
            friction_applied: Vec::new(),
            friction_step: Vec::new(),
            friction_dlambda: Vec::new(),
            dissipation: 0.0,
            input_power: 0.0,
            contact_out: Vec::new(),
            force_contacts: Vec::new(),
            force_contacts_listed: false,
            broad_reference: Vec::new(),
            body_contact: Vec::new(),
            group_out: Vec::new(),
        }
    }

    /// Makes this data what [`Data::with_event_log`]`(model, log_capacity)` gives, keeping its
    /// buffers (they allocate only where they are too small): the data of an island that
    /// ended, made the data of a new one. Every field is set (the destructuring below names
    /// them all); the integrator is made fresh in place where `fresh` can
    /// ([`FreshIntegrators::renew`]), else created anew.
    pub fn refit(&mut self, model: &Model, log_capacity: usize, fresh: &mut FreshIntegrators) {
        let nb = model.bodies.len();
        let (nv, n) = (model.nv, model.nstate());
        let ncontacts = model.initial_contacts.len();
        let mass_len = model.trees.iter().map(|&(_, k)| k * k).sum();
        let Data {
            time,
            state,
            inputs,
            contact_memory,
            contacts,
            candidates,
            step_rtol_powers,
            nc: rows,
            counters,
            energy_watch,
            solver,
            islands,
            partition,
            clamp_events,
            log_peaks,
            max_steps,
            event_log,
            eval_state,
            planned_kinematics,
            dense_pending,
            outputs_valid,
            kinematics_valid,
            events: _,
            impacts: _,
            body_pos,
            body_rot,
            body_quat,
            body_vel,
            body_acc_bias,
            body_inertia,
            body_force,
            dof_s,
            dof_sdot,
            path_joints,
            composite,
            body_wrench,
            mass_blocks,
            qacc,
            tau,
            phi: _,
            phi_dot: _,
            phi_q: _,
            gamma: _,
            minv_phit: _,
            schur: _,
            schur_perm: _,
            schur_rank: _,
            lambda: _,
            work: _,
            work2,
            friction_applied: _,
            friction_step: _,
            friction_dlambda: _,
            dissipation,
            input_power,
            contact_out: _,
            force_contacts: _,
            force_contacts_listed: _,
            broad_reference,
            body_contact,
            group_out,
        } = self;
        *time = 0.0;
        filled(state, n, 0.0);
        for j in &model.joints {
            state[j.qpos..j.qpos + j.nq()].copy_from_slice(&j.q0[..j.nq()]);
        }
        eval_state.clear();
        eval_state.extend_from_slice(state);
        *planned_kinematics = false;
        inputs.clear();
        inputs.extend_from_slice(&model.input_start);
        filled(contact_memory, ncontacts, ContactMemory::default());
        take_contact_list(model, contacts, candidates, step_rtol_powers, rows);
        *counters = Counters::default();
        *energy_watch = EnergyWatch::default();
        islands.clear();
        partition.clear();
        let (method, mut start) = match solver.stepper.take() {
            Some(s) => (fresh.renew(s.method, &model.solver, n), s.start),
            None => (None, Vec::new()),
        };
        let mut method = method.unwrap_or_else(|| integrator::create(&model.solver, n));
        method.use_second_order(fresh.second_order(model));
        filled(&mut start, n, 0.0);
        *solver = Solver {
            stepper: Some(Stepper { method, start }),
            started: false,
            pending_event: f64::INFINITY,
            next_h: 0.0,
            base: Stats::default(),
        };
        *clamp_events = true;
        *log_peaks = false;
        *max_steps = None;
        emptied(event_log, if ncontacts > 0 { log_capacity } else { 0 });
        *dense_pending = false;
        *outputs_valid = false;
        *kinematics_valid = false;
        filled(body_pos, nb, Vector3::zeros());
        filled(body_rot, nb, Matrix3::identity());
        filled(body_quat, nb, UnitQuaternion::identity());
        filled(body_vel, nb, Spatial::zero());
        filled(body_acc_bias, nb, Spatial::zero());
        filled(body_inertia, nb, Inertia::zero());
        filled(body_force, nb, Spatial::zero());
        filled(dof_s, nv, Spatial::zero());
        filled(dof_sdot, nv, Spatial::zero());
        emptied(path_joints, model.joints.len());
        filled(composite, nb, Inertia::zero());
        filled(body_wrench, nb, Spatial::zero());
        filled(mass_blocks, mass_len, 0.0);
        for fb in &model.plan.free {
            model.write_free_block(fb, mass_blocks);
        }
        // the rotors' constant rows of the factor, never assembled (`Plan::leaves`)
        for (t, leaves) in model.plan.leaves.iter().enumerate() {
            let (off, n) = (model.tree_block[t], model.trees[t].1);
            leaves.write(&mut mass_blocks[off..off + n * n], n);
        }
        filled(qacc, nv, 0.0);
        filled(tau, nv, 0.0);
        filled(work2, nv, 0.0);
        *dissipation = 0.0;
        *input_power = 0.0;
        filled(broad_reference, nb, (Vector3::zeros(), UnitQuaternion::identity()));
        filled(body_contact, if model.groups.is_active() { nb } else { 0 }, [0.0; 6]);
        filled(group_out, model.groups.pair_names.len(), (0.0, 0.0));
        // (the fields bound to `_` above: the work of the contact list)
        self.fit_contact_work(model);
    }

    /// Sizes the work buffers that depend on the contact list (`contacts`, `nc`) and zeroes
    /// them: event values, impact work, the constraint rows' arrays, the resting friction's
    /// work, contact outputs.
    pub fn fit_contact_work(&mut self, model: &Model) {
        let (nv, nc, ncontacts) = (model.nv, self.nc, self.contacts.len());
        let impulse_contacts = self.contacts.iter().filter(|c| c.law == Law::Impulse).count();
        let EventWork {
            g,
            g_new,
            aux,
            aux_new,
            changed,
            stage_gaps,
            margin_pending,
        } = &mut self.events;
        filled(g, 3 * ncontacts, 0.0);
        filled(g_new, 3 * ncontacts, 0.0);
        filled(aux, ncontacts + 1, (0.0, 0.0));
        filled(aux_new, ncontacts + 1, (0.0, 0.0));
        emptied(changed, ncontacts);
        filled(stage_gaps, ncontacts, (0.0, 0.0, 0.0));
        *margin_pending = false;
        let ImpactWork {
            solve,
            set,
            restitution,
            approach,
            was,
            candidates,
        } = &mut self.impacts;
        solve.refit(nv, model.fixed_rows(), impulse_contacts);
        emptied(set, impulse_contacts);
        emptied(restitution, impulse_contacts);
        emptied(approach, impulse_contacts);
        emptied(was, ncontacts);
        emptied(candidates, impulse_contacts);
        filled(&mut self.phi, nc, 0.0);
        filled(&mut self.phi_dot, nc, 0.0);
        filled(&mut self.phi_q, nc * nv, 0.0);
        filled(&mut self.gamma, nc, 0.0);
        filled(&mut self.minv_phit, nc * nv, 0.0);
        filled(&mut self.schur, nc * nc, 0.0);
        filled(&mut self.schur_perm, nc, 0);
        self.schur_rank = 0;
        filled(&mut self.lambda, nc, 0.0);
        filled(&mut self.work, nv.max(nc), 0.0);
        // (the resting friction's work: only impulse-law contacts rest)
        let friction_nv = if impulse_contacts > 0 { nv } else { 0 };
        filled(&mut self.friction_applied, friction_nv, 0.0);
        filled(&mut self.friction_step, friction_nv, 0.0);
        filled(&mut self.friction_dlambda, nc, 0.0);
        filled(&mut self.contact_out, ncontacts, ContactOutput::default());
        emptied(&mut self.force_contacts, ncontacts);
        self.force_contacts_listed = false;
    }

    /// Takes the model's contact list (its contact elements, candidate pairs, step powers and
    /// constraint rows), as after a change of its law constants.
    pub fn take_contacts(&mut self, model: &Model) {
        let Data {
            contacts,
            candidates,
            step_rtol_powers,
            nc,
            ..
        } = self;
        take_contact_list(model, contacts, candidates, step_rtol_powers, nc);
    }

    /// Appends a contact event at the current time to the log (the oldest half is dropped
    /// when it is full).
    pub fn log_event(&mut self, contact: usize, kind: ContactEventKind, delta: f64, delta_dot: f64, force: f64) {
        self.log_event_at(self.time, contact, kind, delta, delta_dot, force);
    }

    /// [`Data::log_event`] at time `time`.
    pub fn log_event_at(
        &mut self,
        time: f64,
        contact: usize,
        kind: ContactEventKind,
        delta: f64,
        delta_dot: f64,
        force: f64,
    ) {
        if self.event_log.len() >= EVENT_LOG_CAPACITY {
            self.event_log.drain(..EVENT_LOG_CAPACITY / 2);
        }
        self.event_log.push(ContactEvent {
            time,
            contact,
            kind,
            delta,
            delta_dot,
            force,
        });
    }
}

/// [`Data::take_contacts`] on the data's fields.
fn take_contact_list(
    model: &Model,
    contacts: &mut Vec<ContactElement>,
    candidates: &mut Vec<Candidate>,
    step_rtol_powers: &mut Vec<[f64; 2]>,
    nc: &mut usize,
) {
    contacts.clone_from(&model.initial_contacts);
    candidates.clone_from(&model.groups.initial_candidates);
    crate::model::step_rtol_powers(contacts, model.solver.rtol, step_rtol_powers);
    *nc = model.fixed_rows() + contacts.iter().filter(|c| c.law == Law::Impulse).count();
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compile::compile;
    use crate::scene::Scene;

    /// The compiled model of a bundled scene and its data run to `t` (events, impacts and
    /// counters in it).
    fn run(name: &str, t: f64) -> (Model, Data) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("fmu/{name}/scene.toml"));
        let scene = Scene::from_file(&path).unwrap();
        let (m, mut d) = compile(&scene, name).unwrap();
        crate::engine::advance(&m, &mut d, t).unwrap();
        (m, d)
    }

    /// A used data refitted to a model equals the data made for it, field by field (their
    /// debug forms, every number read back exactly, the integrator by its saved state): to the
    /// same model (its integrator made fresh in place) and to others (a new integrator), from
    /// scenes with contacts (a ball bouncing, a pile of balls) and joints and loops (the
    /// slider-crank, the rail vehicle).
    #[test]
    fn refitted_data_equals_new_data() {
        let names = ["bouncing_ball", "pile_of_balls", "slider_crank", "rail_vehicle"];
        let runs: Vec<(Model, Data)> = names.iter().map(|n| run(n, 0.3)).collect();
        let mut fresh = FreshIntegrators::default();
        for (a, (_, used)) in names.iter().zip(&runs) {
            assert!(used.counters.steps > 0, "{a} ran");
            for (b, (m, _)) in names.iter().zip(&runs) {
                let mut d = run(a, 0.3).1;
                d.refit(m, 0, &mut fresh);
                assert_eq!(
                    format!("{d:?}"),
                    format!("{:?}", Data::with_event_log(m, 0)),
                    "{a} refitted to {b}"
                );
            }
        }
        // a used integrator of the same model was renewed, not created: its buffers stay
        let (m, mut d) = run("bouncing_ball", 0.3);
        let y = d.solver.method().unwrap().y().as_ptr();
        d.refit(&m, 0, &mut fresh);
        assert_eq!(d.solver.method().unwrap().y().as_ptr(), y);
    }
}
