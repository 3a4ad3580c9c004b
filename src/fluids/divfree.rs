//! `fftdivfree`: a velocity sampled on a domain's cells with its divergent part removed, as a
//! grid that is solved only when something reads it.
//!
//! What "divergence-free" means here: the **central-difference** divergence of the stored
//! samples, `Σ_a (u_a[i + e_a] − u_a[i − e_a]) / 2h_a` along the domain's own axes, wrapping
//! around (the grid is one period of a periodic field), vanishes to round-off. The projection
//! removes, in Fourier space, each mode's component along that operator's own wave vector
//! `sin(k_a h_a) / h_a`, with the Nyquist modes (invisible to central differences) kept exactly
//! as they are, so projecting twice changes nothing. Reads of the result use the same central
//! differences for `grad`, `div` and `curl`, so `div(fftdivfree(U, d))` is zero at every cell
//! centre away from the border (at the border the difference reaches the background outside,
//! not the periodic image).
//!
//! The one key decision is laziness with parallelism: making the node samples nothing. The
//! solve runs when an output (through `grid::demand`) or a read first needs it: the input is
//! sampled at every cell centre in `f64`, rotated into the domain's frame, projected, rotated
//! back to world axes and stored in `f64` (`dense`). Then the input field is released, so the
//! previous frame's velocity it read can be freed: memory stays flat over a simulation. A
//! solve first reached from inside another parallel evaluation runs on a thread pool of its
//! own, so it never waits on tasks that could need the grid it is computing.

use crate::base::failure::{Failure, Outcome};
use crate::engine::profile::{self, GridStats};
use crate::fluids::fft::{
    DivergenceOperator, PROJECTION_BYTES_PER_CELL, check_working_memory,
    project_divergence_free_with,
};
use crate::grid::dense::{DenseGrid, SPARE_VALUES};
use crate::space::domain::Domain;
use crate::space::{Aabb, BLOCK, FieldSampler, GridSource, Interp, Lattice};
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

/// A divergence-free projection of a vectorfield over a domain's cells.
pub struct DivergenceFree {
    domain: Domain,
    source: Mutex<Option<Arc<dyn FieldSampler>>>,
    solved: OnceLock<Result<DenseGrid, Failure>>,
    /// The solved grid's share of the run's memory budget, held while it lives.
    memory: OnceLock<crate::engine::budget::Reservation>,
    /// Held while solving, so one thread solves and the others wait for its result.
    solving: Mutex<()>,
    identity: u64,
    label: String,
    profile: Arc<GridStats>,
}

/// The failure of a solve stopped by an interrupt (Ctrl-C, a watchdog).
const INTERRUPTED: &str = "interrupted";

/// Bricks of 8³ cells in a domain, the unit in which `--profile` counts grid work.
fn bricks_of(cells: [usize; 3]) -> u64 {
    cells.iter().map(|&n| n.div_ceil(8) as u64).product()
}

impl DivergenceFree {
    /// The projection of `source` (a vectorfield) over `domain`, labelled `label` in profiles
    /// and messages. Checks the domain and the memory the solve will need now, before any work.
    pub fn new(
        domain: Domain,
        source: Arc<dyn FieldSampler>,
        label: String,
    ) -> Outcome<DivergenceFree> {
        if source.width() != 3 {
            return Err(Failure::new(format!(
                "fftdivfree needs a vectorfield, found a field of {} component(s)",
                source.width()
            )));
        }
        let Some(cells) = domain.resolution else {
            return Err(
                Failure::new("fftdivfree needs a domain with cells").with_help(
                    "give the domain a cell size: domain d(origin, lengths, orientation, cell)",
                ),
            );
        };
        // Stored f64 result, the f64 samples being projected, and the transforms' spectra.
        // Checked here, at the fftdivfree line, so a solve too large fails before any work;
        // the solve takes its share of the budget when it runs.
        drop(check_working_memory(
            cells,
            2 * 3 * 8 + PROJECTION_BYTES_PER_CELL,
            "fftdivfree",
        )?);
        let profile = profile::register("fftdivfree", &label);
        profile.add_instance(bricks_of(cells));
        Ok(DivergenceFree {
            domain,
            source: Mutex::new(Some(source)),
            solved: OnceLock::new(),
            memory: OnceLock::new(),
            solving: Mutex::new(()),
            identity: crate::grid::next_identity(),
            label,
            profile,
        })
    }

    /// The solved value of cell `(i, j, k)` in world axes, solving first; `None` outside or
    /// when the solve failed.
    pub fn cell_value(&self, i: usize, j: usize, k: usize) -> Option<DVec3> {
        let cells = self.domain.resolution?;
        if i >= cells[0] || j >= cells[1] || k >= cells[2] {
            return None;
        }
        let grid = self.solved().ok()?;
        Some(DVec3::from_slice(grid.cell(i, j, k)))
    }

