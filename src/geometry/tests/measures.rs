//! Volume, area, closedness and Euler characteristic of meshes whose answers are known.

use super::*;

#[test]
fn box_measures_match_closed_forms() {
    let half = DVec3::new(0.5, 0.25, 1.5);
    // Far from the origin, where the reference-point volume keeps its precision.
    let mesh = box_mesh(DVec3::new(1e5, -2e5, 3e4), half);
    let size = 2.0 * half;
    assert!((mesh.volume() - size.x * size.y * size.z).abs() < 1e-9);
    let area = 2.0 * (size.x * size.y + size.y * size.z + size.z * size.x);
    assert!((mesh.area() - area).abs() < 1e-9);
    assert!(mesh.is_closed());
    assert_eq!(mesh.euler_characteristic(), 2);
    let b = mesh.bounds().unwrap();
    assert_eq!(b.min, DVec3::new(1e5, -2e5, 3e4) - half);
    assert_eq!(b.max, DVec3::new(1e5, -2e5, 3e4) + half);
}

#[test]
fn inward_orientation_gives_negative_volume() {
    let mut mesh = box_mesh(DVec3::ZERO, DVec3::splat(1.0));
    for t in &mut mesh.triangles {
        t.swap(1, 2);
    }
    assert!((mesh.volume() + 8.0).abs() < 1e-12);
    // Reversed everywhere is still closed: each edge is still used once each way.
    assert!(mesh.is_closed());
}

#[test]
fn open_or_inconsistent_meshes_are_not_closed() {
    let full = box_mesh(DVec3::ZERO, DVec3::ONE);
    let mut open = full.clone();
    open.triangles.pop();
    assert!(!open.is_closed());
    // A box without one face is a disk: V − E + F = 8 − 17 + 10 = 1.
    let mut disk = full.clone();
    disk.triangles.truncate(10);
    assert_eq!(disk.euler_characteristic(), 1);
    let mut flipped = full.clone();
    flipped.triangles[3].swap(0, 1);
    assert!(!flipped.is_closed());
    let mut doubled = full.clone();
    doubled.triangles.extend(full.triangles.iter().copied());
    assert!(!doubled.is_closed());
    let mut degenerate = full;
    degenerate.triangles[0] = [0, 0, 1];
    assert!(!degenerate.is_closed());
}

#[test]
fn invalid_meshes_are_reported_not_trusted() {
    let mut mesh = box_mesh(DVec3::ZERO, DVec3::ONE);
    mesh.triangles.push([0, 1, 99]);
    assert!(mesh.validate().unwrap_err().message.contains("vertex 99"));
    // Measures skip what they cannot read instead of panicking.
    assert!((mesh.volume() - 8.0).abs() < 1e-12);
    assert!(!mesh.is_closed());
    mesh.triangles.pop();
    mesh.positions[3].y = f64::NAN;
    assert!(mesh.validate().unwrap_err().message.contains("not finite"));
    assert_eq!(Mesh::default().bounds(), None);
    assert_eq!(Mesh::default().volume(), 0.0);
}
