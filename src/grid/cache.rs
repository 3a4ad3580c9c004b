//! Caches: a field sampled at the cell centres of a domain, stored sparsely, filled on demand.
//!
//! A [`Cache`] is one immutable *state*: `cachewrite` makes a new one (behind an `Arc`), so a
//! field that read an earlier state keeps reading it. Storage is a table of bricks of 8×8×8
//! cells (the bricks at the far faces are partial). The one key decision: each brick is
//! computed the first time any query touches it — one batch evaluation of its cell centres,
//! behind a `OnceLock`, so any number of threads may query at once and every value equals what
//! an eager fill would store, bit for bit, whatever the order of queries or the thread count.
//!
//! Around that:
//! - Values are stored in `f32`, the storage and rendering precision; positions are `f64`.
//! - Before evaluating a brick the cache asks the source for the range of its values over the
//!   brick's cell centres; when that range is exactly the background, the brick is marked
//!   uniform without evaluating it (counted as *skipped*). Evaluated bricks whose every value
//!   equals the background bit for bit are stored uniform too. Uniform bricks cost no memory.
//! - The source field is held only until every brick is resolved, then dropped, so old states
//!   of a simulation release their field graphs.
//! - A brick fill never uses rayon itself: a thread waiting on a brick another thread is filling
//!   blocks, and a rayon task stolen while filling could be that waiter, which would deadlock.
//! - Non-finite values are stored as computed and counted, with the position of the first such
//!   cell (lowest cell index), for the interpreter to warn about.
//!
//! Filling bricks lives in `cache/fill.rs`; reading (interpolation, gradients, ranges) in
//! `cache/read.rs`.

mod build;
mod fill;
mod map_watch;
pub mod outside;
mod range;
mod read;
pub use build::SparseBuilder;
#[cfg(test)]
mod test_support;
#[cfg(test)]
mod tests;

use crate::base::failure::{Failure, Outcome};
use crate::engine::profile::{self, GridStats};
use crate::space::FieldSampler;
use crate::space::domain::Domain;
use glam::{DMat3, DVec3};
use std::fmt;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, OnceLock};

/// Cells along each edge of a brick.
pub const BRICK: usize = 8;
/// Cells in a brick.
pub const BRICK_CELLS: usize = BRICK * BRICK * BRICK;
/// Components of the widest value (a 3×3 matrix).
const MAX_WIDTH: usize = 9;

/// The resolved contents of one brick.
struct Brick {
    /// Values, cell-major with components interleaved: component `c` of local cell
    /// `x + 8 (y + 8 z)` is at `(x + 8 (y + 8 z)) * width + c`. `None`: all background.
    values: Option<Box<[f32]>>,
    /// Smallest and largest value per component over the brick's cells; `(-inf, inf)` when a
    /// value is NaN.
    range: [(f32, f32); MAX_WIDTH],
    /// Which cells hold anything but zero (in some component, NaN included): bit `x` of byte
    /// `y + 8 z`. A range over part of the brick is exactly zero where its cells' bits are all
    /// clear. Kept only for a brick with values and some zero cells (a pointer in the table,
    /// 64 bytes beside the values); `None` says nothing.
    nonzero: Option<Box<[u8; BRICK * BRICK]>>,
}

/// Cell counts and the brick table's shape.
#[derive(Clone, Copy, Debug)]
struct Shape {
    cells: [usize; 3],
    bricks: [usize; 3],
}

impl Shape {
    fn new(cells: [usize; 3]) -> Shape {
        Shape {
            cells,
            bricks: cells.map(|n| n.div_ceil(BRICK)),
        }
    }

    fn brick_total(&self) -> usize {
        self.bricks[0] * self.bricks[1] * self.bricks[2]
    }

    fn brick_index(&self, b: [usize; 3]) -> usize {
        b[0] + self.bricks[0] * (b[1] + self.bricks[1] * b[2])
    }

    fn brick_coords(&self, index: usize) -> [usize; 3] {
        let x = index % self.bricks[0];
        let rest = index / self.bricks[0];
        [x, rest % self.bricks[1], rest / self.bricks[1]]
    }

    /// First cell and one-past-last cell of a brick.
    fn brick_cells(&self, index: usize) -> ([usize; 3], [usize; 3]) {
        let b = self.brick_coords(index);
        let lo = [0, 1, 2].map(|a| b[a] * BRICK);
        let hi = [0, 1, 2].map(|a| (lo[a] + BRICK).min(self.cells[a]));
        (lo, hi)
    }

    fn cell_index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.cells[0] * (j + self.cells[1] * k)
    }
}

fn local_index(x: usize, y: usize, z: usize) -> usize {
    x + BRICK * (y + BRICK * z)
}

