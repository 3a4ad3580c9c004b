//! Illumination at a sample: the `T_L(x)·L` of the course notes' update, per light, with the
//! phase function and the artistic terms.
//!
//! For light `i` at sample `x` seen along view direction `d`, with `D_i(x)` the density column
//! towards the light, the light scattered towards the camera is, per colour channel `c`,
//!
//! ```text
//! S_i,c = L_i,c(x) · Σ_k b^k · exp(−a^k·κ_c·D_i) · 4π·p_k(cosθ) · P_c      (octaves k < N)
//! P_c   = 1 − s·w·exp(−2κ_c·D_i),  w = (1 − cosθ)/2                          (powder)
//! ```
//!
//! with `cosθ` between the light's travel direction and `−d`, `p_k` the phase with eccentricity
//! scaled by `c^k`, and `(a, b, c, N)` the multiple-scattering octaves (single scattering is
//! `N = 1`). Powder with strength `s`: `P = lerp(1, 1 − exp(−2κD), s·w)`, HZD's "powdered sugar"
//! darkening of the lit surface, weighted by `w` so it shows where the light comes from behind
//! the camera. The ambient term is added unshadowed and isotropic. The one key decision: the
//! columns come from precomputed light grids by default (`Shadows::Cache`), or from a march
//! towards every light per sample (`Shadows::March`) — the same formula either way. A cached
//! column is read trilinearly, except where the eight columns it blends differ by more than a
//! tenth of an optical depth (under the lit surface of a dense medium): there the first four
//! cells towards the light are marched from the sample and only the rest is read.

use super::camera::Ray;
use super::light::Light;
use super::phase::Phase;
use super::settings::{RenderSettings, Shadows};
use super::space::clip_to_box;
use super::transmittance::{
    ColumnScratch, LightGrid, TransmissivityMethod, light_columns, march_columns, sweeps,
};
use crate::base::failure::Outcome;
use crate::space::domain::Domain;
use crate::space::{Aabb, BlockEval, FieldSampler};
use glam::DVec3;

/// Default shadow-grid cells along the box's longest side, at most: swept grids, and grids where
/// every cell marches to the light (cost grows with the fourth power of this).
const MAX_SWEPT_CELLS: f64 = 256.0;
const MAX_MARCHED_CELLS: f64 = 96.0;
/// A cached column is corrected near its sample when the columns its read blends differ by
/// more than this many optical depths (at the largest κ).
const NEAR_FIELD_SPREAD: f64 = 0.1;
/// How far, in cells, the near-field correction marches towards the light before reading the
/// cache: far enough that the read no longer blends columns from the sample's own cell.
const NEAR_FIELD_CELLS: f64 = 4.0;

/// Where light columns come from during the march.
pub enum Columns {
    Grids(Vec<LightGrid>),
    /// March towards the light from each sample, with this step, inside this box.
    March {
        step: f64,
        bounds: Aabb,
    },
}

/// One octave of the multiple-scattering sum.
#[derive(Clone, Copy, Debug)]
struct Octave {
    extinction: f64,
    weight: f64,
    phase: Phase,
}

/// Everything needed to light samples.
pub struct Illumination<'a> {
    pub lights: &'a [Light],
    pub columns: Columns,
    kappa: DVec3,
    grey: bool,
    octaves: Vec<Octave>,
    powder: f64,
    pub ambient: DVec3,
    /// The marched box: density is zero outside it.
    bounds: Aabb,
    /// Largest channel κ, and the column beyond which every octave's light is negligible.
    kappa_max: f64,
    negligible: f64,
}

