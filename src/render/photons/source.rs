//! Where photons start and what each carries: a distant light's footprint on the medium, a
//! point light's cone towards it. The one key decision: a photon carries its light's whole
//! power over the footprint or cone; the tally divides by the number traced, which is known
//! only when the tally stops.

use super::super::camera::Ray;
use super::super::light::{DistantLight, PointLight};
use super::super::path::majorant::Majorants;
use super::super::path::sampling::{PathRandom, around};
use super::Cells;
use crate::space::Aabb;
use glam::DVec3;
use std::f64::consts::PI;

/// The square cells of the plane across a distant light's path, over the bounding sphere's
/// shadow, through which light can meet the medium: the shadows of the majorants' non-empty
/// cells, marked conservatively by the rectangles around their projected corners. Photons
/// start only there, so none is spent on rays that meet nothing.
pub(super) struct Footprint {
    axes: (DVec3, DVec3),
    origin: DVec3,
    side: f64,
    marked: Vec<usize>,
}

/// Cells along each side of a footprint.
const FOOTPRINT_CELLS: usize = 64;

impl Footprint {
    pub(super) fn new(
        direction: DVec3,
        (centre, radius): (DVec3, f64),
        majorants: &Majorants,
    ) -> Footprint {
        let axes = direction.any_orthonormal_pair();
        let n = FOOTPRINT_CELLS;
        let side = 2.0 * radius / n as f64;
        let origin = centre - direction * radius - (axes.0 + axes.1) * radius;
        let mut marks = vec![false; n * n];
        let bounds = majorants.bounds();
        let lattice = Cells::on(bounds, [FOOTPRINT_CELLS / 2; 3]);
        for index in 0..(FOOTPRINT_CELLS / 2).pow(3) {
            let corner = lattice.corner(index);
            let region = Aabb::new(corner, corner + lattice.cell);
            if !majorants.any_density(&region) {
                continue;
            }
            let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for p in region.corners() {
                let uv = [(p - origin).dot(axes.0), (p - origin).dot(axes.1)];
                for a in 0..2 {
                    lo[a] = lo[a].min(uv[a]);
                    hi[a] = hi[a].max(uv[a]);
                }
            }
            let span = |a: usize| {
                let from = (lo[a] / side).floor().max(0.0) as usize;
                let to = ((hi[a] / side).floor().max(0.0) as usize).min(n - 1);
                from..=to
            };
            for j in span(1) {
                for i in span(0) {
                    marks[j * n + i] = true;
                }
            }
        }
        let marked = (0..n * n).filter(|&i| marks[i]).collect();
        Footprint {
            axes,
            origin,
            side,
            marked,
        }
    }

    /// The footprint's area.
    fn area(&self) -> f64 {
        self.marked.len() as f64 * self.side * self.side
    }

    /// A point drawn uniformly over the marked cells.
    fn point(&self, random: &mut PathRandom) -> DVec3 {
        let pick = ((random.uniform() * self.marked.len() as f64) as usize)
            .min(self.marked.len().saturating_sub(1));
        let cell = self.marked.get(pick).copied().unwrap_or(0);
        let (i, j) = (cell % FOOTPRINT_CELLS, cell / FOOTPRINT_CELLS);
        let x = (i as f64 + random.uniform()) * self.side;
        let y = (j as f64 + random.uniform()) * self.side;
        self.origin + self.axes.0 * x + self.axes.1 * y
    }
}

/// A light as photons leave it.
pub(super) enum Source<'a> {
    Distant(&'a DistantLight, Footprint),
    Point(&'a PointLight),
}

impl Source<'_> {
    /// Where a photon starts, the way it goes and the power it would carry alone (the tally
    /// divides by the photon count): from a distant light, a point of its footprint, carrying
    /// `E·A`; from a point light outside the bounding sphere, a direction in the cone the
    /// sphere fills, carrying `I·Ω` (inside it, any direction, `Ω = 4π`).
    pub(super) fn emit(
        &self,
        (centre, radius): (DVec3, f64),
        random: &mut PathRandom,
    ) -> (Ray, DVec3) {
        match self {
            Source::Distant(d, footprint) => {
                let ray = Ray {
                    origin: footprint.point(random),
                    direction: d.direction,
                };
                (ray, d.color * footprint.area())
            }
            Source::Point(p) => {
                let offset = centre - p.position;
                let distance = offset.length();
                let (axis, cos_max) = if distance > radius {
                    let cos_max = (1.0 - (radius / distance).powi(2)).max(0.0).sqrt();
                    (offset / distance, cos_max)
                } else {
                    (DVec3::Z, -1.0)
                };
                let cos_theta = 1.0 - random.uniform() * (1.0 - cos_max);
                let direction = around(axis, cos_theta, 2.0 * PI * random.uniform());
                let solid_angle = 2.0 * PI * (1.0 - cos_max);
                let ray = Ray {
                    origin: p.position,
                    direction,
                };
                (ray, p.color * solid_angle)
            }
        }
    }
}
