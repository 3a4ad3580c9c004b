//! Building sparse grids from voxel values: from a function of the voxel index or a dense
//! array, and pruning uniform blocks into tiles.
//!
//! The key decision is that activity is decided by a rule the caller names (`Activity`), not
//! guessed: a fog volume is active where it differs from its background, a level set inside
//! its narrow band — and a level set's inactive voxels are stored as ±background by the sign
//! of the distance, so a grid felt writes reads back inside-out correctly everywhere. Uniform
//! 8³ blocks become tiles and full uniform groups of tiles merge upward, as OpenVDB's prune
//! does.

use super::{LEAF_VOXELS, TILE_SIZES, VdbGrid, VdbLeaf, VdbTile, VdbValues, align};
use crate::base::failure::{Failure, Outcome};
use std::collections::HashMap;

/// Which voxels of a built grid are active.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Activity {
    /// Active where some component differs from the background by more than the tolerance;
    /// the other voxels are stored inactive at the background, as OpenVDB's `copyFromDense`
    /// stores them. For fog volumes and vector fields.
    AwayFromBackground(f32),
    /// For level sets: active inside the narrow band `|φ| < background`; elsewhere inactive,
    /// stored as `+background` outside and `−background` inside.
    NarrowBand,
}

impl VdbGrid {
    /// Fills an empty grid with the values `value(ijk, out)` writes for every voxel of the
    /// inclusive index box `[min, max]`; voxels outside the box keep the background.
    pub fn with_values_from<F>(
        mut self,
        min: [i32; 3],
        max: [i32; 3],
        activity: Activity,
        mut value: F,
    ) -> Outcome<VdbGrid>
    where
        F: FnMut([i32; 3], &mut [f32]),
    {
        if !self.leaves.is_empty() || !self.tiles.is_empty() {
            return Err(Failure::new(format!(
                "grid '{}' already holds voxels; values can only be added to an empty grid",
                self.name
            )));
        }
        if (0..3).any(|a| min[a] > max[a]) {
            return Err(Failure::new(format!(
                "the index box {min:?}..{max:?} is empty"
            )));
        }
        self.check_activity(activity)?;
        let components = self.components();
        let mut values = vec![0.0f32; LEAF_VOXELS * components];
        let mut voxel = vec![0.0f32; components];
        let first = align(min, 8).map(i64::from);
        let last = align(max, 8).map(i64::from);
        let mut x = first[0];
        while x <= last[0] {
            let mut y = first[1];
            while y <= last[1] {
                let mut z = first[2];
                while z <= last[2] {
                    let origin = [x as i32, y as i32, z as i32];
                    let mut active = [0u64; 8];
                    for offset in 0..LEAF_VOXELS {
                        let ijk = [
                            origin[0] + (offset >> 6) as i32,
                            origin[1] + ((offset >> 3) & 7) as i32,
                            origin[2] + (offset & 7) as i32,
                        ];
                        let slot = &mut values[offset * components..(offset + 1) * components];
                        let inside = (0..3).all(|a| min[a] <= ijk[a] && ijk[a] <= max[a]);
                        if inside {
                            value(ijk, &mut voxel);
                            slot.copy_from_slice(&voxel);
                        } else {
                            slot.copy_from_slice(&self.background[..components]);
                        }
                        if inside && self.classify(activity, slot) {
                            active[offset >> 6] |= 1 << (offset & 63);
                        }
                    }
                    self.add_block(origin, &values, active);
                    z += 8;
                }
                y += 8;
            }
            x += 8;
        }
        self.prune();
        Ok(self)
    }

    /// Fills an empty grid from a dense array over the index box that starts at `origin` and
    /// spans `dims` voxels. The array is indexed `[x][y][z][component]` with the last index
    /// fastest: voxel `(x, y, z)` starts at `((x · dims[1] + y) · dims[2] + z) · components`.
    pub fn with_dense_values(
        self,
        origin: [i32; 3],
        dims: [usize; 3],
        values: &[f32],
        activity: Activity,
    ) -> Outcome<VdbGrid> {
        let components = self.components();
        let expected = dims
            .iter()
            .try_fold(components, |n, &d| n.checked_mul(d))
            .ok_or_else(|| {
                Failure::new(format!("a dense array of {dims:?} voxels is too large"))
            })?;
        if values.len() != expected || expected == 0 {
            return Err(Failure::new(format!(
                "a dense array of {dims:?} voxels with {components} components needs {expected} \
                 values, got {}",
                values.len()
            )));
        }
        let mut max = [0i32; 3];
        for a in 0..3 {
            let last = i64::from(origin[a]) + dims[a] as i64 - 1;
            max[a] = i32::try_from(last).map_err(|_| {
                Failure::new(format!(
                    "a dense array of {dims:?} voxels at {origin:?} leaves the index range"
                ))
            })?;
        }
        self.with_values_from(origin, max, activity, |ijk, out| {
            let local = [0, 1, 2].map(|a| (ijk[a] - origin[a]) as usize);
            let start = ((local[0] * dims[1] + local[1]) * dims[2] + local[2]) * components;
            out.copy_from_slice(&values[start..start + components]);
        })
    }

