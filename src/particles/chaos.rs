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

use super::evaluate::split;
use super::guide::Guide;
use super::random::Stream;
use super::{Particles, Values};
use crate::base::failure::{Failure, Outcome};
use crate::space::{BLOCK, BlockEval, FieldSampler};
use glam::DVec3;
use rayon::prelude::*;

/// Chains advanced together.
const LANES: usize = 1024;
/// Dots a lane keeps before writing them to its chain's run of the output: one lane's dots
/// are `iterations` apart from the next lane's, so writing each dot straight away touches a
/// page per lane per step.
const STAGE: usize = 16;
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
pub(super) struct Block {
    pub guide: usize,
    first: usize,
    pub dots: usize,
}

/// The maps' cumulative weights and the number of dots, after checking the settings.
pub(super) fn prepare(
    guides: &[Guide],
    count: usize,
    settings: &Settings,
) -> Outcome<(Vec<f64>, usize)> {
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
    Ok((cumulative, dots))
}

/// `count` dots per guide.
pub fn generate(
    guides: &[Guide],
    count: usize,
    seed: u64,
    settings: &Settings,
) -> Outcome<(Particles, Report)> {
    let (cumulative, dots) = prepare(guides, count, settings)?;
    super::check_memory(dots, &[3], "flame dots")?;
    let blocks = blocks(guides.len(), count, settings.iterations);
    let mut positions = vec![[0f32; 3]; dots];
    let mut colors = vec![[0f32; 3]; dots];
    let lengths: Vec<usize> = blocks.iter().map(|b| b.dots).collect();
    let restarts: Vec<u64> = split(&mut positions, &lengths)
        .into_par_iter()
        .zip(split(&mut colors, &lengths))
        .zip(blocks.par_iter())
        .map(|((positions, colors), block)| {
            let mut stored = Stored::new(block, settings.iterations, positions, colors);
            run_block(
                &guides[block.guide],
                block,
                seed,
                settings,
                &cumulative,
                &mut stored,
            )
        })
        .collect::<Outcome<_>>()?;
    let restarts = restarts.iter().sum();
    let mut set = Particles::new(positions);
    set.set("Cd", Values::Vector(colors))?;
    Ok((set, Report { restarts }))
}

/// The blocks of lanes for `count` dots per guide in chains of `chain` steps, fixed by the
/// chain numbering alone.
pub(super) fn blocks(guides: usize, count: usize, chain: usize) -> Vec<Block> {
    let mut blocks = Vec::new();
    for g in 0..guides {
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
    blocks
}

/// Where a block's dots go as they are stamped.
pub(super) trait Sink {
    /// Dot `index` (counted from 0 along its chain) of lane `lane`, in world space.
    fn dot(
        &mut self,
        lane: usize,
        index: usize,
        position: [f32; 3],
        color: [f32; 3],
    ) -> Outcome<()>;
}

/// Stores a block's dots in its run of the output, chain after chain.
struct Stored<'a> {
    chain: usize,
    quota: Vec<usize>,
    staged_positions: Vec<[f32; 3]>,
    staged_colors: Vec<[f32; 3]>,
    positions: &'a mut [[f32; 3]],
    colors: &'a mut [[f32; 3]],
}

impl<'a> Stored<'a> {
    fn new(
        block: &Block,
        chain: usize,
        positions: &'a mut [[f32; 3]],
        colors: &'a mut [[f32; 3]],
    ) -> Stored<'a> {
        let lanes = block.dots.div_ceil(chain);
        Stored {
            chain,
            quota: (0..lanes)
                .map(|l| chain.min(block.dots - l * chain))
                .collect(),
            staged_positions: vec![[0f32; 3]; lanes * STAGE],
            staged_colors: vec![[0f32; 3]; lanes * STAGE],
            positions,
            colors,
        }
    }
}