impl<'a> Illumination<'a> {
    /// Prepares the lighting of a render: builds one column grid per light unless shadows are
    /// marched per sample.
    pub fn new(
        density: &dyn FieldSampler,
        lights: &'a [Light],
        settings: &RenderSettings,
        bounds: Aabb,
        step: f64,
    ) -> Outcome<Illumination<'a>> {
        let octaves = match settings.multiscatter {
            None => vec![Octave {
                extinction: 1.0,
                weight: 1.0,
                phase: settings.phase,
            }],
            // In the albedo model each further octave has scattered once more, so it keeps
            // albedo^k of the light as well.
            Some(ms) => (0..ms.octaves)
                .map(|k| Octave {
                    extinction: ms.attenuation.powi(k as i32),
                    weight: (ms.contribution * settings.albedo.unwrap_or(1.0)).powi(k as i32),
                    phase: settings.phase.scaled(ms.eccentricity.powi(k as i32)),
                })
                .collect(),
        };
        // A column beyond which every octave's transmissivity is below e^-40 need not be
        // marched further.
        let thinnest = octaves.iter().map(|o| o.extinction).fold(1.0, f64::min);
        let smallest_kappa = [settings.kappa.x, settings.kappa.y, settings.kappa.z]
            .into_iter()
            .filter(|&k| k > 0.0)
            .fold(f64::INFINITY, f64::min);
        let limit = 40.0 / (smallest_kappa * thinnest);
        let columns = match settings.shadows {
            Shadows::March => Columns::March { step, bounds },
            Shadows::Cache { cell_size, method } => {
                // Swept over a grid density's own cells: one slice per layer of the grid and
                // one density sample per cell, as the source's shading sweep does.
                // The default cache does the same where the grid's cells are no finer than the
                // step: a grid's values are exact at its cell centres and read straight from its
                // bricks, where a lattice of the step's cells would sample the same trilinear
                // interpolant at many more points (64 times more for a grid four steps a cell).
                let aligned = match (method, cell_size) {
                    (TransmissivityMethod::Sweep, None) => grid_domain(density),
                    (TransmissivityMethod::Auto, None) => {
                        grid_domain(density).filter(|grid| no_finer_than_step(grid, bounds, step))
                    }
                    _ => None,
                };
                let stats = crate::engine::profile::register("lightgrid", light_label(method));
                let mut grids = Vec::with_capacity(lights.len());
                for light in lights {
                    let started = std::time::Instant::now();
                    // Auto sweeps the grid's cells only for a light the sweep can take.
                    let domain = match &aligned {
                        Some(d)
                            if method == TransmissivityMethod::Sweep
                                || sweeps(light, d).is_some() =>
                        {
                            d.clone()
                        }
                        _ => shadow_domain(light, bounds, step, cell_size, method)?,
                    };
                    grids.push(light_columns(density, light, &domain, method, limit)?);
                    stats.add_instance(0);
                    stats.add_evaluated();
                    stats.add_work(
                        started.elapsed().as_nanos() as u64,
                        (domain.cell_count() * 4) as u64,
                    );
                }
                Columns::Grids(grids)
            }
        };
        Ok(Illumination {
            lights,
            columns,
            kappa: settings.kappa,
            grey: settings.grey_kappa(),
            octaves,
            powder: settings.powder.unwrap_or(0.0),
            ambient: settings.ambient,
            bounds,
            kappa_max: settings.kappa.max_element(),
            negligible: limit,
        })
    }

    /// Density columns towards light `light` from each of `positions`, into `out`.
    pub fn columns_at(
        &self,
        light: usize,
        positions: &[DVec3],
        density: &mut dyn BlockEval,
        scratch: &mut ColumnScratch,
        out: &mut [f64],
    ) {
        match &self.columns {
            Columns::Grids(grids) => {
                // Cached columns are trilinear blends of columns at cell centres. Where those
                // differ by much (just under a lit surface of a dense medium, where the column
                // grows by several optical depths within one cell) the blend overestimates the
                // column and darkens the surface. There the first cells towards the light are
                // marched from the sample itself and only the rest is read from the cache.
                let grid = &grids[light];
                let reach = NEAR_FIELD_CELLS * grid.cell_extent();
                scratch.rays.clear();
                scratch.near.clear();
                for (n, (o, p)) in out.iter_mut().zip(positions).enumerate() {
                    let (column, lo, hi) = grid.column_and_spread_at(*p);
                    *o = column;
                    if self.kappa_max * (hi - lo) <= NEAR_FIELD_SPREAD || lo > self.negligible {
                        continue;
                    }
                    let (direction, distance) = self.lights[light].towards(*p);
                    let ray = Ray {
                        origin: *p,
                        direction,
                    };
                    let exit = clip_to_box(&ray, &self.bounds).map_or(0.0, |(_, t1)| t1);
                    let length = reach.min(exit).min(distance);
                    // Past the box or at the light there is nothing more to add.
                    let beyond = if length < reach {
                        0.0
                    } else {
                        grid.column_at(*p + direction * length)
                    };
                    scratch.rays.push((*p, direction, length));
                    scratch.near.push((n, beyond));
                }
                if !scratch.rays.is_empty() {
                    let mut near = std::mem::take(&mut scratch.near_columns);
                    near.clear();
                    near.resize(scratch.rays.len(), 0.0);
                    march_columns(
                        density,
                        scratch,
                        grid.cell_extent(),
                        f64::INFINITY,
                        &mut near,
                    );
                    for (&(n, beyond), marched) in scratch.near.iter().zip(&near) {
                        out[n] = marched + beyond;
                    }
                    scratch.near_columns = near;
                }
            }
            Columns::March { step, bounds } => {
                scratch.rays.clear();
                for p in positions {
                    let (direction, distance) = self.lights[light].towards(*p);
                    let ray = Ray {
                        origin: *p,
                        direction,
                    };
                    let exit = clip_to_box(&ray, bounds).map_or(0.0, |(_, t1)| t1);
                    scratch.rays.push((*p, direction, exit.min(distance)));
                }
                out.fill(0.0);
                march_columns(density, scratch, *step, f64::INFINITY, out);
            }
        }
    }

    /// `S_i` of the module formula: light `light` scattered towards the camera at `p`, seen
    /// along `view` (camera to sample), through a density column `column`.
    pub fn scattered(&self, light: usize, p: DVec3, view: DVec3, column: f64) -> DVec3 {
        let (travel, strength) = self.lights[light].arriving(p);
        let cos_theta = -travel.dot(view);
        let mut sum = DVec3::ZERO;
        for octave in &self.octaves {
            let transmitted = self.beer(octave.extinction * column);
            sum += transmitted * (octave.weight * octave.phase.relative(cos_theta));
        }
        if self.powder > 0.0 {
            let weight = self.powder * 0.5 * (1.0 - cos_theta);
            sum *= DVec3::ONE - self.beer(2.0 * column) * weight;
        }
        strength * sum
    }

    /// `exp(−κ·column)` per channel; one exponential when κ is grey.
    fn beer(&self, column: f64) -> DVec3 {
        let optical = self.kappa * column;
        if self.grey {
            DVec3::splat((-optical.x).exp())
        } else {
            DVec3::new((-optical.x).exp(), (-optical.y).exp(), (-optical.z).exp())
        }
    }
}