    /// Has the solve run (successfully or not)?
    pub fn is_solved(&self) -> bool {
        self.solved.get().is_some()
    }

    /// The solved grid, solving it first. An interrupted solve is not kept: the next read
    /// solves again (the REPL's Ctrl-C leaves the simulation usable).
    fn solved(&self) -> Result<&DenseGrid, Failure> {
        fn kept(result: &Result<DenseGrid, Failure>) -> Result<&DenseGrid, Failure> {
            result.as_ref().map_err(Clone::clone)
        }
        if let Some(result) = self.solved.get() {
            return kept(result);
        }
        let _turn = self
            .solving
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        if let Some(result) = self.solved.get() {
            return kept(result);
        }
        let result = if rayon::current_thread_index().is_some() {
            // Inside a parallel evaluation: solve on a pool of our own, from a thread that is
            // no worker of the outer pool, so waiting never steals outer tasks. (A session's
            // own thread is worker 0 of its pool, so this is the path a solve takes.) The pool
            // is made here, where the run's engine is current, so its workers use it.
            let pool = crate::engine::worker_pool(rayon::current_num_threads());
            std::thread::scope(|scope| {
                let solver = std::thread::Builder::new()
                    .stack_size(crate::engine::budget::WORKER_STACK_BYTES)
                    .spawn_scoped(scope, || match pool {
                        Ok(pool) => pool.install(|| self.run()),
                        Err(_) => self.run(),
                    });
                match solver {
                    Ok(solver) => solver
                        .join()
                        .unwrap_or_else(|_| Err(Failure::new("the fftdivfree solve failed"))),
                    Err(e) => Err(Failure::new(format!(
                        "cannot start a thread for the fftdivfree solve: {e}"
                    ))
                    .with_help("pass a smaller `--threads` or raise `ulimit -v`")),
                }
            })
        } else {
            self.run()
        };
        if let Err(failure) = &result
            && failure.message == INTERRUPTED
        {
            return Err(failure.clone());
        }
        let _ = self.solved.set(result);
        match self.solved.get() {
            Some(result) => kept(result),
            None => Err(Failure::new("the fftdivfree solve failed")),
        }
    }

    fn source(&self) -> Option<Arc<dyn FieldSampler>> {
        self.source
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .clone()
    }

    fn run(&self) -> Result<DenseGrid, Failure> {
        let started = Instant::now();
        let Some(source) = self.source() else {
            return Err(Failure::new("fftdivfree lost its input before solving"));
        };
        let result = self.project(source.as_ref());
        if matches!(&result, Err(f) if f.message == INTERRUPTED) {
            return result;
        }
        // The input (and the grids it reads, such as the previous frame's velocity) is no
        // longer needed, whatever the outcome.
        *self
            .source
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner()) = None;
        drop(source);
        if let Ok(grid) = &result {
            self.profile
                .add_work(started.elapsed().as_nanos() as u64, grid.bytes());
            let cells = self.domain.resolution.unwrap_or([1, 1, 1]);
            self.profile.add_resolved(bricks_of(cells), 0);
            self.profile.add_evaluated();
        }
        result
    }

    /// Samples, projects and stores.
    fn project(&self, source: &dyn FieldSampler) -> Result<DenseGrid, Failure> {
        let domain = &self.domain;
        let cells = domain.resolution.unwrap_or([1, 1, 1]);
        let [nx, ny, nz] = cells;
        let n = nx * ny * nz;
        let bytes = (3 * n * std::mem::size_of::<f64>()) as f64;
        let _samples = crate::engine::budget::reserve(bytes, "fftdivfree's samples")?;
        // Sample row by row (x fastest), in blocks of at most BLOCK points: the same blocks on
        // any thread count, so the same values. Component-major, as the projection takes them.
        let mut planes = SPARE_VALUES.take(3 * n);
        let (px, rest) = planes.split_at_mut(n);
        let (py, pz) = rest.split_at_mut(n);
        px.par_chunks_mut(nx)
            .zip(py.par_chunks_mut(nx))
            .zip(pz.par_chunks_mut(nx))
            .enumerate()
            .for_each_init(
                || {
                    (
                        source.evaluator(),
                        [vec![0.0; BLOCK], vec![0.0; BLOCK], vec![0.0; BLOCK]],
                        vec![0.0; 3 * BLOCK],
                    )
                },
                |(evaluator, [xs, ys, zs], out), (row, ((rx, ry), rz))| {
                    if crate::engine::interrupt::requested() {
                        return;
                    }
                    let (j, k) = (row % ny, row / ny);
                    let mut start = 0;
                    while start < nx {
                        let len = (nx - start).min(BLOCK);
                        for t in 0..len {
                            let p = domain.cell_center(start + t, j, k);
                            (xs[t], ys[t], zs[t]) = (p.x, p.y, p.z);
                        }
                        let block = &mut out[..3 * len];
                        evaluator.eval_f64(&xs[..len], &ys[..len], &zs[..len], block);
                        rx[start..start + len].copy_from_slice(&block[..len]);
                        ry[start..start + len].copy_from_slice(&block[len..2 * len]);
                        rz[start..start + len].copy_from_slice(&block[2 * len..]);
                        start += len;
                    }
                },
            );
        if crate::engine::interrupt::requested() {
            return Err(Failure::new(INTERRUPTED));
        }
        // Checked on all threads; the first bad value is then found in order.
        let any_bad = planes.par_iter().any(|v| !v.is_finite());
        if let Some(at) = any_bad
            .then(|| planes.iter().position(|v| !v.is_finite()))
            .flatten()
        {
            let cell = at % n;
            let (i, j, k) = (cell % nx, cell / nx % ny, cell / (nx * ny));
            let p = domain.cell_center(i, j, k);
            return Err(Failure::new(format!(
                "the velocity given to {} is not finite ({}) at cell ({i}, {j}, {k}), position ({}, {}, {})",
                self.label, planes[at], p.x, p.y, p.z
            ))
            .with_help("a NaN or infinite velocity usually comes from a division by zero or a NaN time step upstream"));
        }
        // Into the domain's frame for the projection.
        let rotated = domain.rotation != DMat3::IDENTITY;
        if rotated {
            let to_local = domain.rotation.transpose();
            rotate_planes(&mut planes, n, to_local);
        }
        project_divergence_free_with(
            cells,
            domain.cell,
            &mut planes,
            DivergenceOperator::CentralDifference,
        )?;
        if rotated {
            rotate_planes(&mut planes, n, domain.rotation);
        }
        // Interleaved for reading: a trilinear read touches one place per cell.
        let _ = self.memory.set(crate::engine::budget::reserve(
            bytes,
            "fftdivfree's result",
        )?);
        let mut interleaved = SPARE_VALUES.take(3 * n);
        interleaved
            .par_chunks_mut(3)
            .enumerate()
            .for_each(|(cell, out)| {
                out.copy_from_slice(&[planes[cell], planes[n + cell], planes[2 * n + cell]]);
            });
        SPARE_VALUES.give(planes);
        Ok(DenseGrid::new(domain.clone(), 3, interleaved, vec![0.0; 3]))
    }
}

