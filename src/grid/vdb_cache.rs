//! Caches to and from OpenVDB grids: `cachesave` and `cacheload`.
//!
//! A cache's domain maps onto a VDB linear transform exactly: index `(i, j, k)` is the centre of
//! cell `(i, j, k)`, so `index_to_world = translate(origin + R·cell/2) · R · scale(cell)`. The one
//! key decision: a loaded grid becomes an ordinary sparse cache over the index box that holds
//! every leaf and tile of the file, so everything downstream (interpolation, exact interpolant
//! gradients, empty-brick skipping in the raymarcher) treats file data and sampled fields alike.
//! Transforms with shear, reflection or different x and y voxel sizes are refused with a
//! message, since a cache domain cannot represent them. A frustum cache goes out with OpenVDB's
//! frustum map and a grid with one comes back as a cache over a frustum's index domain
//! (`grid::frustum`'s `vdb_map` says how cells and voxels correspond).

use crate::base::failure::grouped;
use crate::base::failure::{Failure, Outcome};
use crate::base::text::human_bytes;
use crate::grid::cache::{Cache, SparseBuilder};
use crate::grid::frustum::Frustum;
use crate::grid::vdb::{self, Activity, Compression, FrustumMap, VdbGrid, VdbMeta, VdbValues};
use crate::space::domain::{Domain, memory_limit};
use glam::{DMat3, DMat4, DQuat, DVec3};
use std::path::Path;

/// What a grid is, in OpenVDB's words: its `class` metadata.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridClass {
    FogVolume,
    /// A signed distance, stored negative inside as OpenVDB's level sets are (felt's level
    /// sets are positive inside: the values are negated on the way out and back in).
    LevelSet,
    Unknown,
}

impl GridClass {
    pub fn parse(text: &str) -> Outcome<GridClass> {
        match text {
            vdb::FOG_VOLUME => Ok(GridClass::FogVolume),
            vdb::LEVEL_SET => Ok(GridClass::LevelSet),
            vdb::UNKNOWN_CLASS => Ok(GridClass::Unknown),
            other => Err(Failure::new(format!(
                "class must be \"fog volume\", \"level set\" or \"unknown\", found \"{other}\""
            ))),
        }
    }

    fn name(self) -> &'static str {
        match self {
            GridClass::FogVolume => vdb::FOG_VOLUME,
            GridClass::LevelSet => vdb::LEVEL_SET,
            GridClass::Unknown => vdb::UNKNOWN_CLASS,
        }
    }
}

/// OpenVDB's names for how a vector grid's values transform with its index space (the
/// `vector_type` metadata).
pub const VECTOR_TYPES: [&str; 5] = [
    "invariant",
    "covariant",
    "covariant normalize",
    "contravariant relative",
    "contravariant absolute",
];

/// The vector type of a grid felt writes unless told otherwise: velocities and
/// displacements, which is what felt's vector caches usually hold.
pub const DEFAULT_VECTOR_TYPE: &str = "contravariant relative";

/// Grid metadata holding the inclusive index box of the cache a grid was saved from, so
/// `cacheload` gives back the cache's own domain and not the box of its non-empty leaves.
const DOMAIN_MIN_KEY: &str = "felt_domain_min";
const DOMAIN_MAX_KEY: &str = "felt_domain_max";

/// How a cache becomes a VDB grid.
#[derive(Clone, Debug)]
pub struct GridOptions {
    pub name: String,
    pub class: GridClass,
    /// One of `VECTOR_TYPES`; ignored for scalar grids.
    pub vector_type: String,
    /// The grid's `creator` metadata.
    pub creator: String,
}

/// Where a cache's cells go in a VDB grid's index space.
#[derive(Clone, Debug, PartialEq)]
pub struct Placement {
    /// The grid's index-to-world matrix (the second map of a frustum).
    pub index_to_world: DMat4,
    /// OpenVDB's frustum map, for a frustum cache (`Frustum::vdb_placement`).
    pub frustum: Option<FrustumMap>,
    /// The voxel that holds cell `(0, 0, 0)`.
    pub first_voxel: [i32; 3],
}

/// A scalar or vector cache as a VDB grid (filling the cache first).
pub fn grid_of(cache: &Cache, options: &GridOptions) -> Outcome<VdbGrid> {
    let domain = cache.domain();
    let rotation = domain.rotation;
    let axes = rotation * DMat3::from_diagonal(domain.cell);
    let corner = domain.origin + rotation * (domain.cell * 0.5);
    let index_to_world = DMat4::from_cols(
        axes.x_axis.extend(0.0),
        axes.y_axis.extend(0.0),
        axes.z_axis.extend(0.0),
        corner.extend(1.0),
    );
    let placement = Placement {
        index_to_world,
        frustum: None,
        first_voxel: [0; 3],
    };
    grid_placed(cache, options, &placement)
}

