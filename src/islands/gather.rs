//! What the scene's own model and data receive from the islands (see [`Islands::gather`]):
//! coordinates, time, energies, counters, the contact events and the contact memory, so that
//! every output, energy and saved state reads them as with one integrator.

use super::Islands;
use crate::model::log::EVENT_LOG_CAPACITY;
use crate::model::{ContactEvent, Data, Model};

impl Islands {
    /// Writes the islands' coordinates and time into the scene's data.
    pub(super) fn put_coordinates(&self, d: &mut Data) {
        for island in &self.parts {
            island.put_coordinates(&mut d.state);
        }
        d.time = self.time;
    }

    /// Writes the islands' motion into the scene's data `d` of model `m`: coordinates, time,
    /// dissipated energy, counters and the contact events logged since the last gathering
    /// (numbered by the islands' candidate list, their partition's).
    pub fn gather(&mut self, m: &Model, d: &mut Data) {
        self.put_coordinates(d);
        let n_explicit = self.n_explicit;
        let (mut dissipated, mut counters) = (self.dissipated_base, self.retired);
        let mut input_work = self.input_work_base;
        // (the log holds the events gathered before, in order; those of this gathering follow)
        let sorted = d.event_log.len();
        let mut logged = !self.retired_log.is_empty();
        d.event_log.append(&mut self.retired_log);
        for (k, island) in self.parts.iter_mut().enumerate() {
            dissipated += island.dissipated();
            input_work += island.input_work();
            counters = counters + island.data.counters;
            let listed = d.partition.listed(k);
            for e in &island.data.event_log {
                if let Some(g) = island.scene_contact(e.contact, n_explicit, listed) {
                    d.event_log.push(ContactEvent { contact: g, ..*e });
                    logged = true;
                }
            }
            island.data.event_log.clear();
        }
        if logged {
            insert_in_order(&mut d.event_log, sorted);
            let excess = d.event_log.len().saturating_sub(EVENT_LOG_CAPACITY);
            d.event_log.drain(..excess);
        }
        d.state[m.dissipated_index()] = dissipated;
        if let Some(i) = m.input_work_index() {
            d.state[i] = input_work;
        }
        d.counters = counters;
        d.outputs_valid = false;
        d.kinematics_valid = false;
    }

    /// Writes the islands' contact memory into the scene's data `d`, which must have the
    /// islands' candidate pairs (and their partition).
    pub fn gather_contacts(&self, d: &mut Data) {
        debug_assert!(d.candidates == d.partition.list());
        for (j, island) in self.parts.iter().enumerate() {
            let listed = d.partition.listed(j);
            for (k, mem) in island.data.contact_memory.iter().enumerate() {
                if let Some(g) = island.scene_contact(k, self.n_explicit, listed) {
                    d.contact_memory[g] = *mem;
                }
            }
        }
        d.outputs_valid = false;
    }

    /// The dissipated energy and the input work \[J\] that no present island holds: those
    /// of islands that ended, and the work of a host moving a driven joint.
    pub fn work_not_in_islands(&self) -> (f64, f64) {
        (self.dissipated_base, self.input_work_base)
    }

    /// Adds work of the inputs done outside the islands' integration (a host moving a driven
    /// joint) \[J\].
    pub fn add_input_work(&mut self, work: f64) {
        self.input_work_base += work;
    }
}

/// Puts the entries of `log` from `sorted` on in order among those before it (`log[..sorted]`,
/// in order), by time and then by contact: they are sorted among themselves, then each moves
/// back past the former entries that come after it, which are few, as the events of a
/// communication step follow those gathered before (an entry of the same time and contact
/// stays after the former ones). Allocates nothing.
fn insert_in_order(log: &mut [ContactEvent], sorted: usize) {
    let order = |a: &ContactEvent, b: &ContactEvent| a.time.total_cmp(&b.time).then(a.contact.cmp(&b.contact));
    log[sorted..].sort_unstable_by(order);
    for i in sorted..log.len() {
        let e = log[i];
        let mut j = i;
        while j > 0 && order(&log[j - 1], &e).is_gt() {
            log[j] = log[j - 1];
            j -= 1;
        }
        log[j] = e;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ContactEventKind;
    use proptest::collection::vec;
    use proptest::prop_assert;

    fn key(a: &ContactEvent, b: &ContactEvent) -> std::cmp::Ordering {
        a.time.total_cmp(&b.time).then(a.contact.cmp(&b.contact))
    }

    /// An event at `time` of `contact`, numbered `k` (in `delta`: the former entries below 100).
    fn event(time: u8, contact: usize, k: usize) -> ContactEvent {
        ContactEvent {
            time: f64::from(time),
            contact,
            kind: ContactEventKind::Touch,
            delta: k as f64,
            delta_dot: 0.0,
            force: 0.0,
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig { cases: 200, ..Default::default() })]

        /// The insertion leaves the whole log in order (by time, then contact), with every
        /// entry it had, the former entries in their order and before the new ones of the same
        /// time and contact: sorted logs with new entries that interleave with the former
        /// ones, repeat their keys and come in any order.
        #[test]
        fn new_events_go_in_order_among_the_former_ones(
            former in vec((0u8..6, 0usize..3), 0..20),
            new in vec((0u8..8, 0usize..3), 0..20),
        ) {
            let mut log: Vec<ContactEvent> =
                former.iter().enumerate().map(|(k, &(t, c))| event(t, c, k)).collect();
            log.sort_by(key);
            let before = log.clone();
            log.extend(new.iter().enumerate().map(|(k, &(t, c))| event(t, c, 100 + k)));
            let every = log.clone();
            insert_in_order(&mut log, before.len());
            prop_assert!(log.windows(2).all(|w| key(&w[0], &w[1]).is_le()), "{:?}", log);
            let numbers = |v: &[ContactEvent]| {
                let mut n: Vec<u64> = v.iter().map(|e| e.delta as u64).collect();
                n.sort_unstable();
                n
            };
            prop_assert!(numbers(&log) == numbers(&every));
            let kept: Vec<ContactEvent> = log.iter().copied().filter(|e| e.delta < 100.0).collect();
            prop_assert!(kept == before, "the former entries in their order");
            for w in log.windows(2) {
                if key(&w[0], &w[1]).is_eq() && w[1].delta < 100.0 {
                    prop_assert!(w[0].delta < 100.0, "a new entry before a former one of its time and contact");
                }
            }
        }
    }
}
