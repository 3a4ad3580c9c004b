//! Frustum buffers: a cache whose cells follow a camera's pixels and depth (docs/language.md,
//! "Frustum caches").
//!
//! Cell `(i, j, k)` covers pixel `(i − padding, j − padding)` of the camera's image (row 0 at
//! the top, as the renderer numbers pixels) and depth slice `k` of `depth` slices between
//! `near` and `far`, so a distant or camera-filling effect gets its cells where the camera
//! resolves it. The storage is an ordinary [`Cache`](crate::grid::cache::Cache) over an *index
//! domain*: the box `[0, W] × [0, H] × [0, D]` of unit cells, whose cell centres are
//! `(i + ½, j + ½, k + ½)`. Everything a cache does (lazy bricks, brick extremes, budgets,
//! splats, determinism) works there unchanged; the frustum only maps between the two spaces.
//!
//! The one key decision: slices are uniform in depth, not in 1/z. A cell's width then grows
//! in proportion to its depth and its length along the view stays `(far − near) / depth`, so
//! the cells' shape stays bounded (slices uniform in 1/z grow as z², and the farthest slice of
//! a deep frustum is longer than the whole near half), and the index-to-world map is bilinear:
//! a cache fill composes the field with a map that needs no division, and the world-to-index
//! map is one division by depth.

mod read;
pub use read::FrustumRead;
#[cfg(test)]
mod tests;
mod vdb_map;
#[cfg(test)]
mod vdb_tests;

use crate::base::failure::{Failure, Outcome};
use crate::space::Aabb;
use crate::space::domain::Domain;
use glam::{DMat3, DVec3};

/// Where a camera is and what it sees: the numbers of a camera a frustum needs, for an image of
/// a given size (the interpreter takes them from a `camera` value).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    pub eye: DVec3,
    pub right: DVec3,
    pub up: DVec3,
    pub forward: DVec3,
    /// Half the image plane's width and height: at unit distance for a perspective camera, in
    /// world units for an orthographic one.
    pub half_width: f64,
    pub half_height: f64,
    pub orthographic: bool,
}

/// A frustum divided into cells: `width × height` pixels (plus `padding` on each side) by
/// `depth` slices between `near` and `far`.
#[derive(Clone, Debug, PartialEq)]
pub struct Frustum {
    view: View,
    near: f64,
    far: f64,
    /// Image pixels across and down, and depth slices.
    pixels: [usize; 3],
    padding: usize,
}

/// The map from a frustum cache's index coordinates `q` to world points, as numbers: depth
/// `d = q.z·depth.0 + depth.1`, across `a = (q.x·across.0 + across.1)·half_width`, upward
/// `u = (q.y·upward.0 + upward.1)·half_height`, the last two times `d` unless orthographic, and
/// the point `eye + forward·d + right·a + up·u`. It is bilinear in `q`, so a field built from
/// it (`field::shapes::frustum_cell_to_world`) keeps interval bounds sound and tight.
#[derive(Clone, Copy, Debug)]
pub struct IndexMap {
    pub view: View,
    /// `(scale, offset)` of each axis's affine part.
    pub depth: (f64, f64),
    pub across: (f64, f64),
    pub upward: (f64, f64),
}

impl Frustum {
    /// Checks the numbers a script gave and the memory a grid of `components` per cell takes.
    pub fn new(
        view: View,
        near: f64,
        far: f64,
        pixels: [usize; 3],
        padding: usize,
        components: usize,
    ) -> Outcome<Frustum> {
        if !(near.is_finite() && near > 0.0) {
            return Err(Failure::new(format!(
                "a frustum's near distance must be positive, got {near}"
            ))
            .with_help("near is the distance from the eye to the first depth slice, e.g. 0.1"));
        }
        if !(far.is_finite() && far > near) {
            return Err(Failure::new(format!(
                "a frustum's far distance must be beyond its near distance {near}, got {far}"
            ))
            .with_help("far is the distance from the eye to the back of the last depth slice"));
        }
        let [width, height, depth] = pixels;
        if width == 0 || height == 0 || depth == 0 {
            return Err(Failure::new(format!(
                "a frustum needs at least one cell along each axis, got {width} x {height} x {depth}"
            )));
        }
        let limit = pixels[0].max(pixels[1]);
        if padding > limit {
            return Err(Failure::new(format!(
                "a frustum's padding of {padding} pixels is more than its image ({width} x {height})"
            ))
            .with_help("padding adds cells beyond the image's edges: a few pixels are enough"));
        }
        // In floating point: sizes near the integer range's end must not overflow here.
        let padded = |n: usize| n as f64 + 2.0 * padding as f64;
        let cells = padded(width) * padded(height) * depth as f64;
        crate::engine::budget::check(
            cells * components as f64 * 4.0,
            &format!(
                "a frustum cache of {} x {} x {depth} cells",
                padded(width),
                padded(height)
            ),
        )?;
        let frustum = Frustum {
            view,
            near,
            far,
            pixels,
            padding,
        };
        let corners = frustum.corners();
        if corners.iter().any(|c| !c.is_finite()) {
            return Err(Failure::new(format!(
                "a frustum from near {near} to far {far} reaches beyond the range of \
                 floating-point numbers"
            )));
        }
        Ok(frustum)
    }

