//! Splatting a flame as it is made: the chaos game of `chaos`, with every dot added straight
//! into the fixed-point sums of a count cache and a colour cache, so no dot is ever stored.
//! Eighty million dots take the memory of the brick layers they reach, not 1.9 GiB of dots.
//!
//! The key decision: each worker thread keeps its own sparse table of sums, brick layer by
//! brick layer, and the tables are added together at the end. Integer addition is exact and
//! order-free, so which worker adds which block's dots does not matter: the caches are
//! bit-identical for any thread count. The count is also bit-identical to `splat` of the
//! stored dots, since its fixed-point scale (from the number of dots) and each dot's shares
//! are the same. The colour's scale comes from a bound on the dots' colours (the map colours
//! and the colour field's range) rather than from their sum, which only a stored set can take,
//! so a colour cell may differ from the stored path's in its last bit.

use super::chaos::{self, Report, Settings, Sink};
use super::guide::Guide;
use super::splat::{Indexer, Kernel, Landing, SplatReport, Target, check_shape, fixed, shares};
use super::splat_bins::scale_for_magnitude;
use crate::base::failure::{Failure, Outcome};
use crate::engine::budget::Reservation;
use crate::grid::cache::{BRICK, BRICK_CELLS, Cache};
use crate::space::Aabb;
use crate::space::domain::Domain;
use rayon::prelude::*;
use std::sync::Mutex;

/// A cache the flame is splatted into.
pub struct SplatInto<'a> {
    pub domain: &'a Domain,
    pub kernel: Kernel,
    pub background: &'a [f64],
    /// The cache's earlier state, which the dots add to.
    pub previous: Option<&'a Cache>,
}

/// Cells in one layer of a brick (8 × 8 cells at one z): the unit in which sums are kept.
/// A flat or thin flame reaches one or two layers of each brick it crosses, so keeping whole
/// bricks would spread its sums over four times the pages (and TLB entries) it needs.
const LAYER_CELLS: usize = BRICK * BRICK;
/// Layers in each run of sums: a power of two, so a layer's place in the runs is a shift and
/// a mask of its number rather than a lookup. Only the pages a dot reaches are ever touched,
/// so a run's untouched tail costs address space, not memory.
const RUN_LAYERS: usize = 512;

/// One worker's sums of `W` components per cell, brick layer by brick layer, in a few long
/// runs of memory rather than one allocation per layer.
struct LayerSums<const W: usize> {
    /// Brick columns along x, and in all (layer `(bx, by, z)` is `bx + row·by + columns·z`).
    row: usize,
    columns: usize,
    /// Per layer of the grid: 0 when it has no sums yet, else its place in `layers` plus one.
    slots: Vec<u32>,
    /// The layers with sums, in the order they were reached.
    layers: Vec<usize>,
    runs: Vec<Vec<i64>>,
    memory: Vec<Reservation>,
    outside: u64,
}

impl<const W: usize> LayerSums<W> {
    const LAYER_SUMS: usize = LAYER_CELLS * W;

    /// Sums for a grid of `cells`.
    fn new(cells: [usize; 3]) -> Outcome<LayerSums<W>> {
        let (row, column) = (cells[0].div_ceil(BRICK), cells[1].div_ceil(BRICK));
        let total = row.saturating_mul(column).saturating_mul(cells[2]);
        if total >= u32::MAX as usize {
            return Err(Failure::new(
                "a flame splat takes a grid of fewer than 2^32 brick layers",
            ));
        }
        let table = crate::engine::budget::reserve((total * 4) as f64, "flame splat layer table")?;
        Ok(LayerSums {
            row,
            columns: row * column,
            slots: vec![0; total],
            layers: Vec::new(),
            runs: Vec::new(),
            memory: vec![table],
            outside: 0,
        })
    }

    /// The layer holding `cell` and the cell's index in it.
    #[inline]
    fn locate(&self, cell: [usize; 3]) -> (usize, usize) {
        let layer = cell[0] / BRICK + (cell[1] / BRICK) * self.row + cell[2] * self.columns;
        (layer, cell[0] % BRICK + BRICK * (cell[1] % BRICK))
    }

    /// The brick holding layer `layer`, and the layer's depth in it.
    fn brick_of(&self, layer: usize) -> (usize, usize) {
        let (column, z) = (layer % self.columns, layer / self.columns);
        (column + (z / BRICK) * self.columns, z % BRICK)
    }

    /// Where layer `layer`'s sums are (run, start), giving it zeroed sums when it has none.
    #[inline]
    fn place(&mut self, layer: usize) -> Outcome<(usize, usize)> {
        let s = self.slots[layer] as usize;
        if s != 0 {
            return Ok(Self::run_and_start(s - 1));
        }
        self.give_sums(layer)
    }

