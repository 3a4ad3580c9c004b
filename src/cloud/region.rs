//! Region volumes (seed 003, §4.3): the per-cell probabilities `p_hum`, `p_act` and `p_ext`
//! that say where clouds form, grow and fade.
//!
//! A region is any felt scalar field sampled at the automaton's cell centres — the source's
//! ellipsoids (1 at the centre falling linearly to 0 on the surface, combined by maximum) are
//! one such field, `cloudellipsoid`. The one key decision: sampled probabilities are stored as
//! 16-bit thresholds beside a bit plane of the cells where they are non-zero, so a step draws
//! random numbers only where an event can happen, and a field that is zero over most of the
//! sky costs nothing there.

use super::bits::Planes;
use super::random::{threshold, thresholds};
use crate::field::CompiledField;
use crate::space::domain::Domain;
use crate::space::{Aabb, BlockEval, FieldSampler};
use glam::DVec3;
use rayon::prelude::*;

/// One probability over the cells.
#[derive(Clone, Debug)]
pub enum Probability {
    /// The same threshold everywhere.
    Uniform(u16),
    /// Per cell, index `i + nx·(j + ny·k)`, with `nonzero` the plane of cells where the
    /// threshold is above zero.
    Cells {
        thresholds: Vec<u16>,
        nonzero: Vec<u64>,
    },
}

impl Probability {
    pub fn uniform(p: f64) -> Probability {
        Probability::Uniform(threshold(p))
    }

