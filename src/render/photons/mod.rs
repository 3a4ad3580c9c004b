//! The lights' multiply scattered light for the march's indirect grid, by tracing photons.
//!
//! The indirect grid (`render::indirect`) holds, per cell, the light the phase function
//! scatters towards the camera that is not the lights' own: `S(x) = ∫ p(u·d) L(x, u) du`,
//! read by the march as `σs·S`. Gathering it (paths traced from each cell) gives one sample
//! of `S` per path; in a dense cloud each such path is a long random walk with a shadow ray at
//! every vertex, and the grid stays noisy at any affordable count. Here the lights' part is
//! estimated the other way round: photons leave each distant and point light, fly through
//! the medium by the path tracer's own delta tracking, and at every scattering after their
//! first add `Φ·β·p(ω·v)` to the cell they scatter in (`ω` the way the photon travelled, `v`
//! the way to the camera). Scattering events fall with density `σs·φ`, so a cell's sum is an
//! unbiased estimate of `∫_cell σs·S dx` over the light that had scattered before arriving.
//! One photon scores at every collision of its walk (hundreds in a dense cloud) and casts no
//! shadow rays, which is what makes dense media cheap.
//!
//! The one key decision: a cell stores that integral, not `S`; the grid divides the blend of
//! the sums around a point by the blend of the cells' `∫σs dx` (`Tally::mass`), so a cell
//! that barely holds medium, where a few photons would make a wild ratio, weighs in only as
//! much as its medium does. Photons are traced in fixed chunks, each from its own random
//! streams, and the chunks' sums are added in chunk order: bit-identical for any thread count.

mod noise;
mod source;
mod walk;

use super::camera::Camera;
use super::light::Light;
use super::path::Arrivals;
use super::path::majorant::Majorants;
use super::path::sampling::PathRandom;
use super::phase::Phase;
use crate::base::failure::{Failure, Outcome};
use crate::space::{Aabb, BlockEval, FieldSampler};
use glam::DVec3;
use noise::{ViewBins, relative_noise};
use rayon::prelude::*;
use source::{Footprint, Source};
use std::collections::HashMap;
use walk::Photon;

/// A chunk's sums by cell; the hasher's order is never read (the sums are sorted).
type Sums = HashMap<usize, DVec3, foldhash::fast::FixedState>;

/// A stream of path-random numbers no camera path or gathered path uses.
const PHOTON_STREAM: u64 = 0x9407_0a5e_5ca7_7e12;

/// Photons per chunk: the unit of parallel work and of the deterministic sum.
const CHUNK: u64 = 256;

/// Chunks traced in parallel before their sums are added.
const BATCH_CHUNKS: usize = 64;

/// The cells a tally covers: the indirect grid's.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cells {
    pub bounds: Aabb,
    pub counts: [usize; 3],
    pub cell: DVec3,
}

impl Cells {
    pub fn on(bounds: Aabb, counts: [usize; 3]) -> Cells {
        let size = bounds.size();
        let cell = size / DVec3::new(counts[0] as f64, counts[1] as f64, counts[2] as f64);
        Cells {
            bounds,
            counts,
            cell,
        }
    }

    fn flatten(&self, c: [usize; 3]) -> usize {
        c[0] + self.counts[0] * (c[1] + self.counts[1] * c[2])
    }

    /// The centres a trilinear blend at `p` reads and their weights (clamped at the faces).
    pub fn corners(&self, p: DVec3) -> [(usize, f64); 8] {
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
        std::array::from_fn(|corner| {
            let mut c = base;
            let mut weight = 1.0;
            for a in 0..3 {
                if (corner >> a) & 1 == 1 {
                    c[a] = (c[a] + 1).min(self.counts[a] - 1);
                    weight *= frac[a];
                } else {
                    weight *= 1.0 - frac[a];
                }
            }
            (self.flatten(c), weight)
        })
    }
    /// The cell holding `p` (clamped to the grid).
    fn index(&self, p: DVec3) -> usize {
        let mut c = [0usize; 3];
        for a in 0..3 {
            let local = ((p[a] - self.bounds.min[a]) / self.cell[a]).floor();
            c[a] = (local.max(0.0) as usize).min(self.counts[a] - 1);
        }
        c[0] + self.counts[0] * (c[1] + self.counts[1] * c[2])
    }

    fn corner(&self, index: usize) -> DVec3 {
        let c = [
            index % self.counts[0],
            (index / self.counts[0]) % self.counts[1],
            index / (self.counts[0] * self.counts[1]),
        ];
        self.bounds.min + DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) * self.cell
    }
}

