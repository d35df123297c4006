//! Independent islands: the bodies coupled through joints, spring-dampers, joint-force inputs
//! and contacts that can act (the declared contacts, and the contact groups' candidate pairs)
//! form islands. Each island has a model cut from the scene's compiled model (`cut_model.rs`;
//! the islands read nothing else of the scene, and islands of alike bodies share one), with
//! its own integrator, step-size control and located events, so that an impact in one corner
//! of a scene does not restart the integration of the rest.
//!
//! The islands advance in *rounds* and meet at each round's end, where the contact groups'
//! candidate pairs may be found again (they also meet at the communication points, and go on
//! across them: the rounds, like the steps, do not depend on the communication step):
//!
//! 1. the round's length: without contact groups, unbounded; with them, the time in
//!    which no body's shapes can move [`ROUND_FRACTION`] of the broad-phase margin at its
//!    present speed under gravity. A collision can speed a body up: an island then stops by itself once one
//!    of its bodies moved [`ISLAND_STALE_FRACTION`] of the margin, and the islands that went
//!    further are taken back to its time from the state saved at the round's start;
//! 2. every island advances to the round's end (or the communication point before it) with
//!    the engine's `advance` (continuing its last step: meeting costs an interpolation, not a
//!    restart); the state saved for taking islands back is the one at the last meeting;
//! 3. the coordinates are gathered into the scene's data; once a body moved an eighth of the
//!    margin, the candidate pairs are found again for the whole scene and the islands formed
//!    again: an island whose bodies and candidate pairs did not change keeps its integrator,
//!    the others are formed anew with their contacts' memory carried over, their model
//!    cut from the scene's or taken from the pool (`pool.rs`).
//!
//! Two islands stay apart within a round: a pair of shapes left out of the candidate list was
//! farther apart than the margin, and neither body moves half of it before the list is made
//! again (the same bound as for one integrator, see [`crate::contact::broad`]).
//!
//! The scene's own model and data (held by [`crate::simulation`]) receive the gathered state
//! at the communication points ([`Islands::gather`]): every output, energy and saved state
//! reads them as before. A saved state holds what the islands hold beyond the scene's state
//! (their integrators, counters, energies and partition: the state's islands part, gathered by
//! [`Islands::record`]), so a restored simulation continues bit for bit.

use crate::compile::Parameters;
use crate::contact::elements::set_candidates;
use crate::contact::groups;
use crate::engine::{self, EngineError};
use crate::integrator::ExplicitHold;
use crate::kinematics::poses_and_velocities_at_state;
use crate::model::data::FreshIntegrators;
use crate::model::groups::Candidate;
use crate::model::partition::Partition;
use crate::model::{ContactEvent, Counters, Data, Model};
use crate::scene::Num;
#[cfg(test)]
use crate::scene::Scene;
use rustc_hash::FxHashMap as HashMap;
use std::sync::{Arc, Mutex, PoisonError};

mod carry;
mod cut;
mod cut_model;
mod gather;
mod island;
mod part;
mod pool;
mod saved;
#[cfg(test)]
mod tests;

use carry::{memory_of_scene, Memory};
pub use cut::{partition, wanted};
use cut_model::ModelCutter;
pub use island::Island;
use part::Compiled;
use pool::Pool;

/// The fraction of the broad-phase margin after which an island stops inside a round (more
/// than the round is planned for: it only stops when a collision sped a body up; less than
/// the half that bounds every step).
pub const ISLAND_STALE_FRACTION: f64 = 0.45;

/// The fraction of the margin the bodies may have moved at a round's end before the
/// candidate pairs are found again.
const REBUILD_FRACTION: f64 = 0.125;

/// The fraction of the margin a round is planned for (0.25 and 0.35 measured: 0.35 takes 25 %
/// fewer rounds at the same steps).
pub const ROUND_FRACTION: f64 = 0.35;

/// The pool of compiled parts holds up to this many per body of the scene (then it starts
/// empty again).
const POOL_PER_BODY: usize = 4;

/// The data of up to this many islands that ended are kept for new islands (more end at one
/// forming only where as many are formed; 4,096 instead of 256 made 2,696 new data at
/// N = 1,000 instead of 3,152, forming 8.93 % of the instructions instead of 9.38 %). A kept
/// data holds no implicit method's workspace.
const SPARE_DATA: usize = 4096;