/// One state of a cache: values of a field at the cell centres of a domain.
pub struct Cache {
    domain: Domain,
    /// World to local frame: the transpose of the domain's rotation.
    to_local: DMat3,
    /// Whether the domain is unrotated (so `to_local` is the identity).
    axis_aligned: bool,
    shape: Shape,
    width: usize,
    background: Vec<f64>,
    /// A brick's worth of background values; uniform bricks read from it.
    background_brick: Box<[f32]>,
    bricks: Box<[OnceLock<Brick>]>,
    source: Mutex<Option<Arc<dyn FieldSampler>>>,
    /// Bricks filled or skipped so far.
    resolved: AtomicUsize,
    filled: AtomicUsize,
    skipped: AtomicUsize,
    fill_nanos: AtomicU64,
    stored_bytes: AtomicU64,
    nonfinite: AtomicU64,
    /// Lowest cell index holding a non-finite value, and its world position.
    first_nonfinite: Mutex<Option<(usize, DVec3)>>,
    identity: u64,
    label: String,
    profile: Option<Arc<GridStats>>,
    /// Default reads outside the domain, counted for a vector cache that may be a map.
    map_watch: Option<map_watch::MapWatch>,
    /// This cache's share of the run's memory budget, given back when it is dropped.
    _memory: crate::engine::budget::Reservation,
}

/// A brick of a filled cache, for writers: `size` cells from cell `origin`.
pub struct BrickView<'a> {
    pub origin: [usize; 3],
    pub size: [usize; 3],
    width: usize,
    values: &'a [f32],
}

impl<'a> BrickView<'a> {
    /// The value of the cell at `local` (each coordinate below `size`) within the brick.
    pub fn value(&self, local: [usize; 3]) -> &'a [f32] {
        let at = local_index(local[0], local[1], local[2]) * self.width;
        &self.values[at..at + self.width]
    }
}

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    // The guarded data stays consistent across a panic elsewhere (plain replacements only).
    mutex
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

fn kind_name(width: usize) -> &'static str {
    match width {
        1 => "scalarcache",
        3 => "vectorcache",
        _ => "matrixcache",
    }
}

impl Cache {
    /// A cache that samples `source` over `domain`'s cells on demand. `background` (one value
    /// per component) is what the cache reads outside the domain and where the source is known
    /// to equal it. Counted in the profile as `cachewrite` at `origin_label`.
    pub fn from_field(
        domain: Domain,
        width: usize,
        source: Arc<dyn FieldSampler>,
        background: Vec<f64>,
        origin_label: String,
    ) -> Outcome<Cache> {
        Cache::from_source(
            domain,
            width,
            source,
            background,
            "cachewrite",
            origin_label,
        )
    }

    /// The same as `from_field`, counted in the profile under `kind` (for grids an operation
    /// other than `cachewrite` fills lazily, such as `clouddensity`).
    pub fn from_source(
        domain: Domain,
        width: usize,
        source: Arc<dyn FieldSampler>,
        background: Vec<f64>,
        kind: &str,
        origin_label: String,
    ) -> Outcome<Cache> {
        if source.width() != width {
            let field = match source.width() {
                1 => "a scalarfield".to_string(),
                3 => "a vectorfield".to_string(),
                9 => "a matrixfield".to_string(),
                other => format!("a field of {other} components"),
            };
            return Err(Failure::new(format!(
                "cannot write {field} into a {}",
                kind_name(width)
            )));
        }
        let mut cache = Cache::empty(domain, width, background, origin_label)?;
        *lock(&cache.source) = Some(source);
        let stats = profile::register(kind, &cache.label);
        stats.add_instance(cache.bricks.len() as u64);
        stats.add_work(0, cache.table_bytes());
        cache.profile = Some(stats);
        Ok(cache)
    }

    /// A cache holding given values: `data[c][i + nx (j + ny k)]` is component `c` of cell
    /// `(i, j, k)`.
    pub fn from_dense(
        domain: Domain,
        width: usize,
        data: Vec<Vec<f32>>,
        background: Vec<f64>,
    ) -> Outcome<Cache> {
        let cache = Cache::empty(domain, width, background, String::new())?;
        let cell_count = cache.domain.cell_count();
        if data.len() != width || data.iter().any(|d| d.len() != cell_count) {
            let lengths: Vec<String> = data.iter().map(|d| d.len().to_string()).collect();
            return Err(Failure::new(format!(
                "grid data does not match its domain: expected {width} component(s) of {cell_count} values, got [{}]",
                lengths.join(", ")
            )));
        }
        for index in 0..cache.bricks.len() {
            let (lo, hi) = cache.shape.brick_cells(index);
            let mut values = cache.background_brick.clone();
            for z in lo[2]..hi[2] {
                for y in lo[1]..hi[1] {
                    for x in lo[0]..hi[0] {
                        let cell = cache.shape.cell_index(x, y, z);
                        let at = local_index(x - lo[0], y - lo[1], z - lo[2]) * width;
                        for (c, component) in data.iter().enumerate() {
                            values[at + c] = component[cell];
                        }
                    }
                }
            }
            cache.store_given(index, values);
        }
        Ok(cache)
    }

