//! The state: the part of [`Data`] that defines the future, declared once. Everything else in
//! `Data` is workspace that an evaluation recomputes from it.
//!
//! As MuJoCo's `mj_getState`/`mj_setState`, a bit mask of [`StatePart`]s selects what is
//! read or written, as plain numbers in a fixed order (the order of the bits). FMU states,
//! their serialised bytes and the command line's checkpoints all go through [`get`] and
//! [`set`]; [`set`] checks everything before it writes anything, so a refused state leaves
//! the data as it was.

use super::island_state::{self, IslandsState};
use super::{Counters, Data, EnergyWatch, Model};
use crate::integrator::{Integrator, Stats};
use crate::model::groups::Candidate;
use crate::scene::Num;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

named_enum! {
    /// One part of the state (a bit of a mask), by the name its messages give it; declared in
    /// the order of their bits, which `ALL` keeps: the order of the numbers.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    #[repr(u32)]
    pub enum StatePart {
        /// `Data::time`: 1 number.
        Time = 1 => "time",
        /// `Data::state`: positions, velocities, dissipated energy (`Model::nstate` numbers).
        Coordinates = 2 => "coordinates",
        /// `Data::inputs`: one number per input.
        Inputs = 4 => "inputs",
        /// `Data::contact_memory`: active flag, δ̇⁻, impact count per contact. With contact
        /// groups, first the candidate pairs behind the group contacts (their number, then pair,
        /// sphere and other shape of each) and the reference poses where they were found (per
        /// body: position, quaternion w, x, y, z).
        ContactMemory = 8 => "contact memory",
        /// `Data::counters`: steps, rejected, RHS and Jacobian evaluations, events.
        Counters = 16 => "counters",
        /// The integrator: whether it continues its last step (0/1), the step size to try at a
        /// restart, the pending event time (infinite: none), then the length of the method's own
        /// state and that state (`Integrator::save_state`: its last step, dense output,
        /// controller and Newton memory, counters; length 0: none, the method restarts cold).
        Solver = 32 => "integrator",
        /// `Data::energy_watch`: started (0/1), reference \[J\], scale \[J\], the RHS
        /// evaluations at the last check, warned (0/1).
        EnergyWatch = 64 => "energy watch",
        /// `Data::islands`: what a scene that runs as independent islands holds beyond the parts
        /// above (see [`super::island_state`]; 1 number, 0, when it runs as one integrator).
        /// Last, so that the scene's other parts are one prefix of the whole state.
        Islands = 128 => "islands",
    }
}

/// The mask of the whole state: what continues a simulation bit for bit.
pub const FULL: u32 = 255;

/// The parts of an island's own model and data that its record in the islands' part holds
/// ([`super::island_state`]; its coordinates, time and reference poses are the scene's, its
/// contact memory is in the islands' part by their list of candidate pairs).
pub const ISLAND_OWN: u32 = StatePart::Inputs as u32 | StatePart::Counters as u32 | StatePart::Solver as u32;

/// Numbers per contact in [`StatePart::ContactMemory`].
const MEMORY_LEN: usize = 3;
/// Numbers in [`StatePart::Counters`].
const COUNTERS_LEN: usize = 5;
/// Numbers in [`StatePart::EnergyWatch`].
const WATCH_LEN: usize = 5;
/// Fixed numbers of [`StatePart::Solver`] before the method's state: started, next step,
/// pending event, length of the method's state.
const SOLVER_HEAD: usize = 4;

/// The place of `part` in [`StatePart::ALL`] (the bit it is).
fn part_index(part: StatePart) -> usize {
    (part as u32).trailing_zeros() as usize
}

/// Appends the parts of `mask` to `out`.
pub fn get(m: &Model, d: &Data, mask: u32, out: &mut Vec<f64>) {
    for part in StatePart::ALL {
        if mask & part as u32 == 0 {
            continue;
        }
        match part {
            StatePart::Time => out.push(d.time),
            StatePart::Coordinates => out.extend_from_slice(&d.state),
            StatePart::Inputs => out.extend_from_slice(&d.inputs),
            StatePart::ContactMemory => {
                if m.groups.is_active() {
                    out.push(d.candidates.len() as f64);
                    for c in &d.candidates {
                        out.extend_from_slice(&[c.pair as f64, c.sphere as f64, c.other as f64]);
                    }
                    for (p, q) in &d.broad_reference {
                        out.extend_from_slice(&[p.x, p.y, p.z, q.w, q.i, q.j, q.k]);
                    }
                }
                for mem in &d.contact_memory {
                    out.extend_from_slice(&[mem.active as u8 as f64, mem.impact_velocity, mem.impacts as f64]);
                }
            }
            StatePart::Counters => {
                let c = &d.counters;
                out.extend_from_slice(&[
                    c.steps as f64,
                    c.rejected as f64,
                    c.rhs_evals as f64,
                    c.jac_evals as f64,
                    c.events as f64,
                ]);
            }
            StatePart::Solver => {
                out.extend_from_slice(&[d.solver.started as u8 as f64, d.solver.next_h, d.solver.pending_event]);
                let at = out.len();
                out.push(0.0);
                if let Some(i) = d.solver.method() {
                    i.save_state(out);
                }
                out[at] = (out.len() - at - 1) as f64;
            }
            StatePart::EnergyWatch => {
                let w = &d.energy_watch;
                out.extend_from_slice(&[
                    w.started as u8 as f64,
                    w.reference,
                    w.scale,
                    w.checked_at as f64,
                    w.warned as u8 as f64,
                ]);
            }
            StatePart::Islands => island_state::get(&d.islands, out),
        }
    }
}

