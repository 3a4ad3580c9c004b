//! Tests of the geometry module: mesh measures against closed forms (`measures`), marching
//! cubes on shapes with known volume and topology (`marching`), signed distance against closed
//! forms and brute force (`distance`), components (`components`), file round trips and exact
//! parses (`files`), damaged files (`robustness`), attributes in files and on generated
//! shapes (`attributes`), and cuts by several knives (`knives`).

mod attributes;
mod components;
mod distance;
mod files;
mod knives;
mod marching;
mod measures;
mod robustness;

use super::*;
use crate::space::domain::Domain;
use crate::space::{FieldSampler, FnField};
use glam::DVec3;

/// The level set of a ball: its signed distance, positive inside.
fn ball(centre: DVec3, radius: f64) -> impl FieldSampler {
    FnField::new(1, move |p: DVec3, out: &mut [f64]| {
        out[0] = radius - (p - centre).length();
    })
}

/// The cube `centre ± half` with `cells` cells along each side.
fn cube_domain(centre: DVec3, half: f64, cells: usize) -> Domain {
    let cell = 2.0 * half / cells as f64;
    Domain::with_cells(
        centre - DVec3::splat(half),
        DVec3::splat(2.0 * half),
        DVec3::ZERO,
        cell,
        cell,
    )
    .unwrap()
}

/// The closed box `centre ± half` as twelve outward triangles.
fn box_mesh(centre: DVec3, half: DVec3) -> Mesh {
    let positions = (0..8)
        .map(|n| {
            let sign = DVec3::new(
                if n & 1 == 1 { 1.0 } else { -1.0 },
                if n & 2 == 2 { 1.0 } else { -1.0 },
                if n & 4 == 4 { 1.0 } else { -1.0 },
            );
            centre + sign * half
        })
        .collect();
    // Each face as a quad counter-clockwise from outside, split along a diagonal.
    let quads: [[u32; 4]; 6] = [
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
    ];
    let triangles = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    Mesh::new(positions, triangles)
}

/// A reproducible number in [0, 1) from a counter.
fn unit(seed: u64) -> f64 {
    let mut x = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ 0xd1b5_4a32_d192_ed03;
    x ^= x >> 31;
    x = x.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x ^= x >> 29;
    x = x.wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^= x >> 32;
    (x >> 11) as f64 / (1u64 << 53) as f64
}

/// A reproducible point in the box `centre ± half`.
fn point_in(seed: u64, centre: DVec3, half: DVec3) -> DVec3 {
    let r = DVec3::new(unit(3 * seed), unit(3 * seed + 1), unit(3 * seed + 2));
    centre + (2.0 * r - DVec3::ONE) * half
}

/// Asserts that `mesh` is a closed 2-manifold: closed (every edge twice, opposite ways) and
/// around every vertex the triangles form a single fan.
fn assert_manifold(mesh: &Mesh) {
    assert!(mesh.is_closed(), "mesh is not closed");
    // For each vertex, the "next" map of its star: in triangle (v, a, b), a is followed by b.
    let mut star: Vec<Vec<(u32, u32)>> = vec![Vec::new(); mesh.positions.len()];
    for t in &mesh.triangles {
        for k in 0..3 {
            star[t[k] as usize].push((t[(k + 1) % 3], t[(k + 2) % 3]));
        }
    }
    for (v, links) in star.iter().enumerate() {
        if links.is_empty() {
            continue;
        }
        let start = links[0].0;
        let mut at = start;
        let mut steps = 0;
        loop {
            let next = links.iter().find(|l| l.0 == at).map(|l| l.1);
            at = next.unwrap_or_else(|| panic!("vertex {v}: star is not a fan"));
            steps += 1;
            if at == start || steps > links.len() {
                break;
            }
        }
        assert_eq!(steps, links.len(), "vertex {v}: star is not one disk");
    }
}

/// Valid files in every supported form, small enough to mutate thousands of times: a mesh as
/// OBJ, ASCII PLY, and binary PLY in both byte orders.
fn files_for_mutation() -> Vec<(&'static str, Vec<u8>)> {
    let mesh = marching_cubes(&ball(DVec3::ZERO, 0.5), &cube_domain(DVec3::ZERO, 1.0, 4)).unwrap();
    let mut ascii = String::from("ply\nformat ascii 1.0\ncomment mutation seed\n");
    ascii += &format!(
        "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        mesh.positions.len()
    );
    ascii += &format!(
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.triangles.len()
    );
    for p in &mesh.positions {
        ascii += &format!("{} {} {}\n", p.x, p.y, p.z);
    }
    for t in &mesh.triangles {
        ascii += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
    }
    let little = write_ply(&mesh).unwrap();
    let mut big = little.clone();
    let header = big.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let swapped = String::from_utf8_lossy(&big[..header]).replace("little", "big");
    let mut body = big.split_off(header);
    for chunk in body[..mesh.positions.len() * 24].chunks_mut(8) {
        chunk.reverse();
    }
    for face in body[mesh.positions.len() * 24..].chunks_mut(13) {
        for index in face[1..].chunks_mut(4) {
            index.reverse();
        }
    }
    let mut big = swapped.into_bytes();
    big.extend_from_slice(&body);
    vec![
        ("mesh.obj", write_obj(&mesh).unwrap()),
        ("ascii.ply", ascii.into_bytes()),
        ("little.ply", little),
        ("big.ply", big),
    ]
}
