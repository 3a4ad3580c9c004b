//! Connected components of a mesh (`pieces(shape)`).
//!
//! Two triangles belong to the same piece when they share a vertex, where vertices at exactly
//! the same position count as one (files often repeat a vertex per face, and such a mesh is
//! still one piece). The one key decision: the pieces come out in the order of their first
//! triangle in the input, and each keeps its own vertices in their input order, so the result
//! depends on nothing but the mesh — and a mesh that is one piece comes back unchanged apart
//! from dropping unused vertices.

use super::Mesh;
use glam::DVec3;
use std::collections::HashMap;

/// The connected components of `mesh`, ordered by their smallest triangle index, each with
/// vertex indices renumbered from zero. Triangles that name a missing vertex are left out.
pub fn pieces(mesh: &Mesh) -> Vec<Mesh> {
    let n = mesh.positions.len();
    let valid = |t: &[u32; 3]| t.iter().all(|&v| (v as usize) < n);

    // Each vertex starts in the set of the first vertex at its position.
    let mut sets = DisjointSets::new(n);
    for (i, first) in welded(&mesh.positions).into_iter().enumerate() {
        sets.join(first, i as u32);
    }
    for t in mesh.triangles.iter().filter(|t| valid(t)) {
        sets.join(t[0], t[1]);
        sets.join(t[1], t[2]);
    }

    // Number the pieces by first appearance along the triangle list.
    let mut piece_of_root: HashMap<u32, usize> = HashMap::new();
    let mut triangle_piece = Vec::with_capacity(mesh.triangles.len());
    for t in &mesh.triangles {
        if !valid(t) {
            triangle_piece.push(usize::MAX);
            continue;
        }
        let root = sets.find(t[0]);
        let next = piece_of_root.len();
        triangle_piece.push(*piece_of_root.entry(root).or_insert(next));
    }
    let count = piece_of_root.len();

    // Each piece keeps the vertices its triangles use, in their original order.
    let mut vertex_piece = vec![usize::MAX; n];
    for (t, &piece) in mesh.triangles.iter().zip(&triangle_piece) {
        if piece != usize::MAX {
            for &v in t {
                vertex_piece[v as usize] = piece;
            }
        }
    }
    let mut out = vec![Mesh::default(); count];
    let mut renumbered = vec![0u32; n];
    for (v, &piece) in vertex_piece.iter().enumerate() {
        if piece != usize::MAX {
            renumbered[v] = out[piece].positions.len() as u32;
            out[piece].positions.push(mesh.positions[v]);
        }
    }
    for (t, &piece) in mesh.triangles.iter().zip(&triangle_piece) {
        if piece != usize::MAX {
            out[piece].triangles.push(t.map(|v| renumbered[v as usize]));
        }
    }
    for (name, values) in &mesh.attributes {
        for (index, part) in out.iter_mut().enumerate() {
            let kept = (0..n).filter(|&v| vertex_piece[v] == index);
            part.attributes.insert(name.clone(), values.gather(kept));
        }
    }
    out
}

/// The pieces of `mesh` whose enclosed volume is at least `min_volume` (slivers that a grid
/// cannot resolve are dropped), and the number and total volume of those dropped.
pub fn pieces_above(mesh: &Mesh, min_volume: f64) -> (Vec<Mesh>, usize, f64) {
    let (mut dropped, mut dropped_volume) = (0, 0.0);
    let kept = pieces(mesh)
        .into_iter()
        .filter(|piece| {
            let volume = piece.volume().abs();
            let keep = volume >= min_volume;
            if !keep {
                dropped += 1;
                dropped_volume += volume;
            }
            keep
        })
        .collect();
    (kept, dropped, dropped_volume)
}

/// For each vertex, the first vertex at exactly the same position (+0 and −0 being equal).
pub(super) fn welded(positions: &[DVec3]) -> Vec<u32> {
    let mut first_at: HashMap<[u64; 3], u32> = HashMap::with_capacity(positions.len());
    positions
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let key = [p.x, p.y, p.z].map(|c| (c + 0.0).to_bits());
            *first_at.entry(key).or_insert(i as u32)
        })
        .collect()
}

/// Union–find with path halving and union by size.
struct DisjointSets {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl DisjointSets {
    fn new(n: usize) -> DisjointSets {
        DisjointSets {
            parent: (0..n as u32).collect(),
            size: vec![1; n],
        }
    }

    fn find(&mut self, mut v: u32) -> u32 {
        while self.parent[v as usize] != v {
            let grandparent = self.parent[self.parent[v as usize] as usize];
            self.parent[v as usize] = grandparent;
            v = grandparent;
        }
        v
    }

    fn join(&mut self, a: u32, b: u32) {
        let (a, b) = (self.find(a), self.find(b));
        if a == b {
            return;
        }
        let (big, small) = if self.size[a as usize] >= self.size[b as usize] {
            (a, b)
        } else {
            (b, a)
        };
        self.parent[small as usize] = big;
        self.size[big as usize] += self.size[small as usize];
    }
}
