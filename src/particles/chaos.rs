//! The flame-wisp generator: the chaos game over a weighted list of maps, with noise
//! displacement and colour averaging, around guide particles (seed 004, `fractalwalk`).
//!
//! Per guide, the dots come from independent chains of `iterations` stamped steps, each chain
//! starting at a seeded point of the bi-unit cube and running `skip` unstamped steps first (as
//! flam3 "fuses" its orbits). A step: pick map i by weight, `X = fᵢ(P)`, displace
//! `P = X + k·D(X)`, colour `c = (C(X) + cᵢ)/2` with a colour field or the running average
//! `c = (c + cᵢ)/2` without one, and stamp `P` in the guide's frame. A point that leaves the
//! finite world (NaN, or beyond 1e10, flam3's bad value) restarts its chain from a fresh point
//! and is counted, so no NaN or Inf ever becomes a dot.
//!
//! The key decision: chains run in lockstep blocks of `LANES`, and each step evaluates a map
//! once for all the lanes that picked it, so the compiled field programs run on full blocks
//! instead of point by point. Every chain has its own random stream (seed, guide, chain), and
//! blocks are fixed by the chain numbering, so the dots are the same for any thread count.

use super::evaluate::{at_points, split};
use super::guide::Guide;
use super::random::Stream;
use super::{Particles, Values};
use crate::failure::{Failure, Outcome};
use crate::sample::FieldSampler;
use glam::DVec3;
use rayon::prelude::*;

/// Chains advanced together.
const LANES: usize = 1024;
/// flam3's bad value: a coordinate beyond this restarts the chain.
const BAD: f64 = 1e10;

/// One map of the iterated function system.
pub struct Map<'a> {
    pub field: &'a dyn FieldSampler,
    pub weight: f64,
    pub color: DVec3,
}

/// The generator's settings.
pub struct Settings<'a> {
    pub maps: Vec<Map<'a>>,
    pub displace: Option<&'a dyn FieldSampler>,
    /// Displacement coefficient k.
    pub amount: f64,
    pub color: Option<&'a dyn FieldSampler>,
    /// Stamped steps per chain.
    pub iterations: usize,
    /// Unstamped steps at the start of each chain.
    pub skip: usize,
}

/// What the generator did besides the dots.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Report {
    /// Steps that left the finite world and restarted their chain.
    pub restarts: u64,
}

/// One block of lanes: chains `first..first + lanes` of guide `guide`.
struct Block {
    guide: usize,
    first: usize,
    dots: usize,
}

/// `count` dots per guide.
pub fn generate(
    guides: &[Guide],
    count: usize,
    seed: u64,
    settings: &Settings,
) -> Outcome<(Particles, Report)> {
    if settings.maps.is_empty() {
        return Err(Failure::new("a flame needs at least one map"));
    }
    let mut cumulative = Vec::with_capacity(settings.maps.len());
    let mut total = 0.0;
    for m in &settings.maps {
        if !(m.weight.is_finite() && m.weight >= 0.0) {
            return Err(Failure::new(format!(
                "flame weights must be finite and not negative, found {}",
                m.weight
            )));
        }
        if m.field.width() != 3 {
            return Err(Failure::new("flame maps must be vectorfields"));
        }
        total += m.weight;
        cumulative.push(total);
    }
    if total <= 0.0 {
        return Err(Failure::new("flame weights add up to zero"));
    }
    if settings.iterations == 0 {
        return Err(Failure::new("a flame chain needs at least one iteration"));
    }
    let dots = guides
        .len()
        .checked_mul(count)
        .ok_or_else(|| Failure::new("too many dots"))?;
    super::check_memory(dots, &[3], "flame dots")?;
    let chain = settings.iterations;
    let mut blocks = Vec::new();
    for g in 0..guides.len() {
        let chains = count.div_ceil(chain);
        for first in (0..chains).step_by(LANES) {
            let end = ((first + LANES) * chain).min(count);
            blocks.push(Block {
                guide: g,
                first,
                dots: end - first * chain,
            });
        }
    }
    let mut positions = vec![[0f32; 3]; dots];
    let mut colors = vec![[0f32; 3]; dots];
    let lengths: Vec<usize> = blocks.iter().map(|b| b.dots).collect();
    let restarts: Vec<u64> = split(&mut positions, &lengths)
        .into_par_iter()
        .zip(split(&mut colors, &lengths))
        .zip(blocks.par_iter())
        .map(|((p, c), block)| {
            run_block(
                &guides[block.guide],
                block,
                seed,
                settings,
                &cumulative,
                p,
                c,
            )
        })
        .collect::<Outcome<_>>()?;
    let restarts = restarts.iter().sum();
    let mut set = Particles::new(positions);
    set.set("Cd", Values::Vector(colors))?;
    Ok((set, Report { restarts }))
}

