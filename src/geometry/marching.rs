//! Marching cubes: the zero set of a level set (positive inside) as a closed triangle mesh.
//!
//! The level set is sampled at the domain's cell centres; the cubes of the mesh join eight
//! neighbouring samples. Around the samples lies one layer of virtual samples that count as
//! outside, so where the solid meets the domain the surface is closed by a cap on the domain's
//! face (crossings towards a virtual sample sit exactly on the face). Each cube takes its
//! triangles from the derived table in `cases`, with ambiguous faces decided by the asymptotic
//! decider — are the two inside corners joined through the face's bilinear saddle? — computed
//! from the face's four samples alone, so both cubes that share the face make the same choice.
//! That is the one key decision (over marching tetrahedra, which is manifold too but makes
//! two to three times the triangles, all of them worse shaped): the table plus consistent face
//! decisions give a closed, oriented 2-manifold with the usual MC triangle count.
//!
//! The work runs in slabs of cube layers along the domain's third axis, in parallel. A slab
//! samples its own layers in blocks of `BLOCK` points, skipping 8 × 8 columns whose interval
//! range shows a single sign; the plane it shares with the next slab is that slab's, sampled
//! once, so both see one value there. A slab shares each crossing between its cubes through
//! per-layer edge tables. Crossings on the plane between two slabs belong to the upper slab; the lower one
//! records them by edge and the merge resolves them, in slab order, so the output is the same
//! for any number of threads.

use super::Mesh;
use super::cases::{self, CENTRE, EDGE_START, corner_offset, edge_axis, face_corners};
use crate::base::failure::{Failure, Outcome};
use crate::space::domain::Domain;
use crate::space::{Aabb, BLOCK, BlockEval, FieldSampler};
use glam::DVec3;
use rayon::prelude::*;

/// Cells along the longest side of the domain `ls2shape(ls)` lays over the level set's bounds.
pub const DEFAULT_MESH_CELLS: usize = 128;

/// Cells of margin that `default_mesh_domain` leaves around the level set's bounds.
const MARGIN_CELLS: usize = 2;

/// A crossing is kept this fraction of an edge away from its samples, so that a sample that is
/// exactly zero does not make several vertices coincide (and triangles degenerate).
const END_GAP: f64 = 1e-3;

/// Columns of samples (along the first two axes) that share one interval test.
const COLUMN: usize = 8;

/// The domain `ls2shape(ls)` uses without one given: the level set's bounds grown by two cells
/// on every side, with `DEFAULT_MESH_CELLS` cells along the longest side in all.
pub fn default_mesh_domain(levelset: &dyn FieldSampler) -> Outcome<Domain> {
    let help = "give the domain to mesh over: ls2shape(ls, domain)";
    let bounds = match levelset.bounds() {
        Some(b) if b.is_finite() && !b.is_empty() => b,
        Some(b) if b.is_empty() => {
            return Err(
                Failure::new("the level set's bounds are empty: it has no inside to mesh")
                    .with_help(help),
            );
        }
        _ => {
            return Err(
                Failure::new("the level set does not report finite bounds to mesh over")
                    .with_help(help),
            );
        }
    };
    let longest = bounds.size().max_element();
    if longest <= 0.0 {
        return Err(Failure::new("the level set's bounds are a single point").with_help(help));
    }
    let cell = longest / (DEFAULT_MESH_CELLS - 2 * MARGIN_CELLS) as f64;
    let margin = DVec3::splat(MARGIN_CELLS as f64 * cell);
    Domain::fitted(
        bounds.min - margin,
        bounds.size() + 2.0 * margin,
        DVec3::ZERO,
        cell,
    )
}