/// A cache as a VDB grid whose cells sit where `placement` puts them.
pub fn grid_placed(
    cache: &Cache,
    options: &GridOptions,
    placement: &Placement,
) -> Outcome<VdbGrid> {
    let value_type = match cache.width() {
        1 => VdbValues::Float,
        3 => VdbValues::Vec3,
        _ => {
            return Err(
                Failure::new("OpenVDB files hold scalar and vector grids, not matrices")
                    .with_help("save the rows of a matrix cache as three vector caches"),
            );
        }
    };
    if value_type == VdbValues::Vec3 && options.class == GridClass::LevelSet {
        return Err(Failure::new(
            "a level set is a scalar grid, not a vector one",
        ));
    }
    let res = cache.resolution();
    if res.iter().any(|&n| n > i32::MAX as usize / 2) {
        return Err(Failure::new(
            "this cache is too large for an OpenVDB index space",
        ));
    }
    // OpenVDB's level sets are negative inside, felt's positive.
    let sign = if options.class == GridClass::LevelSet {
        -1.0f32
    } else {
        1.0
    };
    let mut background = [0f32; 3];
    for (b, v) in background.iter_mut().zip(cache.background_values()) {
        *b = sign * *v as f32;
    }
    let activity = if options.class == GridClass::LevelSet {
        if background[0].is_nan() || background[0] <= 0.0 {
            return Err(Failure::new(format!(
                "a level set's background is its value outside and must be negative (felt's \
                 level sets are positive inside), found {}",
                -background[0]
            ))
            .with_help("give the cache a background: scalarcache c(d, -1.0)"));
        }
        Activity::NarrowBand
    } else {
        Activity::AwayFromBackground(0.0)
    };
    cache.prepare()?;
    cache.fill_all();
    let first = placement.first_voxel;
    let max = [0, 1, 2].map(|a| first[a] + (res[a] as i32 - 1));
    let mut grid = VdbGrid::new(
        &options.name,
        options.class.name(),
        value_type,
        background,
        placement.index_to_world,
    );
    grid.frustum = placement.frustum;
    let mut grid = grid.with_values_from(first, max, activity, |ijk, out| {
        let [i, j, k] = [0, 1, 2].map(|a| (ijk[a] - first[a]) as usize);
        if let Some(v) = cache.value_at_cell(i, j, k) {
            for (o, x) in out.iter_mut().zip(v) {
                *o = sign * x;
            }
        }
    })?;
    grid.metadata = vec![
        ("creator".into(), VdbMeta::String(options.creator.clone())),
        (DOMAIN_MIN_KEY.into(), VdbMeta::Vec3i(first)),
        (DOMAIN_MAX_KEY.into(), VdbMeta::Vec3i(max)),
    ];
    if value_type == VdbValues::Vec3 {
        if !VECTOR_TYPES.contains(&options.vector_type.as_str()) {
            return Err(Failure::new(format!(
                "vector_type must be one of {}, found \"{}\"",
                VECTOR_TYPES.map(|t| format!("\"{t}\"")).join(", "),
                options.vector_type
            )));
        }
        grid.metadata.push((
            "vector_type".into(),
            VdbMeta::String(options.vector_type.clone()),
        ));
    }
    Ok(grid)
}

/// Writes `grid` to the VDB file at `path` with the file-level `metadata`. With `keep`, the
/// grids already in the file stay, except one of the same name, which `grid` replaces where
/// it was.
pub fn save(path: &Path, grid: VdbGrid, keep: bool, metadata: &[(String, VdbMeta)]) -> Outcome<()> {
    // Held from the read to the rename: runs appending to one file at once (a farm's tasks)
    // take turns, or each would write back the file it read and drop the others' grids.
    let _turn = if keep {
        Some(crate::io::output::lock_for_update(path).map_err(|e| {
            Failure::new(format!(
                "cannot add grid '{}' to the VDB file '{}': {e}",
                grid.name,
                path.display()
            ))
        })?)
    } else {
        None
    };
    let mut grids = if keep && path.exists() {
        vdb::read_file(path).map_err(|f| Failure {
            message: format!(
                "cannot add grid '{}' to the VDB file: {}",
                grid.name, f.message
            ),
            ..f
        })?
    } else {
        Vec::new()
    };
    match grids.iter_mut().find(|g| g.name == grid.name) {
        Some(same) => *same = grid,
        None => grids.push(grid),
    }
    vdb::write_file_with_metadata(path, &grids, Compression::Zip, metadata)
}