    /// The run and start of the `s`-th layer reached.
    #[inline]
    fn run_and_start(s: usize) -> (usize, usize) {
        (s / RUN_LAYERS, (s % RUN_LAYERS) * Self::LAYER_SUMS)
    }

    /// Gives layer `layer` the next free sums, starting a new run of zeroed sums when the
    /// last one is full.
    #[cold]
    fn give_sums(&mut self, layer: usize) -> Outcome<(usize, usize)> {
        let s = self.layers.len();
        let (run, start) = Self::run_and_start(s);
        if run == self.runs.len() {
            let len = RUN_LAYERS * Self::LAYER_SUMS;
            self.memory.push(crate::engine::budget::reserve(
                (len * 8) as f64,
                "flame splat sums",
            )?);
            self.runs.push(vec![0i64; len]);
        }
        self.layers.push(layer);
        self.slots[layer] = self.layers.len() as u32;
        Ok((run, start))
    }

    /// The sums of the `s`-th layer reached.
    fn sums(&self, s: usize) -> &[i64] {
        let (run, start) = Self::run_and_start(s);
        &self.runs[run][start..start + Self::LAYER_SUMS]
    }

    /// Adds one dot's `scaled` value (value times the fixed-point scale).
    #[inline]
    fn add(&mut self, l: &Landing, kernel: Kernel, scaled: [f64; W]) -> Outcome<()> {
        if kernel == Kernel::Nearest {
            let (layer, local) = self.locate(l.cell);
            let (run, start) = self.place(layer)?;
            let at = start + local * W;
            let sums = &mut self.runs[run][at..at + W];
            for c in 0..W {
                sums[c] += fixed(scaled[c]);
            }
            return Ok(());
        }
        let mut at = [(0usize, 0usize); 8];
        // Mostly the stencil's x and y stay in one brick: a lookup per layer it reaches.
        let inside = (0..2).all(|a| l.step[a] == 0 || l.cell[a] % BRICK != BRICK - 1);
        if inside {
            let (layer, local) = self.locate(l.cell);
            let below = self.place(layer)?;
            let above = match l.step[2] {
                0 => below,
                _ => self.place(layer + self.columns)?,
            };
            let (sx, sy) = (l.step[0], l.step[1] * BRICK);
            for (corner, o) in [0, sx, sy, sx + sy].into_iter().enumerate() {
                at[corner] = (below.0, below.1 + (local + o) * W);
                at[corner + 4] = (above.0, above.1 + (local + o) * W);
            }
        } else {
            for (corner, slot) in at.iter_mut().enumerate() {
                let cell = [0, 1, 2].map(|a| l.cell[a] + l.step[a] * (corner >> a & 1));
                let (layer, local) = self.locate(cell);
                let (run, start) = self.place(layer)?;
                *slot = (run, start + local * W);
            }
        }
        let weights = l.weights();
        let runs = &mut self.runs;
        for c in 0..W {
            shares(scaled[c], &weights, |corner, q| {
                let (run, at) = at[corner];
                runs[run][at + c] += q;
            });
        }
        Ok(())
    }

    /// Adds another worker's sums into these.
    fn absorb(&mut self, other: LayerSums<W>) -> Outcome<()> {
        self.outside += other.outside;
        for (s, &layer) in other.layers.iter().enumerate() {
            let (run, start) = self.place(layer)?;
            let mine = &mut self.runs[run][start..start + Self::LAYER_SUMS];
            for (x, y) in mine.iter_mut().zip(other.sums(s)) {
                *x += y;
            }
        }
        Ok(())
    }

    /// The bricks reached, ascending, each with its layers reached: (brick, [(depth, s)]).
    fn bricks(&self) -> Vec<(usize, Vec<(usize, usize)>)> {
        let mut order: Vec<(usize, usize, usize)> = self
            .layers
            .iter()
            .enumerate()
            .map(|(s, &layer)| {
                let (brick, depth) = self.brick_of(layer);
                (brick, depth, s)
            })
            .collect();
        order.sort_unstable();
        let mut bricks: Vec<(usize, Vec<(usize, usize)>)> = Vec::new();
        for (brick, depth, s) in order {
            match bricks.last_mut() {
                Some((b, layers)) if *b == brick => layers.push((depth, s)),
                _ => bricks.push((brick, vec![(depth, s)])),
            }
        }
        bricks
    }

    /// A brick's sums in brick order (x fastest, then y, then z), zero in layers not reached.
    fn brick_sums(&self, layers: &[(usize, usize)]) -> Vec<i64> {
        let mut brick = vec![0i64; BRICK_CELLS * W];
        for &(depth, s) in layers {
            brick[depth * Self::LAYER_SUMS..(depth + 1) * Self::LAYER_SUMS]
                .copy_from_slice(self.sums(s));
        }
        brick
    }
}

