//! The frustum's maps, bounds and reads, each against a second route: the maps against each
//! other and against finite differences, index boxes against points drawn inside their world
//! boxes, a filled cache's reads against the field at the cells' centres.

use super::{Frustum, FrustumRead, View};
use crate::base::test_random::SplitMix;
use crate::grid::cache::Cache;
use crate::space::{Aabb, FnField, GridSource, Interp};
use glam::DVec3;
use std::sync::Arc;

/// A camera's view built the way a camera builds it: forward to `lookat`, right and up
/// perpendicular to it, `fov` degrees across.
pub(super) fn view(eye: DVec3, lookat: DVec3, fov: f64, aspect: f64, ortho: Option<f64>) -> View {
    let forward = (lookat - eye).normalize();
    let right = forward.cross(DVec3::Y).normalize();
    let up = right.cross(forward);
    let half_width = match ortho {
        Some(w) => 0.5 * w,
        None => (0.5 * fov.to_radians()).tan(),
    };
    View {
        eye,
        right,
        up,
        forward,
        half_width,
        half_height: half_width / aspect,
        orthographic: ortho.is_some(),
    }
}

pub(super) fn random_frustum(random: &mut SplitMix) -> Frustum {
    let eye = random.vector(-3.0, 3.0);
    let lookat = eye
        + DVec3::new(
            random.range(-1.0, 1.0),
            random.range(-0.5, 0.5),
            random.sign() * random.range(0.5, 1.0),
        );
    let ortho = (random.below(3) == 0).then(|| random.range(0.5, 4.0));
    let v = view(
        eye,
        lookat,
        random.range(10.0, 120.0),
        random.range(0.5, 2.0),
        ortho,
    );
    let near = random.range(0.05, 1.0);
    let far = near + random.range(0.1, 6.0);
    let pixels = [
        1 + random.below(40),
        1 + random.below(30),
        1 + random.below(20),
    ];
    Frustum::new(v, near, far, pixels, random.below(3), 1).unwrap()
}

#[test]
fn index_and_world_points_map_back_to_themselves() {
    let mut random = SplitMix(0xf2);
    for _ in 0..200 {
        let frustum = random_frustum(&mut random);
        let [x, y, z] = frustum.cells().map(|n| n as f64);
        for _ in 0..50 {
            let q = DVec3::new(x * random.unit(), y * random.unit(), z * random.unit());
            let back = frustum.world_to_index(frustum.index_to_world(q));
            assert!(
                (back - q).abs().max_element() < 1e-8,
                "{q} came back as {back}"
            );
        }
    }
}

#[test]
fn the_jacobian_is_the_derivative_of_the_world_to_index_map() {
    let mut random = SplitMix(0x1ac);
    for _ in 0..100 {
        let frustum = random_frustum(&mut random);
        let [x, y, z] = frustum.cells().map(|n| n as f64);
        let q = DVec3::new(x * random.unit(), y * random.unit(), z * random.unit());
        let p = frustum.index_to_world(q);
        let jacobian = frustum.jacobian(p);
        let h = 1e-6 * (1.0 + p.abs().max_element());
        for j in 0..3 {
            let mut step = DVec3::ZERO;
            step[j] = h;
            let difference =
                (frustum.world_to_index(p + step) - frustum.world_to_index(p - step)) / (2.0 * h);
            for m in 0..3 {
                let exact = jacobian.row(m)[j];
                assert!(
                    (difference[m] - exact).abs() <= 1e-5 * (1.0 + exact.abs()),
                    "d q{m} / d x{j}: {exact} against {}",
                    difference[m]
                );
            }
        }
    }
}

#[test]
fn index_boxes_hold_the_index_of_every_point_of_their_world_boxes() {
    let mut random = SplitMix(0xb0c5);
    let mut inside_some_frustum = 0;
    for _ in 0..300 {
        let frustum = random_frustum(&mut random);
        let centre = frustum.bounds().center() + random.vector(-2.0, 2.0);
        let half = DVec3::new(
            random.range(0.01, 2.0),
            random.range(0.01, 2.0),
            random.range(0.01, 2.0),
        );
        let region = Aabb::new(centre - half, centre + half);
        let index_box = frustum.index_box(&region);
        let [x, y, z] = frustum.cells().map(|n| n as f64);
        let reach = (DVec3::splat(-1.0), DVec3::new(x + 1.0, y + 1.0, z + 1.0));
        for _ in 0..200 {
            let mut p =
                region.min + 2.0 * half * DVec3::new(random.unit(), random.unit(), random.unit());
            for axis in 0..3 {
                match random.below(6) {
                    0 => p[axis] = region.min[axis],
                    1 => p[axis] = region.max[axis],
                    _ => {}
                }
            }
            // Indices beyond the reach read the background as the reach's edge does.
            let q = frustum.world_to_index(p).clamp(reach.0, reach.1);
            assert!(
                index_box.contains(q),
                "{p} maps to {q}, outside {index_box:?} of {region:?}"
            );
            inside_some_frustum += usize::from(q.cmpgt(DVec3::ZERO).all() && q.z < z);
        }
    }
    // Not a test of points that all miss the frustum.
    assert!(inside_some_frustum > 1000, "{inside_some_frustum}");
}

/// A smooth function of the world point with values of order 1, varying over a fraction of a
/// cell of the frustums below.
fn bumps(p: DVec3) -> f64 {
    (3.0 * p.x).sin() * (2.0 * p.y).cos() + 0.5 * (1.5 * p.z + 0.3).sin()
}

