//! Cutting a solid with several knives (FELT chapter 5) into the pieces of their arrangement.
//!
//! The chapter's cut multiplies the solid's level set by each knife in turn, so after a few
//! knives every piece is a product of factors; where a region is thinner than a cell the
//! product's zero set breaks up into many small shells (five planes through a sphere gave 77
//! "pieces" at 128 cells, where the planes make at most 26 regions). Here each region of the
//! arrangement is the intersection `min(l0, s₁k₁, …, sₙkₙ)` for its sign vector `s`, a level
//! set with the region's own faces and no products. The one key decision: only the sign
//! vectors that occur at some cell centre inside the solid are meshed, each over the box of
//! its cells and one cell around — the sampling that marching cubes would see anyway — so the
//! work grows with the number of regions, not with the 2ⁿ sign vectors; and components whose
//! volume is below a stated minimum (slivers no grid of that cell size resolves) are dropped
//! and counted, never silently kept as extra pieces.

use super::{Mesh, marching_cubes, pieces_above};
use crate::base::failure::{Failure, Outcome};
use crate::field::{CompiledField, Field, sample_points};
use crate::space::Lattice;
use crate::space::domain::Domain;
use glam::DVec3;
use std::collections::BTreeMap;

/// The most knives one cut takes: a region is named by a sign vector in a `u64`.
pub const MAX_KNIVES: usize = 63;

/// The pieces of a cut, and what was dropped as slivers.
pub struct Cut {
    /// One closed mesh per piece, ordered by the sign vector of its region (bit `i` set where
    /// knife `i` is positive), then by the order `pieces` gives.
    pub pieces: Vec<Mesh>,
    /// The components below the minimum volume that were left out, and their total volume.
    pub dropped: usize,
    pub dropped_volume: f64,
}

/// Cuts the solid `l0` (positive inside) with `knives` over `domain`'s cells.
pub fn cut(l0: &Field, knives: &[Field], domain: &Domain, min_volume: f64) -> Outcome<Cut> {
    if knives.len() > MAX_KNIVES {
        return Err(Failure::new(format!(
            "a cut takes at most {MAX_KNIVES} knives, found {}",
            knives.len()
        )));
    }
    if !(min_volume >= 0.0 && min_volume.is_finite()) {
        return Err(Failure::new(format!(
            "the minimum piece volume must be zero or positive, found {min_volume}"
        )));
    }
    let Some([nx, ny, nz]) = domain.resolution else {
        return Err(Failure::new("cutting needs a domain with a cell size"));
    };
    let boxes = regions(l0, knives, domain, [nx, ny, nz])?;
    let mut out = Cut {
        pieces: Vec::new(),
        dropped: 0,
        dropped_volume: 0.0,
    };
    for (code, (lo, hi)) in boxes {
        let mut region = l0.clone();
        for (i, knife) in knives.iter().enumerate() {
            let side = if (code >> i) & 1 == 1 {
                knife.clone()
            } else {
                knife.neg()
            };
            region = Field::min(&region, &side)?;
        }
        let sampler = CompiledField::prepared(&region)?;
        let around = sub_domain(domain, lo, hi, [nx, ny, nz]);
        let (kept, dropped, volume) = pieces_above(&marching_cubes(&sampler, &around)?, min_volume);
        out.pieces.extend(kept);
        out.dropped += dropped;
        out.dropped_volume += volume;
    }
    Ok(out)
}

/// Every side of every knife through the solid `l0` (`cutall`, docs/language.md "Knives"):
/// `2ⁿ` level sets for `n` knives, level set `i` being `min(l0, ±k₀, ±k₁, …)` with knife 0
/// deciding the most significant bit of `i` and a 0 bit meaning the knife's positive side. Each
/// knife splits every side so far in two, so the sides share their prefixes: `2ⁿ⁺¹ − 2` `min`
/// nodes in all (`side_nodes`), which the caller checks against the budget first; the
/// graphs are checked again after each knife, so a projection that fell short still stops.
pub fn sides(l0: &Field, knives: &[Field]) -> Outcome<Vec<Field>> {
    let mut sides = vec![l0.clone()];
    for knife in knives {
        crate::field::node::check_graph_memory()?;
        let against = knife.neg();
        let mut next = Vec::with_capacity(2 * sides.len());
        for side in &sides {
            next.push(Field::min(side, knife)?);
            next.push(Field::min(side, &against)?);
        }
        sides = next;
    }
    Ok(sides)
}

