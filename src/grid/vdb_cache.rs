//! Caches to and from OpenVDB grids: `cachesave` and `cacheload`.
//!
//! A cache's domain maps onto a VDB linear transform exactly: index `(i, j, k)` is the centre of
//! cell `(i, j, k)`, so `index_to_world = translate(origin + R·cell/2) · R · scale(cell)`. The one
//! key decision: a loaded grid becomes an ordinary sparse cache over the index box that holds
//! every leaf and tile of the file, so everything downstream (interpolation, exact interpolant
//! gradients, empty-brick skipping in the raymarcher) treats file data and sampled fields alike.
//! Transforms with shear, reflection or different x and y voxel sizes are refused with a
//! message, since a cache domain cannot represent them.

use crate::failure::{Failure, Outcome};
use crate::grid::cache::{Cache, SparseBuilder};
use crate::grid::domain::Domain;
use crate::grid::vdb::{self, Activity, Compression, VdbGrid, VdbValues};
use glam::{DMat3, DMat4, DQuat, DVec3};
use std::path::Path;

/// Writes a scalar or vector cache as one grid called `name` (filling it first).
pub fn save(cache: &Cache, path: &Path, name: &str) -> Outcome<()> {
    let (value_type, class) = match cache.width() {
        1 => (VdbValues::Float, vdb::FOG_VOLUME),
        3 => (VdbValues::Vec3, vdb::UNKNOWN_CLASS),
        _ => {
            return Err(
                Failure::new("OpenVDB files hold scalar and vector grids, not matrices")
                    .with_help("save the rows of a matrix cache as three vector caches"),
            );
        }
    };
    let domain = cache.domain();
    let res = cache.resolution();
    if res.iter().any(|&n| n > i32::MAX as usize / 2) {
        return Err(Failure::new(
            "this cache is too large for an OpenVDB index space",
        ));
    }
    let rotation = domain.rotation;
    let axes = rotation * DMat3::from_diagonal(domain.cell);
    let corner = domain.origin + rotation * (domain.cell * 0.5);
    let index_to_world = DMat4::from_cols(
        axes.x_axis.extend(0.0),
        axes.y_axis.extend(0.0),
        axes.z_axis.extend(0.0),
        corner.extend(1.0),
    );
    let mut background = [0f32; 3];
    for (b, v) in background.iter_mut().zip(cache.background_values()) {
        *b = *v as f32;
    }
    cache.prepare()?;
    cache.fill_all();
    let max = res.map(|n| n as i32 - 1);
    let grid = VdbGrid::new(name, class, value_type, background, index_to_world).with_values_from(
        [0, 0, 0],
        max,
        Activity::AwayFromBackground(0.0),
        |ijk, out| {
            let value = cache.value_at_cell(ijk[0] as usize, ijk[1] as usize, ijk[2] as usize);
            if let Some(v) = value {
                out.copy_from_slice(v);
            }
        },
    )?;
    vdb::write_file(path, &[grid], Compression::Zip)
}

/// Reads grid `name` of a VDB file into a cache of `width` components (1 or 3).
pub fn load(path: &Path, name: &str, width: usize) -> Outcome<Cache> {
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
    let (rotation, voxel) = decompose(&grid.index_to_world, name)?;
    let (min, max) = grid.index_bounds().unwrap_or(([0; 3], [0; 3]));
    let dims = DVec3::new(
        (max[0] - min[0] + 1) as f64,
        (max[1] - min[1] + 1) as f64,
        (max[2] - min[2] + 1) as f64,
    );
    let first_centre =
        grid.index_to_world_point(DVec3::new(min[0] as f64, min[1] as f64, min[2] as f64));
    let origin = first_centre - rotation * (voxel * 0.5);
    let (axis, angle) = DQuat::from_mat3(&rotation).to_axis_angle();
    let domain = Domain::with_cells(origin, dims * voxel, axis * angle, voxel.x, voxel.z)?;
    domain.check_grid_memory(width)?;
    let background: Vec<f64> = grid.background[..width].iter().map(|&b| b as f64).collect();
    let mut builder = SparseBuilder::new(domain, width, background)?;
    let cell = |ijk: [i32; 3]| -> [usize; 3] { [0, 1, 2].map(|a| (ijk[a] - min[a]) as usize) };
    for leaf in &grid.leaves {
        for offset in 0..vdb::LEAF_VOXELS {
            let local = [
                (offset >> 6) as i32,
                ((offset >> 3) & 7) as i32,
                (offset & 7) as i32,
            ];
            let ijk = [0, 1, 2].map(|a| leaf.origin[a] + local[a]);
            builder.set(
                cell(ijk),
                &leaf.values[offset * width..(offset + 1) * width],
            )?;
        }
    }
    for tile in &grid.tiles {
        if tile.value[..width] == grid.background[..width] {
            continue;
        }
        let size = tile.size;
        for i in 0..size {
            for j in 0..size {
                for k in 0..size {
                    let ijk = [tile.origin[0] + i, tile.origin[1] + j, tile.origin[2] + k];
                    builder.set(cell(ijk), &tile.value[..width])?;
                }
            }
        }
    }
    Ok(builder
        .build()
        .with_label(format!("cacheload {}#{name}", path.display()))
        .with_profile("cacheload"))
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
