//! Marching cubes on level sets with known volume and topology.
//!
//! Volume bound used throughout: every vertex lies on the surface up to the error of linear
//! interpolation, h²/(8ρ) for a distance function whose surface has smallest radius of
//! curvature ρ, and every triangle fits in one cell, so within a disk of radius h (Jung's
//! theorem for a diameter of at most √3·h), whose sag below a sphere of radius ρ is at most
//! h²/(2ρ). So the mesh lies within 5h²/(8ρ) of the surface and the volume differs by at most
//! the area times that.

use super::*;
use crate::space::{Aabb, BlockEval};
use std::f64::consts::PI;
use std::sync::atomic::{AtomicUsize, Ordering};

fn volume_bound(area: f64, cell: f64, curvature_radius: f64) -> f64 {
    area * 5.0 * cell * cell / (8.0 * curvature_radius)
}

#[test]
fn ball_is_a_closed_sphere_with_the_right_volume_converging() {
    let (centre, radius) = (DVec3::new(0.05, -0.03, 0.02), 0.7f64);
    let exact = 4.0 / 3.0 * PI * radius.powi(3);
    let mut errors = Vec::new();
    for cells in [24, 48] {
        let h = 2.0 / cells as f64;
        let mesh =
            marching_cubes(&ball(centre, radius), &cube_domain(DVec3::ZERO, 1.0, cells)).unwrap();
        assert_manifold(&mesh);
        assert_eq!(mesh.euler_characteristic(), 2);
        assert_eq!(pieces(&mesh).len(), 1);
        let error = (mesh.volume() - exact).abs();
        let bound = volume_bound(4.0 * PI * radius * radius, h, radius);
        assert!(
            error < bound,
            "{cells} cells: volume error {error} over bound {bound}"
        );
        for p in &mesh.positions {
            let off = ((*p - centre).length() - radius).abs();
            assert!(
                off < h * h / (8.0 * (radius - h)) + 1e-6,
                "vertex {p} is {off} off the sphere"
            );
        }
        // Crossings are shared between cubes: no two vertices at one position.
        let mut keys: Vec<[u64; 3]> = mesh
            .positions
            .iter()
            .map(|p| p.to_array().map(f64::to_bits))
            .collect();
        keys.sort_unstable();
        keys.dedup();
        assert_eq!(keys.len(), mesh.positions.len());
        errors.push(error);
    }
    // Second order: halving the cell size should cut the error about fourfold.
    assert!(
        errors[1] < errors[0] / 3.0,
        "errors {errors:?} do not converge"
    );
}

#[test]
fn torus_has_euler_characteristic_zero() {
    let (major, minor) = (0.55, 0.25);
    let torus = FnField::new(1, move |p: DVec3, out: &mut [f64]| {
        let ring = (p.x * p.x + p.y * p.y).sqrt() - major;
        out[0] = minor - (ring * ring + p.z * p.z).sqrt();
    });
    let cells = 48;
    let mesh = marching_cubes(&torus, &cube_domain(DVec3::ZERO, 1.0, cells)).unwrap();
    assert_manifold(&mesh);
    assert_eq!(mesh.euler_characteristic(), 0);
    let exact = 2.0 * PI * PI * major * minor * minor;
    let bound = volume_bound(4.0 * PI * PI * major * minor, 2.0 / cells as f64, minor);
    let error = (mesh.volume() - exact).abs();
    assert!(error < bound, "volume error {error} over bound {bound}");
}

#[test]
fn two_balls_make_two_pieces_with_their_volumes() {
    let (a, ra) = (DVec3::new(-0.45, 0.0, 0.0), 0.4f64);
    let (b, rb) = (DVec3::new(0.55, 0.1, 0.0), 0.3f64);
    let both = FnField::new(1, move |p: DVec3, out: &mut [f64]| {
        out[0] = (ra - (p - a).length()).max(rb - (p - b).length());
    });
    let cells = 40;
    let h = 2.0 / cells as f64;
    let mesh = marching_cubes(&both, &cube_domain(DVec3::ZERO, 1.0, cells)).unwrap();
    assert_manifold(&mesh);
    let parts = pieces(&mesh);
    assert_eq!(parts.len(), 2);
    let mut volumes: Vec<(f64, f64, f64)> = parts
        .iter()
        .map(|m| {
            (
                m.bounds().unwrap().center().x,
                m.volume(),
                m.euler_characteristic() as f64,
            )
        })
        .collect();
    volumes.sort_by(|x, y| x.0.total_cmp(&y.0));
    for ((_, volume, chi), radius) in volumes.iter().zip([ra, rb]) {
        let exact = 4.0 / 3.0 * PI * radius.powi(3);
        let bound = volume_bound(4.0 * PI * radius * radius, h, radius);
        assert!((volume - exact).abs() < bound, "volume {volume} vs {exact}");
        assert_eq!(*chi, 2.0);
    }
    let total: usize = parts.iter().map(|m| m.triangles.len()).sum();
    assert_eq!(total, mesh.triangles.len());
}

