//! The islands' part of a saved state, declared beside the scene's ([`super::state`]): what a
//! scene that runs as independent islands saves after the scene's whole state, and the checks
//! a loaded one passes before anything is built from it. The islands (`crate::islands`) only
//! map their own fields to and from [`IslandsHead`] and each island's whole state (its own
//! model's [`super::state::FULL`]).
//!
//! Layout (all `f64`, counts as whole numbers):
//!
//! | numbers | contents |
//! |---|---|
//! | 5 | counters of the islands that ended: steps, rejected, RHS and Jacobian evaluations, events |
//! | 1 | energy dissipated by the islands that ended |
//! | 1 | input work of the islands that ended |
//! | 1 | rebuilds of the candidate pairs |
//! | 1 | end of the present round (not before the state's time) |
//! | 1 + 3c | the candidate pairs: their number c, then pair, sphere shape and other shape of each |
//! | 1 | the number of islands k (at most the scene's bodies) |
//! | per island | its number of bodies b, its bodies (ascending, each body in exactly one island), the length s of its state, its state |

use super::groups::Candidate;
use super::{Counters, Model};
use crate::integrator::core::StateReader;

/// The islands' own numbers besides their candidate pairs and their islands.
#[derive(Debug, Clone, Copy, PartialEq)]
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

/// One island as saved: its bodies (scene numbering, ascending) and its whole state.
#[derive(Debug, Clone, PartialEq)]
pub struct SavedIsland<'a> {
    /// Its bodies.
    pub bodies: Vec<usize>,
    /// Its whole state ([`super::state::FULL`] of its own model).
    pub state: &'a [f64],
}

/// Appends the islands' part: `head`, the candidate pairs, then per island its bodies and the
/// state `island_state` appends for it.
pub fn get<'a>(
    head: &IslandsHead,
    candidates: &[Candidate],
    islands: impl ExactSizeIterator<Item = &'a [usize]>,
    mut island_state: impl FnMut(usize, &mut Vec<f64>),
    out: &mut Vec<f64>,
) {
    let r = head.retired;
    out.extend([r.steps, r.rejected, r.rhs_evals, r.jac_evals, r.events].map(|x| x as f64));
    out.extend([
        head.dissipated_base,
        head.input_work_base,
        head.rebuilds as f64,
        head.round_end,
    ]);
    out.push(candidates.len() as f64);
    for c in candidates {
        out.extend([c.pair, c.sphere, c.other].map(|x| x as f64));
    }
    out.push(islands.len() as f64);
    for (k, bodies) in islands.enumerate() {
        out.push(bodies.len() as f64);
        out.extend(bodies.iter().map(|&b| b as f64));
        let at = out.len();
        out.push(0.0);
        island_state(k, out);
        out[at] = (out.len() - at - 1) as f64;
    }
}