    /// Cells along each axis of the index domain: the padded image and the slices.
    pub fn cells(&self) -> [usize; 3] {
        let pad = 2 * self.padding;
        [self.pixels[0] + pad, self.pixels[1] + pad, self.pixels[2]]
    }

    /// The box of unit cells the storage lives on: cell `(i, j, k)` is centred at
    /// `(i + ½, j + ½, k + ½)`.
    pub fn index_domain(&self) -> Outcome<Domain> {
        let [x, y, z] = self.cells().map(|n| n as f64);
        Domain::with_cells(DVec3::ZERO, DVec3::new(x, y, z), DVec3::ZERO, 1.0, 1.0)
    }

    /// Distance along the view of index coordinate `q.z`.
    fn depth_of(&self, q: f64) -> f64 {
        self.near + (self.far - self.near) * q / self.pixels[2] as f64
    }

    /// The image-plane coordinates (-1 at the left and bottom edges, +1 at the right and top) of
    /// index coordinates `q.x, q.y`.
    fn plane_of(&self, q: DVec3) -> (f64, f64) {
        let pad = self.padding as f64;
        (
            2.0 * (q.x - pad) / self.pixels[0] as f64 - 1.0,
            1.0 - 2.0 * (q.y - pad) / self.pixels[1] as f64,
        )
    }

    /// The world point of index coordinates `q` (cell centres at half-integers).
    pub fn index_to_world(&self, q: DVec3) -> DVec3 {
        let v = &self.view;
        let depth = self.depth_of(q.z);
        let (x, y) = self.plane_of(q);
        let spread = if v.orthographic { 1.0 } else { depth };
        v.eye
            + v.forward * depth
            + v.right * (x * v.half_width * spread)
            + v.up * (y * v.half_height * spread)
    }

    /// The camera's coordinates of a world point: across, up, and depth along the view.
    fn camera_coordinates(&self, p: DVec3) -> DVec3 {
        let offset = p - self.view.eye;
        DVec3::new(
            offset.dot(self.view.right),
            offset.dot(self.view.up),
            offset.dot(self.view.forward),
        )
    }

    /// Whether a perspective division by `depth` is safe: points nearer than half the near
    /// distance are outside the frustum whatever their direction, and are sent to a point
    /// outside the index domain instead of being divided.
    fn divisible(&self, depth: f64) -> bool {
        self.view.orthographic || depth > 0.5 * self.near
    }

    /// The index coordinates of a world point; a point outside the frustum maps outside the
    /// index domain, and every result is finite for a finite point.
    pub fn world_to_index(&self, p: DVec3) -> DVec3 {
        let c = self.camera_coordinates(p);
        let qz = (c.z - self.near) / (self.far - self.near) * self.pixels[2] as f64;
        if !self.divisible(c.z) {
            return DVec3::new(-1.0, -1.0, qz.min(-1.0));
        }
        let spread = if self.view.orthographic { 1.0 } else { c.z };
        self.index_of_plane(
            c.x / (spread * self.view.half_width),
            c.y / (spread * self.view.half_height),
            qz,
        )
    }

    fn index_of_plane(&self, x: f64, y: f64, qz: f64) -> DVec3 {
        let pad = self.padding as f64;
        DVec3::new(
            pad + 0.5 * self.pixels[0] as f64 * (x + 1.0),
            pad + 0.5 * self.pixels[1] as f64 * (1.0 - y),
            qz,
        )
    }

    /// The derivatives of `world_to_index` at `p`: row `m` is the gradient of index coordinate
    /// `m` (zero where the point is sent outside).
    pub fn jacobian(&self, p: DVec3) -> DMat3 {
        let v = &self.view;
        let c = self.camera_coordinates(p);
        if !self.divisible(c.z) {
            return DMat3::ZERO;
        }
        let sx = 0.5 * self.pixels[0] as f64 / v.half_width;
        let sy = -0.5 * self.pixels[1] as f64 / v.half_height;
        let sz = self.pixels[2] as f64 / (self.far - self.near);
        // q.x = pad + sx·(x / z + 1): d(x / z) = (right − (x / z)·forward) / z.
        let (dx, dy) = if v.orthographic {
            (v.right, v.up)
        } else {
            (
                (v.right - v.forward * (c.x / c.z)) / c.z,
                (v.up - v.forward * (c.y / c.z)) / c.z,
            )
        };
        DMat3::from_cols(dx * sx, dy * sy, v.forward * sz).transpose()
    }

