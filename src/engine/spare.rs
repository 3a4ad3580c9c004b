//! Spare buffers: large working arrays kept for the next solve of the same size.
//!
//! A simulation solves the same size of grid every frame. Fresh buffers of tens of megabytes
//! cost a page fault per 4 KiB on first touch, which measured as much as the transposes of
//! the FFTs themselves; reusing the last frame's buffers costs nothing. Only buffers of the
//! size asked for are reused, a request of another size empties the store (a different grid
//! now), and at most `KEEP` buffers of one type are kept.
//!
//! The key decision is how kept buffers meet the run's memory budget (`crate::engine::budget`): a
//! buffer in a store is memory the process holds, so it is charged to the budget of the run
//! that gave it back for as long as it waits; a buffer that does not fit is freed instead of
//! kept. A buffer in use is charged by its user (who reserves its working set before taking
//! one), so `take` hands over a kept buffer's charge by dropping it. And because kept buffers
//! are only a speed-up, a reservation that would not fit sheds every store first
//! (`shed_all`): the budget refuses a request only when what is really in use leaves no room.

use crate::engine::budget::Reservation;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

/// Buffers kept per store at most.
const KEEP: usize = 4;

/// A store of spare `Vec<T>` buffers, each with the budget it is charged to.
pub struct Spare<T> {
    buffers: Mutex<Vec<(Vec<T>, Reservation)>>,
    /// Whether this store is in `STORES` (done on its first `give`).
    listed: AtomicBool,
}

/// A store that can free what it keeps.
trait Shed: Sync {
    fn shed(&self);
}

impl<T: Send> Shed for Spare<T> {
    fn shed(&self) {
        // Taken out under the lock, freed after it.
        let kept = std::mem::take(&mut *self.buffers.lock().unwrap_or_else(|e| e.into_inner()));
        drop(kept);
    }
}

/// Every store that has kept a buffer, for `shed_all`.
static STORES: Mutex<Vec<&'static dyn Shed>> = Mutex::new(Vec::new());

/// Frees every kept buffer of every store, giving their bytes back to the budgets they were
/// charged to. Called by the budget before it refuses a request.
pub fn shed_all() {
    let stores: Vec<&'static dyn Shed> = STORES.lock().unwrap_or_else(|e| e.into_inner()).clone();
    for store in stores {
        store.shed();
    }
}

impl<T: Clone + Default + Send> Spare<T> {
    pub const fn new() -> Spare<T> {
        Spare {
            buffers: Mutex::new(Vec::new()),
            listed: AtomicBool::new(false),
        }
    }

    /// A buffer of `len` elements. Its contents are unspecified (a reused buffer keeps what it
    /// held): callers overwrite every element. The caller has reserved its memory already; a
    /// kept buffer's own charge ends here.
    pub fn take(&self, len: usize) -> Vec<T> {
        let mut buffers = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        match buffers.iter().position(|(b, _)| b.len() == len) {
            Some(at) => buffers.swap_remove(at).0,
            None => {
                let stale = std::mem::take(&mut *buffers);
                drop(buffers);
                drop(stale);
                vec![T::default(); len]
            }
        }
    }

    /// Keeps `buffer` for a later `take` if the current run's budget has room for it (without
    /// shedding other stores for it); frees it otherwise.
    pub fn give(&'static self, buffer: Vec<T>) {
        if buffer.is_empty() {
            return;
        }
        {
            let buffers = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
            if buffers.len() >= KEEP || buffers.iter().any(|(b, _)| b.len() != buffer.len()) {
                return;
            }
        }
        let bytes = (buffer.capacity() * std::mem::size_of::<T>()) as f64;
        let Ok(charge) = crate::engine::current()
            .budget
            .reserve_unshed(bytes, "a spare buffer")
        else {
            return;
        };
        if !self.listed.swap(true, Ordering::Relaxed) {
            STORES.lock().unwrap_or_else(|e| e.into_inner()).push(self);
        }
        let mut buffers = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        if buffers.len() < KEEP && buffers.iter().all(|(b, _)| b.len() == buffer.len()) {
            buffers.push((buffer, charge));
        }
    }
}

impl<T: Clone + Default + Send> Default for Spare<T> {
    fn default() -> Spare<T> {
        Spare::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::Engine;

    static STORE: Spare<f64> = Spare::new();

    #[test]
    fn kept_buffers_are_charged_and_shed_before_a_refusal() {
        std::thread::spawn(|| {
            let engine = Engine::with_memory_limit(10_000);
            let _entered = engine.enter();
            STORE.give(vec![0.0; 500]);
            assert_eq!(engine.budget.used(), 4000, "a kept buffer is charged");
            // Another buffer of the same size does not fit beside it and a request that
            // would: the store is shed for the request, not kept against it.
            STORE.give(vec![0.0; 500]);
            assert_eq!(engine.budget.used(), 8000);
            let held = engine.budget.reserve(5000.0, "a cache").unwrap();
            assert_eq!(engine.budget.used(), 5000, "the kept buffers were shed");
            assert_eq!(STORE.take(500).len(), 500);
            // A buffer that does not fit is freed, not kept.
            STORE.give(vec![0.0; 1000]);
            assert_eq!(engine.budget.used(), 5000);
            drop(held);
            // Taking a kept buffer ends its charge: its user has reserved it.
            STORE.give(vec![0.0; 500]);
            assert_eq!(engine.budget.used(), 4000);
            let _in_use = STORE.take(500);
            assert_eq!(engine.budget.used(), 0);
        })
        .join()
        .unwrap();
    }
}