fn fail(time: f64, message: impl Into<String>) -> EngineError {
    EngineError {
        time,
        message: message.into(),
        step_limit: false,
    }
}

/// The islands of a scene, and what they do not hold.
pub struct Islands {
    /// The islands, ordered by their first body.
    pub parts: Vec<Box<Island>>,
    /// The counters of the scene before the islands, and of islands that no longer exist.
    retired: Counters,
    /// Dissipated energy not held by a present island \[J\].
    dissipated_base: f64,
    /// Input work not held by a present island \[J\].
    input_work_base: f64,
    /// Contact events of islands that ended since the last gathering (the scene's contact
    /// numbering of the candidate list then).
    retired_log: Vec<ContactEvent>,
    /// How often the candidate pairs were found again.
    pub rebuilds: u64,
    /// Islands formed anew (a diagnostic).
    pub compiled: u64,
    /// Of those, the islands whose model came from the pool (a diagnostic).
    pub pooled: u64,
    /// Rounds (a diagnostic).
    pub rounds: u64,
    /// Islands taken back to a round's start that had saved their time and coordinates alone
    /// (a diagnostic).
    pub light_takebacks: u64,

    /// The time of the islands \[s\].
    time: f64,
    /// The end of the present round \[s\] (infinite: none planned yet).
    round_end: f64,
    /// Per scene body: (first position, first velocity) index of its joint in the scene's state.
    joint_coords: Vec<(usize, usize)>,
    /// The scene's declared contacts (before the candidate pairs' contacts).
    n_explicit: usize,
    /// Cuts the islands' models from the scene's.
    cutter: ModelCutter,
    params: Arc<Parameters>,
    /// The compiled parts of islands that ended.
    pool: Pool,
    /// The data of islands that ended (with their buffers of the saved state), by the size of
    /// their state, for new islands' data (their buffers and integrators reused), how many it
    /// holds and may hold.
    spare: HashMap<usize, Vec<Spare>>,
    n_spare: usize,
    spare_limit: usize,
    /// Threads that advance the islands of a round side by side (`[solver] threads`, 0
    /// resolved to the machine's).
    threads: usize,
    /// Whether an island that only interpolates in a round saves its time and coordinates
    /// alone ([`Island::save_round_start`]; off: the whole state, for the tests).
    light_saves: bool,
    /// Of the islands formed anew, those whose data was an ended island's (a diagnostic).
    pub reused: u64,
    /// False once a forming failed: every island ended (their counters and energies kept),
    /// and the caller drops the islands, to form them anew from the scene's data.
    pub formed: bool,
    /// Makes the spare data's integrators fresh.
    fresh: FreshIntegrators,
}

/// An ended island's data and its buffer of the saved state, for a new island.
type Spare = (Box<Data>, Vec<f64>);

/// The scene and its origin: what the tests compile an island's part of the scene from (their
/// oracle for the cut models).
#[cfg(test)]
pub struct Source<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Its file (for errors).
    pub origin: &'a str,
}

/// What a new island is made of, as its partition lists it: its bodies (sorted), its
/// candidate pairs (in the list's order) and their indices in the list.
struct Members<'a> {
    bodies: &'a [usize],
    candidates: &'a [Candidate],
    listed: &'a [usize],
}

impl Islands {
    /// Forms the islands of the scene's model `m` (compiled with `params`) at its
    /// data `d` (its candidate pairs and contact memory as they are).
    pub fn new(params: Parameters, m: &Model, d: &mut Data) -> Result<Islands, EngineError> {
        let mut is = Islands::bare(params, m, d);
        is.form_from_scene(m, d)?;
        Ok(is)
    }

    /// Forms the islands of the scene's candidate pairs at its data `d`, with its contact
    /// memory (no islands before them).
    fn form_from_scene(&mut self, m: &Model, d: &mut Data) -> Result<(), EngineError> {
        let candidates = d.candidates.clone();
        let memory = memory_of_scene(m, d, &candidates);
        // (the memory is by the scene's list, which is the islands' list)
        let former: Vec<usize> = (0..candidates.len()).collect();
        self.form(m, d, &candidates, &former, &memory, Vec::new())
    }

