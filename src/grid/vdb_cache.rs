//! Caches to and from OpenVDB grids: `cachesave` and `cacheload`.
//!
//! A cache's domain maps onto a VDB linear transform exactly: index `(i, j, k)` is the centre of
//! cell `(i, j, k)`, so `index_to_world = translate(origin + R·cell/2) · R · scale(cell)`. The one
//! key decision: a loaded grid becomes an ordinary sparse cache over the index box that holds
//! every leaf and tile of the file, so everything downstream (interpolation, exact interpolant
//! gradients, empty-brick skipping in the raymarcher) treats file data and sampled fields alike.
//! Transforms with shear, reflection or different x and y voxel sizes are refused with a
//! message, since a cache domain cannot represent them.

use crate::budget::human as human_bytes;
use crate::diagnostic::grouped;
use crate::failure::{Failure, Outcome};
use crate::grid::cache::{Cache, SparseBuilder};
use crate::grid::domain::{Domain, memory_limit};
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

/// What a loaded grid held that a script author should hear about.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadCheck {
    /// Voxels stored in the file (every voxel of its leaves and of its tiles not equal to the
    /// background), and how many of them are NaN or infinite in some component.
    pub voxels: u64,
    pub non_finite: u64,
    /// The background (the value outside every voxel) is NaN or infinite.
    pub bad_background: bool,
}

impl LoadCheck {
    /// The warning for a grid read from `path`, if it needs one.
    pub fn warning(&self, path: &Path, name: &str) -> Option<String> {
        if self.non_finite == 0 && !self.bad_background {
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
        Some(text)
    }

    fn count(&mut self, voxels: u64, value: &[f32]) {
        self.voxels += voxels;
        if value.iter().any(|v| !v.is_finite()) {
            self.non_finite += voxels;
        }
    }
}

/// Reads grid `name` of a VDB file into a cache of `width` components (1 or 3), and what it
/// found there worth a warning.
pub fn load(path: &Path, name: &str, width: usize) -> Outcome<(Cache, LoadCheck)> {
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
    let background: Vec<f64> = grid.background[..width].iter().map(|&b| b as f64).collect();
    let mut check = LoadCheck {
        bad_background: background.iter().any(|b| !b.is_finite()),
        ..LoadCheck::default()
    };
    let mut builder = SparseBuilder::new(domain, width, background)?;
    let cell =
        |ijk: [i64; 3]| -> [usize; 3] { [0, 1, 2].map(|a| (ijk[a] - i64::from(min[a])) as usize) };
    for leaf in &grid.leaves {
        check.voxels += vdb::LEAF_VOXELS as u64;
        check.non_finite += leaf
            .values
            .chunks_exact(width)
            .filter(|value| value.iter().any(|v| !v.is_finite()))
            .count() as u64;
        builder.set_leaf(cell(leaf.origin.map(i64::from)), &leaf.values)?;
    }
    for tile in &grid.tiles {
        if tile.value[..width] == grid.background[..width] {
            continue;
        }
        let size = i64::from(tile.size);
        check.count((size * size * size) as u64, &tile.value[..width]);
        let lo = cell(tile.origin.map(i64::from));
        builder.fill_box(lo, lo.map(|i| i + tile.size as usize), &tile.value[..width])?;
    }
    let cache = builder
        .build()
        .with_label(format!("cacheload {}#{name}", path.display()))
        .with_profile("cacheload");
    Ok((cache, check))
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
mod tests {
    use super::*;
    use crate::grid::vdb::VdbLeaf;

    /// A file holding one scalar grid "density" with unit voxels and these leaves, each filled
    /// with its value and all active.
    fn file_with_leaves(dir: &Path, leaves: &[([i32; 3], f32)]) -> std::path::PathBuf {
        let mut grid = VdbGrid::new(
            "density",
            vdb::FOG_VOLUME,
            VdbValues::Float,
            [0.0; 3],
            DMat4::IDENTITY,
        );
        for &(origin, value) in leaves {
            grid.leaves.push(VdbLeaf {
                origin,
                values: vec![value; vdb::LEAF_VOXELS],
                active: [u64::MAX; 8],
            });
        }
        grid.sort_nodes();
        let path = dir.join("leaves.vdb");
        vdb::write_file(&path, &[grid], Compression::Zip).unwrap();
        path
    }

    #[test]
    fn an_index_box_past_i32_is_too_large_not_negative() {
        let dir = tempfile::tempdir().unwrap();
        let far = 1 << 30;
        let path = file_with_leaves(dir.path(), &[([-far, 0, 0], 1.0), ([far, 0, 0], 2.0)]);
        let message = load(&path, "density", 1).unwrap_err().message;
        assert!(
            message.contains(
                "spans voxel indices [-1073741824, 0, 0] to [1073741831, 7, 7], a box of \
                 2147483656 x 8 x 8 voxels"
            ) && message.contains("over the memory budget"),
            "{message}"
        );
        assert!(!message.contains("must be positive"), "{message}");
        // One leaf that far out is an ordinary small cache.
        let path = file_with_leaves(dir.path(), &[([far, -far, 0], 3.0)]);
        let (cache, check) = load(&path, "density", 1).unwrap();
        assert_eq!(cache.resolution(), [8, 8, 8]);
        assert_eq!(cache.value_at_cell(7, 7, 7), Some(&[3.0f32][..]));
        assert_eq!(check.warning(&path, "density"), None);
    }

    #[test]
    fn non_finite_voxels_are_counted_on_load() {
        let dir = tempfile::tempdir().unwrap();
        let path = file_with_leaves(dir.path(), &[([0, 0, 0], f32::NAN), ([8, 0, 0], 1.0)]);
        let (_, check) = load(&path, "density", 1).unwrap();
        assert_eq!(
            check,
            LoadCheck {
                voxels: 1024,
                non_finite: 512,
                bad_background: false
            }
        );
        assert_eq!(
            check.warning(&path, "density").unwrap(),
            format!(
                "cacheload: grid 'density' of {} is NaN or infinite at 512 of its 1,024 voxels",
                path.display()
            )
        );
    }
}