/// What a loaded grid held that a script author should hear about.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadCheck {
    /// Voxels stored in the file (every voxel of its leaves and of its tiles not equal to the
    /// background), and how many of them are NaN or infinite in some component.
    pub voxels: u64,
    pub non_finite: u64,
    /// The background (the value outside every voxel) is NaN or infinite.
    pub bad_background: bool,
    /// Voxels beyond a frustum grid's index box that are active or not the background: the
    /// frustum's cells do not reach them, so they are not read.
    pub beyond_frustum: u64,
}

impl LoadCheck {
    /// The warning for a grid read from `path`, if it needs one.
    pub fn warning(&self, path: &Path, name: &str) -> Option<String> {
        if self.non_finite == 0 && !self.bad_background && self.beyond_frustum == 0 {
            return None;
        }
        let mut text = format!("cacheload: grid '{name}' of {}", path.display());
        if self.non_finite > 0 {
            text += &format!(
                " is NaN or infinite at {} of its {} voxels",
                grouped(self.non_finite),
                grouped(self.voxels)
            );
        }
        if self.bad_background {
            if self.non_finite > 0 {
                text += ", and";
            }
            text += " has a NaN or infinite background (its value everywhere outside its voxels)";
        }
        if self.beyond_frustum > 0 {
            if self.non_finite > 0 || self.bad_background {
                text += ", and";
            }
            text += &format!(
                " holds {} voxels beyond its frustum's index box, which are not read",
                grouped(self.beyond_frustum)
            );
        }
        Some(text)
    }

    fn count(&mut self, voxels: u64, value: &[f32]) {
        self.voxels += voxels;
        if value.iter().any(|v| !v.is_finite()) {
            self.non_finite += voxels;
        }
    }
}

/// Reads grid `name` of a VDB file into a cache of `width` components (1 or 3), what it found
/// there worth a warning, and for a grid with OpenVDB's frustum map the frustum whose index
/// domain the cache covers.
pub fn load(path: &Path, name: &str, width: usize) -> Outcome<(Cache, LoadCheck, Option<Frustum>)> {
    let grid = vdb::read_grid(path, name)?;
    if grid.value_type.components() != width {
        let found = match grid.value_type {
            VdbValues::Float => "a scalar",
            VdbValues::Vec3 => "a vector",
        };
        return Err(Failure::new(format!(
            "grid '{name}' of {} is {found} grid",
            path.display()
        ))
        .with_help(if width == 1 {
            "read vector grids with cacheloadvector"
        } else {
            "read scalar grids with cacheload"
        }));
    }
    let (domain, min, max, frustum) = match &grid.frustum {
        Some(map) => {
            let (frustum, first) = Frustum::from_vdb(map, &grid.index_to_world, width, name)?;
            let cells = frustum.cells();
            let last = [0, 1, 2].map(|a| first[a] + (cells[a] as i32 - 1));
            (frustum.index_domain()?, first, last, Some(frustum))
        }
        None => {
            let (domain, min, max) = linear_domain(&grid, path, name, width)?;
            (domain, min, max, None)
        }
    };
    // felt's level sets are positive inside, OpenVDB's negative.
    let sign = if grid.class == vdb::LEVEL_SET {
        -1.0f32
    } else {
        1.0
    };
    let background: Vec<f64> = grid.background[..width]
        .iter()
        .map(|&b| f64::from(sign * b))
        .collect();
    let mut check = LoadCheck {
        bad_background: background.iter().any(|b| !b.is_finite()),
        beyond_frustum: if frustum.is_some() {
            beyond(&grid, min, max)
        } else {
            0
        },
        ..LoadCheck::default()
    };
    let mut builder = SparseBuilder::new(domain, width, background)?;
    let inside =
        |ijk: [i64; 3]| (0..3).all(|a| (i64::from(min[a])..=i64::from(max[a])).contains(&ijk[a]));
    let cell =
        |ijk: [i64; 3]| -> [usize; 3] { [0, 1, 2].map(|a| (ijk[a] - i64::from(min[a])) as usize) };
    let mut signed = [0f32; 3];
    let mut set = |builder: &mut SparseBuilder, ijk: [i64; 3], value: &[f32]| -> Outcome<()> {
        // Outside the cache's box every voxel holds the background (see `cache_box`).
        if !inside(ijk) {
            return Ok(());
        }
        for (s, v) in signed.iter_mut().zip(value) {
            *s = sign * v;
        }
        builder.set(cell(ijk), &signed[..value.len()])
    };
    for leaf in &grid.leaves {
        let origin = leaf.origin.map(i64::from);
        let edge = vdb::LEAF_DIM as i64 - 1;
        if !(inside(origin) && inside(origin.map(|o| o + edge))) {
            // A leaf the cache's box cuts goes voxel by voxel.
            for offset in 0..vdb::LEAF_VOXELS {
                let local = [offset >> 6, (offset >> 3) & 7, offset & 7];
                let ijk = [0, 1, 2].map(|a| origin[a] + local[a] as i64);
                let value = &leaf.values[offset * width..(offset + 1) * width];
                check.count(1, value);
                set(&mut builder, ijk, value)?;
            }
            continue;
        }
        check.voxels += vdb::LEAF_VOXELS as u64;
        check.non_finite += leaf
            .values
            .chunks_exact(width)
            .filter(|value| value.iter().any(|v| !v.is_finite()))
            .count() as u64;
        if sign == 1.0 {
            builder.set_leaf(cell(origin), &leaf.values)?;
        } else {
            let flipped: Vec<f32> = leaf.values.iter().map(|v| sign * v).collect();
            builder.set_leaf(cell(origin), &flipped)?;
        }
    }
    for tile in &grid.tiles {
        if tile.value[..width] == grid.background[..width] {
            continue;
        }
        let size = i64::from(tile.size);
        check.count((size * size * size) as u64, &tile.value[..width]);
        let origin = tile.origin.map(i64::from);
        if inside(origin) && inside(origin.map(|o| o + size - 1)) {
            let lo = cell(origin);
            let value: Vec<f32> = tile.value[..width].iter().map(|v| sign * v).collect();
            builder.fill_box(lo, lo.map(|i| i + tile.size as usize), &value)?;
            continue;
        }
        for i in 0..size {
            for j in 0..size {
                for k in 0..size {
                    let ijk = [origin[0] + i, origin[1] + j, origin[2] + k];
                    set(&mut builder, ijk, &tile.value[..width])?;
                }
            }
        }
    }
    let cache = builder
        .build()
        .with_label(format!("cacheload {}#{name}", path.display()))
        .with_profile("cacheload");
    Ok((cache, check, frustum))
}

