//! The path tracer against closed forms and the march: ratio tracking of a homogeneous slab is
//! Beer–Lambert, an albedo-1 medium under a uniform sky shows the sky (white furnace), one
//! bounce equals the march's exact single scattering, the majorant bounds every density sample
//! of random fields, and the image is the same for any thread count.

use super::majorant::Majorants;
use super::sampling::PathRandom;
use super::tracking::{Flight, Medium};
use crate::base::test_random::SplitMix;
use crate::field::noise::NoiseKind;
use crate::field::{CompiledField, Field};
use crate::grid::cache::Cache;
use crate::render::camera::Ray;
use crate::render::settings::{Integrator, RenderSettings, Shadows};
use crate::render::testing::{Ball, Pieces, check_majorants_over_a_random_box};
use crate::render::{Camera, Image, Light, Phase, Scene, render, render_with_stats};
use crate::space::domain::Domain;
use crate::space::{Aabb, BlockEval, FieldSampler, GridSource};
use glam::DVec3;
use std::sync::Arc;

/// Density `value` between y = 0 and y = `thickness` (all x, z), reporting `bound` as the top
/// of its range: a majorant looser than the density, so ratio tracking has null collisions.
struct Slab {
    value: f64,
    thickness: f64,
    bound: f64,
}

struct SlabEval<'a>(&'a Slab);

impl BlockEval for SlabEval<'_> {
    fn eval_f32(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f32]) {
        let mut wide = vec![0.0; xs.len()];
        self.eval_f64(xs, ys, zs, &mut wide);
        for (o, w) in out.iter_mut().zip(wide) {
            *o = w as f32;
        }
    }

    fn eval_f64(&mut self, _xs: &[f64], ys: &[f64], _zs: &[f64], out: &mut [f64]) {
        for (o, &y) in out.iter_mut().zip(ys) {
            *o = if (0.0..=self.0.thickness).contains(&y) {
                self.0.value
            } else {
                0.0
            };
        }
    }
}

impl FieldSampler for Slab {
    fn width(&self) -> usize {
        1
    }
    fn evaluator(&self) -> Box<dyn BlockEval + '_> {
        Box::new(SlabEval(self))
    }
    fn bounds(&self) -> Option<Aabb> {
        None
    }
    fn range(&self, _region: &Aabb) -> Vec<(f64, f64)> {
        vec![(0.0, self.bound)]
    }
}

/// Mean and standard error of `n` draws of `f`.
fn mean_and_error(n: usize, mut f: impl FnMut(usize) -> f64) -> (f64, f64) {
    let (mut sum, mut squares) = (0.0, 0.0);
    for i in 0..n {
        let v = f(i);
        sum += v;
        squares += v * v;
    }
    let mean = sum / n as f64;
    (mean, ((squares / n as f64 - mean * mean) / n as f64).sqrt())
}

#[test]
fn ratio_tracking_of_a_homogeneous_slab_averages_to_beer_lambert() {
    let slab = Slab {
        value: 0.8,
        thickness: 1.5,
        bound: 2.0,
    };
    let bounds = Aabb::new(DVec3::new(-1.0, 0.0, -1.0), DVec3::new(1.0, 1.5, 1.0));
    let majorants = Majorants::build(&slab, None, bounds, 8).unwrap();
    let kappa = DVec3::new(0.5, 1.0, 2.0);
    let mut medium = Medium::new(&slab, None, None, &majorants, kappa, 1.0, None);
    // Straight up through the slab, and slanted (path length 1.5/cos).
    for direction in [DVec3::Y, DVec3::new(0.3, 1.0, 0.2).normalize()] {
        let ray = Ray {
            origin: DVec3::new(0.0, 0.0, 0.0),
            direction,
        };
        let length = 1.5 / direction.y;
        for channel in 0..3 {
            let expected = (-kappa[channel] * 0.8 * length).exp();
            let (mean, error) = mean_and_error(40_000, |i| {
                let mut random = PathRandom::new(7, i as u64, channel as u64);
                medium.transmittance(&ray, 0.0, length, &mut random)[channel]
            });
            assert!(
                (mean - expected).abs() < 4.0 * error,
                "channel {channel}, {direction}: {mean} ± {error} vs {expected}"
            );
        }
        // Delta tracking with grey κ: the chance of crossing without a collision is the same.
        let grey = DVec3::splat(1.0);
        let mut medium = Medium::new(&slab, None, None, &majorants, grey, 0.0, None);
        let expected = (-0.8 * length).exp();
        let (mean, error) = mean_and_error(40_000, |i| {
            let mut random = PathRandom::new(9, i as u64, 0);
            let (mut weight, mut emitted) = (DVec3::ONE, DVec3::ZERO);
            match medium.fly(&ray, 0.0, length, &mut weight, &mut emitted, &mut random) {
                Flight::Escaped => weight.x,
                _ => 0.0,
            }
        });
        assert!(
            (mean - expected).abs() < 4.0 * error,
            "{mean} ± {error} vs {expected}"
        );
    }
    assert_eq!(medium.counts.above_majorant, 0);
}

