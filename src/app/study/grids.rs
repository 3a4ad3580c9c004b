//! Comparing the grids of a run's VDB file with the grids of its reference's.
//!
//! Each grid of the reference is compared with the run's grid of the same name by RMSE and
//! largest error (the length of the difference for vector grids). Grids on the same voxels are
//! compared voxel by voxel over the union of their active voxels. The key decision is what to
//! do when the voxels differ, as they do whenever a study sweeps resolution: the run's grid is
//! resampled onto the reference's voxels — trilinear, in world space through each grid's own
//! transform, the run's background outside its nodes, as OpenVDB's resampling does — and
//! compared over the reference's active voxels and the reference voxels whose centres lie in
//! an active voxel of the run's. Such measures are marked `resampled`, and the table says so.

use super::compare::{Kind, Measure};
use crate::grid::vdb::{self, VdbGrid};
use glam::{DMat4, DVec3};
use std::path::Path;

/// Voxels a comparison may visit: a billion takes minutes and is far past any cache a study
/// is meant for.
const MAX_COMPARED_VOXELS: u64 = 1 << 30;

/// The measures of every grid of the reference's file `reference` against the run's `run`.
pub fn compare_vdb(name: &str, run: &Path, reference: &Path) -> Result<Vec<Measure>, String> {
    let ours = vdb::read_file(run).map_err(|f| f.message)?;
    let theirs =
        vdb::read_file(reference).map_err(|f| format!("the reference's copy: {}", f.message))?;
    let mut measures = Vec::new();
    for grid in &theirs {
        let label = if theirs.len() == 1 {
            name.to_string()
        } else {
            format!("{name}:{}", grid.name)
        };
        let other = ours
            .iter()
            .find(|g| g.name == grid.name)
            .ok_or_else(|| format!("it has no grid named '{}' (the reference has)", grid.name))?;
        if other.components() != grid.components() {
            return Err(format!(
                "grid '{}' holds {} components, the reference's {}",
                grid.name,
                other.components(),
                grid.components()
            ));
        }
        let resampled = other.index_to_world != grid.index_to_world;
        // Resampling goes through linear maps: frustum grids compare voxel for voxel only.
        let frustum = other.frustum.is_some() || grid.frustum.is_some();
        if frustum && (resampled || other.frustum != grid.frustum) {
            return Err(format!(
                "grid '{}' has a frustum transform unlike the reference's, which felt does not \
                 resample",
                grid.name
            ));
        }
        let (rmse, max) = if resampled {
            resampled_errors(other, grid).map_err(|e| format!("grid '{}': {e}", grid.name))?
        } else {
            grid_errors(other, grid)?
        };
        for (what, value) in [("rmse", rmse), ("max", max)] {
            measures.push(Measure {
                name: format!("{label} {what}"),
                value,
                kind: Kind::Error,
                resampled,
            });
        }
    }
    Ok(measures)
}

/// Sums of squared errors, the largest error and the count of voxels visited.
#[derive(Default)]
struct Errors {
    squared: f64,
    max: f64,
    count: u64,
}

impl Errors {
    fn add(&mut self, a: [f64; 3], b: [f64; 3], components: usize) {
        let d2: f64 = (0..components).map(|c| (a[c] - b[c]).powi(2)).sum();
        self.squared += d2;
        self.max = self.max.max(d2.sqrt());
        self.count += 1;
    }

    fn result(&self) -> (f64, f64) {
        if self.count == 0 {
            return (0.0, 0.0);
        }
        ((self.squared / self.count as f64).sqrt(), self.max)
    }
}

fn wide(v: [f32; 3]) -> [f64; 3] {
    v.map(f64::from)
}

/// RMSE and largest error of `a` against `b`, on the same voxels, over the union of their
/// active voxels.
fn grid_errors(a: &VdbGrid, b: &VdbGrid) -> Result<(f64, f64), String> {
    let n = b.components();
    let mut errors = Errors::default();
    // The active voxels of `b`, then those of `a` that `b` does not have active.
    for (grid, other) in [(b, None), (a, Some(b))] {
        check_size(grid.active_voxel_count())?;
        for_each_active(grid, |ijk| {
            if other.is_none_or(|o| !o.probe(ijk).1) {
                errors.add(wide(a.probe(ijk).0), wide(b.probe(ijk).0), n);
            }
        });
    }
    Ok(errors.result())
}

fn check_size(voxels: u64) -> Result<(), String> {
    if voxels > MAX_COMPARED_VOXELS {
        return Err(format!("{voxels} voxels are too many to compare"));
    }
    Ok(())
}

/// The map from the index space of `from` to the index space of `to`, through world space.
fn index_map(from: &VdbGrid, to: &VdbGrid) -> Result<DMat4, String> {
    let determinant = to.index_to_world.determinant();
    if !determinant.is_finite() || determinant == 0.0 {
        return Err(String::from(
            "its voxel transform cannot be inverted, so it cannot be resampled",
        ));
    }
    Ok(to.index_to_world.inverse() * from.index_to_world)
}

/// The trilinear interpolation of `grid` at index coordinates `p`: its background where a
/// corner has no node.
fn trilinear(grid: &VdbGrid, p: DVec3) -> [f64; 3] {
    let base = p.floor();
    let t = p - base;
    let origin = [base.x as i32, base.y as i32, base.z as i32];
    let mut sum = [0.0f64; 3];
    for corner in 0..8 {
        let step = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
        let mut weight = 1.0;
        for axis in 0..3 {
            weight *= if step[axis] == 1 {
                t[axis]
            } else {
                1.0 - t[axis]
            };
        }
        if weight == 0.0 {
            continue;
        }
        let ijk = [0, 1, 2].map(|a| origin[a] + step[a]);
        let value = grid.probe(ijk).0;
        for (s, v) in sum.iter_mut().zip(value) {
            *s += weight * v as f64;
        }
    }
    sum
}

