//! The islands' own part of a saved state: the counters, energies and rebuilds not held by an
//! island, the end of the present round, the candidate pairs, and per island its bodies and
//! whole state (the section after the scene's state in a snapshot).

use super::{candidate_body, Islands, Source};
use crate::compile::Parameters;
use crate::engine;
use crate::model::groups::Candidate;
use crate::model::{state, Counters, Data, Model};

impl Islands {
    /// Appends the islands' own state: the retired counters, the dissipated energy and the
    /// input work not held by an island, the rebuilds, the end of the present round, the candidate pairs, then per
    /// island its bodies and its whole state.
    pub fn save(&self, out: &mut Vec<f64>) {
        let r = self.retired;
        out.extend([r.steps, r.rejected, r.rhs_evals, r.jac_evals, r.events].map(|x| x as f64));
        out.push(self.dissipated_base);
        out.push(self.input_work_base);
        out.push(self.rebuilds as f64);
        out.push(self.round_end);
        out.push(self.candidates.len() as f64);
        for c in &self.candidates {
            out.extend([c.pair, c.sphere, c.other].map(|x| x as f64));
        }
        out.push(self.parts.len() as f64);
        let mut v = Vec::new();
        for island in &self.parts {
            out.push(island.bodies.len() as f64);
            out.extend(island.bodies.iter().map(|&b| b as f64));
            v.clear();
            state::get(&island.model, &island.data, state::FULL, &mut v);
            out.push(v.len() as f64);
            out.extend_from_slice(&v);
        }
    }

    /// The islands saved by [`Islands::save`], for the scene's model `m` and data `d` (both
    /// restored from the same saved state). Anything that does not fit is refused.
    pub fn load(src: &Source, params: Parameters, m: &Model, d: &Data, v: &[f64]) -> Result<Islands, String> {
        let mut r = Numbers { v, pos: 0 };
        let mut counts = [0u64; 5];
        for c in &mut counts {
            *c = r.count(u64::MAX)? as u64;
        }
        let dissipated_base = r.next()?;
        let input_work_base = r.next()?;
        let rebuilds = r.count(u64::MAX)? as u64;
        let round_end = r.next()?;
        if round_end.is_nan() || round_end < d.time {
            return Err(format!(
                "saved islands: round end {round_end} before their time {}",
                d.time
            ));
        }
        let (np, ns) = (m.groups.pair_names.len() as u64, m.groups.shapes.len() as u64);
        let nc = r.count(v.len() as u64)?;
        if nc > 0 && (np == 0 || ns == 0) {
            return Err("saved islands hold candidate pairs, the scene has no contact groups".into());
        }
        let mut candidates = Vec::with_capacity(nc);
        for _ in 0..nc {
            let pair = r.count(np.saturating_sub(1))?;
            let sphere = r.count(ns.saturating_sub(1))?;
            let other = r.count(ns.saturating_sub(1))?;
            candidates.push(Candidate { pair, sphere, other });
        }
        let nb = m.bodies.len();
        let n = r.count(nb as u64)?;
        let mut lists = Vec::with_capacity(n);
        let mut seen = vec![false; nb];
        let mut states = Vec::with_capacity(n);
        for _ in 0..n {
            let len = r.count(nb as u64)?;
            let mut bodies = Vec::with_capacity(len);
            for _ in 0..len {
                let b = r.count(nb as u64 - 1)?;
                if seen[b] || bodies.last().is_some_and(|&l| l >= b) {
                    return Err("saved islands: a body is listed twice or out of order".into());
                }
                seen[b] = true;
                bodies.push(b);
            }
            let len = r.count(v.len() as u64)?;
            states.push(r.take(len)?);
            lists.push(bodies);
        }
        if r.pos != v.len() || seen.iter().any(|s| !s) {
            return Err("saved islands: they do not hold every body once".into());
        }
        let mut is = Islands::bare(src, params, m, d);
        is.candidate_index = candidates.iter().enumerate().map(|(i, c)| (*c, i)).collect();
        is.candidates = candidates;
        let memory = is.memory_of_scene(m, d);
        let mut parts = Vec::with_capacity(n);
        for (bodies, st) in lists.into_iter().zip(states) {
            let cands: Vec<Candidate> = is
                .candidates
                .iter()
                .filter(|c| candidate_body(m, c).is_some_and(|b| bodies.binary_search(&b).is_ok()))
                .copied()
                .collect();
            let mut island = is
                .compile_island(src, m, d, bodies, cands, &memory)
                .map_err(|e| e.message)?;
            if state::group_candidates(&island.model, st).as_ref() != Some(&island.data.candidates)
                && island.model.groups.is_active()
            {
                return Err("saved islands: an island's candidate pairs are not the scene's".into());
            }
            state::set(&island.model, &mut island.data, state::FULL, st)?;
            engine::resync(&island.model, &mut island.data);
            parts.push(island);
        }
        for (k, island) in parts.iter().enumerate() {
            for &b in &island.bodies {
                is.island_of[b] = k;
            }
        }
        is.parts = parts;
        is.retired = Counters {
            steps: counts[0],
            rejected: counts[1],
            rhs_evals: counts[2],
            jac_evals: counts[3],
            events: counts[4],
        };
        is.dissipated_base = dissipated_base;
        is.input_work_base = input_work_base;
        is.rebuilds = rebuilds;
        is.round_end = round_end;
        is.time = d.time;
        Ok(is)
    }
}

/// Reads numbers with checks.
struct Numbers<'a> {
    v: &'a [f64],
    pos: usize,
}

impl<'a> Numbers<'a> {
    fn next(&mut self) -> Result<f64, String> {
        let x = *self.v.get(self.pos).ok_or("saved islands are truncated")?;
        self.pos += 1;
        Ok(x)
    }
    /// A whole number in 0..=max.
    fn count(&mut self, max: u64) -> Result<usize, String> {
        let x = self.next()?;
        if !(x >= 0.0 && x.fract() == 0.0 && x <= max as f64) {
            return Err(format!("saved islands: {x} is not a count up to {max}"));
        }
        Ok(x as usize)
    }
    fn take(&mut self, n: usize) -> Result<&'a [f64], String> {
        let s = self
            .v
            .get(self.pos..self.pos + n)
            .ok_or("saved islands are truncated")?;
        self.pos += n;
        Ok(s)
    }
}