    /// Validates the layout and makes a cache with every brick unresolved and no source.
    fn empty(domain: Domain, width: usize, background: Vec<f64>, label: String) -> Outcome<Cache> {
        let Some(cells) = domain.resolution else {
            return Err(Failure::new("a cache needs a domain with cells").with_help(
                "give the domain a cell size: domain d(origin, lengths, orientation, cell)",
            ));
        };
        if !matches!(width, 1 | 3 | 9) {
            return Err(Failure::new(format!(
                "a cache holds 1, 3 or 9 components per cell, not {width}"
            )));
        }
        if background.len() != width {
            return Err(Failure::new(format!(
                "a {} needs a background of {width} component(s), got {}",
                kind_name(width),
                background.len()
            )));
        }
        if background.iter().any(|b| !b.is_finite()) {
            return Err(Failure::new(format!(
                "a cache background must be finite, got {background:?}"
            )));
        }
        let memory = domain.reserve_grid_memory(width)?;
        let shape = Shape::new(cells);
        let background_f32: Vec<f32> = background.iter().map(|&b| b as f32).collect();
        let background_brick: Box<[f32]> = (0..BRICK_CELLS * width)
            .map(|i| background_f32[i % width])
            .collect();
        let bricks = (0..shape.brick_total()).map(|_| OnceLock::new()).collect();
        let label = if label.is_empty() {
            format!(
                "{} of {}x{}x{} cells",
                kind_name(width),
                cells[0],
                cells[1],
                cells[2]
            )
        } else {
            label
        };
        Ok(Cache {
            to_local: domain.rotation.transpose(),
            axis_aligned: domain.rotation == DMat3::IDENTITY,
            domain,
            shape,
            width,
            background,
            background_brick,
            bricks,
            source: Mutex::new(None),
            resolved: AtomicUsize::new(0),
            filled: AtomicUsize::new(0),
            skipped: AtomicUsize::new(0),
            fill_nanos: AtomicU64::new(0),
            stored_bytes: AtomicU64::new(0),
            nonfinite: AtomicU64::new(0),
            first_nonfinite: Mutex::new(None),
            identity: crate::grid::next_identity(),
            label,
            profile: None,
            map_watch: None,
            _memory: memory,
        })
    }

    /// Counts a cache made from data (a file, a solve) in the profile under `kind` and its
    /// label, with its bricks and memory. Caches made by `from_field` are counted already.
    pub fn with_profile(mut self, kind: &str) -> Cache {
        if self.profile.is_some() {
            return self;
        }
        let stats = profile::register(kind, &self.label);
        stats.add_instance(self.bricks.len() as u64);
        stats.add_resolved(self.bricks_filled() as u64, self.bricks_skipped() as u64);
        if self.resolved.load(std::sync::atomic::Ordering::Acquire) > 0 {
            stats.add_evaluated();
        }
        stats.add_work(0, self.bytes());
        self.profile = Some(stats);
        self
    }

    /// The same cache under another label (for caches read from files).
    pub fn with_label(mut self, label: impl Into<String>) -> Cache {
        self.label = label.into();
        self
    }

    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    /// Components per cell: 1, 3 or 9.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Cells along the domain's three axes.
    pub fn resolution(&self) -> [usize; 3] {
        self.shape.cells
    }

    /// The value outside the domain, per component.
    pub fn background_values(&self) -> &[f64] {
        &self.background
    }

    pub fn bricks_total(&self) -> usize {
        self.bricks.len()
    }

    /// Bricks whose values were computed or given.
    pub fn bricks_filled(&self) -> usize {
        self.filled.load(Ordering::Relaxed)
    }

    /// Bricks known to be background without evaluating them.
    pub fn bricks_skipped(&self) -> usize {
        self.skipped.load(Ordering::Relaxed)
    }

    /// Is brick `b` (brick coordinates) resolved, filled or skipped?
    pub fn brick_resolved(&self, b: [usize; 3]) -> bool {
        b.iter().zip(self.shape.bricks).all(|(&i, n)| i < n)
            && self.bricks[self.shape.brick_index(b)].get().is_some()
    }

    /// Bricks along each axis.
    pub fn brick_counts(&self) -> [usize; 3] {
        self.shape.bricks
    }

    /// Bytes allocated: stored brick values plus the brick table.
    pub fn bytes(&self) -> u64 {
        self.stored_bytes.load(Ordering::Relaxed) + self.table_bytes()
    }

