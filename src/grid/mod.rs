//! Grids: domains, the caches that sample fields over them, and grid file formats.

pub mod cache;
pub mod dense;
pub mod frustum;
pub mod interp;
pub mod points;
pub mod reach;
pub mod vdb;
pub mod vdb_cache;

/// A number no other grid of this run has: what field nodes that read a grid are keyed by.
/// Every kind of grid draws from this one counter, so two grids never share a key.
pub fn next_identity() -> u64 {
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}