/// Reads and checks an islands' part written by [`get`] for the scene's model `m` at the
/// state's time `time`: counts are counts, the round does not end before `time`, the
/// candidate pairs' numbers are within the model's group pairs and shapes, every island has
/// bodies and every body is in exactly one island, listed in ascending order. Whether the
/// candidate pairs are those of the scene's groups, and the islands' own states, are checked
/// when the islands are built from it and their states set into their models.
pub fn set<'a>(
    m: &Model,
    time: f64,
    v: &'a [f64],
) -> Result<(IslandsHead, Vec<Candidate>, Vec<SavedIsland<'a>>), String> {
    let mut r = StateReader::part(v, "saved islands");
    let mut c = [0u64; 5];
    for x in &mut c {
        *x = r.count()?;
    }
    let retired = Counters {
        steps: c[0],
        rejected: c[1],
        rhs_evals: c[2],
        jac_evals: c[3],
        events: c[4],
    };
    let dissipated_base = r.value()?;
    let input_work_base = r.value()?;
    let rebuilds = r.count()?;
    let round_end = r.value()?;
    if round_end.is_nan() || round_end < time {
        return Err(format!("saved islands: round end {round_end} before their time {time}"));
    }
    let (np, ns) = (m.groups.pair_names.len() as u64, m.groups.shapes.len() as u64);
    let nc = r.count_to(r.left() as u64)? as usize;
    if nc > 0 && (np == 0 || ns == 0) {
        return Err("saved islands hold candidate pairs, the scene has no contact groups".into());
    }
    let mut candidates = Vec::with_capacity(nc);
    for _ in 0..nc {
        let pair = r.count_to(np.saturating_sub(1))? as usize;
        let sphere = r.count_to(ns.saturating_sub(1))? as usize;
        let other = r.count_to(ns.saturating_sub(1))? as usize;
        candidates.push(Candidate { pair, sphere, other });
    }
    let nb = m.bodies.len();
    let n = r.count_to(nb as u64)? as usize;
    let mut seen = vec![false; nb];
    let mut islands = Vec::with_capacity(n);
    for _ in 0..n {
        let len = r.count_to(nb as u64)? as usize;
        if len == 0 {
            return Err("saved islands: an island without bodies".into());
        }
        let mut bodies = Vec::with_capacity(len);
        for _ in 0..len {
            let b = r.count_to(nb as u64 - 1)? as usize;
            if seen[b] || bodies.last().is_some_and(|&l| l >= b) {
                return Err("saved islands: a body is listed twice or out of order".into());
            }
            seen[b] = true;
            bodies.push(b);
        }
        let len = r.count_to(r.left() as u64)? as usize;
        islands.push(SavedIsland {
            bodies,
            state: r.take(len)?,
        });
    }
    r.finish()?;
    if seen.iter().any(|s| !s) {
        return Err("saved islands: they do not hold every body once".into());
    }
    let head = IslandsHead {
        retired,
        dissipated_base,
        input_work_base,
        rebuilds,
        round_end,
    };
    Ok((head, candidates, islands))
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

    /// A part of two islands (bodies 0-9 and 10-26), written and read back.
    fn written(head: &IslandsHead, candidates: &[Candidate]) -> Vec<f64> {
        let islands: [Vec<usize>; 2] = [(0..10).collect(), (10..27).collect()];
        let mut out = Vec::new();
        get(
            head,
            candidates,
            islands.iter().map(|b| &b[..]),
            |k, out| out.extend(std::iter::repeat_n(k as f64 + 0.5, 3 + k)),
            &mut out,
        );
        out
    }

    /// What [`get`] writes, [`set`] reads back; every kind of damage is refused with a reason.
    #[test]
    fn the_islands_part_reads_back_and_damage_is_refused() {
        let m = pile();
        let head = IslandsHead {
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
        };
        let cands = [
            Candidate {
                pair: 0,
                sphere: 1,
                other: 2,
            },
            Candidate {
                pair: 1,
                sphere: 3,
                other: 27,
            },
        ];
        let v = written(&head, &cands);
        let (h, c, islands) = set(&m, 0.1, &v).unwrap();
        assert_eq!((h, &c[..]), (head, &cands[..]));
        assert_eq!(islands.len(), 2);
        assert_eq!(islands[0].bodies, (0..10).collect::<Vec<_>>());
        assert_eq!(islands[1].state, &[1.5; 4]);

        let refused = |v: &[f64], time: f64, why: &str| {
            let e = set(&m, time, v).expect_err(why);
            assert!(e.starts_with("saved islands"), "{why}: {e}");
        };
        refused(&v, 0.2, "a round that ended before the state's time");
        refused(&v[..v.len() - 1], 0.1, "truncated");
        let mut longer = v.clone();
        longer.push(0.0);
        refused(&longer, 0.1, "a number too many");
        let at_cands = 9;
        let mut bad = v.clone();
        bad[at_cands + 1] = m.groups.pair_names.len() as f64;
        refused(&bad, 0.1, "a pair the scene does not have");
        let mut bad = v.clone();
        bad[0] = 0.5;
        refused(&bad, 0.1, "a counter that is not a count");
        let first_island = at_cands + 1 + 3 * cands.len() + 1;
        let mut bad = v.clone();
        bad[first_island + 2] = 0.0;
        refused(&bad, 0.1, "a body listed twice");
        let mut bad = v.clone();
        bad[first_island + 1] = 5.0;
        refused(&bad, 0.1, "bodies out of order");
        let one_island = {
            let mut out = Vec::new();
            let bodies: Vec<usize> = (0..26).collect();
            get(&head, &cands, [&bodies[..]].into_iter(), |_, _| {}, &mut out);
            out
        };
        refused(&one_island, 0.1, "a body in no island");
        let with_an_empty_island = {
            let mut v = v.clone();
            v[first_island - 1] = 3.0;
            v.extend([0.0, 0.0]);
            v
        };
        refused(&with_an_empty_island, 0.1, "an island without bodies");
    }
}