    fn table_bytes(&self) -> u64 {
        (self.bricks.len() * size_of::<OnceLock<Brick>>() + self.background_brick.len() * 4) as u64
    }

    /// Wall time spent filling bricks, summed over threads.
    pub fn fill_seconds(&self) -> f64 {
        self.fill_nanos.load(Ordering::Relaxed) as f64 * 1e-9
    }

    /// Has the cache let go of its source field (every brick resolved)?
    pub fn source_released(&self) -> bool {
        lock(&self.source).is_none()
    }

    /// How many non-finite values the fills so far produced, and the world position of the
    /// one in the lowest-numbered cell; `None` when all were finite.
    pub fn nonfinite_report(&self) -> Option<(u64, DVec3)> {
        let count = self.nonfinite.load(Ordering::Relaxed);
        let first = *lock(&self.first_nonfinite);
        first.map(|(_, position)| (count, position))
    }

    /// The stored value of cell `(i, j, k)`, filling its brick if needed; `None` outside.
    pub fn value_at_cell(&self, i: usize, j: usize, k: usize) -> Option<&[f32]> {
        let cells = self.shape.cells;
        if i >= cells[0] || j >= cells[1] || k >= cells[2] {
            return None;
        }
        let index = self.shape.brick_index([i / BRICK, j / BRICK, k / BRICK]);
        let at = local_index(i % BRICK, j % BRICK, k % BRICK) * self.width;
        Some(&self.brick_values(index)[at..at + self.width])
    }

    /// The values of the brick at brick coordinates `brick` in brick order (see
    /// [`SparseBuilder::set_brick`]), filling it if needed; a uniform brick reads as background.
    pub fn brick_values_at(&self, brick: [usize; 3]) -> Option<&[f32]> {
        if (0..3).any(|a| brick[a] >= self.shape.bricks[a]) {
            return None;
        }
        Some(self.brick_values(self.shape.brick_index(brick)))
    }

    /// Whether the brick at brick coordinates `brick` holds values (is not uniform background),
    /// filling it if needed.
    pub fn brick_stored(&self, brick: [usize; 3]) -> bool {
        (0..3).all(|a| brick[a] < self.shape.bricks[a])
            && self.brick(self.shape.brick_index(brick)).values.is_some()
    }

    /// Bricks that hold values (not uniform background), in brick order; fills all first.
    pub fn stored_bricks(&self) -> impl Iterator<Item = BrickView<'_>> {
        self.fill_all();
        (0..self.bricks.len()).filter_map(move |index| {
            let values = self.bricks[index].get()?.values.as_deref()?;
            let (lo, hi) = self.shape.brick_cells(index);
            Some(BrickView {
                origin: lo,
                size: [0, 1, 2].map(|a| hi[a] - lo[a]),
                width: self.width,
                values,
            })
        })
    }

    /// Every cell of the stored bricks with its value, brick by brick; cells not listed are
    /// background. Fills all first.
    pub fn cells(&self) -> impl Iterator<Item = ([usize; 3], &[f32])> {
        self.stored_bricks().flat_map(|brick| {
            let [sx, sy, sz] = brick.size;
            (0..sx * sy * sz).map(move |n| {
                let local = [n % sx, (n / sx) % sy, n / (sx * sy)];
                let cell = [0, 1, 2].map(|a| brick.origin[a] + local[a]);
                (cell, brick.value(local))
            })
        })
    }

    fn brick(&self, index: usize) -> &Brick {
        if let Some(brick) = self.bricks[index].get() {
            return brick;
        }
        self.bricks[index].get_or_init(|| self.fill_lazily(index))
    }

    /// The values of a brick, background for a uniform one.
    fn brick_values(&self, index: usize) -> &[f32] {
        self.brick(index)
            .values
            .as_deref()
            .unwrap_or(&self.background_brick)
    }

    fn uniform_brick(&self) -> Brick {
        let mut range = [(0.0, 0.0); MAX_WIDTH];
        for (slot, &b) in range.iter_mut().zip(&self.background) {
            *slot = (b as f32, b as f32);
        }
        Brick {
            values: None,
            range,
            nonzero: None,
        }
    }
}

impl Drop for Cache {
    fn drop(&mut self) {
        if let Some(stats) = &self.profile {
            stats.release(self.bytes());
        }
        self.settle_map_reads();
    }
}

impl fmt::Debug for Cache {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Cache")
            .field("label", &self.label)
            .field("width", &self.width)
            .field("resolution", &self.shape.cells)
            .field("bricks_filled", &self.bricks_filled())
            .field("bricks_skipped", &self.bricks_skipped())
            .field("bricks_total", &self.bricks_total())
            .finish()
    }
}
