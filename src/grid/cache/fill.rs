//! Filling bricks: evaluating a field at a brick's cell centres, or finding it empty.
//!
//! The one key decision: a brick is one batch — its cell centres, row by row, go to the
//! source's block evaluator in blocks of `sample::BLOCK` — and it is computed exactly once,
//! inside its `OnceLock`, whether an eager `fill_all` or a lazy query got there first. So the
//! stored values depend only on the brick, never on the order or the thread that filled it.
//! Before evaluating, the evaluator is focused on the box of the brick's cell centres, which
//! gives the source's range there and lets a compiled field drop the choices the box decides
//! (`field::prune`); a range of exactly the background skips the evaluation.

use super::{BRICK, BRICK_CELLS, Brick, Cache, MAX_WIDTH, local_index, lock};
use crate::space::{Aabb, BLOCK, BlockEval, FieldSampler};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::Ordering;
use std::time::Instant;

/// Per-thread space for brick fills: positions of a brick's cell centres and their values.
struct FillScratch {
    xs: Vec<f64>,
    ys: Vec<f64>,
    zs: Vec<f64>,
    out: Vec<f32>,
}

impl FillScratch {
    fn new() -> FillScratch {
        FillScratch {
            xs: vec![0.0; BRICK_CELLS],
            ys: vec![0.0; BRICK_CELLS],
            zs: vec![0.0; BRICK_CELLS],
            out: vec![0.0; BRICK_CELLS * MAX_WIDTH],
        }
    }
}

/// What some brick fills did, added into the cache's counters in one go: counters written by
/// every thread for every brick would bounce one cache line between the cores.
#[derive(Default)]
struct Tally {
    resolved: usize,
    skipped: usize,
    nanos: u64,
}

impl Tally {
    fn and(self, other: Tally) -> Tally {
        Tally {
            resolved: self.resolved + other.resolved,
            skipped: self.skipped + other.skipped,
            nanos: self.nanos + other.nanos,
        }
    }
}

impl Cache {
    /// Fills every unresolved brick, in parallel across bricks. Each rayon task makes one
    /// evaluator and reuses it for the bricks it takes.
    pub fn fill_all(&self) {
        let Some(source) = lock(&self.source).clone() else {
            return;
        };
        let pending: Vec<usize> = (0..self.bricks.len())
            .filter(|&index| self.bricks[index].get().is_none())
            .collect();
        let tally = pending
            .par_iter()
            .map_init(
                || (source.evaluator(), FillScratch::new()),
                |(evaluator, scratch), &index| {
                    let mut tally = Tally::default();
                    self.bricks[index].get_or_init(|| {
                        let source = source.as_ref();
                        self.compute_brick(index, source, evaluator.as_mut(), scratch, &mut tally)
                    });
                    tally
                },
            )
            .reduce(Tally::default, Tally::and);
        self.settle(tally);
    }

    /// Adds what brick fills did into the cache's counters.
    fn settle(&self, tally: Tally) {
        self.skipped.fetch_add(tally.skipped, Ordering::Relaxed);
        self.fill_nanos.fetch_add(tally.nanos, Ordering::Relaxed);
        self.note_resolved_many(tally.resolved);
    }

    /// Runs the whole-grid solves the pending bricks read (see `grid::demand`); outputs call
    /// this before `fill_all`, so that a failed solve is an error of the output.
    pub fn prepare(&self) -> crate::base::failure::Outcome<()> {
        let source = lock(&self.source).clone();
        match source {
            Some(source) => crate::space::demand::solve_ahead(source.grids()),
            None => Ok(()),
        }
    }

    pub(super) fn fill_lazily(&self, index: usize) -> Brick {
        let source = lock(&self.source).clone();
        match source {
            Some(source) => {
                let mut evaluator = source.evaluator();
                let mut scratch = FillScratch::new();
                let mut tally = Tally::default();
                let brick = self.compute_brick(
                    index,
                    source.as_ref(),
                    evaluator.as_mut(),
                    &mut scratch,
                    &mut tally,
                );
                self.settle(tally);
                brick
            }
            // The source goes only after every brick is resolved, so an unresolved brick
            // always finds it; background is the safe answer should that ever change.
            None => self.uniform_brick(),
        }
    }