/// What the photons of a render read.
pub(crate) struct PhotonInputs<'a> {
    pub arrivals: &'a Arrivals<'a>,
    pub density: &'a dyn FieldSampler,
    pub color: Option<&'a dyn FieldSampler>,
    pub camera: &'a Camera,
    pub phase: Phase,
    /// `κ·albedo` per channel: `σs = κ·albedo·colour·ρ`.
    pub scattering: DVec3,
    pub bounces: u32,
    pub lights: &'a [Light],
    pub seed: u64,
    /// The image's width and height, for the noise the camera would see.
    pub image: (usize, usize),
}

/// How much of each cell of a grid the camera sees, `[FLOOR, 1]`: where photons are worth
/// following. A photon's weight is kept near `1/importance` (split where it rises above twice
/// that, Russian roulette below half), so photons are followed in full where the camera sees
/// and rarely, with more weight, deep inside where it does not; both are unbiased.
pub(crate) struct Importance {
    pub cells: Cells,
    pub values: Vec<f64>,
}

/// The least importance: a photon deep in a cloud survives about one scattering in thirteen
/// (fewer survivors make a dense cloud's walks cheaper but their weights wilder).
pub(crate) const IMPORTANCE_FLOOR: f64 = 0.075;

impl Importance {
    fn at(&self, p: DVec3) -> f64 {
        self.values[self.cells.index(p)]
    }
}

/// Per cell: the photons' estimate of `∫ σs·S dx` and the cell's own `∫ σs dx`, side by
/// side (a read blends both from the same eight cells).
pub(crate) struct Tally {
    cells: Cells,
    sums: Vec<(DVec3, DVec3)>,
}

impl Tally {
    /// Traces photons from every light (as many from each) as `budget` says, and integrates
    /// `σs` over the cells the majorants do not prove empty.
    pub fn trace(
        inputs: &PhotonInputs,
        cells: Cells,
        majorants: &Majorants,
        importance: &Importance,
        budget: PhotonBudget,
    ) -> Outcome<Tally> {
        let total = cells.counts.iter().product::<usize>();
        let needed: Vec<usize> = (0..total)
            .filter(|&index| {
                let corner = cells.corner(index);
                majorants.any_density(&Aabb::new(corner, corner + cells.cell))
            })
            .collect();
        let sphere = (
            cells.bounds.center(),
            0.5 * cells.bounds.size().length() * 1.0001,
        );
        let sources: Vec<Source> = inputs
            .lights
            .iter()
            .map(|light| match light {
                Light::Distant(d) => {
                    Source::Distant(d, Footprint::new(d.direction, sphere, majorants))
                }
                Light::Point(p) => Source::Point(p),
            })
            .collect();
        // The sums of the even and of the odd chunks: two independent halves, whose
        // difference says how noisy their sum is.
        let mut halves = [vec![DVec3::ZERO; total], vec![DVec3::ZERO; total]];
        let mut direct = vec![0.0; total];
        let lights = inputs.lights.len().max(1) as u64;
        let mut chunks = (budget.first / lights).div_ceil(CHUNK).max(2);
        let most = (budget.most / lights).div_ceil(CHUNK).max(chunks);
        let mut done = 0u64;
        let view = ViewBins::new(inputs.camera, inputs.image);
        let side = cells.cell.max_element();
        let bins: Vec<noise::Splat> = (0..total)
            .map(|index| {
                let centre = cells.corner(index) + 0.5 * cells.cell;
                let seen = importance.at(centre);
                view.splat(centre, side)
                    .map(|(bin, share)| (bin, share * seen))
            })
            .collect();
        loop {
            let jobs: Vec<(usize, u64)> = (0..inputs.lights.len())
                .flat_map(|light| (done..chunks).map(move |chunk| (light, chunk)))
                .collect();
            // A batch of chunks at a time, so the chunks' sums held at once stay few.
            for batch in jobs.chunks(BATCH_CHUNKS) {
                let sums: Vec<Option<Sums>> = batch
                    .par_iter()
                    .map_init(
                        || inputs.arrivals.medium(),
                        |medium, &(light, chunk)| {
                            if crate::engine::interrupt::requested() {
                                return None;
                            }
                            let mut sums = Sums::default();
                            for k in chunk * CHUNK..(chunk + 1) * CHUNK {
                                let mut random =
                                    PathRandom::new(inputs.seed ^ PHOTON_STREAM, light as u64, k);
                                let (ray, power) = sources[light].emit(sphere, &mut random);
                                let photon = Photon {
                                    inputs,
                                    cells: &cells,
                                    importance,
                                    power,
                                    key: (light as u64) << 48 ^ k,
                                };
                                photon.walk(medium, ray, random, &mut sums);
                            }
                            Some(sums)
                        },
                    )
                    .collect();
                for (&(_, chunk), sums) in batch.iter().zip(sums) {
                    let sums = sums.ok_or_else(|| Failure::new("interrupted"))?;
                    // A hash map's order is not fixed: add each chunk's cells in index order.
                    let mut sums: Vec<_> = sums.into_iter().collect();
                    sums.sort_unstable_by_key(|(index, _)| *index);
                    let half = &mut halves[(chunk % 2) as usize];
                    for (key, value) in sums {
                        if !value.is_finite() {
                            continue;
                        }
                        match key % 2 {
                            0 => half[key / 2] += value,
                            _ => direct[key / 2] += value.element_sum(),
                        }
                    }
                }
            }
            done = chunks;
            let noise = relative_noise(&halves, &direct, &bins, view.count());
            if noise <= budget.tolerance || chunks >= most {
                break;
            }
            chunks = next_chunks(chunks, noise, budget.tolerance).min(most);
        }
        // Each photon carried its light's whole power; a light's sum is over its photons.
        let photons = done * CHUNK;
        let scattered: Vec<DVec3> = halves[0]
            .iter()
            .zip(&halves[1])
            .map(|(a, b)| (*a + *b) / photons as f64)
            .collect();
        let mut mass = vec![DVec3::ZERO; total];
        let masses: Vec<(usize, DVec3)> = needed
            .par_iter()
            .map_init(
                || {
                    (
                        inputs.density.evaluator(),
                        inputs.color.map(|c| c.evaluator()),
                    )
                },
                |(density, color), &index| {
                    let m = cell_mass(
                        density.as_mut(),
                        color.as_deref_mut(),
                        cells.corner(index),
                        cells.cell,
                    );
                    (index, m * inputs.scattering)
                },
            )
            .collect();
        for (index, m) in masses {
            if m.is_finite() {
                mass[index] = m;
            }
        }
        Ok(Tally {
            cells,
            sums: scattered.into_iter().zip(mass).collect(),
        })
    }
}