/// Turns the vector at every cell of component-major planes by `rotation`.
fn rotate_planes(planes: &mut [f64], n: usize, rotation: DMat3) {
    let (px, rest) = planes.split_at_mut(n);
    let (py, pz) = rest.split_at_mut(n);
    px.par_iter_mut()
        .zip(py.par_iter_mut())
        .zip(pz.par_iter_mut())
        .for_each(|((x, y), z)| {
            let v = rotation * DVec3::new(*x, *y, *z);
            (*x, *y, *z) = (v.x, v.y, v.z);
        });
}

impl Drop for DivergenceFree {
    fn drop(&mut self) {
        if let Some(Ok(grid)) = self.solved.get() {
            self.profile.release(grid.bytes());
        }
    }
}

impl std::fmt::Debug for DivergenceFree {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DivergenceFree")
            .field("label", &self.label)
            .field("solved", &self.is_solved())
            .finish()
    }
}

impl GridSource for DivergenceFree {
    fn width(&self) -> usize {
        3
    }

    fn identity(&self) -> u64 {
        self.identity
    }

    fn label(&self) -> String {
        self.label.clone()
    }

    fn sample(&self, interp: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        match self.solved() {
            Ok(grid) => grid.sample(interp, xs, ys, zs, out),
            // The failure is reported by the output that asked for the solve; the values
            // are NaN so that nothing downstream mistakes them for a velocity.
            Err(_) => out[..3 * xs.len()].fill(f64::NAN),
        }
    }

    fn sample_gradient(&self, interp: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        match self.solved() {
            Ok(grid) => grid.sample_gradient(interp, xs, ys, zs, out),
            Err(_) => out[..9 * xs.len()].fill(f64::NAN),
        }
    }

    fn bounds(&self) -> Aabb {
        self.domain.bounds()
    }

    fn background(&self) -> Vec<f64> {
        vec![0.0; 3]
    }

    fn cell_size(&self) -> DVec3 {
        self.domain.cell
    }

    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        match self.solved() {
            Ok(grid) => grid.range(region),
            Err(_) => vec![(f64::NEG_INFINITY, f64::INFINITY); 3],
        }
    }

    fn lattice(&self) -> Option<Lattice> {
        Some(self.domain.lattice())
    }

    fn pending_inputs(&self) -> Vec<Arc<dyn GridSource>> {
        match self.source() {
            Some(source) if !self.is_solved() => source.grids(),
            _ => Vec::new(),
        }
    }

    fn solve(&self) -> Outcome<()> {
        self.solved().map(|_| ())
    }
}

#[cfg(test)]
mod tests;