/// Runs one block's chains, writing its dots; returns the restarts.
fn run_block(
    guide: &Guide,
    block: &Block,
    seed: u64,
    settings: &Settings,
    cumulative: &[f64],
    positions: &mut [[f32; 3]],
    colors: &mut [[f32; 3]],
) -> Outcome<u64> {
    let chain = settings.iterations;
    let lanes = block.dots.div_ceil(chain);
    let mut streams: Vec<Stream> = (0..lanes)
        .map(|l| {
            let id = ((block.guide as u64) << 40) ^ (block.first + l) as u64;
            Stream::new(seed, id)
        })
        .collect();
    let mut point: Vec<[f64; 3]> = streams.iter_mut().map(|s| s.cube()).collect();
    let mut color: Vec<DVec3> = vec![DVec3::ZERO; lanes];
    let mut fresh = vec![true; lanes];
    let mut picked = vec![0usize; lanes];
    let mut mapped: Vec<[f64; 3]> = vec![[0.0; 3]; lanes];
    let mut gather: Vec<[f64; 3]> = Vec::with_capacity(lanes);
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); settings.maps.len()];
    let mut values = Vec::new();
    let mut maps: Vec<_> = settings.maps.iter().map(|m| m.field.evaluator()).collect();
    let mut displace = settings.displace.map(|f| f.evaluator());
    let mut tint = settings.color.map(|f| f.evaluator());
    let offset = guide.offset.to_array();
    let quota: Vec<usize> = (0..lanes)
        .map(|l| chain.min(block.dots - l * chain))
        .collect();
    let mut stamped = vec![0usize; lanes];
    let mut warm = vec![0usize; lanes];
    let mut active: Vec<usize> = (0..lanes).collect();
    let mut restarts = 0u64;
    let most_steps = 16 * (settings.skip + chain) + 1000;
    for _ in 0..most_steps {
        if active.is_empty() {
            return Ok(restarts);
        }
        for m in members.iter_mut() {
            m.clear();
        }
        for &l in &active {
            picked[l] = streams[l].pick(cumulative);
            members[picked[l]].push(l);
        }
        for (j, lanes_of_j) in members.iter().enumerate() {
            if lanes_of_j.is_empty() {
                continue;
            }
            gather.clear();
            gather.extend(lanes_of_j.iter().map(|&l| point[l]));
            at_points(maps[j].as_mut(), 3, &gather, &mut values);
            for (n, &l) in lanes_of_j.iter().enumerate() {
                mapped[l] = [0, 1, 2].map(|c| values[n * 3 + c] as f64);
            }
        }
        gather.clear();
        gather.extend(active.iter().map(|&l| {
            let q = mapped[l];
            [q[0] + offset[0], q[1] + offset[1], q[2] + offset[2]]
        }));
        let mut shift: Vec<[f64; 3]> = Vec::new();
        if let Some(d) = displace.as_mut() {
            at_points(d.as_mut(), 3, &gather, &mut values);
            shift.extend(
                (0..active.len())
                    .map(|n| [0, 1, 2].map(|c| settings.amount * values[n * 3 + c] as f64)),
            );
        }
        let noise_color = match tint.as_mut() {
            Some(t) => {
                at_points(t.as_mut(), 3, &gather, &mut values);
                true
            }
            None => false,
        };
        for (n, &l) in active.iter().enumerate() {
            point[l] = mapped[l];
            if let Some(s) = shift.get(n) {
                for c in 0..3 {
                    point[l][c] += s[c];
                }
            }
            let ci = settings.maps[picked[l]].color;
            color[l] = if noise_color {
                let v = DVec3::new(
                    values[n * 3] as f64,
                    values[n * 3 + 1] as f64,
                    values[n * 3 + 2] as f64,
                );
                (v + ci) * 0.5
            } else if fresh[l] {
                ci
            } else {
                (color[l] + ci) * 0.5
            };
            fresh[l] = false;
            let p = point[l];
            let bad = !p.iter().all(|c| c.is_finite() && c.abs() <= BAD) || !color[l].is_finite();
            if bad {
                restarts += 1;
                point[l] = streams[l].cube();
                fresh[l] = true;
                warm[l] = 0;
                continue;
            }
            warm[l] += 1;
            if warm[l] <= settings.skip {
                continue;
            }
            let dot = l * chain + stamped[l];
            let world = guide.place(DVec3::from_array(p));
            positions[dot] = world.to_array().map(|c| c as f32);
            colors[dot] = color[l].to_array().map(|c| c as f32);
            stamped[l] += 1;
        }
        active.retain(|&l| stamped[l] < quota[l]);
    }
    if active.is_empty() {
        return Ok(restarts);
    }
    Err(Failure::new(
        "the flame's maps send almost every point out of the finite world (NaN or beyond 1e10)",
    )
    .with_help("scale the maps down, or give the diverging maps less weight"))
}