fn front_camera() -> Camera {
    Camera::new(DVec3::new(0.0, 0.0, 3.0), DVec3::ZERO, DVec3::Y, 30.0).unwrap()
}

fn path_settings(size: usize, spp: u32) -> RenderSettings {
    let mut settings = RenderSettings {
        width: size,
        height: size,
        spp,
        integrator: Integrator::Path,
        bounds: Some(Aabb::new(DVec3::splat(-0.6), DVec3::splat(0.6))),
        ..RenderSettings::default()
    };
    settings.aovs.variance = true;
    settings
}

/// Per pixel and channel, the image composited over `sky`: `rgb + (1 − alpha)·sky`.
fn over_sky(image: &Image, sky: f64) -> Vec<[f64; 3]> {
    image
        .rgba
        .iter()
        .map(|p| [0, 1, 2].map(|c| f64::from(p[c]) + (1.0 - f64::from(p[3])) * sky))
        .collect()
}

fn variance(image: &Image) -> &[f32] {
    &image
        .aovs
        .iter()
        .find(|(name, _)| name == "variance.G")
        .expect("a variance AOV")
        .1
}

#[test]
fn white_furnace_shows_the_sky_whatever_the_density() {
    let sky = 0.7;
    for (density, albedo) in [(1.0, 1.0), (50.0, 1.0), (50.0, 0.8)] {
        let ball = Pieces::new(vec![Ball {
            centre: DVec3::ZERO,
            radius: 0.5,
            value: density,
        }]);
        let mut settings = path_settings(8, 16);
        settings.sky = DVec3::splat(sky).into();
        settings.albedo = Some(albedo);
        settings.phase = Phase::HenyeyGreenstein { g: 0.4 };
        settings.bounces = crate::render::settings::MAX_BOUNCES;
        let scene = Scene {
            density: &ball,
            color: None,
            emission: None,
            holdout: None,
            velocity: None,
            camera: front_camera(),
            lights: Vec::new(),
        };
        let image = render(&scene, &settings).unwrap();
        let composite = over_sky(&image, sky);
        let n = composite.len() as f64;
        let mean = composite.iter().map(|p| p[1]).sum::<f64>() / n;
        // The standard error of the mean over pixels, from each pixel's own variance.
        let error = variance(&image)
            .iter()
            .map(|&v| f64::from(v))
            .sum::<f64>()
            .sqrt()
            / n;
        // The ball covers about 19 of the 64 pixels (1 unit across in a view 1.6 wide).
        let covered = image.rgba.iter().filter(|p| p[3] > 0.05).count();
        assert!(covered >= 12, "the ball covers {covered} pixels");
        if albedo == 1.0 {
            assert!(
                (mean - sky).abs() < 4.0 * error + 1e-6,
                "density {density}: {mean} ± {error} vs {sky}"
            );
        } else {
            // Absorption must show: the test can tell a furnace that loses light.
            assert!(mean < sky - 0.05, "albedo {albedo}: {mean}");
        }
    }
}

/// A ball of radius 0.5 filled with Perlin noise at frequency 4, between 0 and `peak`.
fn noise_ball(peak: f64) -> CompiledField {
    let p = Field::identity();
    let scaled = p.mul(&Field::constant_scalar(4.0)).unwrap();
    let noise = Field::noise(NoiseKind::Perlin, 3).compose(&scaled).unwrap();
    let positive = Field::max(
        &noise
            .mul(&Field::constant_scalar(0.5 * peak))
            .unwrap()
            .add(&Field::constant_scalar(0.5 * peak))
            .unwrap(),
        &Field::constant_scalar(0.0),
    )
    .unwrap();
    let inside = Field::constant_scalar(0.5)
        .sub(&p.length().unwrap())
        .unwrap()
        .mask()
        .unwrap();
    CompiledField::new(&positive.mul(&inside).unwrap())
}