    /// Probabilities at the cell centres, index `i + nx·(j + ny·k)`; clamped to [0, 1].
    pub fn from_cells(planes: &Planes, values: &[f32]) -> Probability {
        let thresholds: Vec<u16> = values.iter().map(|&v| threshold(v as f64)).collect();
        let mut nonzero = vec![0u64; planes.len()];
        for k in 0..planes.nz {
            for j in 0..planes.ny {
                let row = planes.row(j, k);
                let first = planes.nx * row;
                for (i, t) in thresholds[first..first + planes.nx].iter().enumerate() {
                    if *t > 0 {
                        nonzero[row * planes.words + i / 64] |= 1 << (i % 64);
                    }
                }
            }
        }
        Probability::Cells {
            thresholds,
            nonzero,
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        match self {
            Probability::Uniform(_) => 0,
            Probability::Cells {
                thresholds,
                nonzero,
            } => thresholds.len() * 2 + nonzero.len() * 8,
        }
    }

    /// The cells of plane word `word` where the event may happen.
    #[inline]
    pub fn nonzero(&self, word: usize) -> u64 {
        match self {
            Probability::Uniform(0) => 0,
            Probability::Uniform(_) => u64::MAX,
            Probability::Cells { nonzero, .. } => nonzero[word],
        }
    }

    /// The threshold of cell `cell` (bit `bit` of plane word `word`).
    #[inline]
    pub fn at(&self, word: usize, bit: usize, cell: usize) -> u16 {
        match self {
            Probability::Uniform(t) => *t,
            Probability::Cells {
                thresholds,
                nonzero,
            } => {
                if nonzero[word] >> bit & 1 == 0 {
                    0
                } else {
                    thresholds[cell]
                }
            }
        }
    }
}

/// The three probabilities of a step.
#[derive(Clone, Debug)]
pub struct Probabilities {
    pub hum: Probability,
    pub act: Probability,
    pub ext: Probability,
}

/// Cells per brick edge when sampling region fields.
const BRICK: usize = 8;
/// Cells along z per parallel slab, and along x and y per block pruned as a whole.
const SLAB: usize = 16;
const BLOCK_CELLS: usize = 32;

impl Probabilities {
    /// The region update: a three-component field (`p_hum`, `p_act`, `p_ext`) sampled at
    /// `domain`'s cell centres in one pass, brick by brick. Each brick first asks the field's
    /// range over its centres: a component whose range is one value there is that value without
    /// evaluating, and the rest is evaluated with the field pruned to the brick (a maximum of
    /// many ellipsoids is, in most bricks, one ellipsoid or none). Slabs of bricks along z
    /// are filled in parallel, each writing only its own cells, so the result does not depend
    /// on the number of threads.
    pub fn sample(field: &CompiledField, domain: &Domain, planes: &Planes) -> Probabilities {
        debug_assert_eq!(field.width(), 3);
        let (nx, ny, nz) = (planes.nx, planes.ny, planes.nz);
        let slab_cells = nx * ny * SLAB;
        let slab_words = planes.words * ny * SLAB;
        let mut thresholds = [0; 3].map(|_| vec![0u16; nx * ny * nz]);
        let mut nonzero = [0; 3].map(|_| vec![0u64; planes.len()]);
        let [t0, t1, t2] = &mut thresholds;
        let [n0, n1, n2] = &mut nonzero;
        t0.par_chunks_mut(slab_cells)
            .zip(t1.par_chunks_mut(slab_cells))
            .zip(t2.par_chunks_mut(slab_cells))
            .zip(n0.par_chunks_mut(slab_words))
            .zip(n1.par_chunks_mut(slab_words))
            .zip(n2.par_chunks_mut(slab_words))
            .enumerate()
            .for_each_init(
                BrickPoints::default,
                |points, (slab, (((((t0, t1), t2), n0), n1), n2))| {
                    let mut out = SlabOut {
                        k0: slab * SLAB,
                        thresholds: [t0, t1, t2],
                        nonzero: [n0, n1, n2],
                    };
                    let k0 = slab * SLAB;
                    let k1 = (k0 + SLAB).min(nz);
                    // Pruned once per block of the slab, then per brick from the shorter tape.
                    for j0 in (0..ny).step_by(BLOCK_CELLS) {
                        for i0 in (0..nx).step_by(BLOCK_CELLS) {
                            let lo = [i0, j0, k0];
                            let hi = [(i0 + BLOCK_CELLS).min(nx), (j0 + BLOCK_CELLS).min(ny), k1];
                            let pruned = field.pruned(&centre_box(domain, lo, hi));
                            let block = pruned.as_ref().unwrap_or(field);
                            let mut eval = block.evaluator();
                            for k in (lo[2]..hi[2]).step_by(BRICK) {
                                for j in (lo[1]..hi[1]).step_by(BRICK) {
                                    for i in (lo[0]..hi[0]).step_by(BRICK) {
                                        let brick = [i, j, k];
                                        let end = [0, 1, 2].map(|a| (brick[a] + BRICK).min(hi[a]));
                                        sample_brick(
                                            block,
                                            eval.as_mut(),
                                            points,
                                            domain,
                                            planes,
                                            brick,
                                            end,
                                            &mut out,
                                        );
                                    }
                                }
                            }
                        }
                    }
                },
            );
        let [hum, act, ext] = [0, 1, 2].map(|c| Probability::Cells {
            thresholds: std::mem::take(&mut thresholds[c]),
            nonzero: std::mem::take(&mut nonzero[c]),
        });
        Probabilities { hum, act, ext }
    }

