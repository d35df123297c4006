//! The handles this library has handed out and not yet freed.
//!
//! An `fmi2Component` or `fmi2FMUstate` is the address of a boxed [`Instance`] or
//! [`SavedState`]. Instead of reading a marker behind the pointer (which, after the free, is
//! itself undefined behaviour), every export first asks the matching registry whether the
//! address is live: NULL, a freed handle, a handle of the other kind or any other value is
//! refused without touching memory.
//!
//! Each registry is a mutex over a set of addresses, held only for the insertion, lookup or
//! removal, never during a call, so instances on different threads run in parallel. It does
//! not make concurrent calls on *one* instance safe (FMI 2.0 forbids them): a host that frees
//! a handle on one thread while using it on another still races. A freed address may be
//! handed out again by a later allocation; a stale handle then names that new, live object.
//!
//! [`Instance`]: super::Instance
//! [`SavedState`]: super::saved::SavedState

use super::instance::Instance;
use super::saved::SavedState;
use std::collections::BTreeMap;
use std::marker::PhantomData;
use std::sync::{Mutex, MutexGuard, PoisonError};

/// The addresses of the live boxes of one type `T`, each with the address of its owner (the
/// instance that made a state; 0: none).
pub(crate) struct Registry<T> {
    live: Mutex<BTreeMap<usize, usize>>,
    // The registry owns no `T` and is `Sync` whatever `T` is: it holds plain addresses.
    kind: PhantomData<fn(T)>,
}

/// Live `fmi2Component`s.
pub(crate) static INSTANCES: Registry<Instance> = Registry::new();
/// Live `fmi2FMUstate`s.
pub(crate) static STATES: Registry<SavedState> = Registry::new();

impl<T> Registry<T> {
    const fn new() -> Registry<T> {
        Registry {
            live: Mutex::new(BTreeMap::new()),
            kind: PhantomData,
        }
    }

    /// The map. A panic while it was held cannot have left it half-updated (each use is one
    /// map operation, or a loop of removals that each leave it whole), so a poisoned lock is
    /// taken over.
    fn lock(&self) -> MutexGuard<'_, BTreeMap<usize, usize>> {
        self.live.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Leaks `value` into a raw pointer and records it as live, owned by nothing.
    pub(crate) fn register(&self, value: Box<T>) -> *mut T {
        self.register_owned(value, 0)
    }

    /// Leaks `value` into a raw pointer and records it as live, owned by `owner` (an address).
    pub(crate) fn register_owned(&self, value: Box<T>, owner: usize) -> *mut T {
        let p = Box::into_raw(value);
        self.lock().insert(p as usize, owner);
        p
    }

    /// Makes `owner` the owner of the live `p` (nothing when `p` is not live).
    pub(crate) fn set_owner(&self, p: *const T, owner: usize) {
        if let Some(o) = self.lock().get_mut(&(p as usize)) {
            *o = owner;
        }
    }

    /// Removes every handle `owner` owns from the live set and gives their boxes back (to be
    /// dropped).
    ///
    /// # Safety
    /// No reference to any of them is in use, on any thread (for FMU states: the host does
    /// not use the states of an instance while it frees the instance).
    pub(crate) unsafe fn release_owned_by(&self, owner: usize) -> Vec<Box<T>> {
        let mut live = self.lock();
        let owned: Vec<usize> = live.iter().filter(|&(_, &o)| o == owner).map(|(&p, _)| p).collect();
        for p in &owned {
            live.remove(p);
        }
        if live.is_empty() {
            *live = BTreeMap::new();
        }
        // SAFETY: each was live, so it came from `Box::into_raw` in `register_owned` and has
        // not been turned back into a box; removing it under the lock makes this its only
        // release, and nothing uses it (this function's contract).
        owned
            .into_iter()
            .map(|p| unsafe { Box::from_raw(p as *mut T) })
            .collect()
    }

    /// True when `p` was returned by [`Registry::register`] and not yet released. NULL never
    /// is.
    pub(crate) fn contains(&self, p: *const T) -> bool {
        !p.is_null() && self.lock().contains_key(&(p as usize))
    }

    /// Removes `p` from the live set and gives its box back (to be dropped); `None`, touching
    /// nothing, when `p` is not live. Of two threads releasing the same handle, one gets it.
    ///
    /// # Safety
    /// No reference to `*p` is in use, on any thread, when it is released (for an FMI handle:
    /// the host does not call functions on it concurrently with the free).
    pub(crate) unsafe fn release(&self, p: *mut T) -> Option<Box<T>> {
        {
            let mut live = self.lock();
            live.remove(&(p as usize))?;
            if live.is_empty() {
                // Frees the set's own node, so nothing is left allocated once every handle is
                // freed (a host may then unload the library).
                *live = BTreeMap::new();
            }
        }
        // SAFETY: `p` was live, so it came from `Box::into_raw` in `register` and has not been
        // turned back into a box; removing it from the set under the lock makes this the only
        // release. No reference to it is in use (this function's contract).
        Some(unsafe { Box::from_raw(p) })
    }

    /// How many handles are live.
    #[cfg(test)]
    fn len(&self) -> usize {
        self.lock().len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registered_boxes_are_live_until_released_once() {
        let r: Registry<u64> = Registry::new();
        let p = r.register(Box::new(7));
        assert!(r.contains(p));
        assert!(!r.contains(std::ptr::null()));
        assert!(!r.contains(p.wrapping_add(1)));
        // SAFETY: no reference to `*p` exists.
        let b = unsafe { r.release(p) };
        assert_eq!(b.as_deref(), Some(&7));
        assert!(!r.contains(p));
        assert_eq!(r.len(), 0);
        // SAFETY: a released address is refused without being read.
        assert!(unsafe { r.release(p) }.is_none());
        // SAFETY: NULL and a never-registered address are refused without being read.
        unsafe {
            assert!(r.release(std::ptr::null_mut()).is_none());
            assert!(r.release(0x10 as *mut u64).is_none());
        }
    }

    #[test]
    fn an_owners_boxes_are_released_together_and_no_others() {
        let r: Registry<u64> = Registry::new();
        let (a, b) = (r.register_owned(Box::new(1), 10), r.register_owned(Box::new(2), 20));
        let c = r.register_owned(Box::new(3), 10);
        r.set_owner(b, 10);
        r.set_owner(a, 30);
        // SAFETY: no reference to any box exists.
        let mut freed: Vec<u64> = unsafe { r.release_owned_by(10) }.into_iter().map(|b| *b).collect();
        freed.sort();
        assert_eq!(freed, [2, 3]);
        assert!(r.contains(a) && !r.contains(b) && !r.contains(c));
        // SAFETY: as above.
        assert!(unsafe { r.release_owned_by(10) }.is_empty());
        // SAFETY: as above.
        assert_eq!(unsafe { r.release(a) }.as_deref(), Some(&1));
        assert_eq!(r.len(), 0);
    }
}