/// Voxels of `grid` outside the inclusive box `[min, max]` that are active or not the
/// background.
fn beyond(grid: &VdbGrid, min: [i32; 3], max: [i32; 3]) -> u64 {
    let width = grid.components();
    let background = &grid.background[..width];
    let inside =
        |ijk: [i64; 3]| (0..3).all(|a| (i64::from(min[a])..=i64::from(max[a])).contains(&ijk[a]));
    let mut count = 0;
    for leaf in &grid.leaves {
        let origin = leaf.origin.map(i64::from);
        if inside(origin) && inside(origin.map(|o| o + vdb::LEAF_DIM as i64 - 1)) {
            continue;
        }
        for offset in 0..vdb::LEAF_VOXELS {
            let local = [offset >> 6, (offset >> 3) & 7, offset & 7];
            let ijk = [0, 1, 2].map(|a| origin[a] + local[a] as i64);
            let value = &leaf.values[offset * width..(offset + 1) * width];
            if !inside(ijk) && (leaf.is_active(offset) || value != background) {
                count += 1;
            }
        }
    }
    for tile in &grid.tiles {
        if !tile.active && tile.value[..width] == *background {
            continue;
        }
        let size = i64::from(tile.size);
        let overlap: i64 = (0..3)
            .map(|a| {
                let lo = i64::from(tile.origin[a]).max(min[a].into());
                let hi = (i64::from(tile.origin[a]) + size - 1).min(max[a].into());
                (hi - lo + 1).max(0)
            })
            .product();
        count += (size * size * size - overlap) as u64;
    }
    count
}

