//! OpenVDB files: felt's own reader and writer for sparse float and vector grids.
//!
//! A `.vdb` file stores each grid as a four-level tree (a root table, 32³ and 16³ internal
//! nodes, 8³ leaves) whose nodes hold either children or constant "tiles". felt reads every
//! layout that OpenVDB 6–12 writes: zip and blosc compression, half floats, all seven
//! mask-compression schemes (so the inactive voxels of a level set come back as ±background),
//! linear transforms and OpenVDB's frustum map, instanced grids. The one key decision: in memory a grid is *flat* — a
//! sorted list of 8³ leaves and a sorted list of constant tiles with their edge length — not a
//! tree. Lookups are binary searches, the consumers (caches, the raymarcher) walk leaves
//! directly, and the tree exists only while a file is read or written. Reading is defensive:
//! every length and count in the file is checked against the bytes that remain before it is
//! trusted, so a corrupt file is a `Failure` naming the byte offset, never a panic or a
//! giant allocation.

mod build;
mod compress;
mod cursor;
mod frustum_map;
mod half;
mod read;
mod read_tree;
mod write;
mod write_tree;

#[cfg(test)]
mod tests;

pub use build::Activity;
pub use frustum_map::{FRUSTUM_MAP, FrustumMap};
pub use read::{read_bytes, read_file, read_file_metadata, read_grid, read_grid_bytes};
pub use write::{write_bytes, write_bytes_with_metadata, write_file, write_file_with_metadata};

use glam::{DMat4, DVec3};

/// Voxels along each edge of a leaf node.
pub const LEAF_DIM: i32 = 8;
/// Voxels in a leaf node.
pub const LEAF_VOXELS: usize = 512;
/// The edge lengths, in voxels, of the tiles the three upper tree levels can hold.
pub const TILE_SIZES: [i32; 3] = [8, 128, 4096];

/// The grid class OpenVDB uses for densities and other non-negative scalar volumes.
pub const FOG_VOLUME: &str = "fog volume";
/// The grid class of narrow-band signed distance fields.
pub const LEVEL_SET: &str = "level set";
/// The grid class of everything else.
pub const UNKNOWN_CLASS: &str = "unknown";

/// The value type of a grid, as felt holds it (files may store halves or doubles).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VdbValues {
    Float,
    Vec3,
}

impl VdbValues {
    /// Components per voxel: 1 or 3.
    pub fn components(self) -> usize {
        match self {
            VdbValues::Float => 1,
            VdbValues::Vec3 => 3,
        }
    }
}

/// How the value buffers of a written file are compressed. Both kinds also store only the
/// active values of each node plus what is needed to restore the inactive ones, as OpenVDB
/// does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Compression {
    None,
    #[default]
    Zip,
}

/// A typed metadata value attached to a grid.
#[derive(Clone, Debug, PartialEq)]
pub enum VdbMeta {
    String(String),
    Bool(bool),
    Int32(i32),
    Int64(i64),
    Float(f32),
    Double(f64),
    Vec3i([i32; 3]),
    Vec3s([f32; 3]),
    Vec3d([f64; 3]),
    /// A type felt does not interpret, kept byte for byte so that it survives a rewrite.
    Other {
        type_name: String,
        bytes: Vec<u8>,
    },
}

/// An 8³ block of voxels.
#[derive(Clone, Debug, PartialEq)]
pub struct VdbLeaf {
    /// Index coordinates of the block's first voxel; each a multiple of 8.
    pub origin: [i32; 3],
    /// `LEAF_VOXELS × components` values, voxel-major: the components of the voxel at local
    /// `(x, y, z)` start at `VdbLeaf::offset(x, y, z) × components`.
    pub values: Vec<f32>,
    /// Bit `offset` of the 512-bit mask (word `offset / 64`, bit `offset % 64`) marks an
    /// active voxel.
    pub active: [u64; 8],
}

impl VdbLeaf {
    /// The position of local voxel `(x, y, z)` (each 0..8) in a leaf, x-major as in OpenVDB.
    pub fn offset(x: usize, y: usize, z: usize) -> usize {
        (x << 6) | (y << 3) | z
    }

