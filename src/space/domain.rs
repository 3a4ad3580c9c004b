//! Domains: oriented boxes in world space, optionally divided into cells.
//!
//! A domain is a corner `origin`, edge `lengths` along its own axes, and an `orientation`
//! rotation vector (axis times angle, radians) from the world axes. With cells, samples sit at
//! cell centres (cell `(i, j, k)` is centred at local `((i + ½)·cx, (j + ½)·cy, (k + ½)·cz)`).
//! The one key decision: cells have exactly the size asked for (cubic with one cell size), and
//! the number of cells along an axis is `round(length / cell)` (at least one); the box's length
//! is then `count × cell`, keeping its origin. So cells tile the box exactly and a VDB file of
//! the grid has cubic voxels; a length that is not a multiple of the cell moves the far faces
//! by up to half a cell, which `length_change` reports so the script can be warned.

use crate::base::failure::vector_text;
use crate::base::failure::{Failure, Outcome};
use crate::space::Aabb;
use glam::{DMat3, DQuat, DVec3};

/// An oriented box, optionally with a cell grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Domain {
    pub origin: DVec3,
    pub lengths: DVec3,
    /// Rotation vector as given (axis × angle).
    pub orientation: DVec3,
    /// Columns are the domain's axes in world space.
    pub rotation: DMat3,
    /// Cell counts along the domain's axes; `None` for a domain without cells.
    pub resolution: Option<[usize; 3]>,
    /// Cell sizes along the domain's axes (zero when there are no cells).
    pub cell: DVec3,
}

/// The run's memory budget: no single grid may be larger.
pub fn memory_limit() -> u64 {
    crate::engine::budget::limit()
}

impl Domain {
    /// A domain without cells.
    pub fn new(origin: DVec3, lengths: DVec3, orientation: DVec3) -> Outcome<Domain> {
        check_finite("origin", origin)?;
        check_finite("orientation", orientation)?;
        check_positive("lengths", lengths)?;
        let rotation = rotation_of(orientation)?;
        let domain = Domain {
            origin,
            lengths,
            orientation,
            rotation,
            resolution: None,
            cell: DVec3::ZERO,
        };
        domain.check_representable()?;
        Ok(domain)
    }

    /// Checks that the box's corners are finite and that its edges survive rounding where it
    /// sits (a box of length 1e-3 at 1e20 would have all its points in one place).
    fn check_representable(&self) -> Outcome<()> {
        let corners = self.corners();
        if let Some(bad) = corners.iter().find(|c| !c.is_finite()) {
            return Err(Failure::new(format!(
                "domain corner {} is not finite: origin {} plus lengths {} leaves the range of \
                 floating-point numbers",
                vector_text(*bad),
                vector_text(self.origin),
                vector_text(self.lengths)
            ))
            .with_help("use a smaller origin or smaller lengths"));
        }
        let precision = self.precision();
        for axis in 0..3 {
            let mut local = DVec3::ZERO;
            local[axis] = self.lengths[axis];
            let edge = (self.local_to_world(local) - self.origin).length();
            if edge < 0.5 * self.lengths[axis] {
                return Err(Failure::new(format!(
                    "domain lengths {} are too small to place at origin {}: positions there are \
                     only accurate to {precision:e}",
                    vector_text(self.lengths),
                    vector_text(self.origin)
                ))
                .with_help("move the domain nearer the world origin or make it larger"));
            }
        }
        Ok(())
    }

    /// How far apart neighbouring floating-point positions are at the box's farthest corner.
    fn precision(&self) -> f64 {
        let farthest = self
            .corners()
            .iter()
            .map(|c| c.abs().max_element())
            .fold(0.0, f64::max);
        farthest * f64::EPSILON
    }

    /// A domain with cells of size `cell_xy` along its first two axes and `cell_z` along the
    /// third.
    pub fn with_cells(
        origin: DVec3,
        lengths: DVec3,
        orientation: DVec3,
        cell_xy: f64,
        cell_z: f64,
    ) -> Outcome<Domain> {
        let requested = DVec3::new(cell_xy, cell_xy, cell_z);
        Domain::divided(origin, lengths, orientation, requested, Fit::Cells)
    }

    /// A domain of exactly `lengths` divided into about `cell`-sized cells, each axis's cell
    /// adjusted to `length / count`: for felt's own working grids (light caches, meshing),
    /// which must cover a box exactly and never reach a file.
    pub fn fitted(origin: DVec3, lengths: DVec3, orientation: DVec3, cell: f64) -> Outcome<Domain> {
        Domain::divided(
            origin,
            lengths,
            orientation,
            DVec3::splat(cell),
            Fit::Lengths,
        )
    }