/// A cache over `frustum` of `bumps`, filled at the world points of its cell centres (what
/// `cachewrite` does, through the field `field::shapes::frustum_cell_to_world`), and its read at
/// world points.
fn frustum_cache(frustum: &Frustum, background: f64) -> (Arc<Cache>, FrustumRead) {
    let at = frustum.clone();
    let fill = FnField::new(1, move |q: DVec3, out: &mut [f64]| {
        out[0] = bumps(at.index_to_world(q));
    });
    let cache = Arc::new(
        Cache::from_field(
            frustum.index_domain().unwrap(),
            1,
            Arc::new(fill),
            vec![background],
            "test".into(),
        )
        .unwrap(),
    );
    let read = FrustumRead::new(Arc::new(frustum.clone()), cache.clone());
    (cache, read)
}

#[test]
fn a_frustum_cache_reads_back_the_field_at_its_cell_centres() {
    for ortho in [None, Some(3.0)] {
        let v = view(DVec3::new(0.3, 0.5, 4.0), DVec3::ZERO, 50.0, 1.5, ortho);
        let frustum = Frustum::new(v, 1.0, 7.0, [12, 8, 9], 2, 1).unwrap();
        let (cache, read) = frustum_cache(&frustum, 0.25);
        let [nx, ny, nz] = frustum.cells();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let centre = DVec3::new(i as f64, j as f64, k as f64) + 0.5;
                    let p = frustum.index_to_world(centre);
                    let exact = [bumps(p)];
                    let mut read_back = [0.0];
                    read.sample(Interp::Linear, &[p.x], &[p.y], &[p.z], &mut read_back);
                    let stored = f64::from(cache.value_at_cell(i, j, k).unwrap()[0]);
                    // Caches store single precision.
                    assert!(
                        (stored - exact[0]).abs() <= 1e-6,
                        "cell ({i}, {j}, {k}): stored {stored}, field {}",
                        exact[0]
                    );
                    assert!(
                        (read_back[0] - stored).abs() <= 1e-9,
                        "cell ({i}, {j}, {k}): read {} stored {stored}",
                        read_back[0]
                    );
                }
            }
        }
        // Behind the eye, before near, beyond far and beside the image: the background.
        let (right, _, forward) = (v.right, v.up, v.forward);
        for p in [
            v.eye - forward,
            v.eye + forward * 0.5,
            v.eye + forward * 7.5,
            v.eye + forward * 4.0 + right * 40.0,
            v.eye,
        ] {
            let mut value = [0.0];
            read.sample(Interp::Linear, &[p.x], &[p.y], &[p.z], &mut value);
            assert_eq!(value[0], 0.25, "at {p}");
        }
    }
}

#[test]
fn the_gradient_of_a_read_is_the_derivative_of_its_values() {
    let v = view(DVec3::new(0.0, 0.0, 4.0), DVec3::ZERO, 40.0, 1.0, None);
    let frustum = Frustum::new(v, 2.0, 6.0, [10, 10, 8], 0, 1).unwrap();
    let (_, read) = frustum_cache(&frustum, 0.0);
    let mut random = SplitMix(0x9ad);
    for _ in 0..200 {
        // Inside a cell, away from its faces, where the interpolant is smooth.
        let cell = DVec3::new(
            (1 + random.below(8)) as f64,
            (1 + random.below(8)) as f64,
            (1 + random.below(6)) as f64,
        );
        let q = cell
            + 0.5
            + DVec3::new(
                random.range(0.1, 0.4),
                random.range(0.1, 0.4),
                random.range(0.1, 0.4),
            );
        let p = frustum.index_to_world(q);
        let mut gradient = [0.0; 3];
        read.sample_gradient(Interp::Linear, &[p.x], &[p.y], &[p.z], &mut gradient);
        let h = 1e-6;
        for j in 0..3 {
            let mut step = DVec3::ZERO;
            step[j] = h;
            let (a, b) = (p + step, p - step);
            let (mut fa, mut fb) = ([0.0], [0.0]);
            read.sample(Interp::Linear, &[a.x], &[a.y], &[a.z], &mut fa);
            read.sample(Interp::Linear, &[b.x], &[b.y], &[b.z], &mut fb);
            let difference = (fa[0] - fb[0]) / (2.0 * h);
            assert!(
                (difference - gradient[j]).abs() <= 1e-4 * (1.0 + gradient[j].abs()),
                "d/dx{j} at {p}: {} against {difference}",
                gradient[j]
            );
        }
    }
}

#[test]
fn bad_frustums_are_refused_with_what_was_wrong() {
    let v = view(DVec3::new(0.0, 0.0, 4.0), DVec3::ZERO, 40.0, 1.0, None);
    let message = |near: f64, far: f64, pixels: [usize; 3], padding: usize| {
        Frustum::new(v, near, far, pixels, padding, 1)
            .unwrap_err()
            .message
    };
    assert!(message(0.0, 1.0, [4, 4, 4], 0).contains("near distance must be positive, got 0"));
    assert!(message(-1.0, 1.0, [4, 4, 4], 0).contains("must be positive, got -1"));
    assert!(message(2.0, 2.0, [4, 4, 4], 0).contains("beyond its near distance 2, got 2"));
    assert!(message(1.0, f64::NAN, [4, 4, 4], 0).contains("got NaN"));
    assert!(message(1.0, 2.0, [4, 0, 4], 0).contains("at least one cell along each axis"));
    assert!(message(1.0, 2.0, [4, 4, 4], 5).contains("padding of 5 pixels"));
    let huge = message(1.0, 2.0, [1 << 20, 1 << 20, 1 << 12], 0);
    assert!(huge.contains("over the memory budget"), "{huge}");
}