    /// World box of the centres of cells `lo .. hi`.
    fn centre_box(&self, lo: [usize; 3], hi: [usize; 3]) -> Aabb {
        let first = self.domain.cell_center(lo[0], lo[1], lo[2]);
        let mut bounds = Aabb::new(first, first);
        // The domain may be rotated: take all eight corner centres.
        for n in 1..8 {
            let pick = |bit: usize, a: usize| if n & bit != 0 { hi[a] - 1 } else { lo[a] };
            let corner = self.domain.cell_center(pick(1, 0), pick(2, 1), pick(4, 2));
            bounds = bounds.union(&Aabb::new(corner, corner));
        }
        bounds
    }

    /// Evaluates one brick (or finds it empty by its range). Called exactly once per brick,
    /// from inside its `OnceLock`.
    fn compute_brick(
        &self,
        index: usize,
        source: &dyn FieldSampler,
        evaluator: &mut dyn BlockEval,
        scratch: &mut FillScratch,
        tally: &mut Tally,
    ) -> Brick {
        let started = Instant::now();
        let (lo, hi) = self.shape.brick_cells(index);
        let centres = self.centre_box(lo, hi);
        let range = evaluator
            .focus(&centres)
            .unwrap_or_else(|| source.range(&centres));
        let background_only = range.len() == self.width
            && range
                .iter()
                .zip(&self.background)
                .all(|(&(low, high), &b)| low == b && high == b);
        if background_only {
            let brick = self.uniform_brick();
            let nanos = started.elapsed().as_nanos() as u64;
            tally.skipped += 1;
            tally.nanos += nanos;
            tally.resolved += 1;
            if let Some(stats) = &self.profile {
                stats.add_skipped(nanos);
            }
            return brick;
        }

        let FillScratch { xs, ys, zs, out } = scratch;
        let row_cells = hi[0] - lo[0];
        let width = self.width;
        let cells = row_cells * (hi[1] - lo[1]) * (hi[2] - lo[2]);
        if source.fill_cells(&self.domain, lo, hi, &mut out[..cells * width]) {
            // Cell-major already: copy row by row into the brick's 8×8×8 order.
            let mut values = self.background_brick.clone();
            let row = row_cells * width;
            for (n, from) in out[..cells * width].chunks_exact(row).enumerate() {
                let (y, z) = (n % (hi[1] - lo[1]), n / (hi[1] - lo[1]));
                let at = local_index(0, y, z) * width;
                values[at..at + row].copy_from_slice(from);
            }
            return self.finish_computed(index, values, started, tally);
        }
        // `Domain::cell_center` computes origin + ((X lx + Y ly) + Z lz) with the rotation's
        // columns X, Y, Z; each product depends on one index, so taking them once per index
        // and adding them in the same order gives the same positions bit for bit, cheaper.
        let rotation = self.domain.rotation;
        let origin = self.domain.origin;
        let cell = self.domain.cell;
        let along = |axis: usize, column: DVec3, i: usize| column * ((i as f64 + 0.5) * cell[axis]);
        let mut row = [DVec3::ZERO; BRICK];
        for (x, product) in (lo[0]..hi[0]).zip(&mut row) {
            *product = along(0, rotation.x_axis, x);
        }
        let mut count = 0;
        for z in lo[2]..hi[2] {
            let cz = along(2, rotation.z_axis, z);
            for y in lo[1]..hi[1] {
                let cy = along(1, rotation.y_axis, y);
                let end = count + row_cells;
                let positions = xs[count..end]
                    .iter_mut()
                    .zip(&mut ys[count..end])
                    .zip(&mut zs[count..end]);
                for (((px, py), pz), cx) in positions.zip(&row[..row_cells]) {
                    let p = origin + (*cx + cy + cz);
                    (*px, *py, *pz) = (p.x, p.y, p.z);
                }
                count = end;
            }
        }
        for block_start in (0..count).step_by(BLOCK) {
            let n = BLOCK.min(count - block_start);
            let block = block_start..block_start + n;
            let out = &mut out[block_start * width..(block_start + n) * width];
            evaluator.eval_f32(&xs[block.clone()], &ys[block.clone()], &zs[block], out);
        }
        // Each block came back component-major; storage is cell-major in 8×8×8 order.
        let mut values = self.background_brick.clone();
        let mut point = 0;
        for z in 0..hi[2] - lo[2] {
            for y in 0..hi[1] - lo[1] {
                let at = local_index(0, y, z) * width;
                if width == 1 {
                    values[at..at + row_cells].copy_from_slice(&out[point..point + row_cells]);
                    point += row_cells;
                    continue;
                }
                for x in 0..row_cells {
                    let block_start = point / BLOCK * BLOCK;
                    let n = BLOCK.min(count - block_start);
                    let block = &out[block_start * width..(block_start + n) * width];
                    for c in 0..width {
                        values[at + x * width + c] = block[c * n + point - block_start];
                    }
                    point += 1;
                }
            }
        }
        self.finish_computed(index, values, started, tally)
    }

