//! The islands' part of the state (`StatePart::Islands` in [`super::state`]), declared beside the
//! scene's other parts: the arrays [`IslandsState`] in [`super::Data::islands`] that a scene
//! running as independent islands saves beyond the scene's own coordinates, inputs, contact
//! memory and counters. The islands (`crate::islands`) hold their state in their own data while
//! they run; they gather it into these arrays when the state is saved, and are built from them
//! (and from the scene's coordinates and reference poses) when it is restored.
//!
//! Layout (all `f64`, counts as whole numbers):
//!
//! | numbers | contents |
//! |---|---|
//! | 1 | the number of islands k (0: the scene runs as one integrator, and nothing follows) |
//! | 5 | counters of the islands that ended: steps, rejected, RHS and Jacobian evaluations, events |
//! | 1 | energy dissipated by the islands that ended |
//! | 1 | input work of the islands that ended |
//! | 1 | rebuilds of the candidate pairs |
//! | 1 | end of the present round (not before the state's time) |
//! | 1 + 3c | the islands' candidate pairs: their number c, then pair, sphere shape and other shape of each |
//! | 3 (e + c) | the contact memory of the e declared contacts, then of the c candidate pairs: active flag, δ̇⁻, impact count |
//! | b | per body of the scene, its island (the islands numbered in the order of their first bodies) |
//! | per island | the length s of its own state, then its dissipated energy, its input work, and its inputs, counters and integrator (the parts [`super::state::ISLAND_OWN`] of its own model) |

use super::contact::ContactMemory;
use super::groups::Candidate;
use super::{Counters, Model};
use crate::integrator::core::StateReader;

/// Numbers of an island's record before its [`super::state::ISLAND_OWN`] parts: dissipated
/// energy, input work.
pub const ENERGIES: usize = 2;

/// The islands' own numbers besides their candidate pairs and their islands.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct IslandsHead {
    /// Counters of the islands that ended.
    pub retired: Counters,
    /// Energy dissipated by the islands that ended.
    pub dissipated_base: f64,
    /// Input work of the islands that ended.
    pub input_work_base: f64,
    /// Rebuilds of the candidate pairs.
    pub rebuilds: u64,
    /// End of the present round.
    pub round_end: f64,
}

/// The islands' state as arrays (empty: the scene runs as one integrator, or its islands hold
/// their state themselves; see the module's documentation).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct IslandsState {
    /// Counters, energies and rebuilds not held by an island, and the round's end.
    pub head: IslandsHead,
    /// The islands' candidate pairs (the scene's shape numbering), sorted as the broad phase
    /// found them.
    pub candidates: Vec<Candidate>,
    /// The contact memory of the declared contacts, then of the candidate pairs.
    pub memory: Vec<ContactMemory>,
    /// Per body of the scene, its island.
    pub island_of: Vec<usize>,
    /// Per island, its record: [`ENERGIES`] numbers, then its [`super::state::ISLAND_OWN`]
    /// parts (none: no islands).
    pub records: Vec<Vec<f64>>,
}

impl IslandsState {
    /// No islands.
    pub fn clear(&mut self) {
        self.head = IslandsHead::default();
        self.candidates.clear();
        self.memory.clear();
        self.island_of.clear();
        self.records.clear();
    }

    /// The number of islands.
    pub fn count(&self) -> usize {
        self.records.len()
    }
}

/// Appends the islands' part of `s` (see the module's documentation).
pub fn get(s: &IslandsState, out: &mut Vec<f64>) {
    out.push(s.count() as f64);
    if s.count() == 0 {
        return;
    }
    let (h, r) = (&s.head, s.head.retired);
    out.extend([r.steps, r.rejected, r.rhs_evals, r.jac_evals, r.events].map(|x| x as f64));
    out.extend([h.dissipated_base, h.input_work_base, h.rebuilds as f64, h.round_end]);
    out.push(s.candidates.len() as f64);
    for c in &s.candidates {
        out.extend([c.pair, c.sphere, c.other].map(|x| x as f64));
    }
    for mem in &s.memory {
        out.extend([mem.active as u8 as f64, mem.impact_velocity, mem.impacts as f64]);
    }
    out.extend(s.island_of.iter().map(|&k| k as f64));
    for record in &s.records {
        out.push(record.len() as f64);
        out.extend_from_slice(record);
    }
}

