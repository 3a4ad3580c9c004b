//! The march's indirect light: a coarse grid of the light arriving inside the medium that is
//! not the lights' own, read by the march like the shadow grid.
//!
//! The march computes single scattering exactly: at each sample, the lights' light attenuated
//! along its column, weighed by the phase function. What it cannot compute per sample is the
//! rest of the light arriving there: light scattered once or more on its way (orders ≥ 2), the
//! sky, and the glow of emission, each shadowed by the medium in between. This grid holds the
//! part of that rest which the phase function scatters towards the camera,
//!
//! ```text
//! S(x) = ∫ p(u·d) L_indirect(x, u) du,      d the direction from the camera to x
//! ```
//!
//! and the march adds `σs·S(x)` per unit length, as it adds an ambient term. Storing what
//! reaches the camera, not an angular average, keeps what a low-order expansion loses in a
//! dense cloud: there the indirect light just under a surface lit from the camera's side is a
//! strong lobe from the sun, which a strongly forward phase scatters almost none of back to
//! the camera.
//!
//! `S` has two parts, each estimated where its estimator is cheap. The lights' scattered light
//! comes from photons (`render::photons`): one photon scores at every scattering of its walk,
//! which in a dense cloud is hundreds of samples for the price of one path. The sky and the
//! scattered emission are gathered here: `paths` path-traced rays per cell from origins
//! jittered over it, their directions drawn from the phase around `d` (`path::Arrivals`: the
//! reference integrator's medium and sky from a scene without the lights, so the two
//! integrators agree by construction). The one key decision: only cells a dense sample can
//! blend are estimated (the cells whose neighbourhood the majorants do not prove empty), in
//! parallel, each from its own random stream, and paths and photons go where the camera sees
//! (`camera_sees`); so the grid is bit-identical for any thread count and costs nothing in
//! empty space. Under motion blur the grid is estimated once, at the frame's time.

use super::Scene;
use super::camera::Camera;
use super::camera::Ray;
use super::light::Light;
use super::path::Arrivals;
use super::path::majorant::Majorants;
use super::path::sampling::{PathRandom, scatter};
use super::path::tracking::Medium;
use super::phase::Phase;
use super::photons::{Cells, IMPORTANCE_FLOOR, Importance, PhotonBudget, PhotonInputs, Tally};
use super::settings::RenderSettings;
use super::space::clip_to_box;
use crate::base::failure::{Failure, Outcome};
use crate::space::{Aabb, BlockEval, FieldSampler};
use glam::DVec3;
use rayon::prelude::*;

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

/// The indirect light scattered towards the camera, `S`, at the centre of each cell of a grid
/// on the render box.
pub struct IndirectGrid {
    cells: Cells,
    /// Per cell (x fastest), per colour channel; zero where no dense sample can read it.
    /// Empty where nothing was gathered (no sky, no emission): the march then reads the
    /// photons alone.
    radiance: Vec<DVec3>,
    /// The lights' multiply scattered light, from photons: per cell `∫σs·S dx` and `∫σs dx`.
    photons: Option<Tally>,
    /// Cells estimated, of all.
    pub estimated: usize,
    /// The run's memory budget held for the cells.
    _reservation: crate::engine::budget::Reservation,
}

/// What estimating a grid reads: the path tracer's view of the medium, its majorants, the
/// density itself (for the camera's view of each cell) and the render's camera, phase,
/// extinction and seed.
pub(crate) struct GridInputs<'a> {
    pub arrivals: &'a Arrivals<'a>,
    pub majorants: &'a Majorants,
    pub density: &'a dyn FieldSampler,
    pub camera: &'a Camera,
    pub phase: Phase,
    pub kappa: DVec3,
    /// The lights the gathered paths aim at (none where photons carry the lights' light).
    pub lights: &'a [Light],
    pub seed: u64,
    /// Whether the cells gather at all: not where nothing but the lights lights the medium.
    pub gather: bool,
}