    /// Stores a computed brick and counts its time.
    fn finish_computed(
        &self,
        index: usize,
        values: Box<[f32]>,
        started: Instant,
        tally: &mut Tally,
    ) -> Brick {
        let brick = self.store_computed(index, values);
        let nanos = started.elapsed().as_nanos() as u64;
        tally.nanos += nanos;
        tally.resolved += 1;
        if let Some(stats) = &self.profile {
            let bytes = brick.values.as_ref().map_or(0, |v| v.len() as u64 * 4);
            stats.add_filled(nanos, bytes);
        }
        brick
    }

    /// Given data for a brick (constructors from data).
    pub(super) fn store_given(&self, index: usize, values: Box<[f32]>) {
        let brick = self.store_computed(index, values);
        // Each index is set once, by the constructor that owns the cache.
        let _ = self.bricks[index].set(brick);
        self.note_resolved();
    }

    /// Scans a brick's values: range, non-finite values, and whether it is all background.
    fn store_computed(&self, index: usize, values: Box<[f32]>) -> Brick {
        let width = self.width;
        let (lo, hi) = self.shape.brick_cells(index);
        let size = [0, 1, 2].map(|a| hi[a] - lo[a]);
        let Scan {
            mut range,
            has_nan,
            all_background,
            nonzero,
        } = match width {
            1 => scan::<1>(&values, size, &self.background_brick),
            3 => scan::<3>(&values, size, &self.background_brick),
            _ => scan::<MAX_WIDTH>(&values, size, &self.background_brick),
        };
        let all_finite =
            (0..width).all(|c| !has_nan[c] && range[c].0.is_finite() && range[c].1.is_finite());
        if !all_finite {
            self.note_nonfinite(&values, lo, size);
        }
        for c in 0..width {
            if has_nan[c] {
                range[c] = (f32::NEG_INFINITY, f32::INFINITY);
            }
        }
        self.filled.fetch_add(1, Ordering::Relaxed);
        let values = if all_background {
            None
        } else {
            self.stored_bytes
                .fetch_add(values.len() as u64 * 4, Ordering::Relaxed);
            Some(values)
        };
        let cells = size[0] * size[1] * size[2];
        let some_zero = nonzero
            .iter()
            .map(|row| row.count_ones() as usize)
            .sum::<usize>()
            < cells;
        let nonzero = (values.is_some() && some_zero).then(|| {
            self.stored_bytes
                .fetch_add(nonzero.len() as u64, Ordering::Relaxed);
            Box::new(nonzero)
        });
        Brick {
            values,
            range,
            nonzero,
        }
    }