/// RMSE and largest error of the run's grid `a`, resampled onto the voxels of the reference's
/// grid `b`, over `b`'s active voxels and the voxels of `b` whose centres lie in an active
/// voxel of `a`.
fn resampled_errors(a: &VdbGrid, b: &VdbGrid) -> Result<(f64, f64), String> {
    let n = b.components();
    let b_to_a = index_map(b, a)?;
    let a_to_b = index_map(a, b)?;
    let at = |ijk: [i32; 3]| {
        b_to_a.transform_point3(DVec3::new(ijk[0] as f64, ijk[1] as f64, ijk[2] as f64))
    };
    let mut errors = Errors::default();
    check_size(b.active_voxel_count())?;
    for_each_active(b, |ijk| {
        errors.add(trilinear(a, at(ijk)), wide(b.probe(ijk).0), n);
    });
    // The voxels of `b` that `a`'s active box covers, found from the box's corners.
    let Some((lo, hi)) = a.active_bounds() else {
        return Ok(errors.result());
    };
    let (mut min, mut max) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for corner in 0..8 {
        let pick = |axis: usize| {
            if (corner >> axis) & 1 == 1 {
                hi[axis] as f64 + 0.5
            } else {
                lo[axis] as f64 - 0.5
            }
        };
        let p = a_to_b.transform_point3(DVec3::new(pick(0), pick(1), pick(2)));
        min = min.min(p);
        max = max.max(p);
    }
    if !min.is_finite() || !max.is_finite() {
        return Err(String::from("its voxels do not map onto the reference's"));
    }
    let (first, last) = (min.floor(), max.ceil());
    let span = last - first + DVec3::ONE;
    check_size((span.x * span.y * span.z).min(u64::MAX as f64) as u64)?;
    for i in first.x as i32..=last.x as i32 {
        for j in first.y as i32..=last.y as i32 {
            for k in first.z as i32..=last.z as i32 {
                let ijk = [i, j, k];
                if b.probe(ijk).1 {
                    continue;
                }
                let p = at(ijk).round();
                if a.probe([p.x as i32, p.y as i32, p.z as i32]).1 {
                    errors.add(trilinear(a, at(ijk)), wide(b.probe(ijk).0), n);
                }
            }
        }
    }
    Ok(errors.result())
}

fn for_each_active(grid: &VdbGrid, mut f: impl FnMut([i32; 3])) {
    for leaf in &grid.leaves {
        for x in 0..8 {
            for y in 0..8 {
                for z in 0..8 {
                    if leaf.is_active(vdb::VdbLeaf::offset(x, y, z)) {
                        let o = leaf.origin;
                        f([o[0] + x as i32, o[1] + y as i32, o[2] + z as i32]);
                    }
                }
            }
        }
    }
    for tile in grid.tiles.iter().filter(|t| t.active) {
        let o = tile.origin;
        for x in 0..tile.size {
            for y in 0..tile.size {
                for z in 0..tile.size {
                    f([o[0] + x, o[1] + y, o[2] + z]);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::vdb::{Activity, VdbValues};

    /// A scalar grid of `n` voxels a side holding `f` at the voxel centres of the unit cube.
    fn cube(n: usize, f: impl Fn(DVec3) -> f32) -> VdbGrid {
        let h = 1.0 / n as f64;
        let index_to_world =
            DMat4::from_translation(DVec3::splat(0.5 * h)) * DMat4::from_scale(DVec3::splat(h));
        let grid = VdbGrid::new(
            "density",
            "fog volume",
            VdbValues::Float,
            [0.0; 3],
            index_to_world,
        );
        let values: Vec<f32> = (0..n * n * n)
            .map(|l| {
                let (i, j, k) = (l / (n * n), (l / n) % n, l % n);
                f(grid.index_to_world_point(DVec3::new(i as f64, j as f64, k as f64)))
            })
            .collect();
        grid.with_dense_values(
            [0, 0, 0],
            [n, n, n],
            &values,
            Activity::AwayFromBackground(0.0),
        )
        .unwrap()
    }

    #[test]
    fn a_linear_field_resamples_exactly_inside_the_coarse_nodes() {
        // Trilinear interpolation reproduces a linear field, so a reference voxel between the
        // coarse grid's nodes has no error; only the border, where the coarse grid's
        // background (0) enters, does.
        let f = |p: DVec3| (1.0 + p.x + 2.0 * p.y - p.z) as f32;
        let (coarse, fine) = (cube(4, f), cube(16, f));
        let b_to_a = index_map(&fine, &coarse).unwrap();
        let inside = b_to_a.transform_point3(DVec3::new(7.0, 8.0, 9.0));
        let value = trilinear(&coarse, inside)[0];
        assert!(
            (value - f64::from(fine.probe([7, 8, 9]).0[0])).abs() < 1e-6,
            "{value}"
        );
        let (rmse, max) = resampled_errors(&coarse, &fine).unwrap();
        assert!(rmse > 0.0 && max > rmse);
        // The same grid on the same voxels has no error either way.
        assert_eq!(grid_errors(&fine, &fine).unwrap(), (0.0, 0.0));
    }
}