    /// No islands yet, the rest from the scene's model and data.
    fn bare(params: Parameters, m: &Model, d: &Data) -> Islands {
        let mut joint_coords = vec![(0, 0); m.bodies.len()];
        for j in &m.joints {
            joint_coords[j.child] = (j.qpos, m.nq + j.qvel);
        }
        Islands {
            parts: Vec::new(),
            retired: d.counters,
            dissipated_base: d.state[m.dissipated_index()],
            input_work_base: m.input_work(&d.state),
            retired_log: Vec::new(),
            rebuilds: 0,
            compiled: 0,
            pooled: 0,
            rounds: 0,
            light_takebacks: 0,
            time: d.time,
            round_end: f64::INFINITY,
            joint_coords,
            n_explicit: m.groups.n_explicit,
            cutter: ModelCutter::new(m),
            params: Arc::new(params),
            pool: Pool::default(),
            spare: HashMap::default(),
            n_spare: 0,
            spare_limit: SPARE_DATA,
            light_saves: true,
            threads: side_by_side(m.solver.threads),
            reused: 0,
            formed: true,
            fresh: FreshIntegrators::default(),
        }
    }

    /// Forms the islands of the candidate pairs `candidates` at the scene's data `d` (its
    /// coordinates and reference poses), keeping those of `old` whose bodies and candidate
    /// pairs are unchanged (with their integrators) and compiling the others with the
    /// contact memory `memory` (by the former list, the partition's; `former` gives
    /// each pair's index in it, [`former_indices`]). Should an island fail to compile (its
    /// error is returned), the islands are left without parts, every island's counters and
    /// energies kept as those of islands that ended.
    // (the islands are boxed: forming moves them between lists, a pointer each instead of the
    // whole island, which saved a tenth of forming's instructions on 300 spheres)
    #[allow(clippy::vec_box)]
    fn form(
        &mut self,
        m: &Model,
        d: &mut Data,
        candidates: &[Candidate],
        former: &[usize],
        memory: &Memory,
        old: Vec<Box<Island>>,
    ) -> Result<(), EngineError> {
        // per body: the step its island would have taken next (a new island starts with the
        // least of its bodies')
        let mut next_h = vec![0.0; m.bodies.len()];
        // and `auto`'s memory of an implicit stint that lost (the new island holds the
        // highest cost and the longest hold of its bodies': a stint of the merged island
        // costs at least what the costliest part's did)
        let mut held = vec![None; m.bodies.len()];
        // (the former islands' partition)
        let before = std::mem::take(&mut d.partition);
        for (k, island) in old.iter().enumerate() {
            let h = island.data.solver.pending_step();
            let hold = island.data.solver.method().and_then(|i| i.explicit_hold());
            for &b in before.bodies(k) {
                next_h[b] = h;
                held[b] = hold;
            }
        }
        let parts = partition(m, candidates);
        // the former islands by their first body
        let mut by_first = vec![usize::MAX; m.bodies.len()];
        for k in 0..old.len() {
            by_first[before.bodies(k)[0]] = k;
        }
        let mut old: Vec<Option<Box<Island>>> = old.into_iter().map(Some).collect();
        let mut out = Vec::with_capacity(parts.len());
        let mut failed = None;
        for (k, bodies) in parts.iter().enumerate() {
            let (cands, listed) = (parts.candidates(k), parts.listed(k));
            let j = by_first[bodies[0]];
            if let Some(mut island) = old.get_mut(j).and_then(Option::take) {
                if before.bodies(j) == bodies && before.candidates(j) == cands {
                    for (lb, &gb) in bodies.iter().enumerate() {
                        island.data.broad_reference[lb] = d.broad_reference[gb];
                    }
                    engine::resync_margins(&island.model, &mut island.data);
                    out.push(island);
                    continue;
                }
                self.retire(*island, before.listed(j));
            }
            let h = bodies.iter().map(|&b| next_h[b]).fold(f64::INFINITY, f64::min);
            let members = Members {
                bodies,
                candidates: cands,
                listed,
            };
            let mut island = match self.compile_island(m, d, members, memory, former) {
                Ok(island) => island,
                Err(e) => {
                    failed = Some(e);
                    break;
                }
            };
            if h.is_finite() {
                island.data.solver.next_h = h;
            }
            let hold = bodies.iter().filter_map(|&b| held[b]).reduce(ExplicitHold::join);
            if let (Some(hold), Some(stepper)) = (hold, island.data.solver.stepper.as_mut()) {
                stepper.method.hold_explicit(hold);
            }
            self.compiled += 1;
            out.push(island);
        }
        for (j, island) in old.into_iter().enumerate() {
            if let Some(island) = island {
                self.retire(*island, before.listed(j));
            }
        }
        if let Some(e) = failed {
            for (k, island) in out.into_iter().enumerate() {
                self.retire(*island, parts.listed(k));
            }
            self.formed = false;
            return Err(e);
        }
        self.parts = out;
        d.partition = parts;
        Ok(())
    }