/// Where one worker's dots go: the indexers and scales of the caches, and its sums. Count
/// and colour on one domain share one table of four sums per cell (count, red, green, blue),
/// so a dot lands once and touches one cell's sums.
struct Worker<'a> {
    count: Option<(&'a Indexer, f64, LayerSums<1>)>,
    color: Option<(&'a Indexer, f64, LayerSums<3>)>,
    joint: Option<(&'a Indexer, [f64; 2], LayerSums<4>)>,
}

impl Sink for Worker<'_> {
    #[inline]
    fn dot(&mut self, _: usize, _: usize, position: [f32; 3], color: [f32; 3]) -> Outcome<()> {
        if let Some((indexer, [count, tint], sums)) = &mut self.joint {
            let [r, g, b] = color.map(|c| c as f64 * *tint);
            return deposit(indexer, sums, position, [*count, r, g, b]);
        }
        if let Some((indexer, scale, sums)) = &mut self.count {
            deposit(indexer, sums, position, [*scale])?;
        }
        if let Some((indexer, scale, sums)) = &mut self.color {
            deposit(indexer, sums, position, color.map(|c| c as f64 * *scale))?;
        }
        Ok(())
    }
}

/// Adds one dot's `scaled` value at `position`, or counts it outside.
#[inline]
fn deposit<const W: usize>(
    indexer: &Indexer,
    sums: &mut LayerSums<W>,
    position: [f32; 3],
    scaled: [f64; W],
) -> Outcome<()> {
    match indexer.land(position) {
        Some(l) => sums.add(&l, indexer.kernel, scaled),
        None => {
            sums.outside += 1;
            Ok(())
        }
    }
}

/// A bound on the sum of |component| over one dot's colour, or `None` when the colour field's
/// range is not finite.
fn color_bound(settings: &Settings) -> Option<f64> {
    let mut bound = 0.0;
    for c in 0..3 {
        let maps = settings
            .maps
            .iter()
            .map(|m| m.color[c].abs())
            .fold(0.0, f64::max);
        // A dot's colour is an average of map colours, or of a map colour and the colour
        // field's value; rounding to f32 can carry it a hair past the bound in f64.
        let field = match settings.color {
            Some(f) => {
                let (lo, hi) = f.range(&Aabb::everything())[c];
                let most = lo.abs().max(hi.abs());
                if !most.is_finite() {
                    return None;
                }
                most
            }
            None => 0.0,
        };
        bound += maps.max(field) * (1.0 + 1e-6);
    }
    Some(bound)
}

/// The dots of `chaos::generate(guides, count, seed, settings)`, splatted as they are made:
/// a count of dots into `count_into` and their colours into `color_into`. Returns the caches'
/// new states (in that order, for those given) with their reports, and the game's report.
pub fn splat_flame(
    guides: &[Guide],
    count: usize,
    seed: u64,
    settings: &Settings,
    count_into: Option<&SplatInto>,
    color_into: Option<&SplatInto>,
) -> Outcome<(Vec<(Cache, SplatReport)>, Report)> {
    let (cumulative, dots) = chaos::prepare(guides, count, settings)?;
    let indexer =
        |into: Option<&SplatInto>| into.map(|i| Indexer::new(i.domain, i.kernel)).transpose();
    let (count_indexer, color_indexer) = (indexer(count_into)?, indexer(color_into)?);
    let count_scale = scale_for_magnitude(dots as f64)?;
    let color_scale = match color_into {
        None => 1.0,
        Some(_) => {
            let bound = color_bound(settings).ok_or_else(|| {
                Failure::new(
                    "the colour field's range is not finite, so it cannot be splatted as made",
                )
                .with_help("use flamewisp and splat, which take the sum of the stored colours")
            })?;
            scale_for_magnitude(dots as f64 * bound)?
        }
    };
    for (into, indexer, width) in [
        (count_into, &count_indexer, 1),
        (color_into, &color_indexer, 3),
    ] {
        if let (Some(into), Some(indexer)) = (into, indexer) {
            check_shape(width, into.background, into.previous, indexer)?;
        }
    }
    let joint = match (count_into, color_into) {
        (Some(a), Some(b)) => a.domain == b.domain && a.kernel == b.kernel,
        _ => false,
    };
    let workers: Vec<Mutex<Option<Worker>>> = (0..rayon::current_num_threads().max(1))
        .map(|_| Mutex::new(None))
        .collect();
    let new_worker = || -> Outcome<Worker> {
        if joint && let Some(i) = &count_indexer {
            return Ok(Worker {
                count: None,
                color: None,
                joint: Some((i, [count_scale, color_scale], LayerSums::new(i.cells)?)),
            });
        }
        Ok(Worker {
            count: match &count_indexer {
                Some(i) => Some((i, count_scale, LayerSums::new(i.cells)?)),
                None => None,
            },
            color: match &color_indexer {
                Some(i) => Some((i, color_scale, LayerSums::new(i.cells)?)),
                None => None,
            },
            joint: None,
        })
    };
    let blocks = chaos::blocks(guides.len(), count, settings.iterations);
    // A worker that waits inside a block (a field that runs parallel work) may take up
    // another block on the same thread; that block gets sums of its own, kept aside.
    let aside: Mutex<Vec<Worker>> = Mutex::new(Vec::new());
    let restarts: Vec<u64> = blocks
        .par_iter()
        .map(|block| {
            let t = rayon::current_thread_index().unwrap_or(0) % workers.len();
            let run = |sink: &mut Worker| {
                chaos::run_block(
                    &guides[block.guide],
                    block,
                    seed,
                    settings,
                    &cumulative,
                    sink,
                )
            };
            match workers[t].try_lock() {
                Ok(mut worker) => {
                    if worker.is_none() {
                        *worker = Some(new_worker()?);
                    }
                    run(worker.as_mut().expect("the worker was just made"))
                }
                Err(_) => {
                    let mut own = new_worker()?;
                    let restarts = run(&mut own)?;
                    aside.lock().unwrap_or_else(|e| e.into_inner()).push(own);
                    Ok(restarts)
                }
            }
        })
        .collect::<Outcome<_>>()?;
    let aside = aside.into_inner().unwrap_or_else(|e| e.into_inner());
    let mut all = workers
        .into_iter()
        .filter_map(|w| w.into_inner().unwrap_or_else(|e| e.into_inner()))
        .chain(aside);
    let mut merged = match all.next() {
        Some(w) => w,
        None => new_worker()?,
    };
    for w in all {
        if let (Some(a), Some(b)) = (&mut merged.count, w.count) {
            a.2.absorb(b.2)?;
        }
        if let (Some(a), Some(b)) = (&mut merged.color, w.color) {
            a.2.absorb(b.2)?;
        }
        if let (Some(a), Some(b)) = (&mut merged.joint, w.joint) {
            a.2.absorb(b.2)?;
        }
    }
    let mut out = Vec::new();
    if let Some((indexer, [count_scale, color_scale], sums)) = merged.joint {
        if let Some(into) = count_into {
            out.push(finish::<1, 4>(into, indexer, count_scale, &sums, 0, dots)?);
        }
        if let Some(into) = color_into {
            out.push(finish::<3, 4>(into, indexer, color_scale, &sums, 1, dots)?);
        }
    }
    if let (Some(into), Some((indexer, scale, sums))) = (count_into, merged.count) {
        out.push(finish::<1, 1>(into, indexer, scale, &sums, 0, dots)?);
    }
    if let (Some(into), Some((indexer, scale, sums))) = (color_into, merged.color) {
        out.push(finish::<3, 3>(into, indexer, scale, &sums, 0, dots)?);
    }
    Ok((
        out,
        Report {
            restarts: restarts.iter().sum(),
        },
    ))
}

/// A cache's new state from components `first..first + W` of the merged sums,
/// and its report, whose total is the integer sums themselves: exactly what the cells got.
fn finish<const W: usize, const S: usize>(
    into: &SplatInto,
    indexer: &Indexer,
    scale: f64,
    sums: &LayerSums<S>,
    first: usize,
    dots: usize,
) -> Outcome<(Cache, SplatReport)> {
    let target = Target {
        domain: into.domain,
        background: into.background,
        previous: into.previous,
        counts: indexer.cells.map(|c| c.div_ceil(BRICK)),
    };
    let mut total = [0i128; 3];
    for s in 0..sums.layers.len() {
        for cell in sums.sums(s).chunks_exact(S) {
            for c in 0..W {
                total[c] += cell[first + c] as i128;
            }
        }
    }
    let bricks: Vec<(usize, Box<[f32]>)> = sums
        .bricks()
        .into_par_iter()
        .map(|(b, layers)| {
            let brick = sums.brick_sums(&layers);
            (b, target.values_of::<W>(b, &brick, S, first, scale))
        })
        .collect();
    let cache = target.assemble(W, bricks)?;
    let report = SplatReport {
        splatted: dots as u64 - sums.outside,
        outside: sums.outside,
        total: total.map(|t| t as f64 / scale),
    };
    Ok((cache, report))
}