impl IndirectGrid {
    /// The march's grid of indirect light, where the render has one and something lights it.
    pub(crate) fn for_render(
        scene: &Scene,
        settings: &RenderSettings,
        bounds: Aabb,
    ) -> Outcome<Option<IndirectGrid>> {
        let Some(grid) = settings.indirect_grid() else {
            return Ok(None);
        };
        if scene.lights.is_empty() && settings.sky.is_black() && scene.emission.is_none() {
            return Ok(None);
        }
        let majorants = Majorants::build(
            scene.density,
            scene.emission,
            bounds,
            super::path::majorant::MAJORANT_CELLS,
        )?;
        // The lights' scattered light comes from photons; the cells gather the rest (the sky,
        // emission and what they scatter), from a scene without the lights.
        let unlit = Scene {
            lights: Vec::new(),
            camera: scene.camera.clone(),
            ..*scene
        };
        let arrivals = Arrivals::new(scene, settings, bounds, &majorants);
        let gathering = Arrivals::new(&unlit, settings, bounds, &majorants);
        let inputs = GridInputs {
            arrivals: &gathering,
            majorants: &majorants,
            density: scene.density,
            camera: &scene.camera,
            phase: settings.phase,
            kappa: settings.kappa,
            lights: &[],
            seed: settings.seed,
            gather: !settings.sky.is_black() || scene.emission.is_some(),
        };
        let photons = PhotonInputs {
            arrivals: &arrivals,
            density: scene.density,
            color: scene.color,
            camera: &scene.camera,
            phase: settings.phase,
            scattering: settings.kappa * settings.albedo.unwrap_or(0.0),
            bounces: settings.bounces,
            lights: &scene.lights,
            seed: settings.seed,
            image: (settings.width, settings.height),
        };
        let photons = (!scene.lights.is_empty()).then_some(&photons);
        IndirectGrid::estimate(&inputs, photons, bounds, grid).map(Some)
    }

    /// Estimates the grid on `bounds`.
    pub(crate) fn estimate(
        inputs: &GridInputs,
        photons: Option<&PhotonInputs>,
        bounds: Aabb,
        settings: IndirectSettings,
    ) -> Outcome<IndirectGrid> {
        let GridInputs {
            arrivals,
            majorants,
            ..
        } = *inputs;
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
        // How much of each needed cell the camera sees: the gathered paths' count and the
        // photons' importance.
        let seen: Vec<f64> = needed
            .par_iter()
            .map_init(
                || inputs.density.evaluator(),
                |density, &index| {
                    let centre = centre(unflatten(index, counts));
                    camera_sees(inputs, density.as_mut(), centre, cell, &bounds)
                },
            )
            .collect();
        // The densest cell's optical depth across, at the largest κ.
        let thickest = inputs.kappa.max_element() * majorants.largest() * cell.max_element();
        let refine = photon_refine(total, thickest);
        // What the grid holds while the march reads it: its cells, and the photons' (their
        // two halves and first scatterings while they are traced, then sums and masses).
        let photon_cells = photons.map_or(0, |_| total * refine.pow(3));
        let bytes = total * std::mem::size_of::<DVec3>() + photon_cells * PHOTON_CELL_BYTES;
        let reservation = crate::engine::budget::reserve(
            bytes as f64,
            &format!("an indirect grid of {total} cells"),
        )?;
        let tally = match photons {
            Some(photons) => {
                let mut values = vec![1.0; total];
                for (&index, &seen) in needed.iter().zip(&seen) {
                    values[index] = (seen / IN_VIEW).clamp(IMPORTANCE_FLOOR, 1.0);
                }
                let importance = Importance {
                    cells: Cells::on(bounds, counts),
                    values,
                };
                let budget = photon_budget(settings, needed.len());
                let cells = Cells::on(bounds, counts.map(|c| c * refine));
                Some(Tally::trace(
                    photons,
                    cells,
                    majorants,
                    &importance,
                    budget,
                )?)
            }
            None => None,
        };
        let gathered = if inputs.gather { needed.len() } else { 0 };
        let values: Vec<Option<(usize, DVec3)>> = (0..gathered)
            .into_par_iter()
            .map_init(
                || arrivals.medium(),
                |medium, n| {
                    if crate::engine::interrupt::requested() {
                        return None;
                    }
                    let index = needed[n];
                    let centre = centre(unflatten(index, counts));
                    let most = path_count(seen[n], settings);
                    let cell_paths = CellPaths {
                        inputs,
                        index,
                        centre,
                        cell,
                    };
                    Some((index, cell_paths.estimate(medium, most)))
                },
            )
            .collect();
        let mut radiance = vec![DVec3::ZERO; if gathered > 0 { total } else { 0 }];
        for value in values {
            let (index, light) = value.ok_or_else(|| Failure::new("interrupted"))?;
            // A non-finite estimate would spread through every read that blends it.
            if light.is_finite() {
                radiance[index] = light;
            }
        }
        Ok(IndirectGrid {
            cells: Cells::on(bounds, counts),
            radiance,
            photons: tally,
            estimated: needed.len(),
            _reservation: reservation,
        })
    }

    /// All cells of the grid.
    pub fn cells(&self) -> usize {
        self.cells.counts.iter().product()
    }

    /// `S` at `p`: a trilinear blend of the centres around it, clamped at the box's faces.
    pub fn at(&self, p: DVec3) -> DVec3 {
        let sum = if self.radiance.is_empty() {
            DVec3::ZERO
        } else {
            self.cells
                .corners(p)
                .into_iter()
                .map(|(index, weight)| self.radiance[index] * weight)
                .sum::<DVec3>()
        };
        match &self.photons {
            Some(tally) => sum + tally.at(p),
            None => sum,
        }
    }
}