impl Tally {
    /// The photons' `S` at `p`: the trilinear blend of the cells' `∫σs·S dx` around it over
    /// the same blend of their `∫σs dx`; zero where the blended cells hold no medium.
    pub fn at(&self, p: DVec3) -> DVec3 {
        let (mut scattered, mut mass) = (DVec3::ZERO, DVec3::ZERO);
        for (index, weight) in self.cells.corners(p) {
            let (s, m) = self.sums[index];
            scattered += s * weight;
            mass += m * weight;
        }
        let held = mass.cmpgt(DVec3::ZERO);
        DVec3::select(
            held,
            scattered / mass.max(DVec3::splat(f64::MIN_POSITIVE)),
            DVec3::ZERO,
        )
    }
}
/// The chunks a tally traces next, having traced `chunks` with relative noise `noise`: the
/// count the noise's fall as one over the square root of the photons says will meet
/// `tolerance`, with a tenth more for the estimate's own noise; at least a quarter more and at
/// most four times as many, so a wild estimate neither stalls nor overshoots far.
fn next_chunks(chunks: u64, noise: f64, tolerance: f64) -> u64 {
    let wanted = 1.1 * chunks as f64 * (noise / tolerance).powi(2);
    let least = chunks + chunks.div_ceil(4);
    if wanted.is_finite() {
        (wanted.ceil() as u64).clamp(least, 4 * chunks)
    } else {
        4 * chunks
    }
}

/// How many photons a tally traces: `first`, then as many more as the noise so far says are
/// needed, until the relative noise of the visible cells is within `tolerance` or `most` are
/// traced.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PhotonBudget {
    pub first: u64,
    pub most: u64,
    pub tolerance: f64,
}
/// Midpoint samples per axis of a cell's `∫ colour·ρ dx`.
const MASS_SAMPLES: usize = 2;

/// `∫ colour·ρ dx` over the cell whose lowest corner is `corner`, by the midpoint rule.
fn cell_mass(
    density: &mut dyn BlockEval,
    color: Option<&mut (dyn BlockEval + '_)>,
    corner: DVec3,
    cell: DVec3,
) -> DVec3 {
    let n = MASS_SAMPLES;
    let (mut xs, mut ys, mut zs) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let f = DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) / n as f64;
                let p = corner + f * cell;
                xs.push(p.x);
                ys.push(p.y);
                zs.push(p.z);
            }
        }
    }
    let count = xs.len();
    let mut rho = vec![0.0; count];
    density.eval_f64(&xs, &ys, &zs, &mut rho);
    let mut colours = vec![1.0; 3 * count];
    if let Some(color) = color {
        color.eval_f64(&xs, &ys, &zs, &mut colours);
    }
    let volume = cell.x * cell.y * cell.z / count as f64;
    let mut sum = DVec3::ZERO;
    for (s, r) in rho.iter().enumerate() {
        let r = if r.is_finite() { r.max(0.0) } else { 0.0 };
        let c = DVec3::new(colours[s], colours[count + s], colours[2 * count + s]);
        sum += c.max(DVec3::ZERO) * r;
    }
    sum * volume
}