    /// The eight corners of the padded frustum in world space.
    pub fn corners(&self) -> [DVec3; 8] {
        let [x, y, z] = self.cells().map(|n| n as f64);
        std::array::from_fn(|n| {
            self.index_to_world(DVec3::new(
                if n & 1 != 0 { x } else { 0.0 },
                if n & 2 != 0 { y } else { 0.0 },
                if n & 4 != 0 { z } else { 0.0 },
            ))
        })
    }

    /// The world box around the frustum: outside it every read is the background.
    pub fn bounds(&self) -> Aabb {
        let corners = self.corners();
        corners[1..]
            .iter()
            .fold(Aabb::new(corners[0], corners[0]), |b, c| {
                Aabb::new(b.min.min(*c), b.max.max(*c))
            })
    }

    /// A box of index coordinates that holds the index of every point of the world box
    /// `region`, as tight as the corners allow: depth and the camera's across and up
    /// coordinates are linear, so their extremes over a box are at its corners, and so are
    /// those of their ratios where the depth is positive throughout (a linear-fractional
    /// function has no extreme inside a convex region where its denominator keeps its sign).
    /// Coordinates are clamped to one cell beyond the index domain, which keeps "outside" in
    /// the box without infinities.
    pub fn index_box(&self, region: &Aabb) -> Aabb {
        let [nx, ny, nz] = self.cells().map(|n| n as f64);
        let reach = Aabb::new(DVec3::splat(-1.0), DVec3::new(nx + 1.0, ny + 1.0, nz + 1.0));
        if region.is_empty() {
            return Aabb::new(reach.max, reach.min);
        }
        let clamp = |v: f64, lo: f64, hi: f64| if v.is_nan() { lo } else { v.clamp(lo, hi) };
        let corner = |n: usize| {
            let pick = |a: usize, bit: usize| {
                let v = if n & bit != 0 {
                    region.max[a]
                } else {
                    region.min[a]
                };
                clamp(v, -f64::MAX, f64::MAX)
            };
            self.camera_coordinates(DVec3::new(pick(0, 1), pick(1, 2), pick(2, 4)))
        };
        let camera: [DVec3; 8] = std::array::from_fn(corner);
        if camera.iter().any(|c| !c.is_finite()) {
            // A box reaching towards infinity: anything may be read.
            return reach;
        }
        let nearest = camera.iter().map(|c| c.z).fold(f64::INFINITY, f64::min);
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for c in &camera {
            let q = if self.divisible(nearest) {
                let spread = if self.view.orthographic { 1.0 } else { c.z };
                self.index_of_plane(
                    c.x / (spread * self.view.half_width),
                    c.y / (spread * self.view.half_height),
                    0.0,
                )
            } else {
                DVec3::ZERO
            };
            let qz = (c.z - self.near) / (self.far - self.near) * nz;
            let q = DVec3::new(q.x, q.y, qz);
            lo = lo.min(q);
            hi = hi.max(q);
        }
        if !self.divisible(nearest) {
            // Some of the box is beside or behind the eye: any pixel, and the point outside
            // the domain that `world_to_index` sends such points to.
            lo = DVec3::new(reach.min.x, reach.min.y, reach.min.z);
            hi = DVec3::new(reach.max.x, reach.max.y, hi.z);
        }
        // A hair wider than rounding, so that a corner computed a bit inside still counts.
        let slack = DVec3::splat(1e-9) * (DVec3::ONE + lo.abs().max(hi.abs()));
        let lo = lo - slack;
        let hi = hi + slack;
        Aabb::new(
            DVec3::new(
                clamp(lo.x, reach.min.x, reach.max.x),
                clamp(lo.y, reach.min.y, reach.max.y),
                clamp(lo.z, reach.min.z, reach.max.z),
            ),
            DVec3::new(
                clamp(hi.x, reach.min.x, reach.max.x),
                clamp(hi.y, reach.min.y, reach.max.y),
                clamp(hi.z, reach.min.z, reach.max.z),
            ),
        )
    }

    /// The numbers of the map from index coordinates to world points (see [`IndexMap`]).
    pub fn index_map(&self) -> IndexMap {
        let v = &self.view;
        let [w, h, d] = self.pixels.map(|n| n as f64);
        let pad = self.padding as f64;
        IndexMap {
            view: *v,
            depth: ((self.far - self.near) / d, self.near),
            across: (2.0 / w, -2.0 * pad / w - 1.0),
            upward: (-2.0 / h, 1.0 + 2.0 * pad / h),
        }
    }

    /// A short description for profiles and messages.
    pub fn label(&self) -> String {
        let [x, y, z] = self.cells();
        format!(
            "frustum of {x} x {y} x {z} cells from {} to {}",
            self.near, self.far
        )
    }
}