    fn check_activity(&self, activity: Activity) -> Outcome<()> {
        if activity == Activity::NarrowBand {
            if self.value_type != VdbValues::Float {
                return Err(Failure::new(format!(
                    "grid '{}' holds vectors; a narrow band needs a scalar level set",
                    self.name
                )));
            }
            if self.background[0].is_nan() || self.background[0] <= 0.0 {
                return Err(Failure::new(format!(
                    "a level set's background is its narrow-band half width and must be positive, \
                     got {}",
                    self.background[0]
                )));
            }
        }
        Ok(())
    }

    /// Decides whether a voxel is active; inactive voxels snap to the background (±background
    /// for a level set).
    fn classify(&self, activity: Activity, value: &mut [f32]) -> bool {
        match activity {
            Activity::AwayFromBackground(tolerance) => {
                let away = value
                    .iter()
                    .zip(self.background)
                    .any(|(v, b)| (v - b).is_nan() || (v - b).abs() > tolerance);
                if !away {
                    value.copy_from_slice(&self.background[..value.len()]);
                }
                away
            }
            Activity::NarrowBand => {
                let width = self.background[0];
                if value[0].abs() < width {
                    true
                } else {
                    value[0] = if value[0] < 0.0 { -width } else { width };
                    false
                }
            }
        }
    }

    /// Keeps an 8³ block as a leaf, a tile if it is uniform, or nothing if it is all
    /// inactive background.
    fn add_block(&mut self, origin: [i32; 3], values: &[f32], active: [u64; 8]) {
        let components = self.components();
        let uniform_state = active.iter().all(|&w| w == 0) || active.iter().all(|&w| w == u64::MAX);
        let first = &values[..components];
        let uniform_value = values.chunks_exact(components).all(|v| v == first);
        if uniform_state && uniform_value {
            let mut value = [0.0; 3];
            value[..components].copy_from_slice(first);
            let is_active = active[0] != 0;
            if is_active || value != self.background {
                self.tiles.push(VdbTile {
                    origin,
                    size: 8,
                    value,
                    active: is_active,
                });
            }
            return;
        }
        self.leaves.push(VdbLeaf {
            origin,
            values: values.to_vec(),
            active,
        });
    }

    /// Turns uniform leaves into tiles, drops tiles and leaves that are inactive background,
    /// and merges every complete group of equal tiles into one tile of the next level.
    pub fn prune(&mut self) {
        let leaves = std::mem::take(&mut self.leaves);
        for leaf in leaves {
            self.add_block(leaf.origin, &leaf.values, leaf.active);
        }
        let background = self.background;
        self.tiles.retain(|t| t.active || t.value != background);
        for level in 0..2 {
            let (size, parent) = (TILE_SIZES[level], TILE_SIZES[level + 1]);
            let needed = ((parent / size) as usize).pow(3);
            let mut groups: HashMap<[i32; 3], Vec<usize>> = HashMap::new();
            for (index, tile) in self
                .tiles
                .iter()
                .enumerate()
                .filter(|(_, t)| t.size == size)
            {
                groups
                    .entry(align(tile.origin, parent))
                    .or_default()
                    .push(index);
            }
            let mut merged = Vec::new();
            let mut absorbed = vec![false; self.tiles.len()];
            for (origin, members) in groups {
                let first = self.tiles[members[0]];
                let same = members.iter().all(|&m| {
                    let t = &self.tiles[m];
                    t.value == first.value && t.active == first.active
                });
                if members.len() == needed && same {
                    for m in members {
                        absorbed[m] = true;
                    }
                    merged.push(VdbTile {
                        origin,
                        size: parent,
                        ..first
                    });
                }
            }
            let mut index = 0;
            self.tiles.retain(|_| {
                index += 1;
                !absorbed[index - 1]
            });
            self.tiles.extend(merged);
        }
        self.sort_nodes();
    }
}
