//! Ctrl-C: a flag of the current engine (`crate::engine`) that a signal handler sets and that
//! long-running work polls (the interpreter at every loop iteration and call, the engine
//! between blocks), so an interrupted evaluation unwinds as an ordinary error and the session
//! keeps its state. The flag belongs to the engine, not the process, so interrupting one
//! session leaves another running; a signal handler holds the engine it interrupts
//! (`Engine::interrupt`).

/// Asks the evaluation running on the current engine to stop.
pub fn request() {
    crate::engine::with(|e| e.interrupt());
}

/// Has a stop been asked for since the last `clear`?
pub fn requested() -> bool {
    crate::engine::with(|e| e.interrupted())
}

/// Forgets an earlier request (at the start of each evaluation).
pub fn clear() {
    crate::engine::with(|e| e.clear_interrupt());
}
