//! The marching-cubes case table, derived rather than typed in.
//!
//! A cube's case is which of its eight corners are inside (positive) plus, for each face whose
//! corners alternate in sign, whether the two inside corners of that face are joined across it.
//! From that the table builder draws, on every face, the segments between the edge crossings
//! (one per face, or two on an ambiguous face), orients each so that the inside lies to its
//! right seen from outside the cube, chains the segments into closed loops, and triangulates
//! each loop. The one key decision: a face's segments depend only on that face's own corners
//! and decision, so the two cubes that share a face draw the same segments in opposite
//! directions, which is what makes the extracted surface watertight and consistently oriented.
//! A loop is triangulated as a fan only if no fan diagonal joins two crossings on a common face
//! (a neighbouring cube could draw the same pair, and the edge would then belong to four
//! triangles); otherwise the loop gets a vertex of its own at its centre. Every cube surface
//! piece is therefore a disk whose boundary is made of face segments, and the union over all
//! cubes is a closed 2-manifold.

use std::sync::OnceLock;

/// The most triangles one cube can produce (twelve crossings, loops fanned about centres).
pub const MAX_TRIANGLES: usize = 12;
/// The most loops in one cube (each has at least three of the twelve crossings).
pub const MAX_LOOPS: usize = 4;
/// Vertex codes below this are cube edges; `CENTRE + l` is the centre of loop `l`.
pub const CENTRE: u8 = 12;

/// Corner `n` of the cube sits at offset `(n & 1, n >> 1 & 1, n >> 2 & 1)`.
pub fn corner_offset(n: usize) -> [usize; 3] {
    [n & 1, (n >> 1) & 1, (n >> 2) & 1]
}

/// Edge `e` runs along axis `e / 4` from corner `EDGE_START[e]`.
pub const EDGE_START: [usize; 12] = [0, 2, 4, 6, 0, 1, 4, 5, 0, 1, 2, 3];

pub fn edge_axis(e: usize) -> usize {
    e / 4
}

pub fn edge_end(e: usize) -> usize {
    EDGE_START[e] | 1 << edge_axis(e)
}

/// The corners of face `f` (perpendicular to axis `f / 2`, on side `f % 2`) in cyclic order.
pub fn face_corners(f: usize) -> [usize; 4] {
    let (a, side) = (f / 2, f % 2);
    let (u, v) = ((a + 1) % 3, (a + 2) % 3);
    let at = |iu: usize, iv: usize| side << a | iu << u | iv << v;
    [at(0, 0), at(1, 0), at(1, 1), at(0, 1)]
}

/// The edge joining two corners that differ in one bit.
fn edge_between(c0: usize, c1: usize) -> usize {
    let axis = (c0 ^ c1).trailing_zeros() as usize;
    let start = c0.min(c1);
    (0..12)
        .find(|&e| edge_axis(e) == axis && EDGE_START[e] == start)
        .unwrap_or(0)
}

/// Bit mask of the two faces that contain edge `e`.
fn edge_faces(e: usize) -> u8 {
    let start = corner_offset(EDGE_START[e]);
    let mut mask = 0u8;
    for (b, &bit) in start.iter().enumerate() {
        if b != edge_axis(e) {
            mask |= 1 << (2 * b + bit);
        }
    }
    mask
}

/// Does face `f` with these inside flags have alternating corners?
pub fn face_is_ambiguous(config: usize, f: usize) -> bool {
    let c = face_corners(f);
    let inside = |k: usize| config >> c[k] & 1 == 1;
    inside(0) == inside(2) && inside(1) == inside(3) && inside(0) != inside(1)
}

/// One cube case: triangles as vertex codes, and for each loop that needs a centre vertex,
/// the edges whose crossings it averages.
#[derive(Clone, Copy, Debug, Default)]
pub struct Case {
    pub triangles: [[u8; 3]; MAX_TRIANGLES],
    pub triangle_count: u8,
    pub centres: [u16; MAX_LOOPS],
    pub centre_count: u8,
}

impl Case {
    pub fn triangles(&self) -> &[[u8; 3]] {
        &self.triangles[..self.triangle_count as usize]
    }

    pub fn centres(&self) -> &[u16] {
        &self.centres[..self.centre_count as usize]
    }
}

/// The case for `config` (bit `n` set when corner `n` is inside) and `joined` (bit `f` set
/// when the inside corners of ambiguous face `f` are joined; ignored on other faces).
pub fn case(config: u8, joined: u8) -> &'static Case {
    static TABLE: OnceLock<Vec<Case>> = OnceLock::new();
    let table = TABLE.get_or_init(|| {
        (0..1usize << 14)
            .map(|index| build_case(index & 0xff, index >> 8))
            .collect()
    });
    &table[config as usize | (joined as usize & 0x3f) << 8]
}

fn midpoint(e: usize) -> [f64; 3] {
    let a = corner_offset(EDGE_START[e]);
    let b = corner_offset(edge_end(e));
    [0, 1, 2].map(|i| 0.5 * (a[i] + b[i]) as f64)
}

fn build_case(config: usize, joined: usize) -> Case {
    // next[e] is the crossing that follows crossing e along its loop.
    let mut next = [u8::MAX; 12];
    for f in 0..6 {
        for (from, to) in face_segments(config, joined, f) {
            next[from] = to as u8;
        }
    }
    let mut case = Case::default();
    let mut visited = [false; 12];
    for first in 0..12 {
        if next[first] == u8::MAX || visited[first] {
            continue;
        }
        let mut ring = Vec::with_capacity(12);
        let mut e = first;
        while !visited[e] {
            visited[e] = true;
            ring.push(e as u8);
            e = next[e] as usize;
        }
        triangulate(&ring, &mut case);
    }
    case
}