    /// Keeps the counters and the dissipated energy of an island that ends (its candidate
    /// pairs' places in the list `listed`, by which its events are numbered), and its compiled
    /// part in the pool.
    fn retire(&mut self, island: Island, listed: &[usize]) {
        self.retired = self.retired + island.data.counters;
        self.dissipated_base += island.dissipated();
        self.input_work_base += island.input_work();
        for e in &island.data.event_log {
            if let Some(g) = island.scene_contact(e.contact, self.n_explicit, listed) {
                self.retired_log.push(ContactEvent { contact: g, ..*e });
            }
        }
        self.pool.put_back(Compiled {
            model: island.model,
            numbering: island.numbering,
        });
        if self.n_spare < self.spare_limit {
            self.n_spare += 1;
            let (mut data, saved) = (island.data, island.saved);
            if data.solver.method().is_some_and(|i| i.linear_stats().is_some()) {
                // (an integrator whose implicit method was built is made anew when the data is
                // refitted: its workspace, the Jacobian and LU factors, is not kept meanwhile)
                data.solver.stepper = None;
            }
            self.spare.entry(data.state.len()).or_default().push((data, saved));
        }
    }

    /// The island of `members` (scene numbering), its model from the pool or cut from the
    /// scene's model `m`, its data set from the scene's data `d` (coordinates, inputs, flags,
    /// the broad phase's reference poses) and the contacts' memory (`memory`, its candidate
    /// pairs' by the former list: `former` gives the former index of each pair of the list).
    fn compile_island(
        &mut self,
        m: &Model,
        d: &Data,
        members: Members,
        memory: &Memory,
        former: &[usize],
    ) -> Result<Box<Island>, EngineError> {
        let Members {
            bodies,
            candidates,
            listed,
        } = members;
        let limit = POOL_PER_BODY * self.joint_coords.len();
        let (part, pooled) = self
            .pool
            .part(&self.params, &mut self.cutter, m, &self.joint_coords, bodies, limit);
        self.pooled += u64::from(pooled);
        let Compiled { model, numbering } = part;
        // (the scene's data keeps the log; an island's holds the events of one advance and
        // starts small: a full log's buffer would cost more to clear than the island to
        // compile)
        let spare = self.spare.get_mut(&model.nstate()).and_then(Vec::pop);
        let (mut data, mut saved) = match spare {
            Some((mut data, saved)) => {
                self.n_spare -= 1;
                self.reused += 1;
                data.refit(&model, 0, &mut self.fresh);
                (data, saved)
            }
            None => (Box::new(Data::with_event_log(&model, 0)), Vec::new()),
        };
        saved.clear();
        let diss = model.dissipated_index();
        data.state[diss] = 0.0;
        if let Some(i) = model.input_work_index() {
            data.state[i] = 0.0;
        }
        data.clamp_events = d.clamp_events;
        data.log_peaks = d.log_peaks;
        for &(l, g) in &numbering.inputs {
            data.inputs[l] = d.inputs[g];
        }
        // the candidate pairs' contact elements, by the island's numbering of the shapes
        let local = cut::local_candidates(&numbering.shapes, candidates);
        set_candidates(&model, &mut data, &local).map_err(|e| fail(d.time, e))?;
        for (k, &g) in numbering.explicit.iter().enumerate() {
            data.contact_memory[k] = memory.explicit[g];
        }
        let n = numbering.explicit.len();
        for (k, &i) in listed.iter().enumerate() {
            data.contact_memory[n + k] = former
                .get(i)
                .and_then(|&j| memory.candidates.get(j))
                .copied()
                .unwrap_or_default();
        }
        for (lb, &gb) in bodies.iter().enumerate() {
            data.broad_reference[lb] = d.broad_reference[gb];
        }
        let mut island = Box::new(Island {
            model,
            data,
            numbering,
            saved,
            saved_light: false,
            saved_log: 0,
        });
        island.take_new_coordinates(d);
        Ok(island)
    }

