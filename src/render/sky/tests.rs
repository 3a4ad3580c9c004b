//! The sky against independent routes: sampling against quadrature over texels (and a fine
//! grid for the daylight sky), the lat-long layout against hand-placed texels, Preetham's
//! zenith values and Perez ratios recomputed here from the paper's printed equations, and the
//! path tracer lit by maps against the uniform sky and a distant light.

use super::envmap::EnvMap;
use super::latlong;
use super::physical::{self, PhysicalSky};
use super::{Sky, sun};
use crate::base::test_random::SplitMix;
use crate::render::settings::{Integrator, RenderSettings};
use crate::render::testing::{Ball, Pieces};
use crate::render::{Camera, Image, Light, Phase, Scene, render};
use glam::DVec3;
use std::f64::consts::PI;
use std::sync::Arc;

/// A smooth coloured map with a bright patch, `width × width/2`.
fn test_map(width: usize, rotate: f64) -> EnvMap {
    let height = width / 2;
    let mut texels = Vec::with_capacity(width * height);
    for j in 0..height {
        for i in 0..width {
            let (u, v) = (
                (i as f64 + 0.5) / width as f64,
                (j as f64 + 0.5) / height as f64,
            );
            let base = 0.2 + 0.8 * (1.0 - v) + 0.3 * (2.0 * PI * u).sin();
            let patch = if i == width / 3 && j == height / 4 {
                40.0
            } else {
                0.0
            };
            texels.push([(base + patch) as f32, (0.5 * base) as f32, (0.1 + v) as f32]);
        }
    }
    EnvMap::new(width, height, texels, 1.5, rotate, "test".into()).unwrap()
}

/// `∫ L dω` of a map, texel by texel: a texel spans `2π/W` in φ and `cos θ₀ − cos θ₁`.
fn texel_quadrature(map: &EnvMap, width: usize) -> DVec3 {
    let height = width / 2;
    let mut total = DVec3::ZERO;
    for j in 0..height {
        let (t0, t1) = (
            PI * j as f64 / height as f64,
            PI * (j + 1) as f64 / height as f64,
        );
        let solid = 2.0 * PI / width as f64 * (t0.cos() - t1.cos());
        for i in 0..width {
            let u = (i as f64 + 0.5) / width as f64;
            let v = (j as f64 + 0.5) / height as f64;
            // The texel's value, read through the unrotated layout.
            let d = latlong::direction(u, v);
            total += map.radiance(d) * solid;
        }
    }
    total
}

/// The mean of `radiance/pdf` over `n` draws and its standard error, per channel.
fn sampled_integral(sky: &Sky, n: usize, seed: u64) -> (DVec3, DVec3) {
    let mut random = SplitMix(seed);
    let (mut sum, mut squares) = (DVec3::ZERO, DVec3::ZERO);
    for _ in 0..n {
        if let Some(s) = sky.sample(random.unit(), random.unit()) {
            let pdf = sky.pdf(s.direction);
            assert!(
                (pdf / s.pdf - 1.0).abs() < 1e-9,
                "pdf {pdf} vs drawn {} at {}",
                s.pdf,
                s.direction
            );
            assert!((s.radiance - sky.radiance(s.direction)).length() < 1e-12);
            let f = s.radiance / s.pdf;
            sum += f;
            squares += f * f;
        }
    }
    let n = n as f64;
    let mean = sum / n;
    (
        mean,
        ((squares / n - mean * mean) / n).max(DVec3::ZERO).sqrt(),
    )
}

/// `Σ f(ω)·Δω` by the midpoint rule over a `width × width/2` lat-long grid: the integral of
/// `f` over the sphere.
fn over_sphere<T: std::ops::AddAssign + std::ops::Mul<f64, Output = T> + Default>(
    width: usize,
    f: impl Fn(DVec3) -> T,
) -> T {
    let height = width / 2;
    let mut total = T::default();
    for j in 0..height {
        let (t0, t1) = (
            PI * j as f64 / height as f64,
            PI * (j + 1) as f64 / height as f64,
        );
        let solid = 2.0 * PI / width as f64 * (t0.cos() - t1.cos());
        for i in 0..width {
            let d = latlong::direction(
                (i as f64 + 0.5) / width as f64,
                (j as f64 + 0.5) / height as f64,
            );
            total += f(d) * solid;
        }
    }
    total
}

