//! The adding half of a splat: binning particles by brick and adding each brick's particles
//! in fixed point.
//!
//! The key decision: a particle is copied, not indexed, into the bin of every brick its
//! stencil reaches (one brick mostly; two, four or eight across brick faces), and each brick is
//! then added up by one task from its own bin, with no sharing. A bin lists particles from all
//! over the input (a flame's chains jump across the attractor), so reading them back by index
//! would miss the cache at every particle; a copy is written in input order and read back in
//! bin order. Batches of `BATCH` particles bound the copies' memory; with more than one batch,
//! each brick's integer sums are kept between batches.
//!
//! In each batch every part of the particles (a part per thread) is counting-sorted by brick
//! into its own region. Which part a particle falls in depends on the thread count, but only
//! integer sums are taken over a bin, so nothing the splat returns does. The floating-point
//! sums (the report's totals and the magnitude that fixes the scale) are taken over fixed
//! chunks of particles and added in chunk order.

use super::evaluate::split;
use super::splat::{Indexer, PADDED, SplatReport, accumulate, interior};
use crate::base::failure::{Failure, Outcome};
use crate::grid::cache::{BRICK, BRICK_CELLS};
use rayon::prelude::*;

/// Particles per floating-point partial sum: fixed, so the sums do not depend on threads.
const CHUNK: usize = 1 << 14;
/// Particles binned at once (a whole number of chunks).
const BATCH: usize = 1 << 22;
/// A particle outside the domain, in the table of bricks.
const OUTSIDE: u32 = u32::MAX;
/// A binned brick index keeps, from this bit on, which neighbours past the brick's far faces
/// the stencil also reaches (bit 0: +x, 1: +y, 2: +z).
const REACH: u32 = 29;

/// A particle as binned: its position and its value.
#[derive(Clone, Copy)]
pub(super) struct Entry<const W: usize> {
    pub position: [f32; 3],
    pub value: [f32; W],
}

/// What binning and adding give.
pub(super) struct Bins {
    pub report: SplatReport,
    /// The bricks the splat reaches, ascending, with their new values.
    pub bricks: Vec<(usize, Box<[f32]>)>,
}

#[derive(Clone, Copy, Default)]
struct ChunkSums {
    outside: u64,
    total: [f64; 3],
}

/// The largest power of two that keeps the sum of every particle's |value| at most 2⁶².
fn scale_for<const W: usize>(
    count: usize,
    value: &(impl Fn(usize) -> [f32; W] + Sync),
) -> Outcome<f64> {
    let partial: Vec<f64> = (0..count.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            (c * CHUNK..((c + 1) * CHUNK).min(count))
                .map(|i| value(i).iter().map(|x| x.abs() as f64).sum::<f64>())
                .sum()
        })
        .collect();
    scale_for_magnitude(partial.iter().sum())
}

/// The largest power of two that keeps `magnitude` (a sum of |values|) at most 2⁶².
pub(super) fn scale_for_magnitude(magnitude: f64) -> Outcome<f64> {
    if !magnitude.is_finite() {
        return Err(Failure::new(
            "the splatted values add up to more than a float can hold",
        ));
    }
    Ok(if magnitude > 0.0 {
        (62.0 - magnitude.log2().ceil()).min(1000.0).exp2()
    } else {
        1.0
    })
}