/// Reads and checks the islands' part at the start of `v` for the scene's model `m` at the
/// state's time `time`; gives it and the numbers it takes. Checked: counts are counts and
/// numbers finite, the round does not end before `time` (but for rounding), the candidate pairs' numbers are
/// of the model's group pairs and their groups' shapes (sorted, each once), the memory's flags
/// are flags, every body's island is one of the part's, and every record holds its energies.
/// Whether the bodies' islands are those the candidate pairs make, and the islands' own parts,
/// are checked when the islands are built from it.
pub fn read(m: &Model, time: f64, v: &[f64]) -> Result<(IslandsState, usize), String> {
    let mut r = StateReader::part(v, "the saved islands");
    let mut s = IslandsState::default();
    let nb = m.bodies.len();
    let count = r.count_to(nb as u64)? as usize;
    if count == 0 {
        return Ok((s, 1));
    }
    let mut c = [0u64; 5];
    for x in &mut c {
        *x = r.count()?;
    }
    let head = IslandsHead {
        retired: Counters {
            steps: c[0],
            rejected: c[1],
            rhs_evals: c[2],
            jac_evals: c[3],
            events: c[4],
        },
        dissipated_base: finite(r.value()?, "energy dissipated by the islands that ended")?,
        input_work_base: finite(r.value()?, "input work of the islands that ended")?,
        rebuilds: r.count()?,
        round_end: r.value()?,
    };
    // (a stop at a contact event may end an advance past a round's end that lay within the
    // rounding of the communication point: 16 ulps of it)
    if head.round_end.is_nan() || head.round_end < time - 32.0 * f64::EPSILON * time.abs() {
        return Err(format!(
            "saved islands: round end {} before their time {time}",
            head.round_end
        ));
    }
    s.head = head;
    let (np, ns) = (m.groups.pair_names.len() as u64, m.groups.shapes.len() as u64);
    let nc = r.count_to(r.left() as u64 / 3)? as usize;
    if nc > 0 && (np == 0 || ns == 0) {
        return Err("saved islands hold candidate pairs, the scene has no contact groups".into());
    }
    for _ in 0..nc {
        let pair = r.count_to(np.saturating_sub(1))? as usize;
        let sphere = r.count_to(ns.saturating_sub(1))? as usize;
        let other = r.count_to(ns.saturating_sub(1))? as usize;
        let c = Candidate { pair, sphere, other };
        let g = &m.groups;
        if !g.is_candidate(&c) {
            return Err(format!(
                "saved islands: candidate pair {} is not of its group pair's groups",
                g.element_name(&c)
            ));
        }
        if s.candidates.last().is_some_and(|l| *l >= c) {
            return Err("saved islands: the candidate pairs are listed twice or out of order".into());
        }
        s.candidates.push(c);
    }
    for _ in 0..m.groups.n_explicit + nc {
        let active = r.flag()?;
        let impact_velocity = finite(r.value()?, "a contact's δ̇⁻")?;
        let impacts = r.count()?;
        s.memory.push(ContactMemory {
            active,
            impact_velocity,
            impacts,
        });
    }
    for _ in 0..nb {
        s.island_of.push(r.count_to(count as u64 - 1)? as usize);
    }
    for _ in 0..count {
        let len = r.count_to(r.left() as u64)? as usize;
        if len < ENERGIES {
            return Err(format!("saved islands: a record of {len} numbers holds no energies"));
        }
        let record = r.take(len)?;
        for &x in &record[..ENERGIES] {
            finite(x, "an island's energy")?;
        }
        s.records.push(record.to_vec());
    }
    Ok((s, v.len() - r.left()))
}

