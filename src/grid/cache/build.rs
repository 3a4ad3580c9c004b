//! Building a cache from values at scattered cells: the grids felt reads from files.
//!
//! The one key decision: a whole 8³ block that lines up with a brick (an OpenVDB leaf, since
//! leaves and bricks are both 8³) is copied into the brick in one reordering pass, and a tile's
//! constant value fills whole bricks at once; only what straddles bricks goes cell by cell.

use super::*;

/// Builds a cache from values at scattered cells (grids read from files); bricks never
/// touched are background.
pub struct SparseBuilder {
    cache: Cache,
    pending: Vec<Option<Box<[f32]>>>,
}

impl SparseBuilder {
    pub fn new(domain: Domain, width: usize, background: Vec<f64>) -> Outcome<SparseBuilder> {
        let cache = Cache::empty(domain, width, background, String::new())?;
        let pending = (0..cache.bricks.len()).map(|_| None).collect();
        Ok(SparseBuilder { cache, pending })
    }

    /// Sets the value of cell `(i, j, k)`; `value` has one entry per component.
    pub fn set(&mut self, cell: [usize; 3], value: &[f32]) -> Outcome<()> {
        let cache = &self.cache;
        let cells = cache.shape.cells;
        if cell.iter().zip(cells).any(|(&i, n)| i >= n) {
            return Err(Failure::new(format!(
                "cell ({}, {}, {}) lies outside a grid of {}x{}x{} cells",
                cell[0], cell[1], cell[2], cells[0], cells[1], cells[2]
            )));
        }
        if value.len() != cache.width {
            return Err(Failure::new(format!(
                "a value of {} components does not fit a {}",
                value.len(),
                kind_name(cache.width)
            )));
        }
        let index = cache.shape.brick_index(cell.map(|i| i / BRICK));
        let values = self.pending[index].get_or_insert_with(|| cache.background_brick.clone());
        let at = local_index(cell[0] % BRICK, cell[1] % BRICK, cell[2] % BRICK) * cache.width;
        values[at..at + cache.width].copy_from_slice(value);
        Ok(())
    }

    /// Sets an 8³ block of cells from cell `first` on, given in OpenVDB's leaf order (the
    /// components of local voxel `(x, y, z)` at `(64 x + 8 y + z) × width`). A block that is a
    /// whole brick is copied in one pass; one that straddles bricks goes cell by cell.
    pub fn set_leaf(&mut self, first: [usize; 3], values: &[f32]) -> Outcome<()> {
        let width = self.cache.width;
        if values.len() != BRICK_CELLS * width {
            return Err(Failure::new(format!(
                "a block of {} values does not fit {BRICK}³ cells of {width} component(s)",
                values.len()
            )));
        }
        let shape = self.cache.shape;
        let whole_brick =
            (0..3).all(|a| first[a].is_multiple_of(BRICK) && first[a] + BRICK <= shape.cells[a]);
        if !whole_brick {
            for (n, value) in values.chunks_exact(width).enumerate() {
                let local = [n >> 6, (n >> 3) & 7, n & 7];
                self.set([0, 1, 2].map(|a| first[a] + local[a]), value)?;
            }
            return Ok(());
        }
        let index = shape.brick_index(first.map(|i| i / BRICK));
        let brick = self.pending[index].get_or_insert_with(|| self.cache.background_brick.clone());
        match width {
            1 => transpose_leaf::<1>(values, brick),
            3 => transpose_leaf::<3>(values, brick),
            _ => transpose_leaf::<MAX_WIDTH>(values, brick),
        }
        Ok(())
    }

    /// Sets the whole brick at brick coordinates `brick` from values in brick order (component
    /// `c` of local cell `x + 8 (y + 8 z)` at `(x + 8 (y + 8 z)) × width + c`, the cells past a
    /// partial brick's far faces ignored): what splats and copies produce, with no per-cell work.
    pub fn set_brick(&mut self, brick: [usize; 3], values: Box<[f32]>) -> Outcome<()> {
        let shape = self.cache.shape;
        let width = self.cache.width;
        if values.len() != BRICK_CELLS * width || (0..3).any(|a| brick[a] >= shape.bricks[a]) {
            return Err(Failure::new(format!(
                "brick {brick:?} of {} values does not fit a grid of {:?} bricks of {width} component(s)",
                values.len(),
                shape.bricks
            )));
        }
        self.pending[shape.brick_index(brick)] = Some(values);
        Ok(())
    }

    /// Sets every cell of the box `[lo, hi)` to `value`; whole bricks inside the box are set
    /// in one piece.
    pub fn fill_box(&mut self, lo: [usize; 3], hi: [usize; 3], value: &[f32]) -> Outcome<()> {
        let width = self.cache.width;
        let shape = self.cache.shape;
        if value.len() != width || (0..3).any(|a| lo[a] > hi[a] || hi[a] > shape.cells[a]) {
            return Err(Failure::new(format!(
                "cannot fill cells {lo:?} to {hi:?} of a grid of {:?} cells with {} component(s)",
                shape.cells,
                value.len()
            )));
        }
        let constant: Box<[f32]> = (0..BRICK_CELLS * width).map(|i| value[i % width]).collect();
        let first_brick = lo.map(|i| i / BRICK);
        let end_brick = [0, 1, 2].map(|a| hi[a].div_ceil(BRICK));
        for bz in first_brick[2]..end_brick[2] {
            for by in first_brick[1]..end_brick[1] {
                for bx in first_brick[0]..end_brick[0] {
                    let b = [bx, by, bz];
                    let cell_lo = b.map(|i| i * BRICK);
                    let cell_hi = [0, 1, 2].map(|a| (cell_lo[a] + BRICK).min(shape.cells[a]));
                    let from = [0, 1, 2].map(|a| cell_lo[a].max(lo[a]));
                    let to = [0, 1, 2].map(|a| cell_hi[a].min(hi[a]));
                    let slot = &mut self.pending[shape.brick_index(b)];
                    if from == cell_lo && to == cell_hi {
                        *slot = Some(constant.clone());
                        continue;
                    }
                    let brick = slot.get_or_insert_with(|| self.cache.background_brick.clone());
                    for z in from[2]..to[2] {
                        for y in from[1]..to[1] {
                            for x in from[0]..to[0] {
                                let at = local_index(x % BRICK, y % BRICK, z % BRICK) * width;
                                brick[at..at + width].copy_from_slice(value);
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }

    pub fn build(self) -> Cache {
        let SparseBuilder { cache, pending } = self;
        for (index, values) in pending.into_iter().enumerate() {
            match values {
                Some(values) => cache.store_given(index, values),
                None => {
                    let _ = cache.bricks[index].set(cache.uniform_brick());
                    cache.skipped.fetch_add(1, Ordering::Relaxed);
                    cache.note_resolved();
                }
            }
        }
        cache
    }
}

/// Copies an 8³ block from OpenVDB's leaf order (z fastest) into brick order (x fastest).
/// `W` is the number of components, a constant so the copies compile to plain moves.
fn transpose_leaf<const W: usize>(leaf: &[f32], brick: &mut [f32]) {
    for x in 0..BRICK {
        for y in 0..BRICK {
            let first = (x * 64 + y * 8) * W;
            let row = &leaf[first..first + BRICK * W];
            for (z, value) in row.chunks_exact(W).enumerate() {
                let at = local_index(x, y, z) * W;
                brick[at..at + W].copy_from_slice(value);
            }
        }
    }
}