/// The `min` nodes `sides` makes for `knives` knives, at most (equal structure is one node):
/// `2 + 4 + … + 2ⁿ`, and a negation per knife.
pub fn side_nodes(knives: usize) -> f64 {
    2f64.powi(knives as i32 + 1) - 2.0 + knives as f64
}

/// The lowest and highest cell index (inclusive) along each axis.
type CellBox = ([usize; 3], [usize; 3]);

/// What a region takes in `regions`' table: its code and box (56 bytes) in a B-tree node,
/// whose eleven slots are two-thirds full on average.
const REGION_BYTES: f64 = 56.0 * 1.5;

/// The sign vectors met at cell centres inside `l0`, each with the box of cell indices where
/// it occurs; the table is checked against the budget each time it doubles.
fn regions(
    l0: &Field,
    knives: &[Field],
    domain: &Domain,
    [nx, ny, nz]: [usize; 3],
) -> Outcome<BTreeMap<u64, CellBox>> {
    let mut boxes: BTreeMap<u64, CellBox> = BTreeMap::new();
    let mut checked_at = 1 << 16;
    let mut slice = Vec::with_capacity(nx * ny);
    for k in 0..nz {
        slice.clear();
        for j in 0..ny {
            for i in 0..nx {
                slice.push(domain.cell_center(i, j, k));
            }
        }
        let inside = sample_points(l0, &slice)?;
        let mut codes = vec![0u64; slice.len()];
        for (bit, knife) in knives.iter().enumerate() {
            for (code, value) in codes.iter_mut().zip(sample_points(knife, &slice)?) {
                if value >= 0.0 {
                    *code |= 1 << bit;
                }
            }
        }
        for (index, (&code, &solid)) in codes.iter().zip(&inside).enumerate() {
            if solid < 0.0 || solid.is_nan() {
                continue;
            }
            let cell = [index % nx, index / nx, k];
            if boxes.len() == checked_at && !boxes.contains_key(&code) {
                // Regions are met, not projected: up to one per cell inside the solid.
                checked_at *= 2;
                let what = format!("cutpieces' table of {checked_at} regions");
                crate::field::node::check_beside_graphs(
                    0.0,
                    checked_at as f64 * REGION_BYTES,
                    &what,
                )
                .map_err(|f| {
                    f.with_help(
                        "every region the knives make inside the solid is met, kept and meshed \
                         on its own: cut with fewer or smoother knives, use a coarser cell, or \
                         raise the budget with --memory-limit MB",
                    )
                })?;
            }
            let entry = boxes.entry(code).or_insert((cell, cell));
            for axis in 0..3 {
                entry.0[axis] = entry.0[axis].min(cell[axis]);
                entry.1[axis] = entry.1[axis].max(cell[axis]);
            }
        }
    }
    Ok(boxes)
}

/// The cells `lo..=hi` of `domain` and one more on every side (within the domain), as a
/// domain whose cell centres are `domain`'s.
fn sub_domain(domain: &Domain, lo: [usize; 3], hi: [usize; 3], counts: [usize; 3]) -> Domain {
    let first = lo.map(|i| i.saturating_sub(1));
    let last: [usize; 3] = std::array::from_fn(|a| (hi[a] + 1).min(counts[a] - 1));
    let corner = DVec3::new(first[0] as f64, first[1] as f64, first[2] as f64) * domain.cell;
    Domain::from_lattice(&Lattice {
        origin: domain.local_to_world(corner),
        rotation: domain.rotation,
        cell: domain.cell,
        counts: std::array::from_fn(|a| last[a] - first[a] + 1),
        extrapolates: false,
    })
}