/// Paths per batch of a cell's estimate (rounded up to a whole number of rounds over the
/// sampling axes), and the relative standard error of the cell's mean at which it stops.
const BATCH: u32 = 8;
const TOLERANCE: f64 = 0.03;

/// The paths of one cell.
struct CellPaths<'a> {
    inputs: &'a GridInputs<'a>,
    index: usize,
    centre: DVec3,
    cell: DVec3,
}

impl CellPaths<'_> {
    /// The cell's `S`: the mean of as many paths as a pilot batch says the cell needs for a
    /// standard error (of the channels' sum) within `TOLERANCE` of the mean, at least a batch
    /// and at most `most`. The pilot's own paths are not in the mean: a count chosen from the
    /// same paths it averages stops early where the paths seen so far happen to agree, which
    /// in a dense medium (rare bright paths) is when they are low, and biases the cell dark.
    /// A smooth, thin medium takes a batch; a speckled one takes every path it may. The
    /// decision reads only the cell's own paths, so it is the same on any thread.
    fn estimate(&self, medium: &mut Medium, most: u32) -> DVec3 {
        let rounds = (self.inputs.lights.len() + 1) as u32;
        let batch = BATCH.div_ceil(rounds) * rounds;
        let mean_of = |medium: &mut Medium, paths: std::ops::Range<u32>| {
            let count = f64::from(paths.len() as u32);
            paths.map(|k| self.path(medium, k)).sum::<DVec3>() / count
        };
        // A cell that gets no more than a batch (one the camera barely sees) needs no pilot.
        if most <= batch {
            return mean_of(medium, 0..most.max(1).div_ceil(rounds) * rounds);
        }
        let (mut pilot, mut squares) = (0.0, 0.0);
        for k in 0..batch {
            let value = self.path(medium, k).element_sum();
            pilot += value;
            squares += value * value;
        }
        let n = f64::from(batch);
        let mean = pilot / n;
        let spread = ((squares / n - mean * mean).max(0.0) * n / (n - 1.0)).sqrt();
        let wanted = (spread / (TOLERANCE * mean.abs())).powi(2);
        let count = if wanted.is_finite() {
            (wanted.ceil().min(f64::from(most)) as u32).div_ceil(batch) * batch
        } else {
            most.div_ceil(batch) * batch
        };
        let count = count.clamp(batch, most.div_ceil(batch) * batch);
        mean_of(medium, batch..batch + count)
    }

    /// Path `k` of the cell: one sample of `S = ∫ p(u·d)·L(u) du` from a point jittered over
    /// the cell, its direction drawn from a mixture of the phase around the view and around
    /// the way to each light (see `towards`), weighted by the mixture's density. Path `k`
    /// uses axis `k mod (lights + 1)`, so every batch draws each axis equally often.
    fn path(&self, medium: &mut Medium, k: u32) -> DVec3 {
        let GridInputs {
            arrivals,
            camera,
            phase,
            ..
        } = *self.inputs;
        // The jitter and the direction come from the stream a camera ray's pixel jitter uses,
        // independent of every bounce's numbers.
        let mut random = PathRandom::new(
            self.inputs.seed ^ GRID_STREAM,
            self.index as u64,
            u64::from(k),
        );
        let jitter = DVec3::new(
            random.uniform() - 0.5,
            random.uniform() - 0.5,
            random.uniform() - 0.5,
        ) * self.cell;
        let origin = self.centre + jitter;
        let view = if camera.is_orthographic() {
            camera.forward()
        } else {
            (origin - camera.eye)
                .try_normalize()
                .unwrap_or(camera.forward())
        };
        let axes = towards(view, origin, self.inputs.lights);
        let chosen = axes[k as usize % axes.len()];
        let direction = scatter(&phase, chosen, &mut random);
        let mixture = axes
            .iter()
            .map(|axis| phase.relative(direction.dot(*axis)))
            .sum::<f64>()
            / axes.len() as f64;
        let weight = phase.relative(direction.dot(view)) / mixture;
        if weight > 0.0 && weight.is_finite() {
            weight * arrivals.arriving(medium, origin, direction, &mut random)
        } else {
            DVec3::ZERO
        }
    }
}

/// The axes the directions of a cell's paths are drawn around: the view (the phase's own
/// importance), and for each light the way towards it. Light from a light that has scattered
/// once more, just before reaching the cell, arrives in a narrow lobe from that light's side
/// (a forward phase scatters most of it on ahead); drawn around the view alone, a direction
/// finds that lobe rarely and then with a large weight, and the grid shows speckles. Drawing
/// an equal share of directions around each axis, weighted by the mixture's density (the
/// balance heuristic), bounds every weight by the number of axes.
fn towards(view: DVec3, origin: DVec3, lights: &[Light]) -> Vec<DVec3> {
    std::iter::once(view)
        .chain(lights.iter().map(|light| light.towards(origin).0))
        .collect()
}