    /// The position in its leaf of the voxel at index coordinates `ijk`.
    pub fn offset_of(ijk: [i32; 3]) -> usize {
        Self::offset(
            (ijk[0] & 7) as usize,
            (ijk[1] & 7) as usize,
            (ijk[2] & 7) as usize,
        )
    }

    pub fn is_active(&self, offset: usize) -> bool {
        self.active[offset >> 6] >> (offset & 63) & 1 == 1
    }

    pub fn active_count(&self) -> u32 {
        self.active.iter().map(|w| w.count_ones()).sum()
    }
}

/// A cube of voxels that all hold one value, stored above the leaf level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VdbTile {
    /// Index coordinates of the first voxel; a multiple of `size`.
    pub origin: [i32; 3],
    /// Edge length in voxels: one of `TILE_SIZES`.
    pub size: i32,
    /// Component 0 only for scalar grids.
    pub value: [f32; 3],
    pub active: bool,
}

/// One grid of a VDB file.
///
/// `leaves` are sorted by origin and `tiles` by (size, origin), without overlaps; the reader
/// and the builders keep this, and code that edits the lists calls `sort_nodes` afterwards.
/// Voxels that no leaf or tile covers hold the background and are inactive. Tiles are listed
/// when they are active or differ from the background (a level set's interior is made of
/// inactive tiles at −background).
#[derive(Clone, Debug, PartialEq)]
pub struct VdbGrid {
    pub name: String,
    /// `"fog volume"`, `"level set"`, `"unknown"` (or whatever else the file says).
    pub class: String,
    pub value_type: VdbValues,
    /// Component 0 only for scalar grids.
    pub background: [f32; 3],
    /// Maps index coordinates to world space; voxel centres sit at integer coordinates. For a
    /// grid with a `frustum`, the affine map applied after the frustum's taper (OpenVDB's
    /// second map).
    pub index_to_world: DMat4,
    /// OpenVDB's `NonlinearFrustumMap`, when the transform is one.
    pub frustum: Option<FrustumMap>,
    pub leaves: Vec<VdbLeaf>,
    pub tiles: Vec<VdbTile>,
    /// The file stored the values as 16-bit halves (the values here are already rounded);
    /// the writer stores them as halves again.
    pub saved_as_half: bool,
    /// The value type named in the file (`float`, `double`, `half`, `vec3s`, `vec3d`).
    pub stored_type: String,
    /// Metadata other than the name, the class and the half-float flag.
    pub metadata: Vec<(String, VdbMeta)>,
}

impl VdbGrid {
    /// An empty grid: every voxel holds `background` and is inactive.
    pub fn new(
        name: &str,
        class: &str,
        value_type: VdbValues,
        background: [f32; 3],
        index_to_world: DMat4,
    ) -> VdbGrid {
        let mut background = background;
        if value_type == VdbValues::Float {
            background[1] = 0.0;
            background[2] = 0.0;
        }
        VdbGrid {
            name: name.to_string(),
            class: class.to_string(),
            value_type,
            background,
            index_to_world,
            frustum: None,
            leaves: Vec::new(),
            tiles: Vec::new(),
            saved_as_half: false,
            stored_type: match value_type {
                VdbValues::Float => "float".into(),
                VdbValues::Vec3 => "vec3s".into(),
            },
            metadata: Vec::new(),
        }
    }

    pub fn components(&self) -> usize {
        self.value_type.components()
    }

    /// The value at voxel `ijk` and whether it is active.
    pub fn probe(&self, ijk: [i32; 3]) -> ([f32; 3], bool) {
        let components = self.components();
        let leaf_origin = align(ijk, LEAF_DIM);
        if let Ok(found) = self
            .leaves
            .binary_search_by(|leaf| leaf.origin.cmp(&leaf_origin))
        {
            let leaf = &self.leaves[found];
            let offset = VdbLeaf::offset_of(ijk);
            let mut value = [0.0; 3];
            value[..components]
                .copy_from_slice(&leaf.values[offset * components..(offset + 1) * components]);
            return (value, leaf.is_active(offset));
        }
        for size in TILE_SIZES {
            let key = (size, align(ijk, size));
            if let Ok(found) = self
                .tiles
                .binary_search_by(|t| (t.size, t.origin).cmp(&key))
            {
                let tile = &self.tiles[found];
                return (tile.value, tile.active);
            }
        }
        (self.background, false)
    }

