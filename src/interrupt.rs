//! Ctrl-C at the REPL: one process-wide flag that a signal handler sets and that long-running
//! work polls (the interpreter at every loop iteration and call, the engine between blocks), so
//! an interrupted evaluation unwinds as an ordinary error and the session keeps its state.

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Asks the running evaluation to stop.
pub fn request() {
    REQUESTED.store(true, Ordering::Relaxed);
}

/// Has a stop been asked for since the last `clear`?
pub fn requested() -> bool {
    REQUESTED.load(Ordering::Relaxed)
}

/// Forgets an earlier request (at the start of each evaluation).
pub fn clear() {
    REQUESTED.store(false, Ordering::Relaxed);
}
