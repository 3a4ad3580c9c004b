//! The march's indirect light against closed forms and the path tracer: an albedo-1 medium
//! under a uniform sky shows the sky (white furnace) through the grid alone, the march with its
//! grid agrees with the converged path tracer on a thin lit medium, the grid is bit-identical
//! for any thread count, and a render with nothing to light it builds no grid.

use crate::render::settings::{Integrator, RenderSettings};
use crate::render::testing::{Ball, Pieces, plain_scene};
use crate::render::{Camera, Image, Light, Phase, Scene, render, render_with_stats};
use crate::space::Aabb;
use glam::DVec3;

fn camera() -> Camera {
    Camera::new(DVec3::new(0.0, 0.0, 3.0), DVec3::ZERO, DVec3::Y, 30.0).unwrap()
}

fn ball(density: f64) -> Pieces {
    Pieces::new(vec![Ball {
        centre: DVec3::ZERO,
        radius: 0.5,
        value: density,
    }])
}

fn settings(size: usize) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        albedo: Some(1.0),
        bounds: Some(Aabb::new(DVec3::splat(-0.6), DVec3::splat(0.6))),
        ..RenderSettings::default()
    }
}

fn scene<'a>(density: &'a Pieces, lights: Vec<Light>) -> Scene<'a> {
    plain_scene(density, camera(), lights)
}

/// The mean of one channel over the pixels the medium covers.
fn covered_mean(image: &Image, channel: usize) -> f64 {
    let covered: Vec<_> = image.rgba.iter().filter(|p| p[3] > 0.5).collect();
    assert!(
        covered.len() > 10,
        "the ball covers {} pixels",
        covered.len()
    );
    covered.iter().map(|p| f64::from(p[channel])).sum::<f64>() / covered.len() as f64
}

#[test]
fn white_furnace_shows_the_sky_through_the_grid() {
    // An albedo-1 medium loses no light: every path from a cell leaves with weight 1 and sees
    // the sky, so every cell holds exactly the sky, and the march's exact step integrals give
    // rgb = sky·(1 − T) = sky·alpha. Composited over the sky the image is the sky everywhere,
    // whatever the density and phase.
    let sky = DVec3::new(0.3, 0.5, 0.7);
    for (density, g) in [(1.0, 0.0), (20.0, 0.8)] {
        let medium = ball(density);
        let mut s = settings(16);
        s.sky = sky.into();
        s.phase = Phase::HenyeyGreenstein { g };
        s.bounces = crate::render::settings::MAX_BOUNCES;
        let image = render(&scene(&medium, Vec::new()), &s).unwrap();
        let mut opaque = 0;
        for p in &image.rgba {
            let alpha = f64::from(p[3]);
            opaque += usize::from(alpha > 0.9);
            for c in 0..3 {
                let composite = f64::from(p[c]) + (1.0 - alpha) * sky[c];
                assert!(
                    (composite - sky[c]).abs() < 1e-4,
                    "density {density}: channel {c} composites to {composite}, not {}",
                    sky[c]
                );
            }
        }
        if density > 1.0 {
            assert!(opaque > 20, "the dense ball is opaque over {opaque} pixels");
        }
    }
}

#[test]
fn without_the_grid_the_sky_is_refused_and_single_scattering_misses_the_sky() {
    let medium = ball(4.0);
    let mut s = settings(8);
    s.sky = DVec3::ONE.into();
    s.indirect = None;
    let err = render(&scene(&medium, Vec::new()), &s).unwrap_err();
    assert!(err.message.contains("indirect grid"), "{}", err.message);
}

#[test]
fn the_march_with_its_grid_matches_the_path_tracer_on_a_thin_lit_medium() {
    // A ball of optical radius 1, albedo 0.8, lit by a sun and a sky: about a third of the
    // light it scatters has scattered more than once. The march with its grid must match the
    // converged path tracer's mean over the ball within 3 %, where single scattering alone
    // falls short by far more.
    let medium = ball(2.0);
    let sun = Light::distant(DVec3::new(-0.5, -1.0, -0.4), DVec3::splat(2.0)).unwrap();
    let mut march = settings(16);
    march.albedo = Some(0.8);
    march.phase = Phase::HenyeyGreenstein { g: 0.3 };
    march.sky = DVec3::new(0.1, 0.2, 0.3).into();
    let mut path = march.clone();
    path.integrator = Integrator::Path;
    path.spp = 512;
    let lit = scene(&medium, vec![sun]);
    let reference = render(&lit, &path).unwrap();
    let fast = render(&lit, &march).unwrap();
    march.indirect = None;
    march.sky = DVec3::ZERO.into();
    let single = render(&lit, &march).unwrap();
    for c in 0..3 {
        let (want, got, alone) = (
            covered_mean(&reference, c),
            covered_mean(&fast, c),
            covered_mean(&single, c),
        );
        assert!(
            (got / want - 1.0).abs() < 0.03,
            "channel {c}: march {got}, path tracer {want}"
        );
        assert!(
            alone / want < 0.9,
            "channel {c}: single scattering {alone} is not far below {want}"
        );
    }
}