impl Sink for Stored<'_> {
    fn dot(
        &mut self,
        lane: usize,
        index: usize,
        position: [f32; 3],
        color: [f32; 3],
    ) -> Outcome<()> {
        let n = index % STAGE;
        self.staged_positions[lane * STAGE + n] = position;
        self.staged_colors[lane * STAGE + n] = color;
        if n + 1 == STAGE || index + 1 == self.quota[lane] {
            let to = lane * self.chain + index - n;
            let from = lane * STAGE;
            self.positions[to..to + n + 1]
                .copy_from_slice(&self.staged_positions[from..from + n + 1]);
            self.colors[to..to + n + 1].copy_from_slice(&self.staged_colors[from..from + n + 1]);
        }
        Ok(())
    }
}

/// Three coordinate arrays indexed by lane.
type Soa = [Vec<f64>; 3];

/// Reused buffers for evaluating a field at some of the lanes.
struct Gather {
    xs: Vec<f64>,
    ys: Vec<f64>,
    zs: Vec<f64>,
    values: Vec<f32>,
}

impl Gather {
    fn new() -> Gather {
        Gather {
            xs: Vec::with_capacity(BLOCK),
            ys: Vec::with_capacity(BLOCK),
            zs: Vec::with_capacity(BLOCK),
            values: vec![0.0; BLOCK * 3],
        }
    }

    /// The vectorfield `eval` at the points `at[·][l] (+ offset)` of the lanes `lanes`, into
    /// `out[·][l]`. The lanes are evaluated in consecutive blocks of `BLOCK` in the order given
    /// (as `at_points` would), so noise sees the same blocks.
    fn eval(
        &mut self,
        eval: &mut dyn BlockEval,
        lanes: &[u32],
        at: &Soa,
        offset: Option<[f64; 3]>,
        out: &mut Soa,
    ) {
        let [ax, ay, az] = at;
        for chunk in lanes.chunks(BLOCK) {
            self.xs.clear();
            self.ys.clear();
            self.zs.clear();
            match offset {
                // No offset is not a zero offset: -0 + 0 is +0, and atan2 tells them apart.
                None => {
                    for &l in chunk {
                        let l = l as usize;
                        self.xs.push(ax[l]);
                        self.ys.push(ay[l]);
                        self.zs.push(az[l]);
                    }
                }
                Some(o) => {
                    for &l in chunk {
                        let l = l as usize;
                        self.xs.push(ax[l] + o[0]);
                        self.ys.push(ay[l] + o[1]);
                        self.zs.push(az[l] + o[2]);
                    }
                }
            }
            let n = chunk.len();
            let values = &mut self.values[..n * 3];
            eval.eval_f32(&self.xs, &self.ys, &self.zs, values);
            let (vx, rest) = values.split_at(n);
            let (vy, vz) = rest.split_at(n);
            let [ox, oy, oz] = &mut *out;
            for (i, &l) in chunk.iter().enumerate() {
                let l = l as usize;
                ox[l] = vx[i] as f64;
                oy[l] = vy[i] as f64;
                oz[l] = vz[i] as f64;
            }
        }
    }
}