/// `Σ pdf(ω)·Δω` over a fine lat-long grid: the integral of the density over the sphere.
fn pdf_total(sky: &Sky, width: usize) -> f64 {
    over_sphere(width, |d| sky.pdf(d))
}

#[test]
fn environment_sampling_is_unbiased_and_its_pdf_is_what_it_draws() {
    for rotate in [0.0, 37.0] {
        let map = test_map(64, rotate);
        let expected = texel_quadrature(&test_map(64, 0.0), 64);
        let sky = Sky::Environment(Arc::new(map));
        let (mean, error) = sampled_integral(&sky, 200_000, 7);
        for c in 0..3 {
            assert!(
                (mean[c] - expected[c]).abs() < 4.0 * error[c] + 1e-9,
                "rotate {rotate}, channel {c}: {} ± {} vs {}",
                mean[c],
                error[c],
                expected[c]
            );
        }
        // Aligned with the texels (4 × 4 sub-cells each), the density integrates to 1.
        assert!(
            (pdf_total(&sky, 256) - 1.0).abs() < 2e-3,
            "{}",
            pdf_total(&sky, 256)
        );
    }
}

#[test]
fn the_layout_is_mitsubas() {
    // One bright texel a quarter of the way across, on the equator's row: +x.
    let (width, height) = (8, 4);
    let mut texels = vec![[0.0f32; 3]; width * height];
    texels[2 * width + 2] = [1.0, 2.0, 3.0];
    // And the zenith row, and the left edge (−z) just below the equator.
    texels[0] = [5.0, 5.0, 5.0];
    texels[2 * width] = [7.0, 0.0, 0.0];
    let map = EnvMap::new(width, height, texels.clone(), 1.0, 0.0, "t".into()).unwrap();
    let ahead = DVec3::new(1.0, -0.1, 0.0).normalize();
    assert_eq!(map.radiance(ahead), DVec3::new(1.0, 2.0, 3.0));
    assert_eq!(
        map.radiance(DVec3::new(0.01, 1.0, -0.05).normalize()),
        DVec3::splat(5.0)
    );
    let minus_z = DVec3::new(0.01, -0.1, -1.0).normalize();
    assert_eq!(map.radiance(minus_z), DVec3::new(7.0, 0.0, 0.0));
    // Rotated 90° about +y, what the file has along −z arrives from −x.
    let turned = EnvMap::new(width, height, texels, 1.0, 90.0, "t".into()).unwrap();
    let minus_x = DVec3::new(-1.0, -0.1, -0.01).normalize();
    assert_eq!(turned.radiance(minus_x), DVec3::new(7.0, 0.0, 0.0));
}

#[test]
fn bad_maps_are_refused() {
    let square = EnvMap::new(4, 4, vec![[1.0; 3]; 16], 1.0, 0.0, "sq".into());
    assert!(square.unwrap_err().message.contains("not a lat-long"));
    let mut texels = vec![[1.0f32; 3]; 8];
    texels[5] = [0.0, f32::NAN, 0.0];
    let nan = EnvMap::new(4, 2, texels, 1.0, 0.0, "nan".into()).unwrap_err();
    assert!(nan.message.contains("column 1, row 1"), "{}", nan.message);
    assert!(EnvMap::new(4, 2, vec![[1.0; 3]; 8], f64::NAN, 0.0, "i".into()).is_err());
}