/// Numbers of the contact groups' section at the start of [`StatePart::ContactMemory`] (0
/// without groups).
fn group_section_len(m: &Model, d: &Data) -> usize {
    if m.groups.is_active() {
        1 + 3 * d.candidates.len() + 7 * m.bodies.len()
    } else {
        0
    }
}

/// The candidate pairs at the start of a contact-group section of model `m` (None: malformed,
/// a pair `m`'s groups cannot list, or a list out of the broad phase's order or with a pair
/// twice).
fn candidates_in(m: &Model, v: &[f64]) -> Option<Vec<Candidate>> {
    let n = count(*v.first()?, "candidates").ok()? as usize;
    let list = v.get(1..1 + 3 * n)?;
    let found: Vec<Candidate> = list
        .chunks(3)
        .map(|c| {
            let k = |x: f64| count(x, "shape").ok().map(|x| x as usize);
            let c = Candidate {
                pair: k(c[0])?,
                sphere: k(c[1])?,
                other: k(c[2])?,
            };
            m.groups.is_candidate(&c).then_some(c)
        })
        .collect::<Option<_>>()?;
    found.windows(2).all(|w| w[0] < w[1]).then_some(found)
}

/// The contact groups' candidate pairs recorded in a whole state `v` ([`FULL`]) of a model
/// with the layout of `m` (the same scene): the list to compile the model with before the
/// state is set. None without groups or when `v` is too short.
pub fn group_candidates(m: &Model, v: &[f64]) -> Option<Vec<Candidate>> {
    if !m.groups.is_active() {
        return None;
    }
    candidates_in(m, v.get(1 + m.nstate() + m.input_values()..)?)
}

/// A count stored as a number: a whole number in range, or an error naming the part.
fn count(x: f64, what: &str) -> Result<u64, String> {
    if x.fract() == 0.0 && (0.0..9.0e15).contains(&x) {
        Ok(x as u64)
    } else {
        Err(format!("state: {what} = {x} is not a count"))
    }
}

/// The base of the method's counters `stats` at which the data's counters are `c` (counters
/// since initialisation = the method's − base).
fn counter_base(stats: &Stats, c: &Counters) -> Stats {
    Stats {
        steps: stats.steps.saturating_sub(c.steps),
        rejected: stats.rejected.saturating_sub(c.rejected),
        rhs_evals: stats.rhs_evals.saturating_sub(c.rhs_evals),
        jac_evals: stats.jac_evals.saturating_sub(c.jac_evals),
    }
}

/// Whether the method `method` that continues its last step (`started`; one that does not
/// restarts cold from the state), with its first event in that step at `pending` (infinite:
/// none), fits the state's `time`: the step began at or before it, ends after it or a few
/// rounding errors short of it (an advance that ended that close to its end takes the end),
/// an event it has not yet stopped at comes at or after it, and the step's end, the next step
/// size and the dense output at `time` are finite (an accepted step's are). The engine
/// interpolates the state there and steps on from the step's end.
fn continued_step_fits(started: bool, method: &(dyn Integrator + Send), pending: f64, time: f64) -> Result<(), String> {
    if !started {
        return Ok(());
    }
    let (t_prev, t) = (method.t_prev(), method.t());
    let close = 16.0 * f64::EPSILON * time.abs().max(1e-300);
    if !(t_prev <= time && time <= t + close) {
        return Err(format!(
            "state: the integrator continues a step from t = {} to {}, which does not hold the state's time {}",
            Num(t_prev),
            Num(t),
            Num(time)
        ));
    }
    if t > time && pending < time {
        return Err(format!(
            "state: the integrator's next event, at t = {}, comes before the state's time {}",
            Num(pending),
            Num(time)
        ));
    }
    let h = method.next_step();
    if !(h.is_finite() && h >= 0.0) {
        return Err(format!(
            "state: the integrator's next step {} is not a step size",
            Num(h)
        ));
    }
    let mut at_time = vec![0.0; method.y().len()];
    method.interpolate(time.min(t), &mut at_time);
    if method.y().iter().chain(&at_time).any(|x| !x.is_finite()) {
        return Err(format!(
            "state: the integrator continues a step whose state at t = {} or at its end is not finite",
            Num(time)
        ));
    }
    Ok(())
}