#[test]
fn the_grid_is_the_same_for_any_thread_count_and_absent_when_nothing_lights_it() {
    let medium = ball(6.0);
    let sun = Light::distant(DVec3::new(0.3, -1.0, -0.2), DVec3::ONE).unwrap();
    let lit = scene(&medium, vec![sun]);
    let s = settings(12);
    let images: Vec<Image> = [1, 3]
        .into_iter()
        .map(|threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| render(&lit, &s).unwrap())
        })
        .collect();
    assert_eq!(images[0].rgba, images[1].rgba);
    let dark = scene(&medium, Vec::new());
    let (image, _) = render_with_stats(&dark, &s).unwrap();
    assert!(
        image
            .rgba
            .iter()
            .all(|p| p[0] == 0.0 && p[3] > 0.0 || p[3] == 0.0)
    );
}

#[test]
fn photons_and_gathered_paths_estimate_the_same_scattered_light() {
    // Two independent routes to the light a sun's light brings to each cell after scattering
    // at least once: paths gathered from the cell towards the camera's phase lobe and the sun
    // (ratio tracking to the sun at every vertex), and photons from the sun scoring where they
    // scatter. Inside a ball of optical radius 1.5 they agree within 3 % over seeds; a photon
    // that also scored its first scattering (the sun's own light) is far off. (Gathering
    // converges slowly in denser media: its rare bright paths are what photons find easily.)
    use crate::render::indirect::{GridInputs, IndirectGrid, IndirectSettings};
    use crate::render::path::Arrivals;
    use crate::render::path::majorant::{MAJORANT_CELLS, Majorants};
    use crate::render::photons::PhotonInputs;
    let medium = ball(3.0);
    let sun = Light::distant(DVec3::new(-0.5, -1.0, -0.4), DVec3::splat(2.0)).unwrap();
    let lit = scene(&medium, vec![sun]);
    let mut s = settings(8);
    s.albedo = Some(0.9);
    s.phase = Phase::HenyeyGreenstein { g: 0.5 };
    let bounds = s.bounds.unwrap();
    let majorants = Majorants::build(&medium, None, bounds, MAJORANT_CELLS).unwrap();
    let arrivals = Arrivals::new(&lit, &s, bounds, &majorants);
    let grid = IndirectSettings {
        cells: 8,
        paths: 4096,
    };
    let inputs = GridInputs {
        arrivals: &arrivals,
        majorants: &majorants,
        density: &medium,
        camera: &lit.camera,
        phase: s.phase,
        kappa: s.kappa,
        lights: &lit.lights,
        seed: 3,
        gather: true,
    };
    let gathered = IndirectGrid::estimate(&inputs, None, bounds, grid).unwrap();
    let inputs = GridInputs {
        gather: false,
        ..inputs
    };
    // The photons stop at the noise a camera would see in an image, which at these few cells
    // is a few per cent: three independent tallies, summed, bring it below the gathered grid's.
    let traced: Vec<IndirectGrid> = [5, 6, 7]
        .into_iter()
        .map(|seed| {
            let photons = PhotonInputs {
                arrivals: &arrivals,
                density: &medium,
                color: None,
                camera: &lit.camera,
                phase: s.phase,
                scattering: s.kappa * 0.9,
                bounces: s.bounces,
                lights: &lit.lights,
                seed,
                image: (s.width, s.height),
            };
            IndirectGrid::estimate(&inputs, Some(&photons), bounds, grid).unwrap()
        })
        .collect();
    // Points that blend only the eight central cells of the gathered grid (cells 0.15 wide,
    // wholly inside the ball): a cell gathers from origins over all of it, so a cell that
    // reaches outside the ball would mix in the light of the empty space around it, which the
    // photons' mass-weighted cells do not.
    let (mut a, mut b) = (0.0, 0.0);
    for i in 0..5 {
        for j in 0..5 {
            for k in 0..5 {
                let p = (DVec3::new(i as f64, j as f64, k as f64) / 4.0 - 0.5) * 0.15;
                a += gathered.at(p).element_sum();
                b += traced.iter().map(|t| t.at(p).element_sum()).sum::<f64>() / 3.0;
            }
        }
    }
    assert!(a > 0.0, "the gathered paths found no scattered light");
    assert!(
        (b / a - 1.0).abs() < 0.05,
        "photons {b} against gathered paths {a}: ratio {}",
        b / a
    );
}