    /// Advances every island to `t_end` in rounds (see the module's text), the scene's model
    /// `m` and data `d` receiving the coordinates at each round's end (the rest of the state
    /// is gathered by [`Islands::gather`]). On failure every island is taken back to the start
    /// of the round, whose time the error carries. With `stop_at_events` the islands stop at
    /// the first contact event before `t_end` (see [`engine::advance_with`]): those that went
    /// further are taken back to it, and the result is `Ok(true)`.
    pub fn advance(&mut self, m: &Model, d: &mut Data, t_end: f64, stop_at_events: bool) -> Result<bool, EngineError> {
        if t_end.is_nan() || t_end < self.time {
            return Err(fail(self.time, format!("cannot integrate backwards to {}", Num(t_end))));
        }
        for island in &mut self.parts {
            island.take_inputs(d);
        }
        let t_close = 16.0 * f64::EPSILON * t_end.abs().max(1e-300);
        let grouped = m.groups.is_active();
        let mut rounds = 0u64;
        // the scene's poses and velocities in `d` are those of its state (evaluated at the
        // last round's end, where nothing changed the state since)
        let mut poses_fresh = false;
        // solver.max_steps bounds each island's steps per advance, and the steps of all islands
        // together to that many per island there is (counted at each round): a scene of many
        // independent bodies gets a budget that grows with them, a pile whose islands merged
        // the budget of one island, and no advance is unbounded
        let steps_start = self.total_steps();
        let per_island = m.solver.max_steps;
        while t_end - self.time > t_close {
            rounds += 1;
            self.rounds += 1;
            if rounds > m.solver.max_steps {
                return Err(EngineError {
                    time: self.time,
                    message: format!(
                        "solver.max_steps = {} rounds of the islands did not reach t = {} (stopped at t = {}); \
                         {}take shorter communication steps or raise solver.max_steps",
                        m.solver.max_steps,
                        Num(t_end),
                        Num(self.time),
                        if grouped {
                            format!(
                                "a round ends once a body may have moved {ROUND_FRACTION} of broad_phase.margin = \
                                 {:e} m: raise the margin if it is small for the bodies' speeds, or ",
                                m.groups.margin
                            )
                        } else {
                            String::new()
                        }
                    ),
                    step_limit: true,
                });
            }
            // (the rounds do not depend on the communication points: a round planned from the
            // state at its start goes on across them)
            if grouped && !self.round_end.is_finite() {
                if !poses_fresh {
                    poses_and_velocities_at_state(m, d);
                }
                self.round_end = self.time + round_length(m, d);
            }
            poses_fresh = false;
            let mut t_round = t_end;
            let mut ends_round = false;
            if self.round_end < t_end - t_close {
                // (a round's end a rounding error before the islands' time, which a stop at a
                // contact event past it can leave, see `model::island_state`: the round ends now)
                t_round = self.round_end.max(self.time);
                ends_round = true;
            } else if self.round_end <= t_end + t_close {
                ends_round = true;
            }
            for island in &mut self.parts {
                island.save_round_start(t_round, self.light_saves);
            }
            let mut t_met = t_round;
            // the earliest contact event an island stopped at
            let mut t_event = f64::INFINITY;
            let mut used = self.total_steps() - steps_start;
            let budget = per_island.saturating_mul(self.parts.len().max(1) as u64);
            // each island may take the steps left of the budget at the round's start (the same
            // limit whichever thread advances it, and in whatever order)
            let limit = per_island.min(budget.saturating_sub(used));
            let threads = self.threads.min(self.parts.len());
            let mut outcomes = if threads > 1 {
                advance_side_by_side(&mut self.parts, threads, limit, t_round, stop_at_events)
            } else {
                Vec::new()
            };
            for k in 0..self.parts.len() {
                let (result, steps) = match outcomes.get_mut(k).and_then(Option::take) {
                    Some(outcome) => outcome,
                    None => {
                        let island = &mut self.parts[k];
                        island.data.max_steps = Some(limit);
                        advance_island(island, t_round, stop_at_events)
                    }
                };
                used += steps;
                let island = &self.parts[k];
                if let Ok(true) = result {
                    t_event = t_event.min(island.data.time);
                }
                if let Err(e) = result {
                    let n = self.parts.len();
                    let name = island_name(m, &d.partition, k);
                    let mut e = self.take_back(m, &d.partition, k, e);
                    if e.step_limit {
                        e.message = format!(
                            "solver.max_steps = {per_island} integrator steps per island and communication step \
                             ({n} islands now, {used} steps in all in this one) did not reach t = {} (stopped at \
                             t = {}, in the island of body {name:?}); take shorter communication steps or raise \
                             solver.max_steps",
                            Num(t_end),
                            Num(self.time)
                        );
                    }
                    return Err(e);
                }
                t_met = t_met.min(island.data.time);
            }
            // An island stopped early (a body moved farther than planned, or at a contact
            // event): the others are taken back to its time.
            while self.parts.iter().any(|i| i.data.time > t_met) {
                for k in 0..self.parts.len() {
                    let island = &mut self.parts[k];
                    if island.data.time <= t_met {
                        continue;
                    }
                    if island.saved_light {
                        self.light_takebacks += 1;
                    }
                    island.restore();
                    // (the same steps again, counted once)
                    island.data.max_steps = Some(m.solver.max_steps);
                    if let Err(e) = engine::advance(&island.model, &mut island.data, t_met) {
                        return Err(self.take_back(m, &d.partition, k, e));
                    }
                }
                t_met = self.parts.iter().map(|i| i.data.time).fold(t_met, f64::min);
            }
            self.time = t_met;
            self.put_coordinates(d);
            // (a stop at a contact event leaves the round as planned: the rounds, like the
            // steps, do not depend on where an advance ended)
            let at_event = t_event <= t_met;
            let stale = t_met < t_round && !at_event;
            if grouped && ((ends_round && t_met >= t_round) || stale) {
                self.round_end = f64::INFINITY;
                poses_and_velocities_at_state(m, d);
                poses_fresh = true;
                let moved = (0..m.bodies.len())
                    .filter(|&b| m.groups.has_shape[b])
                    .map(|b| groups::displacement(m, d, b))
                    .fold(0.0, f64::max);
                if moved >= REBUILD_FRACTION * m.groups.margin || stale {
                    self.rebuild(m, d)?;
                }
            }
            if at_event {
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// The steps of every island since the islands were formed, with those of the islands
    /// that ended.
    fn total_steps(&self) -> u64 {
        self.retired.steps + self.parts.iter().map(|i| i.data.counters.steps).sum::<u64>()
    }

    /// After island `k` of partition `p` failed with `e`: every island back to the start of
    /// the round (its saved state) and the error, naming the island, at that time.
    fn take_back(&mut self, m: &Model, p: &Partition, k: usize, e: EngineError) -> EngineError {
        let name = island_name(m, p, k);
        let message = self.parts[k].in_scene_names(&e.message);
        for island in &mut self.parts {
            island.restore();
        }
        EngineError {
            time: self.time,
            message: format!("in the island of body {name:?}: {message}"),
            step_limit: e.step_limit,
        }
    }

    /// Finds the candidate pairs again at the scene's data `d` (kinematics evaluated at the
    /// gathered coordinates), makes the present poses the reference and forms the islands
    /// again. A candidate pair new to the list that already touches is an error (the bounds on
    /// the step were broken), found before anything changes.
    fn rebuild(&mut self, m: &Model, d: &mut Data) -> Result<(), EngineError> {
        // (checked before anything changes: on an error the islands stay as they are)
        let (found, former) =
            groups::find_candidates(m, d, d.partition.list()).map_err(|message| fail(self.time, message))?;
        groups::take_reference_poses(m, d);
        d.time = self.time;
        let memory = self.memory_of_islands(m, &d.partition);
        let old = std::mem::take(&mut self.parts);
        self.rebuilds += 1;
        self.form(m, d, &found, &former, &memory, old)
    }

    /// The parameter values the islands are compiled with.
    pub fn params(&self) -> &Parameters {
        &self.params
    }

    /// Sets the peak logging and the force-cut events of every island.
    pub fn set_flags(&mut self, log_peaks: bool, clamp_events: bool) {
        for island in &mut self.parts {
            island.data.log_peaks = log_peaks;
            if island.data.clamp_events != clamp_events {
                island.data.clamp_events = clamp_events;
                island.data.solver.started = false;
            }
        }
    }
}

/// The name of island `k` of partition `p`: that of its first body.
fn island_name<'m>(m: &'m Model, p: &Partition, k: usize) -> &'m str {
    let first = p.bodies(k).first();
    first.and_then(|&b| m.bodies.get(b)).map_or("?", |b| b.name.as_str())
}

/// The outcome of one island's advance to `t_round` ([`engine::advance_with`]) and the steps
/// it took.
type Outcome = (Result<bool, EngineError>, u64);

/// Advances `island` to `t_round` ([`engine::advance_with`]).
fn advance_island(island: &mut Island, t_round: f64, stop_at_events: bool) -> Outcome {
    let before = island.data.counters.steps;
    let result = engine::advance_with(&island.model, &mut island.data, t_round, stop_at_events);
    (result, island.data.counters.steps - before)
}

/// The threads that advance the islands side by side for the scene key `threads` (0: as many
/// as the machine has, asked once: the answer costs system calls).
fn side_by_side(threads: usize) -> usize {
    match threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    }
}