/// The zero set of `levelset` over `domain`'s cells, closed where it meets the domain's
/// boundary, triangles counter-clockwise seen from outside (negative values).
pub fn marching_cubes(levelset: &dyn FieldSampler, domain: &Domain) -> Outcome<Mesh> {
    if levelset.width() != 1 {
        return Err(Failure::new(format!(
            "a shape is the zero set of a scalar level set, but this field has {} components",
            levelset.width()
        )));
    }
    let Some(resolution) = domain.resolution else {
        return Err(
            Failure::new("meshing a level set needs a domain with cells")
                .with_help("give the domain a cell size"),
        );
    };
    let grid = Lattice::new(domain, resolution);
    let cube_layers = resolution[2] + 1;
    // Every slab's samples may be alive at once: the padded grid of f32 values.
    let padded = grid.padded.map(|n| n as f64);
    let _samples = crate::engine::budget::reserve(
        padded[0] * padded[1] * padded[2] * 4.0,
        &format!(
            "meshing over {} x {} x {} cells (its samples)",
            resolution[0], resolution[1], resolution[2]
        ),
    )?;
    // The slabs depend on the resolution alone, never on the number of threads, so neither
    // does the order of the vertices. Each slab samples one layer that the next samples again;
    // thicker slabs waste less, thinner ones share the work more evenly.
    let thickness = (cube_layers / 32).clamp(4, 32);
    let slabs: Vec<(usize, usize)> = (0..cube_layers)
        .step_by(thickness)
        .map(|c0| (c0, (c0 + thickness).min(cube_layers)))
        .collect();
    // Each slab samples its own layers and the last slab the closing virtual one too, so every
    // sample is evaluated once. Two slabs must see the same value on the plane they share: a
    // noise value evaluated again in another block can round to the other side of zero (noise
    // is exactly zero at many points of a regular lattice), and the lower slab would then
    // have a crossing the upper one lacks.
    let sampled: Vec<Outcome<Vec<f32>>> = slabs
        .par_iter()
        .map(|&(c0, c1)| {
            let end = if c1 == cube_layers { c1 + 1 } else { c1 };
            grid.sample_layers(levelset, c0, end)
        })
        .collect();
    let mut values = Vec::with_capacity(sampled.len());
    for layers in sampled {
        values.push(layers?);
    }
    let layer = grid.layer_size();
    for s in 1..values.len() {
        let (lower, upper) = values.split_at_mut(s);
        lower[s - 1].extend_from_slice(&upper[0][..layer]);
    }
    let meshes: Vec<SlabMesh> = slabs
        .par_iter()
        .zip(&values)
        .map(|(&(c0, c1), values)| grid.extract_slab(values, c0, c1))
        .collect();
    drop(values);
    merge(meshes)
}

/// The samples with their virtual outside layer: padded index `p` along an axis is real cell
/// `p - 1`; padded 0 and `n + 1` are virtual.
struct Lattice<'a> {
    domain: &'a Domain,
    resolution: [usize; 3],
    /// Padded sample counts.
    padded: [usize; 3],
}

/// The stored value of a virtual sample: outside, and never interpolated (see `crossing`).
const VIRTUAL: f32 = f32::NAN;
/// Stored for a sample whose neighbourhood the interval test showed to be all outside or all
/// inside; such values are only ever compared with zero.
const SURELY_OUTSIDE: f32 = -1.0;
const SURELY_INSIDE: f32 = 1.0;

struct SlabMesh {
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    /// Crossings on the slab's top plane, owned by the next slab: (local index, edge key).
    foreign: Vec<(u32, usize)>,
    /// Crossings on the slab's bottom plane, by edge key, sorted: (edge key, local index).
    bottom: Vec<(usize, u32)>,
}

