//! A background is what each camera ray sees where it leaves the medium, weighed by what it
//! has left: through an absorbing slab that is the background times Beer–Lambert's
//! transmittance, per channel; where a ray meets nothing it is the sky along that ray,
//! exactly; and alpha is 1 in both integrators.

use super::*;
use crate::render::settings::Integrator;
use crate::render::sky::Sky;
use crate::render::sky::physical::PhysicalSky;
use std::sync::Arc;

const BACKGROUND: DVec3 = DVec3::new(0.2, 0.4, 0.8);

fn with_background(integrator: Integrator, spp: u32) -> RenderSettings {
    RenderSettings {
        kappa: DVec3::new(1.25, 0.5, 2.0),
        step: Some(0.07),
        integrator,
        spp,
        background: Some(Sky::Uniform(BACKGROUND)),
        ..small(4, 4)
    }
}

#[test]
fn the_march_sees_the_background_through_a_slab_as_beer_lambert_says() {
    let (rho, thickness) = (1.5, 0.8);
    let density = slab(1, DVec3::splat(rho), -0.4, 0.4);
    let settings = with_background(Integrator::March, 1);
    let image = render(&scene(&density, vec![]), &settings).unwrap();
    // No light and no emission: the only colour is the background the slab lets through.
    let expected = BACKGROUND * (-settings.kappa * rho * thickness).exp();
    for p in &image.rgba {
        for c in 0..3 {
            assert!(
                (p[c] as f64 - expected[c]).abs() < 1e-6,
                "channel {c}: {} vs {}",
                p[c],
                expected[c]
            );
        }
        assert_eq!(p[3], 1.0);
    }
}

#[test]
fn the_path_tracer_sees_the_background_through_a_slab_in_expectation() {
    let (rho, thickness) = (1.5, 0.8);
    let density = slab(1, DVec3::splat(rho), -0.4, 0.4).with_range(0.0, rho);
    // Albedo 1 and no light: paths that scatter see nothing, so a pixel's colour is the
    // background times the chance (per channel, under spectral tracking) of crossing unscattered.
    let settings = RenderSettings {
        width: 8,
        height: 8,
        ..with_background(Integrator::Path, 1024)
    };
    let image = render(&scene(&density, vec![]), &settings).unwrap();
    let expected = BACKGROUND * (-settings.kappa * rho * thickness).exp();
    assert!(image.rgba.iter().all(|p| p[3] == 1.0));
    // Each pixel is an independent mean of `spp` paths: their spread gives the standard error
    // of the image's mean.
    let n = image.rgba.len() as f64;
    for c in 0..3 {
        let values: Vec<f64> = image.rgba.iter().map(|p| p[c] as f64).collect();
        let mean = values.iter().sum::<f64>() / n;
        let spread = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let error = (spread / n).sqrt();
        assert!(
            (mean - expected[c]).abs() < 4.0 * error,
            "channel {c}: {mean} ± {error} vs {}",
            expected[c]
        );
        assert!(error < 0.03 * expected[c], "channel {c}: ± {error}");
    }
}

#[test]
fn where_a_ray_meets_nothing_it_sees_the_sky_along_it() {
    let density = slab(1, DVec3::ONE, -0.4, 0.4).with_range(0.0, 1.0);
    let sky = PhysicalSky::new(DVec3::new(1.0, -0.3, 0.2), 3.0, 1.0).unwrap();
    let sky = Sky::Physical(Arc::new(sky));
    // Orthographic cameras looking away from the slab: every ray leaves along `forward`.
    let views = [
        (
            DVec3::new(0.0, 0.0, 5.0),
            DVec3::new(0.0, 0.0, 9.0),
            DVec3::Y,
        ),
        (
            DVec3::new(0.0, 5.0, 0.0),
            DVec3::new(0.0, 9.0, 0.0),
            DVec3::Z,
        ),
        (
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::new(6.0, 0.5, 0.0),
            DVec3::Y,
        ),
    ];
    for (eye, lookat, up) in views {
        let camera = Camera::new(eye, lookat, up, 45.0)
            .unwrap()
            .orthographic(1.0)
            .unwrap();
        let expected = sky.radiance((lookat - eye).normalize());
        assert!(expected.min_element() > 0.0);
        for integrator in [Integrator::March, Integrator::Path] {
            let mut looking_away = scene(&density, vec![]);
            looking_away.camera = camera.clone();
            let settings = RenderSettings {
                integrator,
                spp: 2,
                background: Some(sky.clone()),
                ..small(3, 2)
            };
            let image = render(&looking_away, &settings).unwrap();
            for p in &image.rgba {
                for c in 0..3 {
                    let relative = p[c] as f64 / expected[c] - 1.0;
                    assert!(relative.abs() < 1e-6, "{integrator:?} {c}: {relative}");
                }
                assert_eq!(p[3], 1.0);
            }
            // Without a background the same pixels are transparent black.
            let bare = RenderSettings {
                background: None,
                ..settings
            };
            let image = render(&looking_away, &bare).unwrap();
            assert!(image.rgba.iter().all(|p| *p == [0.0; 4]));
        }
    }
}

#[test]
fn a_negative_or_infinite_background_is_refused_by_name() {
    for bad in [
        DVec3::new(0.1, -0.2, 0.3),
        DVec3::new(f64::INFINITY, 0.0, 0.0),
    ] {
        let settings = RenderSettings {
            background: Some(Sky::Uniform(bad)),
            ..small(2, 2)
        };
        let message = settings.validate().unwrap_err().to_string();
        assert!(message.contains("background"), "{message}");
    }
}