    fn divided(
        origin: DVec3,
        lengths: DVec3,
        orientation: DVec3,
        requested: DVec3,
        fit: Fit,
    ) -> Outcome<Domain> {
        let mut domain = Domain::new(origin, lengths, orientation)?;
        check_positive("cell size", requested)?;
        let mut resolution = [0usize; 3];
        let mut cells = 1f64;
        for axis in 0..3 {
            let count = (lengths[axis] / requested[axis]).round().max(1.0);
            cells *= count;
            resolution[axis] = count as usize;
        }
        let bytes = cells * 4.0;
        if bytes.is_nan() || bytes > memory_limit() as f64 || cells > (u32::MAX as f64) * 64.0 {
            return Err(Failure::new(format!(
                "a domain of {} x {} x {} cells needs {} for one scalar grid, over the memory budget of {}",
                resolution[0],
                resolution[1],
                resolution[2],
                crate::base::text::human_bytes(bytes),
                crate::base::text::human_bytes(memory_limit() as f64)
            ))
            .with_help("use a larger cell size or a smaller domain, or raise the limit with --memory-limit"));
        }
        let counts = DVec3::new(
            resolution[0] as f64,
            resolution[1] as f64,
            resolution[2] as f64,
        );
        match fit {
            Fit::Cells => {
                domain.cell = requested;
                domain.lengths = requested * counts;
                domain.check_representable()?;
            }
            Fit::Lengths => domain.cell = lengths / counts,
        }
        // Neighbouring cell centres must be told apart, or a cache holds one value many times.
        let precision = domain.precision();
        if domain.cell.min_element() <= 16.0 * precision {
            return Err(Failure::new(format!(
                "domain cells of size {} cannot be told apart at origin {}: positions there are \
                 only accurate to {precision:e}",
                vector_text(domain.cell),
                vector_text(origin)
            ))
            .with_help("move the domain nearer the world origin or use larger cells"));
        }
        domain.resolution = Some(resolution);
        Ok(domain)
    }

    /// How far the box's lengths moved from `requested` to make whole cells, when that is more
    /// than rounding: `(axis, requested, made)` for the axis that moved most, relative to its
    /// length.
    pub fn length_change(&self, requested: DVec3) -> Option<(usize, f64, f64)> {
        let relative = (self.lengths - requested).abs() / requested;
        let axis = (0..3).max_by(|&a, &b| relative[a].total_cmp(&relative[b]))?;
        (relative[axis] > LENGTH_TOLERANCE).then_some((axis, requested[axis], self.lengths[axis]))
    }

    /// The domain whose cells are `lattice`'s (the rotation is taken as given, not rebuilt
    /// from a rotation vector, so the cell centres are the same to the bit).
    pub fn from_lattice(lattice: &crate::space::Lattice) -> Domain {
        let counts = lattice.counts.map(|n| n as f64);
        Domain {
            origin: lattice.origin,
            lengths: lattice.cell * DVec3::from_array(counts),
            orientation: DQuat::from_mat3(&lattice.rotation).to_scaled_axis(),
            rotation: lattice.rotation,
            resolution: Some(lattice.counts),
            cell: lattice.cell,
        }
    }

    /// Where the cell centres sit, for readers of grids over this domain.
    pub fn lattice(&self) -> crate::space::Lattice {
        crate::space::Lattice {
            origin: self.origin,
            rotation: self.rotation,
            cell: self.cell,
            counts: self.resolution.unwrap_or([1, 1, 1]),
            extrapolates: false,
        }
    }

    /// Number of cells (0 for a domain without cells).
    pub fn cell_count(&self) -> usize {
        self.resolution.map(|r| r[0] * r[1] * r[2]).unwrap_or(0)
    }

    /// Checks that a grid of `width` components per cell fits in memory.
    pub fn check_grid_memory(&self, width: usize) -> Outcome<()> {
        let bytes = self.cell_count() as f64 * width as f64 * 4.0;
        if bytes > memory_limit() as f64 {
            return Err(Failure::new(format!(
                "a grid of {} cells with {} components needs {}, over the memory budget of {}",
                self.cell_count(),
                width,
                crate::base::text::human_bytes(bytes),
                crate::base::text::human_bytes(memory_limit() as f64)
            ))
            .with_help("use a larger cell size or a smaller domain, or raise the limit with --memory-limit"));
        }
        Ok(())
    }

    /// Takes the memory of a grid of `width` components per cell from the run's budget.
    pub fn reserve_grid_memory(&self, width: usize) -> Outcome<crate::engine::budget::Reservation> {
        let bytes = self.cell_count() as f64 * width as f64 * 4.0;
        crate::engine::budget::reserve(
            bytes,
            &format!(
                "a grid of {} cells with {} component{}",
                self.cell_count(),
                width,
                if width == 1 { "" } else { "s" }
            ),
        )
    }

