//! Connected components: welding, order, renumbering.

use super::*;

#[test]
fn separate_boxes_come_apart_in_triangle_order() {
    let a = box_mesh(DVec3::new(3.0, 0.0, 0.0), DVec3::splat(0.5));
    let b = box_mesh(DVec3::ZERO, DVec3::new(1.0, 0.5, 0.25));
    // Interleave: b's first triangle comes before a's, so b is the first piece.
    let mut mesh = Mesh::default();
    mesh.positions.extend(&a.positions);
    mesh.positions.extend(&b.positions);
    for (ta, tb) in a.triangles.iter().zip(&b.triangles) {
        mesh.triangles.push(tb.map(|v| v + 8));
        mesh.triangles.push(*ta);
    }
    let parts = pieces(&mesh);
    assert_eq!(parts.len(), 2);
    assert_eq!(parts[0], b);
    assert_eq!(parts[1], a);
    assert!((parts[0].volume() - 1.0).abs() < 1e-12);
    assert!((parts[1].volume() - 1.0).abs() < 1e-12);
}

#[test]
fn repeated_vertices_are_welded_into_one_piece() {
    // A box as a triangle soup: three fresh vertices per triangle.
    let solid = box_mesh(DVec3::ZERO, DVec3::ONE);
    let mut soup = Mesh::default();
    for t in &solid.triangles {
        let base = soup.positions.len() as u32;
        soup.positions
            .extend(t.map(|v| solid.positions[v as usize]));
        soup.triangles.push([base, base + 1, base + 2]);
    }
    // -0.0 and +0.0 are one position too.
    soup.positions.push(DVec3::new(0.0, 0.0, 0.0));
    soup.positions.push(DVec3::new(-0.0, 0.0, 0.0));
    soup.positions.push(DVec3::new(-1.0, -1.0, -1.0));
    soup.triangles.push([36, 38, 0]);
    soup.triangles.push([37, 2, 1]);
    let parts = pieces(&soup);
    assert_eq!(parts.len(), 1);
    assert_eq!(parts[0].triangles.len(), soup.triangles.len());
    assert_eq!(parts[0].positions.len(), soup.positions.len());
}

#[test]
fn unused_and_invalid_parts_are_dropped() {
    let mut mesh = box_mesh(DVec3::ZERO, DVec3::ONE);
    mesh.positions.insert(0, DVec3::splat(9.0));
    for t in &mut mesh.triangles {
        *t = t.map(|v| v + 1);
    }
    mesh.triangles.push([0, 1, 100]);
    let parts = pieces(&mesh);
    assert_eq!(parts.len(), 1);
    assert_eq!(parts[0], box_mesh(DVec3::ZERO, DVec3::ONE));
    assert!(pieces(&Mesh::default()).is_empty());
}