/// Runs one block's chains, handing each stamped dot to `sink`; returns the restarts.
///
/// Lane state is kept as structure of arrays and gathered straight into the evaluator's
/// input blocks, map by map.
pub(super) fn run_block(
    guide: &Guide,
    block: &Block,
    seed: u64,
    settings: &Settings,
    cumulative: &[f64],
    sink: &mut impl Sink,
) -> Outcome<u64> {
    let chain = settings.iterations;
    let lanes = block.dots.div_ceil(chain);
    let mut streams: Vec<Stream> = (0..lanes)
        .map(|l| {
            let id = ((block.guide as u64) << 40) ^ (block.first + l) as u64;
            Stream::new(seed, id)
        })
        .collect();
    let soa = || -> Soa { [vec![0.0; lanes], vec![0.0; lanes], vec![0.0; lanes]] };
    let mut point = soa();
    for (l, s) in streams.iter_mut().enumerate() {
        let p = s.cube();
        for c in 0..3 {
            point[c][l] = p[c];
        }
    }
    let mut mapped = soa();
    let mut shift = soa();
    let mut tinted = soa();
    let mut color = soa();
    let mut picked = vec![0u32; lanes];
    let mut members: Vec<Vec<u32>> = vec![Vec::with_capacity(lanes); settings.maps.len()];
    let mut gather = Gather::new();
    let mut maps: Vec<_> = settings.maps.iter().map(|m| m.field.evaluator()).collect();
    let map_colors: Vec<[f64; 3]> = settings.maps.iter().map(|m| m.color.to_array()).collect();
    let mut displace = settings.displace.map(|f| f.evaluator());
    let mut tint = settings.color.map(|f| f.evaluator());
    let offset = guide.offset.to_array();
    let identity = guide.is_identity();
    let quota: Vec<usize> = (0..lanes)
        .map(|l| chain.min(block.dots - l * chain))
        .collect();
    let mut stamped = vec![0usize; lanes];
    let mut warm = vec![0usize; lanes];
    let mut active: Vec<u32> = (0..lanes as u32).collect();
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
            let j = streams[l as usize].pick(cumulative);
            picked[l as usize] = j as u32;
            members[j].push(l);
        }
        for (j, lanes_of_j) in members.iter().enumerate() {
            if !lanes_of_j.is_empty() {
                gather.eval(maps[j].as_mut(), lanes_of_j, &point, None, &mut mapped);
            }
        }
        if let Some(d) = displace.as_mut() {
            gather.eval(d.as_mut(), &active, &mapped, Some(offset), &mut shift);
        }
        if let Some(t) = tint.as_mut() {
            gather.eval(t.as_mut(), &active, &mapped, Some(offset), &mut tinted);
        }
        let displaced = displace.is_some();
        let noise_color = tint.is_some();
        for &l in &active {
            let l = l as usize;
            let ci = map_colors[picked[l] as usize];
            let mut p = [mapped[0][l], mapped[1][l], mapped[2][l]];
            if displaced {
                for c in 0..3 {
                    p[c] += settings.amount * shift[c][l];
                }
            }
            let mut k = [0.0; 3];
            for c in 0..3 {
                k[c] = if noise_color {
                    (tinted[c][l] + ci[c]) * 0.5
                } else if warm[l] == 0 {
                    // A fresh chain (just started or restarted) takes the map's colour.
                    ci[c]
                } else {
                    (color[c][l] + ci[c]) * 0.5
                };
            }
            let bad = !p.iter().all(|c| c.is_finite() && c.abs() <= BAD)
                || !k.iter().all(|c| c.is_finite());
            if bad {
                restarts += 1;
                let q = streams[l].cube();
                for c in 0..3 {
                    point[c][l] = q[c];
                    color[c][l] = k[c];
                }
                warm[l] = 0;
                continue;
            }
            for c in 0..3 {
                point[c][l] = p[c];
                color[c][l] = k[c];
            }
            warm[l] += 1;
            if warm[l] <= settings.skip {
                continue;
            }
            // Points here are finite, where an identity guide's `place` only adds +0.
            let world = if identity {
                DVec3::from_array(p) + 0.0
            } else {
                guide.place(DVec3::from_array(p))
            };
            sink.dot(
                l,
                stamped[l],
                world.to_array().map(|c| c as f32),
                k.map(|c| c as f32),
            )?;
            stamped[l] += 1;
        }
        active.retain(|&l| stamped[l as usize] < quota[l as usize]);
    }
    if active.is_empty() {
        return Ok(restarts);
    }
    Err(Failure::new(
        "the flame's maps send almost every point out of the finite world (NaN or beyond 1e10)",
    )
    .with_help("scale the maps down, or give the diverging maps less weight"))
}