/// Writes the parts of `mask` from `v` (as [`get`] wrote them for this model). Checks the
/// length of every part, that numbers are finite (but the energy watch's reference and scale,
/// which are what the energies were) and counts are counts, before it writes anything; on an
/// error the data is unchanged. The integrator continues from its restored
/// state exactly as it would have.
pub fn set(m: &Model, d: &mut Data, mask: u32, v: &[f64]) -> Result<(), String> {
    if mask & !FULL != 0 {
        return Err(format!("state: unknown parts in mask {mask:#x}"));
    }
    // Pass 1: locate and check every part.
    let mut at = 0;
    let mut spans = [(0usize, 0usize); StatePart::ALL.len()];
    let mut islands: Option<IslandsState> = None;
    for (k, part) in StatePart::ALL.iter().enumerate() {
        if mask & *part as u32 == 0 {
            continue;
        }
        let len = match part {
            StatePart::Time => 1,
            StatePart::Coordinates => m.nstate(),
            StatePart::Inputs => m.input_values(),
            StatePart::ContactMemory => group_section_len(m, d) + MEMORY_LEN * d.contacts.len(),
            StatePart::Counters => COUNTERS_LEN,
            StatePart::Solver => {
                let head = v
                    .get(at..at + SOLVER_HEAD)
                    .ok_or("state: the integrator part is truncated")?;
                let own = count(head[SOLVER_HEAD - 1], "integrator state length")? as usize;
                SOLVER_HEAD + own
            }
            StatePart::EnergyWatch => WATCH_LEN,
            StatePart::Islands => {
                let time = if mask & StatePart::Time as u32 != 0 {
                    v[spans[part_index(StatePart::Time)].0]
                } else {
                    d.time
                };
                let (read, len) = island_state::read(m, time, v.get(at..).unwrap_or_default())?;
                islands = Some(read);
                len
            }
        };
        let Some(slice) = v.get(at..at + len) else {
            return Err(format!(
                "state: the {} part needs {len} numbers, {} are left (truncated, or not a state of this model)",
                part.name(),
                v.len().saturating_sub(at)
            ));
        };
        let checked = match part {
            StatePart::Solver => &slice[1..2],
            // (the watch's numbers are what the energies were, whatever they were)
            StatePart::Counters | StatePart::Islands | StatePart::EnergyWatch => &[],
            _ => slice,
        };
        if let Some(x) = checked.iter().find(|x| !x.is_finite()) {
            return Err(format!(
                "state: the {} part holds a non-finite number ({x})",
                part.name()
            ));
        }
        match part {
            StatePart::Coordinates => {
                // (a joint quaternion is kept at unit length: one far from it is no orientation)
                for &q in &m.quaternions {
                    let norm = slice[q..q + 4].iter().map(|x| x * x).sum::<f64>().sqrt();
                    if !(0.5..2.0).contains(&norm) {
                        return Err(format!(
                            "state: a joint quaternion of length {norm} (at coordinate {q}) is no orientation"
                        ));
                    }
                }
            }
            StatePart::ContactMemory => {
                let groups = group_section_len(m, d);
                if groups > 0 && candidates_in(m, &slice[..groups]) != Some(d.candidates.clone()) {
                    return Err("state: its contact-group candidate pairs are not this model's".into());
                }
                for c in slice[groups..].chunks(MEMORY_LEN) {
                    if c[0] != 0.0 && c[0] != 1.0 {
                        return Err(format!("state: contact active flag {} is not 0 or 1", c[0]));
                    }
                    count(c[2], "impact count")?;
                }
            }
            StatePart::Counters => {
                for x in slice {
                    count(*x, "counter")?;
                }
            }
            StatePart::Solver => {
                if slice[0] != 0.0 && slice[0] != 1.0 {
                    return Err(format!("state: integrator started flag {} is not 0 or 1", slice[0]));
                }
                if slice[2].is_nan() || slice[2] == f64::NEG_INFINITY {
                    return Err(format!("state: pending event time {} is not a time", slice[2]));
                }
            }
            StatePart::EnergyWatch => {
                for (x, what) in [(slice[0], "started"), (slice[4], "warned")] {
                    if x != 0.0 && x != 1.0 {
                        return Err(format!("state: energy watch {what} flag {x} is not 0 or 1"));
                    }
                }
                let checked_at = count(slice[3], "energy watch check")?;
                // (it checked at a number of evaluations the run had made)
                if mask & StatePart::Counters as u32 != 0 {
                    let rhs_evals = v[spans[part_index(StatePart::Counters)].0 + 2];
                    if checked_at as f64 > rhs_evals {
                        return Err(format!(
                            "state: the energy watch last checked at {checked_at} evaluations, the counters \
                             hold {rhs_evals}"
                        ));
                    }
                }
            }
            _ => {}
        }
        spans[k] = (at, at + len);
        at += len;
    }
    if at != v.len() {
        return Err(format!(
            "state: {} numbers, the parts of this model take {at} (not a state of this model)",
            v.len()
        ));
    }
    // The method's state may still be refused by the method: restore it first.
    let mut solver_head = None;
    if mask & StatePart::Solver as u32 != 0 {
        let (a, b) = spans[part_index(StatePart::Solver)];
        let s = &v[a..b];
        let stepper = d
            .solver
            .stepper
            .as_mut()
            .ok_or("state: the integrator was lost after an internal error")?;
        let own = &s[SOLVER_HEAD..];
        let (started, pending) = (s[0] == 1.0, s[2]);
        if own.is_empty() {
            // no method state: the method restarts cold at the state's time
            if started {
                return Err("state: the integrator continues a step but its state is missing".into());
            }
            stepper.method.set_warm_state(&[])?;
        } else {
            // (the method's present state, put back if the restored one does not fit the time)
            let mut present = Vec::new();
            stepper.method.save_state(&mut present);
            stepper.method.load_state(own)?;
            let time = if mask & StatePart::Time as u32 != 0 {
                v[spans[part_index(StatePart::Time)].0]
            } else {
                d.time
            };
            if let Err(e) = continued_step_fits(started, &*stepper.method, pending, time) {
                // (it was saved from the method: it loads; if it did not, the method would
                // restart cold from the data's state, its counters counting on from there)
                if stepper.method.load_state(&present).is_err() {
                    d.solver.started = false;
                    let stats = d.solver.method().map(|i| i.stats()).unwrap_or_default();
                    d.solver.base = counter_base(&stats, &d.counters);
                }
                return Err(e);
            }
        }
        solver_head = Some((started, s[1], pending));
    }
    // Pass 2: write (nothing below fails).
    for (k, part) in StatePart::ALL.iter().enumerate() {
        if mask & *part as u32 == 0 {
            continue;
        }
        let (a, b) = spans[k];
        let s = &v[a..b];
        match part {
            StatePart::Time => d.time = s[0],
            StatePart::Coordinates => {
                d.state.copy_from_slice(s);
                d.dense_pending = false;
            }
            StatePart::Inputs => d.inputs.copy_from_slice(s),
            StatePart::ContactMemory => {
                let groups = group_section_len(m, d);
                let poses = &s[(1 + 3 * d.candidates.len()).min(groups)..groups];
                for (r, p) in d.broad_reference.iter_mut().zip(poses.chunks(7)) {
                    r.0 = Vector3::new(p[0], p[1], p[2]);
                    r.1 = UnitQuaternion::new_unchecked(Quaternion::new(p[3], p[4], p[5], p[6]));
                }
                for (mem, c) in d.contact_memory.iter_mut().zip(s[groups..].chunks(MEMORY_LEN)) {
                    mem.active = c[0] != 0.0;
                    mem.impact_velocity = c[1];
                    mem.impacts = c[2] as u64;
                }
            }
            StatePart::Counters => {
                let c = &mut d.counters;
                c.steps = s[0] as u64;
                c.rejected = s[1] as u64;
                c.rhs_evals = s[2] as u64;
                c.jac_evals = s[3] as u64;
                c.events = s[4] as u64;
            }
            StatePart::Solver => {}
            StatePart::EnergyWatch => {
                d.energy_watch = EnergyWatch {
                    started: s[0] == 1.0,
                    reference: s[1],
                    scale: s[2],
                    checked_at: s[3] as u64,
                    warned: s[4] == 1.0,
                }
            }
            StatePart::Islands => d.islands = islands.take().unwrap_or_default(),
        }
    }
    if let Some((started, h, pending)) = solver_head {
        // counters since initialisation = the method's counters − base
        let stats = d.solver.method().map(|i| i.stats()).unwrap_or_default();
        d.solver.base = counter_base(&stats, &d.counters);
        d.solver.next_h = h;
        d.solver.pending_event = pending;
        d.solver.started = started;
    } else {
        d.solver.started = false;
    }
    d.outputs_valid = false;
    d.kinematics_valid = false;
    Ok(())
}