/// The profile label of a render's light grids.
fn light_label(method: TransmissivityMethod) -> &'static str {
    match method {
        TransmissivityMethod::Auto => "render shadows (light cache)",
        TransmissivityMethod::Sweep => "render shadows (sweep)",
        TransmissivityMethod::March => "render shadows (marched cache)",
    }
}

/// The cells of the one axis-aligned grid a density reads, if it reads exactly one.
pub fn grid_domain(density: &dyn FieldSampler) -> Option<Domain> {
    let grids = density.grids();
    let [grid] = grids.as_slice() else {
        return None;
    };
    let lattice = grid.lattice()?;
    if lattice.rotation != glam::DMat3::IDENTITY {
        return None;
    }
    let counts = lattice.counts.map(|n| n as f64);
    Some(Domain {
        origin: lattice.origin,
        lengths: lattice.cell * DVec3::from_array(counts),
        orientation: DVec3::ZERO,
        rotation: glam::DMat3::IDENTITY,
        resolution: Some(lattice.counts),
        cell: lattice.cell,
    })
}

/// Whether `grid`'s cells are at least the step across and the grid holds no more cells than
/// the default light cache over `bounds` would: then sweeping the grid's own cells is cheaper
/// than the default cache and as exact.
fn no_finer_than_step(grid: &Domain, bounds: Aabb, step: f64) -> bool {
    let cell = default_cell(bounds, step, MAX_SWEPT_CELLS);
    let default_cells = (bounds.size() / cell).ceil();
    let grid_cells = grid.cell_count() as f64;
    grid.cell.x.min(grid.cell.y).min(grid.cell.z) >= 0.999 * cell
        && grid_cells
            <= default_cells.x.max(1.0) * default_cells.y.max(1.0) * default_cells.z.max(1.0)
}

