//! A frustum as a VDB file places it: OpenVDB's `NonlinearFrustumMap`, which `cachesave` writes
//! for a frustum cache and `cacheload` reads back (docs/language.md, "Frustum caches").
//!
//! felt centres cell `(i, j, k)` at index coordinates `(i + ½, j + ½, k + ½)`; OpenVDB keeps a
//! voxel's value at integer index coordinates. The voxel of cell `(i, j, k)` is
//! `(i − padding, j − padding, k)`: its x and y are the pixel's, the padding lies at negative
//! indices. OpenVDB's index box is then felt's index domain shifted by the same amount and by
//! −½, `[−p − ½, W + p − ½] × [−p − ½, H + p − ½] × [−½, D − ½]`, so its voxel `v` is felt's
//! index point `q = v − bbox_min` and its x/y middle is the camera's axis. The taper is
//! `near / far`. The one key decision: the depth is counted in widths of the padded near
//! plane, as OpenVDB's own camera constructor counts it, so the second map stretches x and z
//! alike (for square pixels it is a rotation and one scale, the frustum OpenVDB calls simple);
//! its y axis is the camera's down, as felt's rows count down, and with the camera's
//! `right × up = −forward` that keeps it a rotation. An orthographic frustum is a box: it is
//! written as the affine map of that box, and read back as an ordinary cache.

use super::{Frustum, View};
use crate::base::failure::{Failure, Outcome};
use crate::grid::vdb::FrustumMap;
use crate::grid::vdb_cache::Placement;
use glam::{DMat4, DVec3};

/// How far (relative) a file's index box may be off a voxel or a half voxel and still count as
/// on it: rounding, not a different box.
const TOLERANCE: f64 = 1e-9;
/// Axes of a second map this far from perpendicular (the cosine of their angle) are sheared.
const SHEAR: f64 = 1e-6;

impl Frustum {
    /// The voxel that holds cell `(0, 0, 0)`.
    fn first_voxel(&self) -> [i32; 3] {
        // The budget keeps a frustum's padding far inside the index range.
        let pad = i32::try_from(self.padding).map_or(i32::MIN, |p| -p);
        [pad, pad, 0]
    }

    /// Where the cells go in a VDB grid: the transform and the voxel of the first cell.
    pub fn vdb_placement(&self) -> Placement {
        let first_voxel = self.first_voxel();
        let [w, h, d] = self.pixels.map(|n| n as f64);
        let padded = self.cells()[0] as f64;
        let v = &self.view;
        let slab = self.far - self.near;
        // felt's index point of voxel (0, 0, 0).
        let shift = DVec3::new(
            0.5 - first_voxel[0] as f64,
            0.5 - first_voxel[1] as f64,
            0.5,
        );
        if v.orthographic {
            let index_to_world = DMat4::from_cols(
                (v.right * (2.0 * v.half_width / w)).extend(0.0),
                (v.up * (-2.0 * v.half_height / h)).extend(0.0),
                (v.forward * (slab / d)).extend(0.0),
                self.index_to_world(shift).extend(1.0),
            );
            return Placement {
                index_to_world,
                frustum: None,
                first_voxel,
            };
        }
        let near_width = 2.0 * v.half_width * self.near * padded / w;
        let across = v.right * near_width;
        let down = v.up * (-2.0 * v.half_height * self.near * padded / h);
        let index_to_world = DMat4::from_cols(
            across.extend(0.0),
            down.extend(0.0),
            (v.forward * near_width).extend(0.0),
            (v.eye + v.forward * self.near).extend(1.0),
        );
        let cells = DVec3::from_array(self.cells().map(|n| n as f64));
        Placement {
            index_to_world,
            frustum: Some(FrustumMap {
                bbox_min: -shift,
                bbox_max: cells - shift,
                taper: self.near / self.far,
                depth: slab / near_width,
            }),
            first_voxel,
        }
    }

