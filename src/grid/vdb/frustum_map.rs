//! OpenVDB's `NonlinearFrustumMap`, the one transform of a VDB file that is not linear: how a
//! file stores it.
//!
//! OpenVDB maps index coordinates to the world in two steps: the frustum's own map takes the
//! index box `bbox` to a tapered box (x and y centred on the box's middle and divided by its x
//! extent, z scaled to `depth` over the box's z extent, x and y then grown by `1 + γ·z` with
//! `γ = (1/taper − 1)/depth`), and a second, affine map places that in the world. The file
//! holds the box (two `Vec3d`), the taper and the depth (`f64`), then the second map as a map of
//! its own (its type name and its numbers). The one key decision: a grid keeps the second map in
//! its `index_to_world` matrix, where every linear transform lives, and only the frustum's own
//! numbers here, so the checks and the serialisation of affine maps serve both.

use super::cursor::Cursor;
use crate::base::failure::Outcome;
use glam::{DMat4, DVec3};

/// The OpenVDB name of the map.
pub const FRUSTUM_MAP: &str = "NonlinearFrustumMap";

/// The frustum part of a `NonlinearFrustumMap` (its second map is the grid's `index_to_world`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrustumMap {
    /// The index box the frustum spans, in continuous index coordinates (voxel centres at
    /// integers): its x/y middle is the view's axis, its low and high z faces the near and far
    /// planes.
    pub bbox_min: DVec3,
    pub bbox_max: DVec3,
    /// The near plane's width over the far plane's.
    pub taper: f64,
    /// The distance from the near plane to the far one, in widths of the near plane (before
    /// the second map scales it).
    pub depth: f64,
}

impl FrustumMap {
    /// Reads the frustum's numbers, up to the second map's type name; checks what OpenVDB's
    /// `init` checks (a box of positive extent) and that the numbers give a finite map.
    pub(super) fn read(cur: &mut Cursor) -> Outcome<FrustumMap> {
        let at = cur.pos();
        let map = FrustumMap {
            bbox_min: cur.vec3d("a frustum map's index box")?,
            bbox_max: cur.vec3d("a frustum map's index box")?,
            taper: cur.f64("a frustum map's taper")?,
            depth: cur.f64("a frustum map's depth")?,
        };
        let extent = map.bbox_max - map.bbox_min;
        if !(map.bbox_min.is_finite() && map.bbox_max.is_finite() && extent.min_element() > 0.0) {
            return Err(cur.fail(
                at,
                format!(
                    "the frustum map's index box {} to {} is empty or not finite",
                    map.bbox_min, map.bbox_max
                ),
            ));
        }
        if !(map.taper.is_finite() && map.taper > 0.0 && map.depth.is_finite() && map.depth > 0.0) {
            return Err(cur.fail(
                at,
                format!(
                    "the frustum map's taper {} and depth {} must be positive and finite",
                    map.taper, map.depth
                ),
            ));
        }
        Ok(map)
    }

    /// OpenVDB's `applyMap`: the world point of index coordinates `index`, with `second` the
    /// map applied after the frustum's own.
    pub fn apply(&self, second: &DMat4, index: DVec3) -> DVec3 {
        let extent = self.bbox_max - self.bbox_min;
        let gamma = (1.0 / self.taper - 1.0) / self.depth;
        let centred = index - self.bbox_min - DVec3::new(0.5 * extent.x, 0.5 * extent.y, 0.0);
        let z = centred.z * (self.depth / extent.z);
        let grow = (gamma * z + 1.0) / extent.x;
        second.transform_point3(DVec3::new(centred.x * grow, centred.y * grow, z))
    }

    /// Appends the frustum's numbers; the second map follows.
    pub(super) fn write(&self, out: &mut Vec<u8>) {
        for value in [self.bbox_min, self.bbox_max]
            .iter()
            .flat_map(|v| v.to_array())
            .chain([self.taper, self.depth])
        {
            out.extend_from_slice(&value.to_le_bytes());
        }
    }
}