/// Bins the particles by the bricks their stencils reach, adds each brick's particles, and
/// turns each brick's sums into values with `finish(brick, sums, scale)`.
pub(super) fn bin<const W: usize>(
    indexer: &Indexer,
    positions: &[[f32; 3]],
    value: &(impl Fn(usize) -> [f32; W] + Sync),
    finish: &(impl Fn(usize, &[i64], f64) -> Box<[f32]> + Sync),
) -> Outcome<Bins> {
    let n = positions.len();
    let counts = indexer.cells.map(|c| c.div_ceil(BRICK));
    let total_bricks: usize = counts.iter().product();
    if total_bricks >= 1 << REACH {
        return Err(Failure::new(format!(
            "a splat takes a grid of fewer than 2^{REACH} bricks"
        )));
    }
    // The brick index steps to the neighbour past each far face.
    let strides = [1, counts[0], counts[0] * counts[1]];
    let neighbour = |b: usize, d: u32| {
        b + (0..3)
            .filter(|a| d >> a & 1 == 1)
            .map(|a| strides[a])
            .sum::<usize>()
    };
    let scale = scale_for(n, value)?;
    let batch = BATCH.min(n.div_ceil(CHUNK).max(1) * CHUNK);
    let batches = n.div_ceil(batch);
    let parts = rayon::current_num_threads().clamp(1, batch / CHUNK);
    let part_len = (batch / CHUNK).div_ceil(parts) * CHUNK;
    let _binning = crate::engine::budget::reserve(
        (batch * 4 + parts * (total_bricks + 1) * 4) as f64,
        "splat binning",
    )?;
    let mut home = vec![OUTSIDE; batch];
    let mut entries: Vec<Entry<W>> = Vec::new();
    let mut entry_memory = crate::engine::budget::reserve(0.0, "splat bins")?;
    let mut offsets = vec![vec![0u32; total_bricks + 1]; parts];
    let mut kept: Vec<Option<Box<[i64]>>> = Vec::new();
    let mut kept_memory = Vec::new();
    let mut bricks = Vec::new();
    let mut report = SplatReport::default();
    for first in (0..n).step_by(batch) {
        let len = batch.min(n - first);
        // Each particle's brick and reach, and each part's count of entries per brick (parts
        // past the batch's end stay empty).
        for o in offsets.iter_mut() {
            o.fill(0);
        }
        let sums: Vec<Vec<ChunkSums>> = home[..len]
            .par_chunks_mut(part_len)
            .zip(offsets.par_iter_mut())
            .enumerate()
            .map(|(p, (home, histogram))| {
                let start = first + p * part_len;
                let mut sums = Vec::with_capacity(part_len / CHUNK);
                for (c, home) in home.chunks_mut(CHUNK).enumerate() {
                    let start = start + c * CHUNK;
                    let mut s = ChunkSums::default();
                    for (k, slot) in home.iter_mut().enumerate() {
                        let i = start + k;
                        let Some(landing) = indexer.land(positions[i]) else {
                            *slot = OUTSIDE;
                            s.outside += 1;
                            continue;
                        };
                        let b = (0..3)
                            .map(|a| landing.cell[a] / BRICK * strides[a])
                            .sum::<usize>();
                        let reach = (0..3)
                            .map(|a| {
                                let crosses =
                                    landing.cell[a] % BRICK == BRICK - 1 && landing.step[a] == 1;
                                (crosses as u32) << a
                            })
                            .sum::<u32>();
                        *slot = b as u32 | reach << REACH;
                        for d in 0..8 {
                            if d & !reach == 0 {
                                histogram[neighbour(b, d) + 1] += 1;
                            }
                        }
                        let v = value(i);
                        for a in 0..W {
                            s.total[a] += v[a] as f64;
                        }
                    }
                    sums.push(s);
                }
                for b in 0..total_bricks {
                    histogram[b + 1] += histogram[b];
                }
                sums
            })
            .collect();
        for s in sums.into_iter().flatten() {
            report.outside += s.outside;
            for a in 0..W {
                report.total[a] += s.total[a];
            }
        }
        // Copy each part's particles into its region, sorted by brick.
        let lengths: Vec<usize> = offsets.iter().map(|o| o[total_bricks] as usize).collect();
        let needed: usize = lengths.iter().sum();
        if needed > entries.len() {
            entry_memory = crate::engine::budget::reserve(
                (needed * std::mem::size_of::<Entry<W>>()) as f64,
                "splat bins",
            )?;
            entries.resize(
                needed,
                Entry {
                    position: [0.0; 3],
                    value: [0.0; W],
                },
            );
        }
        let mut regions = split(&mut entries, &lengths);
        home[..len]
            .par_chunks(part_len)
            .zip(regions.par_iter_mut())
            .zip(offsets.par_iter())
            .enumerate()
            .for_each(|(p, ((home, region), starts))| {
                let mut cursor = starts[..total_bricks].to_vec();
                for (k, &slot) in home.iter().enumerate() {
                    if slot == OUTSIDE {
                        continue;
                    }
                    let i = first + p * part_len + k;
                    let entry = Entry {
                        position: positions[i],
                        value: value(i),
                    };
                    let (b, reach) = ((slot & ((1 << REACH) - 1)) as usize, slot >> REACH);
                    for d in 0..8 {
                        if d & !reach == 0 {
                            let at = &mut cursor[neighbour(b, d)];
                            region[*at as usize] = entry;
                            *at += 1;
                        }
                    }
                }
            });
        // Each brick's sums, from its bins in every part's region.
        let regions: Vec<&[Entry<W>]> = regions.into_iter().map(|r| &*r).collect();
        let offsets = &offsets;
        let busy = |b: usize| offsets.iter().any(|o| o[b + 1] > o[b]);
        let sums_of = |b: usize, scratch: &mut Vec<i64>, out: &mut [i64]| {
            scratch.clear();
            scratch.resize(PADDED * W, 0);
            let first_cell = [0, 1, 2].map(|a| b / strides[a] % counts[a] * BRICK);
            for (o, region) in offsets.iter().zip(&regions) {
                let bin = &region[o[b] as usize..o[b + 1] as usize];
                accumulate(indexer, bin, scale, first_cell, scratch);
            }
            interior::<W>(scratch, out);
        };
        if batches == 1 {
            let reached: Vec<usize> = (0..total_bricks).filter(|&b| busy(b)).collect();
            bricks = reached
                .par_iter()
                .map_init(
                    || (Vec::new(), vec![0i64; BRICK_CELLS * W]),
                    |(scratch, out), &b| {
                        sums_of(b, scratch, out);
                        (b, finish(b, out, scale))
                    },
                )
                .collect();
            continue;
        }
        // More batches: keep each brick's sums until the last.
        if kept.is_empty() {
            kept = vec![None; total_bricks];
        }
        let fresh = (0..total_bricks)
            .filter(|&b| kept[b].is_none() && busy(b))
            .count();
        kept_memory.push(crate::engine::budget::reserve(
            (fresh * BRICK_CELLS * W * 8) as f64,
            "splat sums",
        )?);
        kept.par_iter_mut().enumerate().for_each_init(
            || (Vec::new(), vec![0i64; BRICK_CELLS * W]),
            |(scratch, out), (b, sums)| {
                if !busy(b) {
                    return;
                }
                sums_of(b, scratch, out);
                let sums = sums.get_or_insert_with(|| vec![0; BRICK_CELLS * W].into());
                for (s, x) in sums.iter_mut().zip(out.iter()) {
                    *s += x;
                }
            },
        );
    }
    drop((home, entries, entry_memory));
    if batches > 1 {
        bricks = kept
            .into_par_iter()
            .enumerate()
            .filter_map(|(b, sums)| sums.map(|s| (b, finish(b, &s, scale))))
            .collect();
    }
    report.splatted = n as u64 - report.outside;
    Ok(Bins { report, bricks })
}