/// Advances every island of `parts` to `t_round` on up to `threads` threads (this one and
/// `threads − 1` more, each taking the largest island not yet taken, so that a round does not
/// wait for a large island taken last), each island with the step limit `limit`: the outcome of
/// each, in their order. An island's advance reads and writes its own model and data alone, so
/// each outcome is the one of advancing the islands one after the other. Every thread is joined
/// before it returns, also when an island's advance panicked (the first panic is then resumed
/// here); a thread the system does not start leaves its share to the others.
fn advance_side_by_side(
    parts: &mut [Box<Island>],
    threads: usize,
    limit: u64,
    t_round: f64,
    stop_at_events: bool,
) -> Vec<Option<Outcome>> {
    let mut outcomes: Vec<Option<Outcome>> = (0..parts.len()).map(|_| None).collect();
    let mut order: Vec<(usize, &mut Box<Island>)> = parts.iter_mut().enumerate().collect();
    order.sort_by_key(|(k, island)| (std::cmp::Reverse(island.model.bodies.len()), *k));
    let queue = Mutex::new(order.into_iter());
    let work = || {
        let mut done = Vec::new();
        loop {
            // (the lock is held for `next` alone: no panic can poison it)
            let next = queue.lock().unwrap_or_else(PoisonError::into_inner).next();
            let Some((k, island)) = next else {
                return done;
            };
            island.data.max_steps = Some(limit);
            done.push((k, advance_island(island, t_round, stop_at_events)));
        }
    };
    std::thread::scope(|scope| {
        let others: Vec<_> = (1..threads)
            .filter_map(|_| std::thread::Builder::new().spawn_scoped(scope, work).ok())
            .collect();
        let own = std::panic::catch_unwind(std::panic::AssertUnwindSafe(work));
        let mut panic = None;
        let mut all = Vec::with_capacity(threads);
        for joined in std::iter::once(own).chain(others.into_iter().map(|other| other.join())) {
            match joined {
                Ok(done) => all.push(done),
                Err(payload) => {
                    panic.get_or_insert(payload);
                }
            }
        }
        if let Some(payload) = panic {
            std::panic::resume_unwind(payload);
        }
        for (k, outcome) in all.into_iter().flatten() {
            outcomes[k] = Some(outcome);
        }
    });
    outcomes
}

/// The time in which no body's group shapes can move [`ROUND_FRACTION`] of the margin from
/// the reference poses at their present speed under gravity (from the poses and velocities
/// in the scene's data `d`, [`poses_and_velocities_at_state`]).
fn round_length(m: &Model, d: &Data) -> f64 {
    let g = &m.groups;
    let a = m.gravity.norm();
    let mut time = f64::INFINITY;
    for b in 0..m.bodies.len() {
        if !g.has_shape[b] {
            continue;
        }
        let moved = groups::displacement(m, d, b);
        let v = d.body_vel[b].point_velocity(&d.body_pos[b]).norm() + d.body_vel[b].ang.norm() * g.reach[b];
        let slack = (ROUND_FRACTION * g.margin - moved).max(0.5 * REBUILD_FRACTION * g.margin);
        let t = 2.0 * slack / (v + (v * v + 2.0 * a * slack).sqrt());
        if t.is_finite() {
            time = time.min(t);
        }
    }
    time
}