/// The domain of the cache a grid with a linear transform loads into, and the inclusive voxel
/// box it covers.
fn linear_domain(
    grid: &VdbGrid,
    path: &Path,
    name: &str,
    width: usize,
) -> Outcome<(Domain, [i32; 3], [i32; 3])> {
    let (rotation, voxel) = decompose(&grid.index_to_world, name)?;
    let (min, max) = cache_box(grid);
    // In i64: the box of voxels at -2^30 and 2^30 is 2^31 + 8 wide, past i32.
    let extent: [i64; 3] = [0, 1, 2].map(|a| i64::from(max[a]) - i64::from(min[a]) + 1);
    let bytes = extent.iter().map(|&n| n as f64).product::<f64>() * 4.0 * width as f64;
    if bytes > memory_limit() as f64 {
        return Err(Failure::new(format!(
            "grid '{name}' of {} spans voxel indices {min:?} to {max:?}, a box of {} x {} x {} \
             voxels; felt reads a grid into a cache over that whole box, which would need {}, \
             over the memory budget of {}",
            path.display(),
            extent[0],
            extent[1],
            extent[2],
            human_bytes(bytes),
            human_bytes(memory_limit() as f64)
        ))
        .with_help(
            "crop the grid to where its values are, or raise the limit with --memory-limit",
        ));
    }
    let dims = DVec3::new(extent[0] as f64, extent[1] as f64, extent[2] as f64);
    let first_centre =
        grid.index_to_world_point(DVec3::new(min[0] as f64, min[1] as f64, min[2] as f64));
    let origin = first_centre - rotation * (voxel * 0.5);
    let (axis, angle) = DQuat::from_mat3(&rotation).to_axis_angle();
    let domain = Domain::with_cells(origin, dims * voxel, axis * angle, voxel.x, voxel.z)?;
    domain.check_grid_memory(width)?;
    Ok((domain, min, max))
}

/// The index box a loaded grid's cache covers: for a grid felt saved, the saved cache's own
/// box (recorded in its metadata), grown to any voxel outside it that is active or not the
/// background; for any other grid, the box of all its leaves and tiles.
/// An empty grid without that metadata gives a single voxel at the origin.
fn cache_box(grid: &VdbGrid) -> ([i32; 3], [i32; 3]) {
    let leaves = grid.index_bounds().unwrap_or(([0; 3], [0; 3]));
    let (Some(VdbMeta::Vec3i(lo)), Some(VdbMeta::Vec3i(hi))) =
        (grid.meta(DOMAIN_MIN_KEY), grid.meta(DOMAIN_MAX_KEY))
    else {
        return leaves;
    };
    let (mut lo, mut hi) = (*lo, *hi);
    if (0..3).any(|a| lo[a] > hi[a]) {
        return leaves;
    }
    let width = grid.components();
    let background = &grid.background[..width];
    let saved = (lo, hi);
    let within = |first: [i32; 3], size: i32| {
        (0..3).all(|a| first[a] >= saved.0[a] && first[a] + (size - 1) <= saved.1[a])
    };
    let mut include = |ijk: [i32; 3]| {
        for a in 0..3 {
            lo[a] = lo[a].min(ijk[a]);
            hi[a] = hi[a].max(ijk[a]);
        }
    };
    for leaf in &grid.leaves {
        if within(leaf.origin, vdb::LEAF_DIM) {
            continue;
        }
        for offset in 0..vdb::LEAF_VOXELS {
            let value = &leaf.values[offset * width..(offset + 1) * width];
            if leaf.is_active(offset) || value != background {
                let local = [offset >> 6, (offset >> 3) & 7, offset & 7];
                include([0, 1, 2].map(|a| leaf.origin[a] + local[a] as i32));
            }
        }
    }
    for tile in &grid.tiles {
        if (tile.active || tile.value[..width] != *background) && !within(tile.origin, tile.size) {
            include(tile.origin);
            include(tile.origin.map(|c| c + (tile.size - 1)));
        }
    }
    (lo, hi)
}

/// Rotation and per-axis voxel size of an index-to-world map, if it has no shear or reflection
/// and equal x and y voxel sizes.
fn decompose(m: &DMat4, name: &str) -> Outcome<(DMat3, DVec3)> {
    let axes = [
        m.x_axis.truncate(),
        m.y_axis.truncate(),
        m.z_axis.truncate(),
    ];
    let voxel = DVec3::new(axes[0].length(), axes[1].length(), axes[2].length());
    let refuse = |why: &str| {
        Failure::new(format!(
            "grid '{name}' has a transform felt cannot place in a domain: {why}"
        ))
    };
    if !voxel.is_finite() || voxel.min_element() <= 0.0 {
        return Err(refuse("a voxel size is zero or not finite"));
    }
    let r = DMat3::from_cols(axes[0] / voxel.x, axes[1] / voxel.y, axes[2] / voxel.z);
    let shear =
        r.x_axis.dot(r.y_axis).abs() + r.x_axis.dot(r.z_axis).abs() + r.y_axis.dot(r.z_axis).abs();
    if shear > 1e-6 {
        return Err(refuse("its axes are not perpendicular"));
    }
    if r.determinant() < 0.0 {
        return Err(refuse("it mirrors space"));
    }
    if (voxel.x - voxel.y).abs() > 1e-9 * voxel.x {
        return Err(refuse("its voxels differ in size along x and y"));
    }
    Ok((r, voxel))
}

#[cfg(test)]
#[path = "vdb_cache_tests.rs"]
mod round_trip_tests;
