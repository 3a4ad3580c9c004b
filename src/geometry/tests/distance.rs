//! Signed distance to meshes: against the closed-form distance to a box, against the sphere a
//! mesh approximates, and the winding number against its exact (unaccelerated) sum.

use super::*;
use crate::space::Aabb;
use std::f64::consts::PI;

/// Signed distance to the box `centre ± half`, positive inside.
fn box_distance(p: DVec3, centre: DVec3, half: DVec3) -> f64 {
    let q = (p - centre).abs() - half;
    if q.max_element() > 0.0 {
        -q.max(DVec3::ZERO).length()
    } else {
        -q.max_element()
    }
}

/// The winding number summed over every triangle, with no hierarchy.
fn exact_winding(mesh: &Mesh, p: DVec3) -> f64 {
    let total: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| mesh.positions[v as usize] - p);
            let (la, lb, lc) = (a.length(), b.length(), c.length());
            let below = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
            2.0 * a.dot(b.cross(c)).atan2(below)
        })
        .sum();
    total / (4.0 * PI)
}

#[test]
fn box_mesh_gives_the_closed_form_box_distance() {
    let (centre, half) = (DVec3::new(0.2, -0.1, 0.3), DVec3::new(0.5, 0.3, 0.2));
    let field = MeshDistance::new(&box_mesh(centre, half)).unwrap();
    let (mut inside, mut outside) = (0, 0);
    for s in 0..2000 {
        let p = point_in(s, centre, DVec3::splat(1.0));
        let expected = box_distance(p, centre, half);
        let got = field.distance(p);
        assert!(
            (got - expected).abs() < 1e-12,
            "at {p}: {got} vs {expected}"
        );
        if expected > 0.0 {
            inside += 1
        } else {
            outside += 1
        }
    }
    assert!(inside > 50 && outside > 50);
}

#[test]
fn blocks_agree_with_points_whatever_the_order() {
    let (centre, half) = (DVec3::new(0.0, 0.1, -0.2), DVec3::new(0.4, 0.6, 0.3));
    let field = MeshDistance::new(&box_mesh(centre, half)).unwrap();
    let points: Vec<DVec3> = (0..200)
        .map(|s| point_in(s, centre, DVec3::splat(1.0)))
        .collect();
    let xs: Vec<f64> = points.iter().map(|p| p.x).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.y).collect();
    let zs: Vec<f64> = points.iter().map(|p| p.z).collect();
    let mut out = vec![0.0; points.len()];
    let mut narrow = vec![0.0f32; points.len()];
    let mut eval = field.evaluator();
    eval.eval_f64(&xs, &ys, &zs, &mut out);
    eval.eval_f32(&xs, &ys, &zs, &mut narrow);
    // Backwards, so every search starts from a different hint.
    for i in (0..points.len()).rev() {
        let alone = field.distance(points[i]);
        assert_eq!(out[i].to_bits(), alone.to_bits());
        assert_eq!(narrow[i], alone as f32);
        assert!((alone - box_distance(points[i], centre, half)).abs() < 1e-12);
    }
}

#[test]
fn distance_to_a_meshed_ball_is_the_ball_distance_near_its_surface() {
    let (centre, radius) = (DVec3::new(0.03, -0.02, 0.01), 0.6);
    let cells = 32;
    let h = 2.0 / cells as f64;
    let mesh =
        marching_cubes(&ball(centre, radius), &cube_domain(DVec3::ZERO, 1.0, cells)).unwrap();
    let field = MeshDistance::new(&mesh).unwrap();
    let mut worst: f64 = 0.0;
    let mut checked = 0;
    for s in 0..4000 {
        let p = point_in(s, centre, DVec3::splat(radius + 2.0 * h));
        let exact = radius - (p - centre).length();
        if exact.abs() > 2.0 * h {
            continue;
        }
        let got = field.distance(p);
        worst = worst.max((got - exact).abs());
        checked += 1;
    }
    assert!(checked > 500);
    // The mesh lies within 5h²/(8R) of the sphere (see the marching tests), so distances to
    // the two differ by at most about that; h²/R leaves room for the sphere's side.
    assert!(
        worst < h * h / radius,
        "worst difference {worst} with cell {h}"
    );
}

#[test]
fn hierarchical_winding_number_is_close_to_the_exact_sum() {
    let mesh = marching_cubes(&ball(DVec3::ZERO, 0.6), &cube_domain(DVec3::ZERO, 1.0, 20)).unwrap();
    let field = MeshDistance::new(&mesh).unwrap();
    let mut worst: f64 = 0.0;
    for s in 0..300 {
        let p = point_in(s, DVec3::ZERO, DVec3::splat(1.0));
        let exact = exact_winding(&mesh, p);
        // The exact sum itself is 1 or 0 for this closed mesh.
        let inside = p.length() < 0.55;
        let outside = p.length() > 0.65;
        if inside {
            assert!((exact - 1.0).abs() < 1e-9);
        } else if outside {
            assert!(exact.abs() < 1e-9);
        }
        worst = worst.max((field.winding_number(p) - exact).abs());
    }
    // Two expansion terms beyond three radii: the third-order remainder is about (1/3)³ of a
    // node's share, some hundredths in all (0.02 measured), far from the ½ that decides.
    assert!(worst < 0.05, "worst winding error {worst}");
}

#[test]
fn a_missing_triangle_does_not_flip_the_sign() {
    let (centre, half) = (DVec3::ZERO, DVec3::new(0.5, 0.4, 0.3));
    let mut mesh = box_mesh(centre, half);
    mesh.triangles.remove(7);
    assert!(!mesh.is_closed());
    let field = MeshDistance::new(&mesh).unwrap();
    for s in 0..500 {
        let p = point_in(s, centre, DVec3::splat(0.8));
        let expected = box_distance(p, centre, half);
        // Away from the hole's own plane the solid angle of the gap is small.
        if expected.abs() < 0.05 {
            continue;
        }
        let got = field.distance(p);
        assert_eq!(got > 0.0, expected > 0.0, "sign at {p}");
    }
}

#[test]
fn ranges_contain_every_value() {
    let (centre, half) = (DVec3::new(0.1, 0.0, 0.0), DVec3::new(0.3, 0.2, 0.4));
    let field = MeshDistance::new(&box_mesh(centre, half)).unwrap();
    for r in 0..60u64 {
        let lo = point_in(1000 + r, DVec3::ZERO, DVec3::splat(1.5));
        let size = DVec3::new(unit(7 * r), unit(7 * r + 1), unit(7 * r + 2)) * 0.6;
        let region = Aabb::new(lo, lo + size);
        let (low, high) = field.range(&region)[0];
        for s in 0..40 {
            let t = DVec3::new(
                unit(100 * r + 3 * s),
                unit(100 * r + 3 * s + 1),
                unit(100 * r + 3 * s + 2),
            );
            let v = field.distance(region.min + t * size);
            assert!(v >= low && v <= high, "{v} outside [{low}, {high}]");
        }
    }
    let far = Aabb::new(DVec3::splat(5.0), DVec3::splat(6.0));
    let (low, high) = field.range(&far)[0];
    assert!(high < 0.0 && low < high);
    assert_eq!(field.bounds(), None);
    assert_eq!(field.width(), 1);
}

#[test]
fn meshes_without_a_surface_are_failures() {
    assert!(
        MeshDistance::new(&Mesh::default())
            .unwrap_err()
            .message
            .contains("no triangles")
    );
    let mut mesh = box_mesh(DVec3::ZERO, DVec3::ONE);
    mesh.triangles[4][1] = 8;
    assert!(MeshDistance::new(&mesh).is_err());
}