#[test]
fn one_bounce_equals_the_marchs_single_scattering() {
    let density = noise_ball(4.0);
    let color = CompiledField::new(&Field::constant_vector(DVec3::new(0.9, 0.7, 0.5)));
    // Grey κ (delta tracking) and per-channel κ (spectral tracking).
    for kappa in [DVec3::splat(2.0), DVec3::new(1.0, 2.0, 4.0)] {
        let scene = Scene {
            density: &density,
            color: Some(&color),
            emission: None,
            holdout: None,
            velocity: None,
            camera: front_camera(),
            lights: vec![
                Light::distant(DVec3::new(1.0, -1.0, -0.5), DVec3::splat(3.0)).unwrap(),
                Light::point(DVec3::new(-0.3, 0.8, 0.6), DVec3::new(1.0, 0.5, 0.2)).unwrap(),
            ],
        };
        let mut path = path_settings(12, 96);
        path.kappa = kappa;
        path.albedo = Some(0.8);
        path.phase = Phase::HenyeyGreenstein { g: 0.5 };
        path.bounces = 1;
        let mut march = path.clone();
        march.integrator = Integrator::March;
        // Single scattering alone: no grid of indirect light.
        march.indirect = None;
        march.aovs.variance = false;
        march.spp = 4;
        march.step = Some(0.004);
        march.threshold = 0.0;
        march.shadows = Shadows::March;
        let traced = render(&scene, &path).unwrap();
        let marched = render(&scene, &march).unwrap();
        for c in 0..3 {
            let name = ["variance.R", "variance.G", "variance.B"][c];
            let variances = &traced.aovs.iter().find(|(n, _)| n == name).unwrap().1;
            // Quadrants of the image and the whole: each mean within its noise.
            let half = 6;
            for (x0, y0, side) in [
                (0, 0, 12),
                (0, 0, half),
                (half, 0, half),
                (0, half, half),
                (half, half, half),
            ] {
                let (mut a, mut b, mut v, mut n) = (0.0, 0.0, 0.0, 0.0);
                for y in y0..y0 + side {
                    for x in x0..x0 + side {
                        let i = y * 12 + x;
                        a += f64::from(traced.rgba[i][c]);
                        b += f64::from(marched.rgba[i][c]);
                        v += f64::from(variances[i]);
                        n += 1.0;
                    }
                }
                let (a, b, error) = (a / n, b / n, v.sqrt() / n);
                assert!(
                    (a - b).abs() < 4.0 * error + 0.01 * b,
                    "κ {kappa}, channel {c}, block ({x0}, {y0}): path {a} ± {error}, march {b}"
                );
            }
        }
    }
}

/// A cache of random values in [-0.5, 1] on a random domain, read trilinearly.
fn random_cache(random: &mut SplitMix) -> CompiledField {
    let cell = random.range(0.05, 0.2);
    let origin = random.vector(-1.0, 0.0);
    let lengths = DVec3::new(
        random.range(0.5, 1.5),
        random.range(0.5, 1.5),
        random.range(0.5, 1.5),
    );
    let domain = Domain::with_cells(origin, lengths, DVec3::ZERO, cell, cell).unwrap();
    let [nx, ny, nz] = domain.resolution.unwrap();
    let data: Vec<f32> = (0..nx * ny * nz)
        .map(|_| random.range(-0.5, 1.0) as f32)
        .collect();
    let cache = Cache::from_dense(domain, 1, vec![data], vec![0.0]).unwrap();
    let grid: Arc<dyn GridSource> = Arc::new(cache);
    CompiledField::new(&Field::from_linear_grid(grid).unwrap())
}

/// Noise of a random kind, frequency and offset, scaled and shifted at random.
fn random_noise(random: &mut SplitMix) -> CompiledField {
    let kind = [NoiseKind::Perlin, NoiseKind::Simplex, NoiseKind::Worley][random.below(3)];
    let at = Field::identity()
        .mul(&Field::constant_scalar(random.range(0.5, 12.0)))
        .unwrap()
        .add(&Field::constant_vector(random.vector(-50.0, 50.0)))
        .unwrap();
    let noise = Field::noise(kind, random.below(1000) as u32)
        .compose(&at)
        .unwrap();
    let field = noise
        .mul(&Field::constant_scalar(random.range(0.1, 5.0)))
        .unwrap()
        .add(&Field::constant_scalar(random.range(-1.0, 1.0)))
        .unwrap();
    CompiledField::new(&field)
}

#[test]
fn majorants_bound_every_density_sample_of_random_fields() {
    let mut random = SplitMix(0x9a7);
    for case in 0..24 {
        let field = if case % 2 == 0 {
            random_noise(&mut random)
        } else {
            random_cache(&mut random)
        };
        check_majorants_over_a_random_box(&field, &mut random, 0.2, 12, 3000, case);
    }
}

#[test]
fn the_image_is_the_same_for_any_thread_count() {
    let density = noise_ball(6.0);
    let emission = CompiledField::new(&Field::constant_vector(DVec3::new(0.2, 0.1, 0.0)));
    let scene = Scene {
        density: &density,
        color: None,
        emission: Some(&emission),
        holdout: None,
        velocity: None,
        camera: front_camera(),
        lights: vec![Light::distant(DVec3::new(0.0, -1.0, -1.0), DVec3::ONE).unwrap()],
    };
    let mut settings = path_settings(9, 4);
    settings.sky = DVec3::new(0.1, 0.2, 0.3).into();
    settings.kappa = DVec3::new(2.0, 3.0, 4.0);
    let images: Vec<Image> = [1, 3]
        .map(|threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| render_with_stats(&scene, &settings).unwrap().0)
        })
        .into();
    let bits = |image: &Image| -> Vec<u32> {
        let mut bits: Vec<u32> = image.rgba.iter().flatten().map(|v| v.to_bits()).collect();
        for (_, values) in &image.aovs {
            bits.extend(values.iter().map(|v| v.to_bits()));
        }
        bits
    };
    assert_eq!(bits(&images[0]), bits(&images[1]));
    // The emission and the lights show: the image is not blank.
    assert!(images[0].rgba.iter().any(|p| p[0] > 0.0 && p[3] > 0.0));
}
