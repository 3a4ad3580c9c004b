//! Spare buffers: large working arrays kept for the next solve of the same size.
//!
//! A simulation solves the same size of grid every frame. Fresh buffers of tens of megabytes
//! cost a page fault per 4 KiB on first touch, which measured as much as the transposes of
//! the FFTs themselves; reusing the last frame's buffers costs nothing. The one key decision:
//! only buffers of the size asked for are reused, a request of another size empties the store
//! (a different grid now), and at most `KEEP` buffers of one type are kept, so what the store
//! holds is bounded by a few grids of the largest size in use.

use std::sync::Mutex;

/// Buffers kept per store at most.
const KEEP: usize = 4;

/// A store of spare `Vec<T>` buffers.
pub struct Spare<T> {
    buffers: Mutex<Vec<Vec<T>>>,
}

impl<T: Clone + Default> Spare<T> {
    pub const fn new() -> Spare<T> {
        Spare {
            buffers: Mutex::new(Vec::new()),
        }
    }

    /// A buffer of `len` elements. Its contents are unspecified (a reused buffer keeps what it
    /// held): callers overwrite every element.
    pub fn take(&self, len: usize) -> Vec<T> {
        let mut buffers = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        match buffers.iter().position(|b| b.len() == len) {
            Some(at) => buffers.swap_remove(at),
            None => {
                buffers.clear();
                drop(buffers);
                vec![T::default(); len]
            }
        }
    }

    /// Keeps `buffer` for a later `take`.
    pub fn give(&self, buffer: Vec<T>) {
        let mut buffers = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        if buffers.len() < KEEP && buffers.iter().all(|b| b.len() == buffer.len()) {
            buffers.push(buffer);
        }
    }
}

impl<T: Clone + Default> Default for Spare<T> {
    fn default() -> Spare<T> {
        Spare::new()
    }
}