/// Transmittance below which a cell is hidden from the camera: its light reaches no pixel
/// by more than this fraction, so one path estimates it well enough.
const HIDDEN: f64 = 1e-3;
/// Transmittance above which a cell gets all its paths; below it, paths shrink in proportion.
const IN_VIEW: f64 = 0.1;

/// How many paths a cell the camera sees by `seen` gets: all of them where the camera sees
/// into its neighbourhood, fewer in proportion where the medium in front hides it, one where
/// the camera cannot see it at all (its value is then blended into pixels only with weights
/// below `HIDDEN`).
fn path_count(seen: f64, settings: IndirectSettings) -> u32 {
    if seen >= IN_VIEW {
        settings.paths
    } else if seen < HIDDEN {
        1
    } else {
        ((f64::from(settings.paths) * seen / IN_VIEW).ceil() as u32).max(1)
    }
}

/// How much the camera sees of the cell at `centre`: the transmittance, at the smallest κ, of
/// a march of the density a cell at a step from where the camera ray enters the box to the
/// corner of the cell's neighbourhood (one cell around it) nearest the camera.
fn camera_sees(
    inputs: &GridInputs,
    density: &mut dyn BlockEval,
    centre: DVec3,
    cell: DVec3,
    bounds: &Aabb,
) -> f64 {
    let camera = inputs.camera;
    let towards_camera = if camera.is_orthographic() {
        -camera.forward()
    } else {
        (camera.eye - centre)
            .try_normalize()
            .unwrap_or(-camera.forward())
    };
    let near = centre + towards_camera.signum() * cell;
    let back = Ray {
        origin: near,
        direction: towards_camera,
    };
    let length = match clip_to_box(&back, bounds) {
        Some((_, exit)) => exit,
        None => 0.0,
    };
    let length = if camera.is_orthographic() {
        length
    } else {
        length.min((camera.eye - near).length())
    };
    let step = cell.min_element();
    let steps = (length / step).ceil() as usize;
    let (mut xs, mut ys, mut zs) = (Vec::new(), Vec::new(), Vec::new());
    for n in 0..steps {
        let p = back.at((n as f64 + 0.5) * length / steps as f64);
        xs.push(p.x);
        ys.push(p.y);
        zs.push(p.z);
    }
    let mut values = vec![0.0; steps];
    density.eval_f64(&xs, &ys, &zs, &mut values);
    let column: f64 = values
        .iter()
        .filter(|v| v.is_finite())
        .map(|v| v.max(0.0))
        .sum::<f64>()
        * length
        / steps.max(1) as f64;
    let kappa = [inputs.kappa.x, inputs.kappa.y, inputs.kappa.z]
        .into_iter()
        .fold(f64::INFINITY, f64::min);
    (-kappa * column).exp()
}

/// The photons' cells are twice as fine as the gathered grid's along each axis where the
/// densest cell is at least a mean free path across (`thickest`, its optical depth): a dense
/// cloud's light changes within a few of its mean free paths. Where every cell is thinner the
/// light changes little across a cell, and the gathered grid's own cells hold eight times the
/// photons each, so the same noise takes fewer. Fine cells only while they number no more
/// than `MOST_PHOTON_CELLS`.
fn photon_refine(cells: usize, thickest: f64) -> usize {
    if thickest >= 1.0 && cells * 8 <= MOST_PHOTON_CELLS {
        2
    } else {
        1
    }
}

const MOST_PHOTON_CELLS: usize = 1 << 24;

/// Bytes a photon cell needs at most: two halves, the first scatterings, the masses, the sums
/// and its share of the image's bins.
const PHOTON_CELL_BYTES: usize = 4 * std::mem::size_of::<DVec3>()
    + std::mem::size_of::<f64>()
    + std::mem::size_of::<[(usize, f64); 4]>();

/// The photons for a grid of `needed` cells: at first a sixteenth of the paths the cells would
/// gather (a thin medium often needs little more), then as many more as the noise so far says
/// are needed until the noise the camera would see is within 7 %, at most four times as many
/// as the cells would gather.
fn photon_budget(settings: IndirectSettings, needed: usize) -> PhotonBudget {
    let paths = u64::from(settings.paths) * needed as u64;
    PhotonBudget {
        first: (paths / 16).max(1),
        most: (paths * 4).max(1),
        tolerance: 0.07,
    }
}

fn unflatten(index: usize, counts: [usize; 3]) -> [usize; 3] {
    [
        index % counts[0],
        (index / counts[0]) % counts[1],
        index / (counts[0] * counts[1]),
    ]
}

#[cfg(test)]
#[path = "indirect_tests.rs"]
mod tests;
