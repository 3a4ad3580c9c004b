//! Scattering points uniformly inside a level set (positive inside), seeded.
//!
//! The key decision: the search box is cut into equal cells, interval evaluation throws away
//! the cells where the level set is certainly not positive, and points are drawn by picking a
//! surviving cell uniformly, then a point uniformly in it, kept when the level set is
//! positive there. Equal cells keep the distribution uniform over the inside; discarding empty
//! cells keeps rejection cheap for thin shapes. Candidates are drawn in fixed rounds of
//! independent streams (one per candidate index), so the points depend only on the seed.

use super::Particles;
use super::random::Stream;
use crate::base::failure::{Failure, Outcome};
use crate::space::{Aabb, FieldSampler};
use glam::DVec3;
use rayon::prelude::*;

/// Cells along each axis of the search box.
const CELLS: usize = 24;
/// Candidates drawn per round.
const ROUND: usize = 1 << 14;
/// Give up after this many candidates per requested point with none accepted.
const PATIENCE: usize = 64;

/// `count` points inside `level_set` (where it is > 0) within `region`.
pub fn scatter(
    level_set: &dyn FieldSampler,
    region: Aabb,
    count: usize,
    seed: u64,
) -> Outcome<Particles> {
    if !region.is_finite() || region.is_empty() {
        return Err(Failure::new("scatter needs a finite, non-empty region"));
    }
    super::check_memory(count, &[], "scattering particles")?;
    let size = region.size() / CELLS as f64;
    let live: Vec<DVec3> = (0..CELLS * CELLS * CELLS)
        .filter_map(|i| {
            let c = DVec3::new(
                (i % CELLS) as f64,
                ((i / CELLS) % CELLS) as f64,
                (i / (CELLS * CELLS)) as f64,
            );
            let lo = region.min + c * size;
            let (_, hi) = level_set.range(&Aabb::new(lo, lo + size))[0];
            (hi > 0.0).then_some(lo)
        })
        .collect();
    if live.is_empty() {
        return Err(
            Failure::new("the level set is nowhere positive inside the region")
                .with_help("level sets are positive inside; check its sign and the region"),
        );
    }
    let mut positions: Vec<[f32; 3]> = Vec::with_capacity(count);
    let mut drawn = 0usize;
    while positions.len() < count {
        if drawn > PATIENCE * count.max(ROUND) && positions.is_empty() {
            return Err(Failure::new(
                "scatter found no point inside the level set after many tries",
            ));
        }
        let start = drawn;
        let candidates: Vec<[f64; 3]> = (start..start + ROUND)
            .map(|n| {
                let mut s = Stream::new(seed, n as u64);
                let cell = live[(s.next_u64() % live.len() as u64) as usize];
                let u = DVec3::new(s.uniform(), s.uniform(), s.uniform());
                (cell + u * size).to_array()
            })
            .collect();
        drawn += ROUND;
        let inside = inside(level_set, &candidates);
        for (p, ok) in candidates.iter().zip(inside) {
            if ok && positions.len() < count {
                positions.push(p.map(|c| c as f32));
            }
        }
    }
    Ok(Particles::new(positions))
}

/// Whether the level set is positive at each point, evaluated in blocks in parallel.
fn inside(level_set: &dyn FieldSampler, points: &[[f64; 3]]) -> Vec<bool> {
    const CHUNK: usize = 256;
    points
        .par_chunks(CHUNK)
        .flat_map_iter(|chunk| {
            let mut eval = level_set.evaluator();
            let xs: Vec<f64> = chunk.iter().map(|p| p[0]).collect();
            let ys: Vec<f64> = chunk.iter().map(|p| p[1]).collect();
            let zs: Vec<f64> = chunk.iter().map(|p| p[2]).collect();
            let mut out = vec![0.0f64; chunk.len()];
            eval.eval_f64(&xs, &ys, &zs, &mut out);
            out.into_iter().map(|v| v > 0.0)
        })
        .collect()
}