impl Lattice<'_> {
    fn new(domain: &Domain, resolution: [usize; 3]) -> Lattice<'_> {
        Lattice {
            domain,
            resolution,
            padded: resolution.map(|n| n + 2),
        }
    }

    fn layer_size(&self) -> usize {
        self.padded[0] * self.padded[1]
    }

    /// Samples padded layers `c0..end` into a buffer of `end - c0` layers.
    fn sample_layers(
        &self,
        levelset: &dyn FieldSampler,
        c0: usize,
        end: usize,
    ) -> Outcome<Vec<f32>> {
        let [nx, ny, nz] = self.resolution;
        let [px, _, _] = self.padded;
        let mut values = vec![VIRTUAL; (end - c0) * self.layer_size()];
        // Real layers among them, as real indices (padded layer `k + 1` is real layer `k`).
        let k0 = c0.max(1) - 1;
        let k1 = end.min(nz + 1) - 1;
        if k0 >= k1 {
            return Ok(values);
        }
        let mut evaluator = levelset.evaluator();
        let mut block = Block::default();
        for j0 in (0..ny).step_by(COLUMN) {
            for i0 in (0..nx).step_by(COLUMN) {
                let (i1, j1) = ((i0 + COLUMN).min(nx), (j0 + COLUMN).min(ny));
                let fill = self.column_sign(levelset, [i0, j0, k0], [i1, j1, k1]);
                for k in k0..k1 {
                    for j in j0..j1 {
                        for i in i0..i1 {
                            let at = (k + 1 - c0) * self.layer_size() + (j + 1) * px + i + 1;
                            match fill {
                                Some(v) => values[at] = v,
                                None => {
                                    block.push(self.domain.cell_center(i, j, k), at);
                                    if block.len() == BLOCK {
                                        block.run(evaluator.as_mut(), &mut values)?;
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        block.run(evaluator.as_mut(), &mut values)?;
        Ok(values)
    }

    /// A value standing for every sample of the column of real cells `lo..hi` when the level
    /// set's range over the column and its neighbours has one sign, else `None`.
    fn column_sign(
        &self,
        levelset: &dyn FieldSampler,
        lo: [usize; 3],
        hi: [usize; 3],
    ) -> Option<f32> {
        let first = DVec3::new(lo[0] as f64, lo[1] as f64, lo[2] as f64) - DVec3::ONE;
        let last = DVec3::new(hi[0] as f64, hi[1] as f64, hi[2] as f64);
        let count = DVec3::new(
            self.resolution[0] as f64,
            self.resolution[1] as f64,
            self.resolution[2] as f64,
        );
        let first = first.max(DVec3::ZERO) + DVec3::splat(0.5);
        let last = last.min(count - DVec3::ONE) + DVec3::splat(0.5);
        let (a, b) = (first * self.domain.cell, last * self.domain.cell);
        let mut region = Aabb::new(DVec3::INFINITY, DVec3::NEG_INFINITY);
        for n in 0..8 {
            let [x, y, z] = corner_offset(n);
            let local = DVec3::new(
                if x == 0 { a.x } else { b.x },
                if y == 0 { a.y } else { b.y },
                if z == 0 { a.z } else { b.z },
            );
            let world = self.domain.local_to_world(local);
            region = region.union(&Aabb::new(world, world));
        }
        let (low, high) = *levelset.range(&region).first()?;
        if high <= 0.0 {
            Some(SURELY_OUTSIDE)
        } else if low > 0.0 {
            Some(SURELY_INSIDE)
        } else {
            None
        }
    }

    /// The cubes of layers `c0..c1` over the slab's samples.
    fn extract_slab(&self, values: &[f32], c0: usize, c1: usize) -> SlabMesh {
        let [px, py, _] = self.padded;
        let layer = self.layer_size();
        let mut out = SlabMesh {
            positions: Vec::new(),
            triangles: Vec::new(),
            foreign: Vec::new(),
            bottom: Vec::new(),
        };
        // Vertex index of the crossing on each edge: x and y edges of the cube layer's lower and
        // upper sample planes, z edges between them.
        let mut plane_low = vec![u32::MAX; 2 * layer];
        let mut plane_high = vec![u32::MAX; 2 * layer];
        let mut rising = vec![u32::MAX; layer];
        for c in c0..c1 {
            let base = (c - c0) * layer;
            for j in 0..py - 1 {
                for i in 0..px - 1 {
                    let mut corner = [0f32; 8];
                    let mut config = 0u8;
                    for (n, value) in corner.iter_mut().enumerate() {
                        let [x, y, z] = corner_offset(n);
                        *value = values[base + z * layer + (j + y) * px + i + x];
                        if *value > 0.0 {
                            config |= 1 << n;
                        }
                    }
                    if config == 0 || config == 0xff {
                        continue;
                    }
                    let case = cases::case(config, joined_faces(config, &corner));
                    let mut vertex = [u32::MAX; 12 + cases::MAX_LOOPS];
                    for triangle in case.triangles() {
                        for &code in triangle {
                            if code < CENTRE && vertex[code as usize] == u32::MAX {
                                let e = code as usize;
                                let [x, y, z] = corner_offset(EDGE_START[e]);
                                let axis = edge_axis(e);
                                let (table, slot) = match (axis, z) {
                                    (2, _) => (&mut rising, (j + y) * px + i + x),
                                    (_, 0) => (&mut plane_low, axis * layer + (j + y) * px + i + x),
                                    _ => (&mut plane_high, axis * layer + (j + y) * px + i + x),
                                };
                                if table[slot] == u32::MAX {
                                    table[slot] = out.positions.len() as u32;
                                    let start = [i + x, j + y, c + z];
                                    out.positions.push(self.crossing(values, c0, start, axis));
                                    if axis != 2 && c + z == c0 {
                                        out.bottom.push((slot, table[slot]));
                                    } else if axis != 2 && c + z == c1 {
                                        out.foreign.push((table[slot], slot));
                                    }
                                }
                                vertex[e] = table[slot];
                            }
                        }
                    }
                    for (l, &mask) in case.centres().iter().enumerate() {
                        let sum: DVec3 = (0..12)
                            .filter(|e| mask >> e & 1 == 1)
                            .map(|e| out.positions[vertex[e] as usize])
                            .sum();
                        vertex[12 + l] = out.positions.len() as u32;
                        out.positions.push(sum / mask.count_ones() as f64);
                    }
                    for triangle in case.triangles() {
                        out.triangles
                            .push(triangle.map(|code| vertex[code as usize]));
                    }
                }
            }
            std::mem::swap(&mut plane_low, &mut plane_high);
            plane_high.fill(u32::MAX);
            rising.fill(u32::MAX);
        }
        out.bottom.sort_unstable();
        out
    }

    /// The world position where the level set crosses zero on the edge from padded sample
    /// `start` along `axis`, by linear interpolation; on the domain's face when one end is
    /// virtual.
    fn crossing(&self, values: &[f32], c0: usize, start: [usize; 3], axis: usize) -> DVec3 {
        let [px, _, _] = self.padded;
        let index = |p: [usize; 3]| (p[2] - c0) * self.layer_size() + p[1] * px + p[0];
        let mut end = start;
        end[axis] += 1;
        let (a, b) = (values[index(start)] as f64, values[index(end)] as f64);
        let mut t = a / (a - b);
        if !t.is_finite() {
            t = 0.5;
        } else {
            t = t.clamp(END_GAP, 1.0 - END_GAP);
        }
        let mut padded = DVec3::new(start[0] as f64, start[1] as f64, start[2] as f64);
        padded[axis] += t;
        self.domain
            .local_to_world((padded - DVec3::splat(0.5)) * self.domain.cell)
    }
}

/// Bit `f` set when face `f` is ambiguous and the bilinear interpolant joins its two inside
/// corners through the face's saddle: the product along the inside diagonal exceeds the product
/// along the outside one. Products commute, so the neighbour across the face agrees.
fn joined_faces(config: u8, corner: &[f32; 8]) -> u8 {
    let mut joined = 0u8;
    for f in 0..6 {
        if !cases::face_is_ambiguous(config as usize, f) {
            continue;
        }
        let c = face_corners(f);
        let (d0, d1) = (corner[c[0]] * corner[c[2]], corner[c[1]] * corner[c[3]]);
        let (inside, outside) = if corner[c[0]] > 0.0 {
            (d0, d1)
        } else {
            (d1, d0)
        };
        if inside > outside {
            joined |= 1 << f;
        }
    }
    joined
}

/// Points waiting to be evaluated together, with where their values go.
#[derive(Default)]
struct Block {
    xs: Vec<f64>,
    ys: Vec<f64>,
    zs: Vec<f64>,
    slots: Vec<usize>,
    out: Vec<f32>,
}

impl Block {
    fn len(&self) -> usize {
        self.slots.len()
    }

    fn push(&mut self, p: DVec3, slot: usize) {
        self.xs.push(p.x);
        self.ys.push(p.y);
        self.zs.push(p.z);
        self.slots.push(slot);
    }

    fn run(&mut self, evaluator: &mut dyn BlockEval, values: &mut [f32]) -> Outcome<()> {
        let n = self.len();
        if n == 0 {
            return Ok(());
        }
        self.out.resize(n, 0.0);
        evaluator.eval_f32(&self.xs, &self.ys, &self.zs, &mut self.out);
        for i in 0..n {
            let v = self.out[i];
            if v.is_nan() {
                return Err(Failure::new(format!(
                    "the level set is NaN at ({}, {}, {}), so its surface is undefined there",
                    self.xs[i], self.ys[i], self.zs[i]
                )));
            }
            values[self.slots[i]] = v;
        }
        self.xs.clear();
        self.ys.clear();
        self.zs.clear();
        self.slots.clear();
        Ok(())
    }
}

/// Joins the slabs' meshes: each slab's own vertices in slab order, and the crossings a slab
/// shares with the next one resolved to that slab's copy.
fn merge(slabs: Vec<SlabMesh>) -> Outcome<Mesh> {
    // The merged mesh is as large again as the slabs' pieces.
    let (positions, triangles): (usize, usize) = slabs
        .iter()
        .map(|s| (s.positions.len(), s.triangles.len()))
        .fold((0, 0), |(p, t), (a, b)| (p + a, t + b));
    let bytes = (positions * std::mem::size_of::<DVec3>() + triangles * 12) as f64;
    crate::engine::budget::check(
        bytes,
        &format!("a mesh of {triangles} triangles and {positions} vertices"),
    )?;
    let mut mesh = Mesh::new(
        Vec::with_capacity(slabs.iter().map(|s| s.positions.len()).sum()),
        Vec::with_capacity(slabs.iter().map(|s| s.triangles.len()).sum()),
    );
    // Global index of each slab's local vertices; foreign ones are resolved in a second pass,
    // once the next slab's vertices have their numbers.
    let mut global: Vec<Vec<u32>> = Vec::with_capacity(slabs.len());
    for slab in &slabs {
        let mut map = vec![0u32; slab.positions.len()];
        for &(local, _) in &slab.foreign {
            map[local as usize] = u32::MAX;
        }
        for (entry, p) in map.iter_mut().zip(&slab.positions) {
            if *entry != u32::MAX {
                if mesh.positions.len() >= u32::MAX as usize {
                    return Err(
                        Failure::new("the mesh has more vertices than a shape can hold")
                            .with_help("use a larger cell size"),
                    );
                }
                *entry = mesh.positions.len() as u32;
                mesh.positions.push(*p);
            }
        }
        global.push(map);
    }
    for s in 0..slabs.len() {
        for &(local, key) in &slabs[s].foreign {
            // The upper slab made a vertex on every crossing edge of its bottom plane.
            let resolved = slabs.get(s + 1).and_then(|next| {
                let at = next.bottom.binary_search_by_key(&key, |&(k, _)| k).ok()?;
                Some(global[s + 1][next.bottom[at].1 as usize])
            });
            global[s][local as usize] = resolved
                .ok_or_else(|| Failure::internal("a crossing between two slabs has no owner"))?;
        }
    }
    for (slab, map) in slabs.iter().zip(&global) {
        mesh.triangles
            .extend(slab.triangles.iter().map(|t| t.map(|v| map[v as usize])));
    }
    Ok(mesh)
}