    /// No random events: the deterministic rules alone.
    pub fn none() -> Probabilities {
        Probabilities {
            hum: Probability::Uniform(0),
            act: Probability::Uniform(0),
            ext: Probability::Uniform(0),
        }
    }
}

/// The source's ellipsoid profile: 1 at `center`, falling linearly along each ray from it to
/// 0 on the surface `Σ ((p − c)/r)² = 1`, and 0 outside.
pub fn ellipsoid_profile(p: [f64; 3], center: [f64; 3], radii: [f64; 3]) -> f64 {
    let s: f64 = (0..3)
        .map(|a| ((p[a] - center[a]) / radii[a]).powi(2))
        .sum();
    (1.0 - s.sqrt()).max(0.0)
}

/// One slab's share of the three probabilities: its cells' thresholds and its rows' words.
struct SlabOut<'a> {
    /// The slab's first cell along z.
    k0: usize,
    thresholds: [&'a mut [u16]; 3],
    nonzero: [&'a mut [u64]; 3],
}

/// The cell centres of one brick, structure of arrays.
#[derive(Default)]
struct BrickPoints {
    xs: Vec<f64>,
    ys: Vec<f64>,
    zs: Vec<f64>,
    values: Vec<f32>,
    thresholds: Vec<u16>,
}

/// The world box of the centres of cells `[lo, hi)`.
fn centre_box(domain: &Domain, lo: [usize; 3], hi: [usize; 3]) -> Aabb {
    let first = domain.cell_center(lo[0], lo[1], lo[2]);
    let mut centres = Aabb::new(first, first);
    for n in 1..8 {
        let pick = |bit: usize, a: usize| if n & bit != 0 { hi[a] - 1 } else { lo[a] };
        let corner = domain.cell_center(pick(1, 0), pick(2, 1), pick(4, 2));
        centres = centres.union(&Aabb::new(corner, corner));
    }
    centres
}

/// Samples the cells `[lo, hi)` (within one slab along z) into the slab's arrays.
#[allow(clippy::too_many_arguments)]
fn sample_brick(
    field: &dyn FieldSampler,
    eval: &mut dyn BlockEval,
    points: &mut BrickPoints,
    domain: &Domain,
    planes: &Planes,
    lo: [usize; 3],
    hi: [usize; 3],
    out: &mut SlabOut,
) {
    let centres = centre_box(domain, lo, hi);
    let range = eval
        .focus(&centres)
        .unwrap_or_else(|| field.range(&centres));
    // A component that is one value over the brick needs no evaluation.
    let constant: Vec<Option<f64>> = range
        .iter()
        .map(|&(l, h)| {
            if l == h {
                Some(l)
            } else if h <= 0.0 {
                Some(0.0)
            } else {
                None
            }
        })
        .collect();
    let count = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
    let evaluate = constant.iter().any(|c| c.is_none());
    if evaluate {
        points.xs.clear();
        points.ys.clear();
        points.zs.clear();
        // `cell_center` is origin + ((X·x + Y·y) + Z·z) with the rotation's columns: each
        // product depends on one index, so they are taken once per index.
        let r = domain.rotation;
        let along =
            |column: DVec3, axis: usize, i: usize| column * ((i as f64 + 0.5) * domain.cell[axis]);
        let row: Vec<DVec3> = (lo[0]..hi[0]).map(|i| along(r.x_axis, 0, i)).collect();
        for k in lo[2]..hi[2] {
            let cz = along(r.z_axis, 2, k);
            for j in lo[1]..hi[1] {
                let cy = along(r.y_axis, 1, j);
                for cx in &row {
                    let p = domain.origin + (*cx + cy + cz);
                    points.xs.push(p.x);
                    points.ys.push(p.y);
                    points.zs.push(p.z);
                }
            }
        }
        points.values.resize(3 * count, 0.0);
        eval.eval_f32(&points.xs, &points.ys, &points.zs, &mut points.values);
        // All three components at once, in one loop the compiler vectorises.
        thresholds(&points.values, &mut points.thresholds);
    }
    let (nx, ny) = (planes.nx, planes.ny);
    for c in 0..3 {
        let fixed = constant[c].map(threshold);
        if fixed == Some(0) {
            continue; // the slab's arrays start at zero
        }
        let values: &[u16] = match fixed {
            Some(_) => &[],
            None => &points.thresholds[c * count..(c + 1) * count],
        };
        // Bricks start at multiples of 8 along x, so a brick's row lies in one plane word.
        let width = hi[0] - lo[0];
        let (word, shift) = (lo[0] / 64, lo[0] % 64);
        let mut n = 0;
        for k in lo[2]..hi[2] {
            let dk = k - out.k0;
            for j in lo[1]..hi[1] {
                let row = j + ny * dk;
                let cells = &mut out.thresholds[c][lo[0] + nx * row..][..width];
                let mask = match fixed {
                    Some(t) => {
                        cells.fill(t);
                        (1u64 << width) - 1
                    }
                    None => {
                        let mut mask = 0u64;
                        let row = &values[n..n + width];
                        cells.copy_from_slice(row);
                        for (x, &t) in row.iter().enumerate() {
                            mask |= ((t > 0) as u64) << x;
                        }
                        mask
                    }
                };
                n += width;
                out.nonzero[c][row * planes.words + word] |= mask << shift;
            }
        }
    }
}