#[test]
fn solid_cut_by_the_domain_is_capped() {
    // Inside below z = 0.3: the domain caps it into the box [-1, 1]² × [-1, 0.3], with edges
    // along the domain's faces bevelled by at most a cell (the outermost samples are half a
    // cell inside the faces).
    let half_space = FnField::new(1, |p: DVec3, out: &mut [f64]| out[0] = 0.3 - p.z);
    let cells = 24;
    let h = 2.0 / cells as f64;
    let mesh = marching_cubes(&half_space, &cube_domain(DVec3::ZERO, 1.0, cells)).unwrap();
    assert_manifold(&mesh);
    assert_eq!(mesh.euler_characteristic(), 2);
    let b = mesh.bounds().unwrap();
    assert!((b.min - DVec3::splat(-1.0)).abs().max_element() < 1e-12);
    assert!((b.max - DVec3::new(1.0, 1.0, 0.3)).abs().max_element() < 1e-6);
    let box_volume = 2.0 * 2.0 * 1.3;
    let edges = 4.0 * 2.0 + 4.0 * 2.0 + 4.0 * 1.3;
    let bevel = edges * h * h / 4.0;
    let volume = mesh.volume();
    assert!(
        volume <= box_volume + 1e-9 && volume > box_volume - bevel,
        "volume {volume}"
    );
}

#[test]
fn rotated_domain_gives_world_positions() {
    let orientation = DVec3::new(0.3, -0.5, 0.8);
    let (centre, radius) = (DVec3::new(2.0, -1.0, 0.5), 0.6f64);
    let cells = 32;
    let rotation = Domain::new(DVec3::ZERO, DVec3::ONE, orientation)
        .unwrap()
        .rotation;
    let origin = centre - rotation * DVec3::ONE;
    let domain = Domain::with_cells(
        origin,
        DVec3::splat(2.0),
        orientation,
        2.0 / 32.0,
        2.0 / 32.0,
    )
    .unwrap();
    let h = 2.0 / cells as f64;
    let mesh = marching_cubes(&ball(centre, radius), &domain).unwrap();
    assert_manifold(&mesh);
    for p in &mesh.positions {
        assert!(((*p - centre).length() - radius).abs() < h * h / (8.0 * (radius - h)) + 1e-6);
    }
    let exact = 4.0 / 3.0 * PI * radius.powi(3);
    let bound = volume_bound(4.0 * PI * radius * radius, h, radius);
    assert!((mesh.volume() - exact).abs() < bound);
}

#[test]
fn output_does_not_depend_on_the_thread_count() {
    let wobbly = FnField::new(1, |p: DVec3, out: &mut [f64]| {
        out[0] = 0.6 - p.length() + 0.1 * (7.0 * p.x).sin() * (5.0 * p.y).cos() * (6.0 * p.z).sin();
    });
    let domain = cube_domain(DVec3::ZERO, 1.0, 40);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| marching_cubes(&wobbly, &domain).unwrap())
    };
    let one = run(1);
    assert_manifold(&one);
    assert_eq!(one, run(2));
}

/// Random values at every sample: nearly every face ambiguous, every case exercised. Besides
/// being a closed manifold, the mesh must wind once around every inside sample and not at all
/// around outside ones — which also checks that it faces outward everywhere.
#[test]
fn random_samples_still_give_a_closed_manifold_around_the_inside() {
    for seed in 0..6u64 {
        let value = move |p: DVec3| {
            let bits =
                p.x.to_bits() ^ p.y.to_bits().rotate_left(21) ^ p.z.to_bits().rotate_left(42);
            unit(bits ^ seed) - 0.5
        };
        let noise = FnField::new(1, move |p: DVec3, out: &mut [f64]| out[0] = value(p));
        let cells = 12;
        let domain = cube_domain(DVec3::ZERO, 1.0, cells);
        let mesh = marching_cubes(&noise, &domain).unwrap();
        assert_manifold(&mesh);
        let distance = MeshDistance::new(&mesh).unwrap();
        for k in 0..cells {
            for j in 0..cells {
                for i in 0..cells {
                    let p = domain.cell_center(i, j, k);
                    let expected = if value(p) > 0.0 { 1.0 } else { 0.0 };
                    let w = distance.winding_number(p);
                    assert!(
                        (w - expected).abs() < 0.1,
                        "winding {w} at {p}, value {}",
                        value(p)
                    );
                }
            }
        }
    }
}

#[test]
fn exact_zeros_at_samples_do_not_make_coincident_vertices() {
    // The plane x = 0 through a column of sample centres (cells of 0.1 from -1.05).
    let plane = FnField::new(1, |p: DVec3, out: &mut [f64]| out[0] = -p.x);
    let domain = Domain::with_cells(
        DVec3::splat(-1.05),
        DVec3::splat(2.1),
        DVec3::ZERO,
        0.1,
        0.1,
    )
    .unwrap();
    let mesh = marching_cubes(&plane, &domain).unwrap();
    assert_manifold(&mesh);
    let mut keys: Vec<[u64; 3]> = mesh
        .positions
        .iter()
        .map(|p| p.to_array().map(f64::to_bits))
        .collect();
    keys.sort_unstable();
    keys.dedup();
    assert_eq!(keys.len(), mesh.positions.len());
    assert!(mesh.triangles.iter().all(|t| {
        let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
        (b - a).cross(c - a).length() > 0.0
    }));
}