    /// World position of a point given in the domain's local frame (corner at zero).
    pub fn local_to_world(&self, local: DVec3) -> DVec3 {
        self.origin + self.rotation * local
    }

    /// The domain's local coordinates of a world point.
    pub fn world_to_local(&self, world: DVec3) -> DVec3 {
        self.rotation.transpose() * (world - self.origin)
    }

    /// World position of the centre of cell `(i, j, k)`.
    pub fn cell_center(&self, i: usize, j: usize, k: usize) -> DVec3 {
        let local = DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * self.cell;
        self.local_to_world(local)
    }

    /// Continuous cell-index coordinates of a world point: cell centre `(i, j, k)` maps to
    /// `(i, j, k)` exactly.
    pub fn world_to_index(&self, world: DVec3) -> DVec3 {
        self.world_to_local(world) / self.cell - DVec3::splat(0.5)
    }

    /// The eight corners of the box in world space.
    pub fn corners(&self) -> [DVec3; 8] {
        let mut corners = [DVec3::ZERO; 8];
        for (n, corner) in corners.iter_mut().enumerate() {
            let local = DVec3::new(
                if n & 1 != 0 { self.lengths.x } else { 0.0 },
                if n & 2 != 0 { self.lengths.y } else { 0.0 },
                if n & 4 != 0 { self.lengths.z } else { 0.0 },
            );
            *corner = self.local_to_world(local);
        }
        corners
    }

    /// The world-axis-aligned box that encloses the domain.
    pub fn bounds(&self) -> Aabb {
        let corners = self.corners();
        let mut min = corners[0];
        let mut max = corners[0];
        for c in &corners[1..] {
            min = min.min(*c);
            max = max.max(*c);
        }
        Aabb::new(min, max)
    }

    /// Is the world point inside the box (boundary included)?
    pub fn contains(&self, world: DVec3) -> bool {
        let local = self.world_to_local(world);
        local.cmpge(DVec3::ZERO).all() && local.cmple(self.lengths).all()
    }
}

/// Which of a divided domain's numbers are kept as given.
#[derive(Clone, Copy)]
enum Fit {
    /// The cell size; the lengths become whole cells.
    Cells,
    /// The lengths; the cells shrink or grow to tile them.
    Lengths,
}

/// A relative change of a domain's length beyond rounding: smaller ones are not reported.
const LENGTH_TOLERANCE: f64 = 1e-9;

/// The largest rotation angle an orientation may ask for: beyond it one unit in the last place
/// of the angle is more than a thousandth of a radian, so the rotation is noise.
const MAX_ANGLE: f64 = 1e12;

/// The rotation matrix of a rotation vector (axis × angle in radians).
fn rotation_of(orientation: DVec3) -> Outcome<DMat3> {
    if orientation == DVec3::ZERO {
        return Ok(DMat3::IDENTITY);
    }
    // The length of a vector scaled to unit size, so that 1e155 does not overflow when squared.
    let scale = orientation.abs().max_element();
    let angle = scale * (orientation / scale).length();
    if angle > MAX_ANGLE {
        return Err(Failure::new(format!(
            "domain orientation {} turns by {angle:e} radians; at most {MAX_ANGLE:e} radians \
             make an accurate rotation",
            vector_text(orientation)
        ))
        .with_help(
            "the orientation is the rotation axis times the angle in radians: reduce the angle \
             modulo 2π (6.283185307179586)",
        ));
    }
    let rotation = DMat3::from_quat(DQuat::from_scaled_axis(orientation));
    if !rotation.is_finite() {
        return Err(Failure::new(format!(
            "domain orientation {} does not give a finite rotation",
            vector_text(orientation)
        )));
    }
    Ok(rotation)
}

fn check_finite(what: &str, v: DVec3) -> Outcome<()> {
    if !v.is_finite() {
        return Err(Failure::new(format!(
            "domain {what} must be finite, got {v}"
        )));
    }
    Ok(())
}

