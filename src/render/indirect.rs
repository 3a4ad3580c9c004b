//! The march's indirect light: a coarse grid of the light arriving inside the medium that is
//! not the lights' own, filled by the path tracer and read by the march like the shadow grid.
//!
//! The march computes single scattering exactly: at each sample, the lights' light attenuated
//! along its column, weighed by the phase function. What it cannot compute per sample is the
//! rest of the light arriving there: light scattered once or more on its way (orders ≥ 2), the
//! sky, and the glow of emission, each shadowed by the medium in between. This grid holds that
//! rest, averaged over all directions,
//!
//! ```text
//! I(x) = 1/4π ∫ L_indirect(x, ω) dω
//! ```
//!
//! estimated at the centre of each grid cell by `paths` path-traced rays in stratified
//! directions (`path::Arrivals`: the reference integrator's medium, lights and sky, so the two
//! integrators agree by construction), from origins jittered over the cell so a cell holds its
//! mean, not a point value. The march adds `σs·I(x)` per unit length, as it adds an isotropic
//! ambient: indirect light deep in a medium has forgotten where it came from, and an isotropic
//! read of it is the approximation this grid makes. The one key decision: only cells a dense
//! sample can blend are estimated (the cells whose neighbourhood the majorants do not prove
//! empty), in parallel, each from its own random stream, so the grid is bit-identical for any
//! thread count and costs nothing in empty space. Under motion blur the grid is estimated once,
//! at the frame's time.

use super::path::Arrivals;
use super::path::majorant::Majorants;
use super::path::sampling::{PathRandom, around};
use crate::failure::{Failure, Outcome};
use crate::sample::Aabb;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;

/// A stream of path-random numbers no camera path uses: the grid's paths are keyed by cell and
/// direction, not by pixel and sample.
const GRID_STREAM: u64 = 0x1d1e_c7ed_11b7_0000;

/// How the indirect grid is estimated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IndirectSettings {
    /// Cells along the render box's longest side.
    pub cells: usize,
    /// Path-traced rays per cell.
    pub paths: u32,
}

impl Default for IndirectSettings {
    fn default() -> IndirectSettings {
        IndirectSettings {
            cells: 32,
            paths: 64,
        }
    }
}

/// The mean indirect radiance `I` at the centre of each cell of a grid on the render box.
pub struct IndirectGrid {
    bounds: Aabb,
    counts: [usize; 3],
    cell: DVec3,
    /// Per cell (x fastest); zero where no dense sample can read it.
    radiance: Vec<DVec3>,
    /// Cells estimated, of all.
    pub estimated: usize,
}

impl IndirectGrid {
    /// Estimates the grid for the medium `arrivals` traces, with `occupied` telling which cells
    /// of the same lattice may hold density.
    pub(crate) fn estimate(
        arrivals: &Arrivals,
        majorants: &Majorants,
        bounds: Aabb,
        settings: IndirectSettings,
        seed: u64,
    ) -> Outcome<IndirectGrid> {
        let size = bounds.size();
        let side = size.max_element() / settings.cells.max(1) as f64;
        let counts =
            [0, 1, 2].map(|a| ((size[a] / side).ceil() as usize).clamp(1, settings.cells.max(1)));
        let cell = size / DVec3::new(counts[0] as f64, counts[1] as f64, counts[2] as f64);
        let total = counts[0] * counts[1] * counts[2];
        let centre = |c: [usize; 3]| {
            bounds.min + DVec3::new(c[0] as f64 + 0.5, c[1] as f64 + 0.5, c[2] as f64 + 0.5) * cell
        };
        // A sample blends the eight centres around it, all within a cell of it: a centre is
        // needed where the box one cell around it may hold density.
        let needed: Vec<usize> = (0..total)
            .filter(|&index| {
                let c = unflatten(index, counts);
                let p = centre(c);
                majorants.any_density(&Aabb::new(p - cell, p + cell))
            })
            .collect();
        let stratum = (settings.paths as f64).sqrt().ceil().max(1.0) as u32;
        let values: Vec<Option<(usize, DVec3)>> = needed
            .par_iter()
            .map_init(
                || arrivals.medium(),
                |medium, &index| {
                    if crate::interrupt::requested() {
                        return None;
                    }
                    let origin = centre(unflatten(index, counts));
                    let mut sum = DVec3::ZERO;
                    for k in 0..settings.paths {
                        let mut random = PathRandom::new(seed ^ GRID_STREAM, index as u64, k as u64);
                        // Stratified over the sphere: the k-th cell of a stratum × stratum
                        // grid on (cos θ, φ), jittered, cycling when `paths` is not a square.
                        let (i, j) = (k % stratum, (k / stratum) % stratum);
                        let cos_theta =
                            1.0 - 2.0 * (f64::from(i) + random.uniform()) / f64::from(stratum);
                        let phi = 2.0 * PI * (f64::from(j) + random.uniform()) / f64::from(stratum);
                        let direction = around(DVec3::Z, cos_theta, phi);
                        let jitter = DVec3::new(
                            random.uniform() - 0.5,
                            random.uniform() - 0.5,
                            random.uniform() - 0.5,
                        ) * cell;
                        sum += arrivals.arriving(medium, origin + jitter, direction, &mut random);
                    }
                    Some((index, sum / f64::from(settings.paths.max(1))))
                },
            )
            .collect();
        let mut radiance = vec![DVec3::ZERO; total];
        for value in values {
            let (index, mean) = value.ok_or_else(|| Failure::new("interrupted"))?;
            // A non-finite estimate would spread through every read that blends it.
            radiance[index] = if mean.is_finite() { mean } else { DVec3::ZERO };
        }
        Ok(IndirectGrid {
            bounds,
            counts,
            cell,
            radiance,
            estimated: needed.len(),
        })
    }

    /// All cells of the grid.
    pub fn cells(&self) -> usize {
        self.radiance.len()
    }

    /// `I` at `p`: a trilinear blend of the centres around it, clamped at the box's faces.
    pub fn at(&self, p: DVec3) -> DVec3 {
        let mut base = [0usize; 3];
        let mut frac = [0.0f64; 3];
        for a in 0..3 {
            let local = (p[a] - self.bounds.min[a]) / self.cell[a] - 0.5;
            let top = (self.counts[a] - 1) as f64;
            let clamped = local.clamp(0.0, top);
            let floor = clamped.floor().min((top - 1.0).max(0.0));
            base[a] = floor as usize;
            frac[a] = clamped - floor;
        }
        let mut sum = DVec3::ZERO;
        for corner in 0..8 {
            let mut c = base;
            let mut weight = 1.0;
            for a in 0..3 {
                let upper = (corner >> a) & 1 == 1;
                if upper {
                    c[a] = (c[a] + 1).min(self.counts[a] - 1);
                    weight *= frac[a];
                } else {
                    weight *= 1.0 - frac[a];
                }
            }
            if weight > 0.0 {
                sum += self.radiance[flatten(c, self.counts)] * weight;
            }
        }
        sum
    }
}

fn unflatten(index: usize, counts: [usize; 3]) -> [usize; 3] {
    [
        index % counts[0],
        (index / counts[0]) % counts[1],
        index / (counts[0] * counts[1]),
    ]
}

fn flatten(c: [usize; 3], counts: [usize; 3]) -> usize {
    c[0] + counts[0] * (c[1] + counts[1] * c[2])
}

#[cfg(test)]
#[path = "indirect_tests.rs"]
mod tests;
