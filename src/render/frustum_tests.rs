//! Frustum caches in the renderer: a field cached in a frustum renders to the image of the
//! procedural field, closer as the frustum's cells get finer, and a camera-filling fog closer
//! than in a box cache of as many cells; the path tracer's majorants bound it; the image is the same for any thread count;
//! a frustum's cell centres sit on the rays through the camera's pixel centres.

use crate::base::test_random::SplitMix;
use crate::field::noise::NoiseKind;
use crate::field::{CompiledField, Field};
use crate::grid::cache::Cache;
use crate::grid::frustum::{Frustum, FrustumRead};
use crate::render::settings::{Integrator, RenderSettings};
use crate::render::testing::{check_majorants_over_a_random_box, plain_scene};
use crate::render::{Camera, Image, Light, render};
use crate::space::domain::Domain;
use crate::space::{Aabb, GridSource};
use glam::DVec3;
use std::sync::Arc;

/// Pixels across and down: prime, so no frustum's pixels line up with the image's.
const IMAGE: usize = 23;

fn camera() -> Camera {
    Camera::new(DVec3::new(0.4, 0.6, 3.0), DVec3::ZERO, DVec3::Y, 40.0).unwrap()
}

/// A lumpy ball of smoke: smooth enough that trilinear reads converge as cells shrink.
fn smoke() -> Field {
    let p = Field::identity();
    let lumps = Field::noise(NoiseKind::Perlin, 7)
        .compose(&p.mul(&Field::constant_scalar(2.5)).unwrap())
        .unwrap();
    let falloff = Field::max(
        &Field::constant_scalar(0.9)
            .sub(&p.length().unwrap())
            .unwrap(),
        &Field::constant_scalar(0.0),
    )
    .unwrap();
    falloff
        .mul(&Field::constant_scalar(5.0))
        .unwrap()
        .mul(
            &Field::constant_scalar(1.0)
                .add(&lumps.mul(&Field::constant_scalar(0.6)).unwrap())
                .unwrap(),
        )
        .unwrap()
}

/// `field` cached over a frustum of `pixels` cells from near 2 to far 4.2, read at world points.
fn in_frustum(field: &Field, pixels: [usize; 3]) -> CompiledField {
    let frustum = Frustum::new(
        camera().frustum_view(pixels[0], pixels[1]),
        2.0,
        4.2,
        pixels,
        1,
        1,
    )
    .unwrap();
    let (read, _) = cached(field, frustum, "frustum");
    CompiledField::new(&Field::from_linear_grid(read).unwrap())
}

/// `field` filled into a cache over `frustum`'s cells (at their world centres), read at world
/// points; and the cache itself.
fn cached(field: &Field, frustum: Frustum, name: &str) -> (Arc<dyn GridSource>, Arc<Cache>) {
    let composed = field
        .compose(&crate::field::shapes::frustum_cell_to_world(&frustum.index_map()).unwrap())
        .unwrap();
    let cache = Cache::from_field(
        frustum.index_domain().unwrap(),
        1,
        CompiledField::shared(&composed),
        vec![0.0],
        name.into(),
    )
    .unwrap();
    let cache = Arc::new(cache);
    let read: Arc<dyn GridSource> = Arc::new(FrustumRead::new(Arc::new(frustum), cache.clone()));
    (read, cache)
}

fn settings(integrator: Integrator) -> RenderSettings {
    RenderSettings {
        width: IMAGE,
        height: IMAGE,
        spp: if integrator == Integrator::Path { 4 } else { 1 },
        integrator,
        step: Some(0.01),
        kappa: DVec3::splat(2.0),
        bounds: Some(Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0))),
        ..RenderSettings::default()
    }
}

fn render_density(density: &CompiledField, integrator: Integrator) -> Image {
    let sun = Light::distant(DVec3::new(-0.3, -1.0, -0.5), DVec3::ONE).unwrap();
    let scene = plain_scene(density, camera(), vec![sun]);
    render(&scene, &settings(integrator)).unwrap()
}

/// Root-mean-square difference of the colour and alpha channels.
fn rms(a: &Image, b: &Image) -> f64 {
    let sum: f64 = a
        .rgba
        .iter()
        .zip(&b.rgba)
        .flat_map(|(p, q)| (0..4).map(move |c| (f64::from(p[c]) - f64::from(q[c])).powi(2)))
        .sum();
    (sum / (4 * a.rgba.len()) as f64).sqrt()
}

#[test]
fn a_field_cached_in_a_frustum_renders_to_the_procedural_image_as_cells_shrink() {
    let field = smoke();
    let exact = render_density(&CompiledField::new(&field), Integrator::March);
    let alpha: f64 =
        exact.rgba.iter().map(|p| f64::from(p[3])).sum::<f64>() / (IMAGE * IMAGE) as f64;
    assert!(alpha > 0.1, "the smoke fills part of the image: {alpha}");
    let errors: Vec<f64> = [6, 12, 24, 48]
        .iter()
        .map(|&n| {
            rms(
                &render_density(&in_frustum(&field, [n, n, n]), Integrator::March),
                &exact,
            )
        })
        .collect();
    // Trilinear reads: the error falls about fourfold each time the cells halve.
    for pair in errors.windows(2) {
        assert!(pair[1] < 0.6 * pair[0], "errors {errors:?}");
    }
    assert!(errors[3] < 0.005, "errors {errors:?}");
}

/// Ground fog from the camera's feet to 30 units away, seen from 0.8 above the ground.
fn fog_camera() -> Camera {
    Camera::new(
        DVec3::new(0.0, 0.8, 0.0),
        DVec3::new(0.0, 0.5, -10.0),
        DVec3::Y,
        60.0,
    )
    .unwrap()
}