/// The default light cache's cell: the step, or coarser where the box would otherwise hold
/// more than `max_cells` cells along its longest side.
fn default_cell(bounds: Aabb, step: f64, max_cells: f64) -> f64 {
    step.max(bounds.size().max_element() / max_cells)
}

/// The grid over `bounds` for one light's columns.
fn shadow_domain(
    light: &Light,
    bounds: Aabb,
    step: f64,
    cell_size: Option<f64>,
    method: TransmissivityMethod,
) -> Outcome<Domain> {
    let cells = |max_cells: f64| {
        let cell = cell_size.unwrap_or(default_cell(bounds, step, max_cells));
        Domain::fitted(bounds.min, bounds.size(), DVec3::ZERO, cell)
    };
    let swept = cells(MAX_SWEPT_CELLS)?;
    let marches = match method {
        TransmissivityMethod::March => true,
        TransmissivityMethod::Sweep => false,
        // Whether a point light is swept depends on where it is: ask the grid's own question.
        TransmissivityMethod::Auto => sweeps(light, &swept).is_none(),
    };
    if marches && cell_size.is_none() {
        cells(MAX_MARCHED_CELLS)
    } else {
        Ok(swept)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::settings::MultiScatter;
    use crate::space::FnField;

    fn illumination<'a>(lights: &'a [Light], settings: &RenderSettings) -> Illumination<'a> {
        let empty = FnField::new(1, |_p: DVec3, out: &mut [f64]| out[0] = 0.0);
        let bounds = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0));
        Illumination::new(&empty, lights, settings, bounds, 0.05).unwrap()
    }

    #[test]
    fn single_scattering_is_beer_times_phase() {
        let lights = [Light::distant(-DVec3::Y, DVec3::new(1.0, 2.0, 3.0)).unwrap()];
        let settings = RenderSettings {
            kappa: DVec3::new(1.0, 0.5, 0.0),
            phase: Phase::HenyeyGreenstein { g: 0.5 },
            ..RenderSettings::default()
        };
        let lit = illumination(&lights, &settings);
        // Looking up into the light (view -Y... camera below looking up means view = +Y):
        // cosθ = 1, HG(0.5, 1) = 1.5/0.25 = 6.
        let s = lit.scattered(0, DVec3::ZERO, DVec3::Y, 2.0);
        let expected = DVec3::new((-2.0f64).exp(), 2.0 * (-1.0f64).exp(), 3.0) * 6.0;
        assert!((s - expected).length() < 1e-12, "{s} vs {expected}");
    }

    #[test]
    fn octaves_and_powder_follow_their_formulas() {
        let lights = [Light::distant(-DVec3::Y, DVec3::ONE).unwrap()];
        let settings = RenderSettings {
            kappa: DVec3::splat(2.0),
            multiscatter: Some(MultiScatter {
                octaves: 3,
                attenuation: 0.5,
                contribution: 0.25,
                eccentricity: 0.5,
            }),
            powder: Some(1.0),
            ..RenderSettings::default()
        };
        let lit = illumination(&lights, &settings);
        // Light behind the camera: view along the light's travel, cosθ = -1, powder weight 1.
        let column = 0.3;
        let s = lit.scattered(0, DVec3::ZERO, -DVec3::Y, column);
        let octaves: f64 = (0..3)
            .map(|k| 0.25f64.powi(k) * (-(0.5f64.powi(k)) * 2.0 * column).exp())
            .sum();
        let expected = octaves * (1.0 - (-4.0f64 * column).exp());
        assert!((s.x - expected).abs() < 1e-12, "{} vs {expected}", s.x);
        // Looking into the light the powder weight is zero.
        let forward = lit.scattered(0, DVec3::ZERO, DVec3::Y, column);
        assert!((forward.x - octaves).abs() < 1e-12);
    }

    #[test]
    fn cached_columns_under_a_dense_lit_surface_match_the_chord() {
        // A ball whose density falls smoothly to zero at its surface, ρ = 1 − |p|²/R², lit from
        // one side. The exact column from a point inside is the integral of that quadratic along
        // the chord, in closed form. The points lie in the lit shell, where κρ per cell reaches
        // 2 and the column grows by several optical depths within a cell: a trilinear blend of
        // cell-centre columns overestimates it there. The near-field march must cut the mean
        // error of the transmittance exp(−κD) at least in half, to under 0.5%.
        let radius = 0.8f64;
        let ball = FnField::new(1, move |p: DVec3, out: &mut [f64]| {
            out[0] = (1.0 - p.length_squared() / (radius * radius)).max(0.0);
        })
        .with_bounds(Aabb::new(DVec3::splat(-radius), DVec3::splat(radius)));
        let travel = DVec3::new(0.5, -1.0, -0.3).normalize();
        let lights = [Light::distant(travel, DVec3::ONE).unwrap()];
        let (kappa, step) = (200.0, 0.02);
        let settings = RenderSettings {
            kappa: DVec3::splat(kappa),
            ..RenderSettings::default()
        };
        let bounds = Aabb::new(DVec3::splat(-radius), DVec3::splat(radius));
        let lit = Illumination::new(&ball, &lights, &settings, bounds, step).unwrap();
        let u = -travel;
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut points = Vec::new();
        while points.len() < 2000 {
            let n = DVec3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5);
            if n.length() > 0.5 || n.length() < 0.1 || n.normalize().dot(u) < 0.3 {
                continue;
            }
            points.push(n.normalize() * (radius - 0.15 * uniform()));
        }
        // ∫₀ᵉ 1 − |p + t·u|²/R² dt, with e where the chord leaves the ball.
        let exact_column = |p: DVec3| {
            let b = p.dot(u);
            let e = -b + (b * b - (p.length_squared() - radius * radius)).sqrt();
            e - (p.length_squared() * e + b * e * e + e * e * e / 3.0) / (radius * radius)
        };
        let mut eval = ball.evaluator();
        let mut scratch = ColumnScratch::default();
        let mut columns = vec![0.0; points.len()];
        lit.columns_at(0, &points, eval.as_mut(), &mut scratch, &mut columns);
        let Columns::Grids(grids) = &lit.columns else {
            panic!("the default shadows are cached");
        };
        let (mut corrected, mut bare) = (0.0, 0.0);
        for (p, column) in points.iter().zip(&columns) {
            let exact = (-kappa * exact_column(*p)).exp();
            corrected += ((-kappa * column).exp() - exact).abs();
            bare += ((-kappa * grids[0].column_at(*p)).exp() - exact).abs();
        }
        let (corrected, bare) = (corrected / 2000.0, bare / 2000.0);
        assert!(
            corrected < 0.5 * bare,
            "near field {corrected}, cache alone {bare}"
        );
        assert!(
            corrected < 0.005,
            "near field {corrected}, cache alone {bare}"
        );
    }
}
