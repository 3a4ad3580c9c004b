//! Demand: running the whole-grid solves an output needs, before the output runs.
//!
//! Caches fill brick by brick on first touch, from any thread, and never start parallel work
//! inside a fill. A whole-grid solve (`fftdivfree`) cannot work that way: it must sample its
//! input at every cell and transform the lot, and it wants all threads for that. Started from
//! inside another parallel evaluation, a solve that waits on its own worker tasks lets the
//! waiting thread steal unrelated tasks, which may touch the very grid being solved — a
//! deadlock. The one key decision: every output (`render`, `probe`, `stats`, `cachefill`,
//! `cachesave`, meshing) first walks the grids its field reads, through every pending cache
//! and solve to the grids *they* read, and runs the unsolved solves oldest first, from the
//! calling thread, before any parallel evaluation starts. A solve reached some other way (by a
//! caller that skipped this step) still runs correctly, on one thread.
//!
//! What nothing reaches is never visited, so a simulation whose results no output reads
//! solves nothing, and frame 40 of a sequence solves only what frame 40 depends on.

use crate::base::failure::Outcome;
use crate::space::GridSource;
use std::collections::HashSet;
use std::sync::Arc;

/// Solves every unsolved grid that `grids` depend on, inputs before the grids that read them.
/// Iterative, so a dependency chain thousands of frames long does not exhaust the stack.
pub fn solve_ahead(grids: Vec<Arc<dyn GridSource>>) -> Outcome<()> {
    let mut visited = HashSet::new();
    let mut stack: Vec<(Arc<dyn GridSource>, bool)> =
        grids.into_iter().rev().map(|g| (g, false)).collect();
    while let Some((grid, inputs_done)) = stack.pop() {
        if inputs_done {
            grid.solve()?;
            continue;
        }
        if !visited.insert(grid.identity()) {
            continue;
        }
        let inputs = grid.pending_inputs();
        stack.push((grid, true));
        for input in inputs.into_iter().rev() {
            if !visited.contains(&input.identity()) {
                stack.push((input, false));
            }
        }
    }
    Ok(())
}