    /// The frustum of a grid with OpenVDB's frustum map `map` and second map `second`, and the
    /// voxel that holds its cell `(0, 0, 0)`; a map felt cannot represent exactly is refused
    /// with the reason, naming grid `name`.
    ///
    /// The cells are the voxels inside the map's index box: along z from the first to the
    /// last, across x and y as many on each side of the box's middle (the view's axis), which
    /// therefore has to lie on a voxel or halfway between two. A box that starts half a voxel
    /// before its first voxel (as felt and Houdini write it) has exactly its voxels as cells;
    /// one that starts on a voxel (as OpenVDB's camera frustums do) gains the voxels on its
    /// far faces.
    pub fn from_vdb(
        map: &FrustumMap,
        second: &DMat4,
        components: usize,
        name: &str,
    ) -> Outcome<(Frustum, [i32; 3])> {
        let refuse = |why: String| {
            Failure::new(format!(
                "grid '{name}' has a frustum transform felt cannot represent: {why}"
            ))
            .with_help("resample the grid to a linear transform")
        };
        // Nudged by rounding's width, so that a face a hair past a voxel still holds it.
        let slack = |x: f64| TOLERANCE * x.abs().max(1.0);
        let first_z = (map.bbox_min.z - slack(map.bbox_min.z)).ceil();
        let last_z = (map.bbox_max.z + slack(map.bbox_max.z)).floor();
        // Twice the middle, in voxels: an integer when the axis is on a voxel or between two.
        let middle = map.bbox_min + map.bbox_max;
        let whole = |x: f64| (x - x.round()).abs() <= slack(x);
        if !(whole(middle.x) && whole(middle.y)) {
            return Err(refuse(format!(
                "the middle of its index box, ({}, {}), is neither on a voxel nor halfway \
                 between two, so its voxels cannot be cells around the view's axis",
                0.5 * middle.x,
                0.5 * middle.y
            )));
        }
        // The first voxel across, and as many cells as reach the same distance past the middle.
        let first_x = (map.bbox_min.x - slack(map.bbox_min.x)).ceil();
        let first_y = (map.bbox_min.y - slack(map.bbox_min.y)).ceil();
        let counts = [
            middle.x.round() - 2.0 * first_x + 1.0,
            middle.y.round() - 2.0 * first_y + 1.0,
            last_z - first_z + 1.0,
        ];
        let first = [first_x, first_y, first_z];
        let fits = |x: f64| x.abs() < f64::from(1 << 30);
        if counts.iter().any(|&n| n < 1.0) || !counts.iter().chain(&first).all(|&x| fits(x)) {
            return Err(refuse(format!(
                "its index box {} to {} holds no whole voxel along some axis, or too many",
                map.bbox_min, map.bbox_max
            )));
        }
        if map.taper > 1.0 {
            return Err(refuse(format!(
                "its taper {} makes the near face wider than the far one",
                map.taper
            )));
        }
        let axes = [second.x_axis, second.y_axis, second.z_axis].map(|a| a.truncate());
        let lengths = axes.map(|a| a.length());
        let [right, down, forward] = [0, 1, 2].map(|a| axes[a] / lengths[a]);
        let up = -down;
        if [right.dot(up), right.dot(forward), up.dot(forward)]
            .iter()
            .any(|c| c.abs() > SHEAR)
        {
            return Err(refuse(
                "its second map shears space (its axes are not perpendicular)".into(),
            ));
        }
        let [fx, fy, fz] = first.map(|c| c as i64);
        let [nx, ny, nz] = counts.map(|n| n as i64);
        // One padding on every side: where the cells start as far before voxel 0 in x as in y.
        let padding = match (fx == fy && fx <= 0).then_some(-fx) {
            Some(p) if nx > 2 * p && ny > 2 * p && p <= (nx - 2 * p).max(ny - 2 * p) => p,
            _ => 0,
        };
        let pixels = [nx - 2 * padding, ny - 2 * padding, nz].map(|n| n as usize);
        let (w, h) = (pixels[0] as f64, pixels[1] as f64);
        let extent = map.bbox_max - map.bbox_min;
        // OpenVDB's z' (the frustum's depth coordinate) of the cells' near and far faces.
        let depth_at = |z: f64| (z - map.bbox_min.z) * map.depth / extent.z;
        let (front, back) = (depth_at(first_z - 0.5), depth_at(last_z + 0.5));
        let translation = second.w_axis.truncate();
        // OpenVDB divides x and y alike by the box's x extent.
        let per_x = 1.0 / extent.x;
        let (eye, near, far, half_width, half_height, orthographic) = if map.taper == 1.0 {
            // A box: any positive near distance places it; one slice keeps the numbers alike.
            let near = lengths[2] * (back - front) / nz as f64;
            let eye = translation + axes[2] * front - forward * near;
            let half = |a: usize, n: f64| 0.5 * lengths[a] * n * per_x;
            let far = near + lengths[2] * (back - front);
            (eye, near, far, half(0, w), half(1, h), true)
        } else {
            // The apex is where OpenVDB's growth factor 1 + γ·z' vanishes, `apex` before z' = 0.
            let gamma = (1.0 / map.taper - 1.0) / map.depth;
            let apex = lengths[2] / gamma;
            let half = |a: usize, n: f64| 0.5 * lengths[a] * n * per_x / apex;
            let eye = translation - axes[2] / gamma;
            let (near, far) = (apex + lengths[2] * front, apex + lengths[2] * back);
            (eye, near, far, half(0, w), half(1, h), false)
        };
        let view = View {
            eye,
            right,
            up,
            forward,
            half_width,
            half_height,
            orthographic,
        };
        let frustum =
            Frustum::new(view, near, far, pixels, padding as usize, components).map_err(|f| {
                Failure {
                    message: format!("grid '{name}': {}", f.message),
                    ..f
                }
            })?;
        Ok((frustum, [fx, fy, fz].map(|c| c as i32)))
    }
}