fn check_positive(what: &str, v: DVec3) -> Outcome<()> {
    check_finite(what, v)?;
    if v.min_element() <= 0.0 {
        return Err(Failure::new(format!(
            "domain {what} must be positive, got ({}, {}, {})",
            v.x, v.y, v.z
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_tile_the_box_exactly() {
        let d = Domain::with_cells(DVec3::splat(-1.0), DVec3::splat(2.0), DVec3::ZERO, 0.1, 0.1)
            .unwrap();
        assert_eq!(d.resolution, Some([20, 20, 20]));
        assert!((d.cell_center(0, 0, 0) - DVec3::splat(-0.95)).length() < 1e-12);
        assert!((d.cell_center(19, 19, 19) - DVec3::splat(0.95)).length() < 1e-12);
        let idx = d.world_to_index(d.cell_center(3, 7, 11));
        assert!((idx - DVec3::new(3.0, 7.0, 11.0)).length() < 1e-9);
    }

    #[test]
    fn cells_are_cubic_and_the_length_follows_them() {
        // 1 / 0.3 = 3.33 cells: three cells of exactly 0.3, and a box 0.9 long.
        let lengths = DVec3::new(1.0, 2.0, 0.45);
        let d = Domain::with_cells(DVec3::ONE, lengths, DVec3::ZERO, 0.3, 0.3).unwrap();
        assert_eq!(d.resolution, Some([3, 7, 2]));
        assert_eq!(d.cell, DVec3::splat(0.3));
        assert!((d.lengths - DVec3::new(0.9, 2.1, 0.6)).abs().max_element() < 1e-15);
        // The far face of z moved most: 0.45 became 0.6 (a third of the length).
        let (axis, asked, made) = d.length_change(lengths).unwrap();
        assert_eq!((axis, asked), (2, 0.45));
        assert!((made - 0.6).abs() < 1e-15);
        // Whole cells up to rounding are not a change.
        let exact =
            Domain::with_cells(DVec3::ZERO, DVec3::splat(2.0), DVec3::ZERO, 0.1, 0.1).unwrap();
        assert_eq!(exact.length_change(DVec3::splat(2.0)), None);
    }

    #[test]
    fn rotated_domain_round_trips() {
        let d = Domain::with_cells(
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(1.0, 2.0, 0.5),
            DVec3::new(0.3, -0.2, 0.9),
            0.05,
            0.1,
        )
        .unwrap();
        let p = DVec3::new(1.3, 2.1, 3.2);
        assert!((d.local_to_world(d.world_to_local(p)) - p).length() < 1e-12);
        assert_eq!(d.resolution, Some([20, 40, 5]));
    }

    #[test]
    fn bad_sizes_are_errors() {
        assert!(Domain::new(DVec3::ZERO, DVec3::new(1.0, 0.0, 1.0), DVec3::ZERO).is_err());
        assert!(Domain::with_cells(DVec3::ZERO, DVec3::ONE, DVec3::ZERO, -0.1, 0.1).is_err());
        let huge = Domain::with_cells(DVec3::ZERO, DVec3::splat(1e4), DVec3::ZERO, 1e-3, 1e-3);
        assert!(huge.unwrap_err().message.contains("memory budget"));
    }

    #[test]
    fn rotations_and_corners_must_be_finite_and_distinct() {
        let one = DVec3::ONE;
        // 1e155 squared overflows: the rotation used to be NaN and every cell centre with it.
        let spun = Domain::with_cells(DVec3::ZERO, one, DVec3::splat(1e155), 0.1, 0.1).unwrap_err();
        assert_eq!(
            spun.message,
            "domain orientation (1e155, 1e155, 1e155) turns by 1.7320508075688772e155 radians; \
             at most 1e12 radians make an accurate rotation"
        );
        assert!(spun.help.unwrap().contains("modulo 2π"));
        // A large but accurate angle is a rotation like any other.
        let turned = Domain::new(DVec3::ZERO, one, DVec3::new(0.0, 0.0, 1e6)).unwrap();
        assert!(turned.rotation.is_finite());
        assert!((turned.rotation.determinant() - 1.0).abs() < 1e-12);
        let overflow = Domain::new(DVec3::splat(1e308), DVec3::splat(1e308), DVec3::ZERO);
        assert_eq!(
            overflow.unwrap_err().message,
            "domain corner (inf, 1e308, 1e308) is not finite: origin (1e308, 1e308, 1e308) plus \
             lengths (1e308, 1e308, 1e308) leaves the range of floating-point numbers"
        );
        let lost = Domain::new(DVec3::splat(1e20), DVec3::splat(1e-3), DVec3::ZERO).unwrap_err();
        assert!(
            lost.message.starts_with(
                "domain lengths (0.001, 0.001, 0.001) are too small to place at origin"
            ),
            "{}",
            lost.message
        );
        let blurred = Domain::with_cells(
            DVec3::splat(1e9),
            DVec3::splat(1e-6),
            DVec3::ZERO,
            1e-8,
            1e-8,
        )
        .unwrap_err();
        assert!(
            blurred.message.starts_with("domain cells of size")
                && blurred.message.contains("cannot be told apart"),
            "{}",
            blurred.message
        );
        // Far from the origin, cells a good many ulps wide are fine.
        let far = Domain::with_cells(DVec3::splat(1e9), one, DVec3::ZERO, 0.01, 0.01).unwrap();
        assert!(far.cell_center(99, 0, 0).is_finite());
        assert!(far.cell_center(1, 0, 0).x > far.cell_center(0, 0, 0).x);
    }
}