/// `x`, when it is finite.
fn finite(x: f64, what: &str) -> Result<f64, String> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!("saved islands: {what} = {x} is not finite"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compile::compile;
    use crate::scene::Scene;

    /// The pile's model (27 bodies, contact groups).
    fn pile() -> Model {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/pile_of_balls/scene.toml");
        compile(&Scene::from_file(&path).unwrap(), "pile_of_balls").unwrap().0
    }

    /// Two islands (bodies 0-9 and 10-26) with two of the pile's candidate pairs.
    fn two_islands(m: &Model) -> IslandsState {
        // (ball_ball: the first ball and the second; ball_box: the first ball and the first wall)
        let g = &m.groups;
        let candidates: Vec<Candidate> = (0..2)
            .map(|pair| {
                let (a, b) = g.pair_groups[pair];
                let sphere = g.shapes.iter().position(|s| s.group == a).unwrap();
                let other = (0..g.shapes.len())
                    .find(|&o| o != sphere && g.shapes[o].group == b)
                    .unwrap();
                Candidate { pair, sphere, other }
            })
            .collect();
        let memory = (0..m.groups.n_explicit + 2)
            .map(|k| ContactMemory {
                active: k % 2 == 1,
                impact_velocity: -0.25 * k as f64,
                impacts: k as u64,
            })
            .collect();
        IslandsState {
            head: IslandsHead {
                retired: Counters {
                    steps: 7,
                    rejected: 1,
                    rhs_evals: 50,
                    jac_evals: 2,
                    events: 3,
                },
                dissipated_base: 0.25,
                input_work_base: -1.5,
                rebuilds: 4,
                round_end: 0.125,
            },
            candidates,
            memory,
            island_of: (0..27).map(|b| usize::from(b >= 10)).collect(),
            records: vec![vec![0.5, 0.0, 1.0, 2.0, 3.0], vec![1.5, 0.0, 9.0]],
        }
    }

    /// What [`get`] writes, [`read`] reads back; every kind of damage is refused with a reason.
    #[test]
    fn the_islands_part_reads_back_and_damage_is_refused() {
        let m = pile();
        let s = two_islands(&m);
        let mut v = Vec::new();
        get(&s, &mut v);
        let (back, len) = read(&m, 0.1, &v).unwrap();
        assert_eq!((&back, len), (&s, v.len()));
        assert_eq!(
            (0..27).filter(|&b| back.island_of[b] == 1).collect::<Vec<_>>(),
            (10..27).collect::<Vec<_>>()
        );
        // (what follows the part is not its)
        let mut followed = v.clone();
        followed.push(7.0);
        assert_eq!(read(&m, 0.1, &followed).unwrap().1, v.len());
        let none = IslandsState::default();
        let mut empty = Vec::new();
        get(&none, &mut empty);
        assert_eq!(read(&m, 0.1, &empty).unwrap(), (none, 1));

        let refused = |v: &[f64], time: f64, why: &str| {
            let e = read(&m, time, v).expect_err(why);
            assert!(e.contains("saved islands"), "{why}: {e}");
        };
        refused(&v, 0.2, "a round that ended before the state's time");
        // (but for the rounding of an advance that stopped at a contact event past it)
        assert!(
            read(&m, 0.125f64.next_up(), &v).is_ok(),
            "a round's end an ulp before the time"
        );
        refused(&v[..v.len() - 1], 0.1, "truncated");
        let at_cands = 10;
        let mut bad = v.clone();
        bad[at_cands + 1] = m.groups.pair_names.len() as f64;
        refused(&bad, 0.1, "a pair the scene does not have");
        let mut bad = v.clone();
        bad.swap(at_cands + 5, at_cands + 6);
        refused(&bad, 0.1, "a wall as the sphere of ball_box");
        let mut bad = v.clone();
        bad.copy_within(at_cands + 1..at_cands + 4, at_cands + 4);
        refused(&bad, 0.1, "a candidate pair listed twice");
        let mut bad = v.clone();
        bad[1] = 0.5;
        refused(&bad, 0.1, "a counter that is not a count");
        let mut bad = v.clone();
        bad[0] = 28.0;
        refused(&bad, 0.1, "more islands than bodies");
        let at_memory = at_cands + 1 + 3 * s.candidates.len();
        let mut bad = v.clone();
        bad[at_memory] = 0.5;
        refused(&bad, 0.1, "an active flag that is not a flag");
        let at_bodies = at_memory + 3 * s.memory.len();
        let mut bad = v.clone();
        bad[at_bodies + 26] = 2.0;
        refused(&bad, 0.1, "an island the part does not have");
        let mut bad = v.clone();
        bad[0] = 3.0;
        refused(&bad, 0.1, "a record more than the part holds");
        // (islands out of their order, without bodies, or not joining a candidate pair's two
        // bodies are refused where they are built: `islands_other_than_their_partition_are_refused`)
        let at_records = at_bodies + 27;
        let mut bad = v.clone();
        bad[at_records + 1] = f64::NAN;
        refused(&bad, 0.1, "an energy that is not finite");
        let mut bad = v.clone();
        bad[at_records] = 1.0;
        refused(&bad, 0.1, "a record without its energies");
    }
}