    /// The value at voxel `ijk` (component 0 only for scalar grids).
    pub fn value_at(&self, ijk: [i32; 3]) -> [f32; 3] {
        self.probe(ijk).0
    }

    /// The smallest index box `(min, max)`, both inclusive, holding every active voxel.
    pub fn active_bounds(&self) -> Option<([i32; 3], [i32; 3])> {
        let mut bounds = Bounds::default();
        for leaf in &self.leaves {
            for (word_index, &word) in leaf.active.iter().enumerate() {
                let mut bits = word;
                while bits != 0 {
                    let offset = word_index * 64 + bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let local = [
                        (offset >> 6) as i32,
                        ((offset >> 3) & 7) as i32,
                        (offset & 7) as i32,
                    ];
                    let ijk = [0, 1, 2].map(|a| leaf.origin[a] + local[a]);
                    bounds.include(ijk, ijk);
                }
            }
        }
        for tile in self.tiles.iter().filter(|t| t.active) {
            bounds.include(tile.origin, tile.origin.map(|c| c + (tile.size - 1)));
        }
        bounds.get()
    }

    /// The smallest index box holding every leaf and listed tile: outside it every voxel
    /// holds the background.
    pub fn index_bounds(&self) -> Option<([i32; 3], [i32; 3])> {
        let mut bounds = Bounds::default();
        for leaf in &self.leaves {
            bounds.include(leaf.origin, leaf.origin.map(|c| c + (LEAF_DIM - 1)));
        }
        for tile in &self.tiles {
            bounds.include(tile.origin, tile.origin.map(|c| c + (tile.size - 1)));
        }
        bounds.get()
    }

    /// The number of active voxels, counting every voxel of an active tile.
    pub fn active_voxel_count(&self) -> u64 {
        let in_leaves: u64 = self
            .leaves
            .iter()
            .map(|l| u64::from(l.active_count()))
            .sum();
        let in_tiles: u64 = self
            .tiles
            .iter()
            .filter(|t| t.active)
            .map(|t| (t.size as u64).pow(3))
            .sum();
        in_leaves + in_tiles
    }

    /// Restores the order that lookups rely on after the lists were edited.
    pub fn sort_nodes(&mut self) {
        self.leaves.sort_by_key(|leaf| leaf.origin);
        self.tiles.sort_by_key(|tile| (tile.size, tile.origin));
    }

    /// The world-space length of one voxel step along each index axis (for a frustum grid, of
    /// its second map).
    pub fn voxel_size(&self) -> DVec3 {
        let m = self.index_to_world;
        DVec3::new(
            m.x_axis.truncate().length(),
            m.y_axis.truncate().length(),
            m.z_axis.truncate().length(),
        )
    }

    /// The world position of index coordinates `ijk` (a voxel centre when integer).
    pub fn index_to_world_point(&self, ijk: DVec3) -> DVec3 {
        match &self.frustum {
            Some(frustum) => frustum.apply(&self.index_to_world, ijk),
            None => self.index_to_world.transform_point3(ijk),
        }
    }

    /// The metadata value called `key`, if the grid has one.
    pub fn meta(&self, key: &str) -> Option<&VdbMeta> {
        self.metadata
            .iter()
            .find(|(name, _)| name == key)
            .map(|(_, value)| value)
    }
}

/// The origin of the `size`-aligned cube holding `ijk` (`size` a power of two).
pub(crate) fn align(ijk: [i32; 3], size: i32) -> [i32; 3] {
    ijk.map(|c| c & !(size - 1))
}

/// A running inclusive index box.
#[derive(Default)]
struct Bounds {
    min_max: Option<([i32; 3], [i32; 3])>,
}

impl Bounds {
    fn include(&mut self, lo: [i32; 3], hi: [i32; 3]) {
        self.min_max = Some(match self.min_max {
            None => (lo, hi),
            Some((min, max)) => (
                [0, 1, 2].map(|a| min[a].min(lo[a])),
                [0, 1, 2].map(|a| max[a].max(hi[a])),
            ),
        });
    }

    fn get(&self) -> Option<([i32; 3], [i32; 3])> {
        self.min_max
    }
}