/// The paper's zenith fits as it prints them, Appendix A.2: `Y_z` from χ, and `x_z`, `y_z` as
/// `(T², T, 1)·M·(θ³, θ², θ, 1)ᵀ`.
fn paper_zenith(t: f64, theta: f64) -> (f64, f64, f64) {
    let chi = (4.0 / 9.0 - t / 120.0) * (PI - 2.0 * theta);
    let y_kcd = (4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192;
    let mx = [
        [0.00166, -0.00375, 0.00209, 0.0],
        [-0.02903, 0.06377, -0.03202, 0.00394],
        [0.11693, -0.21196, 0.06052, 0.25886],
    ];
    let my = [
        [0.00275, -0.00610, 0.00317, 0.0],
        [-0.04214, 0.08970, -0.04153, 0.00516],
        [0.15346, -0.26756, 0.06670, 0.26688],
    ];
    let row = [t * t, t, 1.0];
    let col = [theta.powi(3), theta.powi(2), theta, 1.0];
    let form = |m: [[f64; 4]; 3]| -> f64 {
        (0..3)
            .map(|r| row[r] * (0..4).map(|c| m[r][c] * col[c]).sum::<f64>())
            .sum()
    };
    (y_kcd * 1000.0, form(mx), form(my))
}

/// A sun `elevation` degrees above the horizon, sunlight travelling towards +x and down.
fn sun_at(elevation: f64) -> DVec3 {
    let e = elevation.to_radians();
    DVec3::new(e.cos(), -e.sin(), 0.0)
}

#[test]
fn the_zenith_is_the_papers() {
    for (t, elevation) in [(3.0, 60.0), (2.0, 30.0), (6.5, 10.0), (10.0, 75.0)] {
        let sky = PhysicalSky::new(sun_at(elevation), t, 1.0).unwrap();
        let theta_s = (90.0f64 - elevation).to_radians();
        let (y, x, yc) = paper_zenith(t, theta_s);
        let at = sky.xy_luminance(DVec3::Y);
        assert!((at.x / y - 1.0).abs() < 1e-12, "Y {} vs {y}", at.x);
        assert!((at.y - x).abs() < 1e-12 && (at.z - yc).abs() < 1e-12);
    }
}

#[test]
fn luminance_ratios_follow_perez() {
    let t = 4.0;
    let sky = PhysicalSky::new(sun_at(40.0), t, 1.0).unwrap();
    // Perez's F with the paper's luminance coefficients, written out here.
    let f = |theta: f64, gamma: f64| {
        let (a, b, c, d, e) = (
            0.1787 * t - 1.4630,
            -0.3554 * t + 0.4275,
            -0.0227 * t + 5.3251,
            0.1206 * t - 2.5771,
            -0.0670 * t + 0.3703,
        );
        (1.0 + a * (b / theta.cos()).exp())
            * (1.0 + c * (d * gamma).exp() + e * gamma.cos().powi(2))
    };
    let to_sun = -sun_at(40.0);
    let directions = [
        DVec3::new(0.3, 0.8, 0.5).normalize(),
        DVec3::new(-0.9, 0.2, 0.1).normalize(),
        DVec3::new(0.7, 0.6, -0.2).normalize(),
    ];
    for a in directions {
        for b in directions {
            let angles = |d: DVec3| (d.y.acos(), d.dot(to_sun).acos());
            let ((ta, ga), (tb, gb)) = (angles(a), angles(b));
            let expected = f(ta, ga) / f(tb, gb);
            let got = sky.xy_luminance(a).x / sky.xy_luminance(b).x;
            assert!((got / expected - 1.0).abs() < 1e-12, "{got} vs {expected}");
        }
    }
}

#[test]
fn the_sky_is_bluer_away_from_the_sun_and_redder_when_it_is_low() {
    let blueness = |c: DVec3| c.z / c.x;
    let sky = PhysicalSky::new(sun_at(35.0), 3.0, 1.0).unwrap();
    let to_sun = -sun_at(35.0);
    let near = (to_sun + DVec3::new(0.0, 0.0, 0.15)).normalize();
    let away = DVec3::new(-to_sun.x, to_sun.y, 0.3).normalize();
    assert!(
        blueness(sky.radiance(away)) > blueness(sky.radiance(near)),
        "{} near the sun, {} away",
        sky.radiance(near),
        sky.radiance(away)
    );
    let redness = |c: DVec3| c.x / c.z;
    let colour = |light: &Light| match light {
        Light::Distant(d) => d.color,
        Light::Point(p) => p.color,
    };
    let high = PhysicalSky::new(sun_at(60.0), 3.0, 1.0).unwrap();
    let low = PhysicalSky::new(sun_at(4.0), 3.0, 1.0).unwrap();
    assert!(redness(colour(low.sun())) > 1.5 * redness(colour(high.sun())));
    assert!(colour(low.sun()).y < 0.5 * colour(high.sun()).y);
    // The horizon around a low sun is redder than the same spot under a high sun.
    let horizon = DVec3::new(1.0, 0.05, 0.2).normalize();
    assert!(redness(low.radiance(horizon)) > redness(high.radiance(horizon)));
}

#[test]
fn the_suns_strength_is_daylight() {
    // A high sun through a clear sky gives 70 to 110 klux at the ground (a clear-day figure
    // from any daylighting handbook), so about 3 in felt's units.
    let xyz = sun::illuminance_xyz(20f64.to_radians(), 3.0);
    assert!((70_000.0..110_000.0).contains(&xyz.y), "{}", xyz.y);
    let sky = PhysicalSky::new(sun_at(70.0), 3.0, 1.0).unwrap();
    let Light::Distant(d) = sky.sun() else {
        panic!()
    };
    let luminance = 0.2126 * d.color.x + 0.7152 * d.color.y + 0.0722 * d.color.z;
    assert!((2.0..4.0).contains(&luminance), "{}", d.color);
    assert!((d.direction - sun_at(70.0)).length() < 1e-12);
    // The sun below the horizon, and turbidities outside the fits, are refused.
    assert!(PhysicalSky::new(DVec3::new(1.0, 0.2, 0.0), 3.0, 1.0).is_err());
    assert!(PhysicalSky::new(sun_at(30.0), 1.0, 1.0).is_err());
    assert!(PhysicalSky::new(sun_at(30.0), 12.0, 1.0).is_err());
}

#[test]
fn daylight_sampling_is_unbiased() {
    let sky = Sky::Physical(Arc::new(PhysicalSky::new(sun_at(25.0), 3.0, 1.0).unwrap()));
    // The integral by the midpoint rule over a grid eight times finer than the sampler's.
    let expected = over_sphere(2048, |d| sky.radiance(d));
    let (mean, error) = sampled_integral(&sky, 200_000, 11);
    for c in 0..3 {
        assert!(
            (mean[c] - expected[c]).abs() < 4.0 * error[c] + 1e-4 * expected[c],
            "channel {c}: {} ± {} vs {}",
            mean[c],
            error[c],
            expected[c]
        );
    }
    assert!((pdf_total(&sky, 1024) - 1.0).abs() < 2e-3);
    assert_eq!(physical::CANDELAS_PER_UNIT, 30_000.0);
}

/// A thin or dense ball in front of the camera, path traced at `size²` pixels.
fn render_ball(density: f64, sky: Sky, lights: Vec<Light>, size: usize, spp: u32) -> Image {
    let ball = Pieces::new(vec![Ball {
        centre: DVec3::ZERO,
        radius: 0.5,
        value: density,
    }]);
    let settings = RenderSettings {
        width: size,
        height: size,
        spp,
        integrator: Integrator::Path,
        bounds: Some(crate::space::Aabb::new(
            DVec3::splat(-0.6),
            DVec3::splat(0.6),
        )),
        albedo: Some(1.0),
        phase: Phase::HenyeyGreenstein { g: 0.3 },
        // Every bounce: a furnace that cuts paths short loses light.
        bounces: crate::render::settings::MAX_BOUNCES,
        sky,
        ..RenderSettings::default()
    };
    let scene = Scene {
        density: &ball,
        color: None,
        emission: None,
        holdout: None,
        velocity: None,
        camera: Camera::new(DVec3::new(0.0, 0.0, 3.0), DVec3::ZERO, DVec3::Y, 30.0).unwrap(),
        lights,
    };
    render(&scene, &settings).unwrap()
}

/// The mean over pixels of channel `c` composited over a uniform `background`.
fn mean_over(image: &Image, background: f64, c: usize) -> f64 {
    image
        .rgba
        .iter()
        .map(|p| f64::from(p[c]) + (1.0 - f64::from(p[3])) * background)
        .sum::<f64>()
        / image.rgba.len() as f64
}

#[test]
fn a_constant_map_is_a_white_furnace_like_the_uniform_sky() {
    let c = 0.7;
    let map = EnvMap::new(16, 8, vec![[c as f32; 3]; 128], 1.0, 0.0, "c".into()).unwrap();
    let image = render_ball(20.0, Sky::Environment(Arc::new(map)), Vec::new(), 8, 64);
    let covered = image.rgba.iter().filter(|p| p[3] > 0.05).count();
    assert!(covered >= 12, "the ball covers {covered} pixels");
    // Every pixel composited over the sky shows c: an albedo-1 medium loses nothing.
    for channel in 0..3 {
        let mean = mean_over(&image, c, channel);
        eprintln!("constant map {c}: channel {channel} shows {mean:.5}");
        assert!((mean - c).abs() < 0.01, "channel {channel}: {mean} vs {c}");
    }
    // And it shows what the uniform sky of the same radiance shows.
    let dim = EnvMap::new(16, 8, vec![[c as f32; 3]; 128], 1.0, 0.0, "c".into()).unwrap();
    let uniform = render_ball(20.0, Sky::Uniform(DVec3::splat(c)), Vec::new(), 8, 64);
    let same = mean_over(&uniform, c, 1);
    let lit = render_ball(20.0, Sky::Environment(Arc::new(dim)), Vec::new(), 8, 64);
    assert!((mean_over(&lit, c, 1) - same).abs() < 0.01);
}

#[test]
fn a_small_bright_patch_lights_like_a_distant_light() {
    let (width, height) = (256, 128);
    // The patch: one texel up and to the side, its radiance giving irradiance 2.
    let (i, j) = (40, 40);
    let (t0, t1) = (
        PI * j as f64 / height as f64,
        PI * (j + 1) as f64 / height as f64,
    );
    let solid = 2.0 * PI / width as f64 * (t0.cos() - t1.cos());
    let irradiance = 2.0;
    let mut texels = vec![[0.0f32; 3]; width * height];
    texels[j * width + i] = [(irradiance / solid) as f32; 3];
    let map = EnvMap::new(width, height, texels, 1.0, 0.0, "patch".into()).unwrap();
    let towards = latlong::direction(
        (i as f64 + 0.5) / width as f64,
        (j as f64 + 0.5) / height as f64,
    );
    let patch = render_ball(1.0, Sky::Environment(Arc::new(map)), Vec::new(), 12, 384);
    let sun = Light::distant(-towards, DVec3::splat(irradiance)).unwrap();
    let distant = render_ball(1.0, Sky::default(), vec![sun], 12, 384);
    let (a, b) = (mean_over(&patch, 0.0, 1), mean_over(&distant, 0.0, 1));
    eprintln!("patch {a:.5}, distant light {b:.5}, ratio {:.4}", a / b);
    assert!(b > 0.01, "the distant light lights the ball: {b}");
    assert!((a / b - 1.0).abs() < 0.03, "patch {a} vs distant light {b}");
}

/// A sun disc (a few texels of radiance 2000 on a dim sky): drawing directions by the map's
/// own distribution estimates `∫ L dω` with far less variance than drawing them uniformly over
/// the sphere at the same count, and both agree with the texel quadrature.
#[test]
fn importance_sampling_lowers_the_noise_of_a_sun_disc_map() {
    let (width, height) = (256, 128);
    let mut texels = vec![[0.05f32; 3]; width * height];
    for (i, j) in [(60, 30), (61, 30), (60, 31), (61, 31)] {
        texels[j * width + i] = [2000.0; 3];
    }
    let map = EnvMap::new(width, height, texels, 1.0, 0.0, "sun disc".into()).unwrap();
    let exact = texel_quadrature(&map, width).x;
    let sky = Sky::Environment(Arc::new(map));
    let n = 20_000;
    let (mean, error) = sampled_integral(&sky, n, 0x5d1);
    let mut random = SplitMix(0x5d2);
    let (mut sum, mut squares) = (0.0, 0.0);
    for _ in 0..n {
        // Uniform on the sphere: z uniform in [-1, 1], φ uniform.
        let z = 2.0 * random.unit() - 1.0;
        let phi = 2.0 * PI * random.unit();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let f = 4.0 * PI * sky.radiance(DVec3::new(r * phi.cos(), r * phi.sin(), z)).x;
        sum += f;
        squares += f * f;
    }
    let uniform_mean = sum / n as f64;
    let uniform_error = ((squares / n as f64 - uniform_mean * uniform_mean) / n as f64).sqrt();
    let ratio = (uniform_error / error.x).powi(2);
    eprintln!(
        "exact {exact:.4}; importance {:.4} ± {:.5}; uniform {uniform_mean:.4} ± {uniform_error:.4}; \
         variance ratio {ratio:.0}",
        mean.x, error.x
    );
    assert!((mean.x - exact).abs() < 4.0 * error.x + 1e-9 * exact);
    assert!((uniform_mean - exact).abs() < 4.0 * uniform_error);
    assert!(ratio > 100.0, "variance ratio {ratio}");
}