/// The oriented segments `(from edge, to edge)` on face `f`.
fn face_segments(config: usize, joined: usize, f: usize) -> Vec<(usize, usize)> {
    let corners = face_corners(f);
    let inside = |k: usize| config >> corners[k % 4] & 1 == 1;
    // Side edge k joins corner k to corner k + 1.
    let side_edge = |k: usize| edge_between(corners[k % 4], corners[(k + 1) % 4]);
    let crossing: Vec<usize> = (0..4).filter(|&k| inside(k) != inside(k + 1)).collect();
    // Each segment is the pair of side edges around the corners it cuts off, with one of
    // those corners to tell its side.
    let mut cuts: Vec<(usize, usize, usize)> = Vec::new();
    match crossing.len() {
        2 => cuts.push((crossing[0], crossing[1], crossing[0] + 1)),
        4 => {
            let join_inside = joined >> f & 1 == 1;
            for k in 0..4 {
                // Cut off the inside corners unless they are joined, else the outside ones.
                if inside(k) != join_inside {
                    cuts.push(((k + 3) % 4, k, k));
                }
            }
        }
        _ => {}
    }
    let axis = f / 2;
    let mut normal = [0.0; 3];
    normal[axis] = if f % 2 == 1 { 1.0 } else { -1.0 };
    cuts.into_iter()
        .map(|(k0, k1, corner)| {
            let (e0, e1) = (side_edge(k0), side_edge(k1));
            let (p, q) = (midpoint(e0), midpoint(e1));
            let c = corner_offset(corners[corner % 4]).map(|x| x as f64);
            let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
            let right = cross(d, normal);
            let side: f64 = (0..3)
                .map(|i| right[i] * (c[i] - 0.5 * (p[i] + q[i])))
                .sum();
            // Inside corners lie to the right of the segment (seen from outside the cube).
            if (side > 0.0) == inside(corner) {
                (e0, e1)
            } else {
                (e1, e0)
            }
        })
        .collect()
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn triangulate(ring: &[u8], case: &mut Case) {
    let k = ring.len();
    let mut push = |t: [u8; 3]| {
        case.triangles[case.triangle_count as usize] = t;
        case.triangle_count += 1;
    };
    let share_face = |a: u8, b: u8| edge_faces(a as usize) & edge_faces(b as usize) != 0;
    let fan_start = (0..k).find(|&s| (2..k - 1).all(|i| !share_face(ring[s], ring[(s + i) % k])));
    match fan_start {
        Some(s) => {
            for i in 1..k - 1 {
                push([ring[s], ring[(s + i) % k], ring[(s + i + 1) % k]]);
            }
        }
        None => {
            let centre = CENTRE + case.centre_count;
            case.centres[case.centre_count as usize] =
                ring.iter().fold(0u16, |mask, &e| mask | 1 << e);
            case.centre_count += 1;
            for i in 0..k {
                push([centre, ring[i], ring[(i + 1) % k]]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every crossing starts exactly one segment and ends exactly one, in every case: the loops
    /// close. And each face's segments are the reverse of what the neighbour across it draws.
    #[test]
    fn segments_form_loops_and_neighbours_agree() {
        for config in 0..256usize {
            for joined in 0..64usize {
                let mut starts = [0; 12];
                let mut ends = [0; 12];
                for f in 0..6 {
                    for (a, b) in face_segments(config, joined, f) {
                        starts[a] += 1;
                        ends[b] += 1;
                    }
                }
                for e in 0..12 {
                    let crosses = (config >> EDGE_START[e] & 1) != (config >> edge_end(e) & 1);
                    assert_eq!(starts[e], crosses as i32, "config {config} edge {e}");
                    assert_eq!(ends[e], crosses as i32, "config {config} edge {e}");
                }
                // The neighbour across face f sees the same four corners mirrored.
                for f in 0..6 {
                    let axis = f / 2;
                    let mirrored =
                        (0..8).fold(0usize, |m, n| m | (config >> (n ^ 1 << axis) & 1) << n);
                    let mirror_edge = |e: usize| {
                        let a = EDGE_START[e] ^ 1 << axis;
                        let b = edge_end(e) ^ 1 << axis;
                        edge_between(a, b)
                    };
                    let mut mine = face_segments(config, joined, f);
                    // The neighbour decides its face f ^ 1 from the same four values.
                    let joined_there = (joined >> f & 1) << (f ^ 1);
                    let mut theirs: Vec<(usize, usize)> =
                        face_segments(mirrored, joined_there, f ^ 1)
                            .into_iter()
                            .map(|(a, b)| (mirror_edge(b), mirror_edge(a)))
                            .collect();
                    mine.sort();
                    theirs.sort();
                    assert_eq!(mine, theirs, "config {config} face {f}");
                }
            }
        }
    }

    /// A single inside corner gives one triangle facing away from it.
    #[test]
    fn one_corner_gives_one_outward_triangle() {
        let c = case(1, 0);
        assert_eq!(c.triangles().len(), 1);
        let t = c.triangles()[0];
        let [a, b, d] = t.map(|e| midpoint(e as usize));
        let n = cross(
            [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
            [d[0] - a[0], d[1] - a[1], d[2] - a[2]],
        );
        assert!(n[0] > 0.0 && n[1] > 0.0 && n[2] > 0.0, "normal {n:?}");
    }

    #[test]
    fn uniform_cubes_give_nothing() {
        assert!(case(0, 0).triangles().is_empty());
        assert!(case(255, 0x3f).triangles().is_empty());
    }
}