    /// Counts a brick's non-finite values and keeps the lowest-numbered cell holding one.
    /// The brick's cells start at cell `lo` and span `size`.
    fn note_nonfinite(&self, values: &[f32], lo: [usize; 3], size: [usize; 3]) {
        let width = self.width;
        let mut count = 0u64;
        let mut first: Option<[usize; 3]> = None;
        for z in 0..size[2] {
            for y in 0..size[1] {
                let at = local_index(0, y, z) * width;
                let row = &values[at..at + size[0] * width];
                for (x, sample) in row.chunks_exact(width).enumerate() {
                    let bad = sample.iter().filter(|v| !v.is_finite()).count() as u64;
                    if bad > 0 {
                        count += bad;
                        first.get_or_insert([lo[0] + x, lo[1] + y, lo[2] + z]);
                    }
                }
            }
        }
        let Some([x, y, z]) = first else {
            return;
        };
        self.nonfinite.fetch_add(count, Ordering::Relaxed);
        let cell = self.shape.cell_index(x, y, z);
        let mut slot = lock(&self.first_nonfinite);
        if slot.is_none_or(|(earliest, _)| cell < earliest) {
            *slot = Some((cell, self.domain.cell_center(x, y, z)));
        }
    }

    /// Counts a resolved brick; the last one releases the source.
    pub(super) fn note_resolved(&self) {
        self.note_resolved_many(1);
    }

    /// Notes `count` more resolved bricks; the last drops the source.
    fn note_resolved_many(&self, count: usize) {
        if count == 0 {
            return;
        }
        let before = self.resolved.fetch_add(count, Ordering::AcqRel);
        if before == 0
            && let Some(stats) = &self.profile
        {
            // The first brick of this cache: one more grid evaluated at its line.
            stats.add_evaluated();
        }
        if before + count == self.bricks.len() {
            let source = lock(&self.source).take();
            drop(source);
        }
    }
}

/// What a pass over a brick's cells finds.
struct Scan {
    /// Smallest and largest non-NaN value per component.
    range: [(f32, f32); MAX_WIDTH],
    has_nan: [bool; MAX_WIDTH],
    /// Does every cell equal the background, bit for bit?
    all_background: bool,
    /// Cells with a component other than zero, as `Brick::nonzero`.
    nonzero: [u8; BRICK * BRICK],
}

/// Scans the cells of a brick whose cells span `size`, with `W` components each.
fn scan<const W: usize>(values: &[f32], size: [usize; 3], background: &[f32]) -> Scan {
    let mut low = [f32::INFINITY; W];
    let mut high = [f32::NEG_INFINITY; W];
    let mut nan = [false; W];
    let mut differs = false;
    let background: [u32; W] = std::array::from_fn(|c| background[c].to_bits());
    let mut nonzero = [0u8; BRICK * BRICK];
    for z in 0..size[2] {
        for y in 0..size[1] {
            let at = local_index(0, y, z) * W;
            let (samples, _) = values[at..at + size[0] * W].as_chunks::<W>();
            // NaN compares unequal to zero, so it counts as not zero.
            nonzero[y + BRICK * z] = samples.iter().enumerate().fold(0u8, |bits, (x, sample)| {
                bits | (u8::from(sample.iter().any(|&v| v != 0.0)) << x)
            });
            for sample in samples {
                for c in 0..W {
                    let v = sample[c];
                    // Comparisons with NaN are false, so NaN stays out of the range (it is
                    // noted apart); written as selects so the loop vectorises.
                    low[c] = if v < low[c] { v } else { low[c] };
                    high[c] = if v > high[c] { v } else { high[c] };
                    nan[c] |= v.is_nan();
                    differs |= v.to_bits() != background[c];
                }
            }
        }
    }
    let mut scan = Scan {
        range: [(f32::INFINITY, f32::NEG_INFINITY); MAX_WIDTH],
        has_nan: [false; MAX_WIDTH],
        all_background: !differs,
        nonzero,
    };
    for c in 0..W {
        scan.range[c] = (low[c], high[c]);
        scan.has_nan[c] = nan[c];
    }
    scan
}