fn fog() -> Field {
    let p = Field::identity();
    let height = p.component(1).unwrap();
    let lumps = Field::noise(NoiseKind::Perlin, 11)
        .compose(&p.mul(&Field::constant_scalar(1.5)).unwrap())
        .unwrap();
    let layer = Field::max(
        &Field::constant_scalar(1.0)
            .sub(&height.mul(&Field::constant_scalar(1.0 / 1.5)).unwrap())
            .unwrap(),
        &Field::constant_scalar(0.0),
    )
    .unwrap();
    let broken = Field::max(
        &lumps.add(&Field::constant_scalar(0.5)).unwrap(),
        &Field::constant_scalar(0.0),
    )
    .unwrap();
    layer
        .mul(&height.mask().unwrap())
        .unwrap()
        .mul(&broken)
        .unwrap()
}

fn render_fog(density: &CompiledField) -> Image {
    let sun = Light::distant(DVec3::new(-0.4, -0.5, -1.0), DVec3::ONE).unwrap();
    let scene = plain_scene(density, fog_camera(), vec![sun]);
    let settings = RenderSettings {
        step: Some(0.05),
        kappa: DVec3::splat(0.5),
        bounds: Some(Aabb::new(
            DVec3::new(-18.0, -0.1, -30.0),
            DVec3::new(18.0, 1.6, 0.0),
        )),
        ..settings(Integrator::March)
    };
    render(&scene, &settings).unwrap()
}

#[test]
fn a_camera_filling_fog_is_closer_in_a_frustum_than_in_a_box_of_as_many_cells() {
    let field = fog();
    let exact = render_fog(&CompiledField::new(&field));
    // Slices are uniform in depth, so a deep frustum spends its cells on depth: 16 x 16 pixels
    // (18 x 18 with the padding) by 128 slices of 0.23.
    let frustum = Frustum::new(
        fog_camera().frustum_view(16, 16),
        0.2,
        30.0,
        [16, 16, 128],
        1,
        1,
    )
    .unwrap();
    let cells = frustum.index_domain().unwrap().cell_count();
    let (read, cache) = cached(&field, frustum, "fog");
    let in_frustum = rms(
        &render_fog(&CompiledField::new(&Field::from_linear_grid(read).unwrap())),
        &exact,
    );
    // The box the camera sees of the fog layer, in cubic cells, as many as the frustum has.
    let (origin, lengths) = (DVec3::new(-18.0, -0.1, -30.0), DVec3::new(36.0, 1.7, 30.0));
    let side = (lengths.x * lengths.y * lengths.z / cells as f64).cbrt();
    let domain = Domain::with_cells(origin, lengths, DVec3::ZERO, side, side).unwrap();
    let box_cells = domain.cell_count();
    let boxed = Arc::new(
        Cache::from_field(
            domain,
            1,
            CompiledField::shared(&field),
            vec![0.0],
            "box".into(),
        )
        .unwrap(),
    );
    let grid: Arc<dyn GridSource> = boxed.clone();
    let in_box = rms(
        &render_fog(&CompiledField::new(&Field::from_linear_grid(grid).unwrap())),
        &exact,
    );
    eprintln!(
        "fog: frustum of {cells} cells ({} bytes stored) rms {in_frustum}, box of {box_cells} cells ({} bytes stored) rms {in_box}",
        cache.bytes(),
        boxed.bytes()
    );
    assert!(
        (box_cells as f64) < 1.1 * cells as f64,
        "{box_cells} against {cells}"
    );
    assert!(
        in_frustum < 0.8 * in_box,
        "frustum {in_frustum}, box {in_box}"
    );
}

#[test]
fn majorants_bound_a_frustum_cache_over_random_boxes() {
    let mut random = SplitMix(0x7e5);
    let field = in_frustum(&smoke(), [10, 9, 7]);
    for case in 0..16 {
        check_majorants_over_a_random_box(&field, &mut random, 0.6, 10, 2000, case);
    }
}

#[test]
fn a_path_traced_frustum_cache_is_the_same_for_any_thread_count() {
    let field = in_frustum(&smoke(), [12, 12, 10]);
    let images: Vec<Image> = [1, 3]
        .iter()
        .map(|&threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| render_density(&field, Integrator::Path))
        })
        .collect();
    let bits =
        |image: &Image| -> Vec<u32> { image.rgba.iter().flatten().map(|v| v.to_bits()).collect() };
    assert_eq!(bits(&images[0]), bits(&images[1]));
    assert!(images[0].rgba.iter().any(|p| p[3] > 0.0));
}

#[test]
fn frustum_cell_centres_lie_on_the_rays_through_pixel_centres() {
    for camera in [
        camera(),
        camera().orthographic(2.5).unwrap(),
        camera().with_aspect(2.0).unwrap(),
    ] {
        let (width, height) = (7, 5);
        let frustum = Frustum::new(
            camera.frustum_view(width, height),
            1.0,
            5.0,
            [width, height, 4],
            0,
            1,
        )
        .unwrap();
        let raster = camera.raster(width, height);
        for y in 0..height {
            for x in 0..width {
                let ray = raster.ray(x, y, 0.5, 0.5);
                for k in 0..4 {
                    let depth = 1.0 + 4.0 * (k as f64 + 0.5) / 4.0;
                    // The ray's point at that depth along the view.
                    let along = ray
                        .at((depth - camera.depth(ray.origin))
                            / ray.direction.dot(camera.forward()));
                    let centre =
                        frustum.index_to_world(DVec3::new(x as f64, y as f64, k as f64) + 0.5);
                    assert!(
                        (along - centre).length() < 1e-12,
                        "pixel ({x}, {y}) slice {k}: {along} against {centre}"
                    );
                }
            }
        }
    }
}