/// A ball whose level set reports an exact interval range, counting the points it evaluates.
struct CountingBall {
    centre: DVec3,
    radius: f64,
    with_range: bool,
    evaluated: AtomicUsize,
}

struct CountingEval<'a>(&'a CountingBall);

impl BlockEval for CountingEval<'_> {
    fn eval_f32(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f32]) {
        self.0.evaluated.fetch_add(xs.len(), Ordering::Relaxed);
        for i in 0..xs.len() {
            out[i] =
                (self.0.radius - (DVec3::new(xs[i], ys[i], zs[i]) - self.0.centre).length()) as f32;
        }
    }
    fn eval_f64(&mut self, _: &[f64], _: &[f64], _: &[f64], _: &mut [f64]) {
        unreachable!("marching cubes samples in f32")
    }
}

impl FieldSampler for CountingBall {
    fn width(&self) -> usize {
        1
    }
    fn evaluator(&self) -> Box<dyn BlockEval + '_> {
        Box::new(CountingEval(self))
    }
    fn bounds(&self) -> Option<Aabb> {
        None
    }
    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        if !self.with_range {
            return vec![(f64::NEG_INFINITY, f64::INFINITY)];
        }
        let nearest = (self.centre.clamp(region.min, region.max) - self.centre).length();
        let far = (region.min - self.centre)
            .abs()
            .max((region.max - self.centre).abs())
            .length();
        vec![(self.radius - far, self.radius - nearest)]
    }
}

#[test]
fn interval_ranges_skip_samples_without_changing_the_mesh() {
    let make = |with_range| CountingBall {
        centre: DVec3::new(0.1, 0.0, -0.05),
        radius: 0.5,
        with_range,
        evaluated: AtomicUsize::new(0),
    };
    let domain = cube_domain(DVec3::ZERO, 1.0, 48);
    let (plain, culled) = (make(false), make(true));
    let a = marching_cubes(&plain, &domain).unwrap();
    let b = marching_cubes(&culled, &domain).unwrap();
    assert_eq!(a, b);
    let (all, some) = (plain.evaluated.into_inner(), culled.evaluated.into_inner());
    assert!(all >= 48 * 48 * 48);
    assert!(some * 3 < all, "evaluated {some} of {all}");
}

#[test]
fn bad_inputs_are_failures() {
    let domain = cube_domain(DVec3::ZERO, 1.0, 8);
    let vector = FnField::new(3, |_: DVec3, out: &mut [f64]| out.fill(1.0));
    assert!(
        marching_cubes(&vector, &domain)
            .unwrap_err()
            .message
            .contains("3 components")
    );
    let nan = FnField::new(1, |p: DVec3, out: &mut [f64]| {
        out[0] = if p.x > 0.5 { f64::NAN } else { 1.0 }
    });
    assert!(
        marching_cubes(&nan, &domain)
            .unwrap_err()
            .message
            .contains("NaN")
    );
    let no_cells = Domain::new(DVec3::ZERO, DVec3::ONE, DVec3::ZERO).unwrap();
    assert!(marching_cubes(&ball(DVec3::ZERO, 0.5), &no_cells).is_err());
    // Nothing inside, and everything inside: empty, and the domain's own box.
    let empty = marching_cubes(&ball(DVec3::splat(5.0), 0.5), &domain).unwrap();
    assert!(empty.triangles.is_empty() && empty.positions.is_empty());
    let full = marching_cubes(&ball(DVec3::ZERO, 50.0), &domain).unwrap();
    assert_manifold(&full);
    assert_eq!(full.euler_characteristic(), 2);
}

#[test]
fn default_domain_covers_the_bounds_with_a_margin() {
    let bounded =
        FnField::new(1, |p: DVec3, out: &mut [f64]| out[0] = 0.5 - p.length()).with_bounds(
            Aabb::new(DVec3::new(-0.5, -0.5, -0.5), DVec3::new(0.5, 0.5, 0.5)),
        );
    let domain = default_mesh_domain(&bounded).unwrap();
    let cells = domain.resolution.unwrap();
    assert_eq!(cells, [DEFAULT_MESH_CELLS; 3]);
    let cell = 1.0 / (DEFAULT_MESH_CELLS - 4) as f64;
    assert!((domain.origin - DVec3::splat(-0.5 - 2.0 * cell)).length() < 1e-12);
    let unbounded = FnField::new(1, |_: DVec3, out: &mut [f64]| out[0] = 1.0);
    let failure = default_mesh_domain(&unbounded).unwrap_err();
    assert!(failure.help.unwrap().contains("ls2shape(ls, domain)"));
}
