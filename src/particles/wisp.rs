//! Wisps (seed 004, after Kaplan): dots from a seeded walk, pushed onto a noisy sphere around
//! each guide particle.
//!
//! Per dot: a walk step `X` (random, correlated or Lévy); the colour lookup point is `X`;
//! `P₀ = X/|X|` on the unit sphere (a zero `X` stays zero); `P₁ = P₀·|F₁(P₀)|^α` displaced
//! radially by the first noise field; `X = X₀ + (P₁ₓ N + P₁ᵧ r + P₁𝓏 t)·S` in the guide's
//! frame; `X += D(X)·S₂` by the vector noise; colour `C(X_colour)` by the third. Noise lookups
//! in the guide's own frame (F₁, C) add the guide's `offset`.
//!
//! The correlated walk's ε is the *correlation*, as the thesis's prose says (ε = 0.7 is "70%
//! correlated"): `x ← ε x + (1 − ε) v` with `v` uniform in the bi-unit cube, so ε = 0 is the
//! random walk and ε = 1 never moves. (The printed formula weights the other way.) The Lévy
//! walk then divides by `mag^q`, `mag = |x|²`, keeping the scaled point as its state, as
//! printed; a `mag` below 1e-30 is taken as 1e-30 so `mag = 0` stays finite.
//!
//! The key decision: a guide's walk is cut into chains of `CHAIN` dots, each with its own
//! random stream (seed, guide, chain); chains are independent units of parallel work and the
//! fields are evaluated over a chain's dots in fixed blocks, so the dots are the same for any
//! thread count. A chain starts with a fresh uniform point, as the walk itself starts.

use super::evaluate::{at_points, split};
use super::guide::Guide;
use super::random::Stream;
use super::{Particles, Values};
use crate::base::failure::{Failure, Outcome};
use crate::space::FieldSampler;
use glam::DVec3;
use rayon::prelude::*;

/// Dots per chain.
const CHAIN: usize = 4096;
/// Smallest `mag` the Lévy walk divides by.
const LEVY_FLOOR: f64 = 1e-30;

/// The walk that places a wisp's dots before they are pushed onto the sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Walk {
    Random,
    Correlated { epsilon: f64 },
    Levy { epsilon: f64, q: f64 },
}

impl Walk {
    pub fn new(name: &str, epsilon: f64, q: f64) -> Outcome<Walk> {
        let check_epsilon = || {
            if (0.0..=1.0).contains(&epsilon) {
                Ok(())
            } else {
                Err(Failure::new(format!(
                    "the walk's epsilon must be between 0 and 1, found {epsilon}"
                )))
            }
        };
        match name {
            "random" => Ok(Walk::Random),
            "correlated" => {
                check_epsilon()?;
                Ok(Walk::Correlated { epsilon })
            }
            "levy" => {
                check_epsilon()?;
                if !q.is_finite() {
                    return Err(Failure::new(format!(
                        "the Lévy walk's q must be finite, found {q}"
                    )));
                }
                Ok(Walk::Levy { epsilon, q })
            }
            other => Err(Failure::new(format!(
                "walk must be \"random\", \"correlated\" or \"levy\", found \"{other}\""
            ))),
        }
    }

    /// The next point of the walk from `x`.
    pub fn step(&self, x: [f64; 3], stream: &mut Stream) -> [f64; 3] {
        let v = stream.cube();
        match *self {
            Walk::Random => v,
            Walk::Correlated { epsilon } => blend(x, v, epsilon),
            Walk::Levy { epsilon, q } => {
                let y = blend(x, v, epsilon);
                let mag = (y[0] * y[0] + y[1] * y[1] + y[2] * y[2]).max(LEVY_FLOOR);
                let s = mag.powf(-q);
                let out = y.map(|c| c * s);
                if out.iter().all(|c| c.is_finite()) {
                    out
                } else {
                    v
                }
            }
        }
    }
}

fn blend(x: [f64; 3], v: [f64; 3], epsilon: f64) -> [f64; 3] {
    [0, 1, 2].map(|c| epsilon * x[c] + (1.0 - epsilon) * v[c])
}

/// The wisp's fields and exponent.
pub struct Settings<'a> {
    pub walk: Walk,
    /// F₁: radial displacement noise, read on the unit sphere.
    pub radial: Option<&'a dyn FieldSampler>,
    /// α.
    pub alpha: f64,
    /// D: vector displacement, read in world space.
    pub displace: Option<&'a dyn FieldSampler>,
    /// C: colour, read at the walk's point.
    pub color: Option<&'a dyn FieldSampler>,
}

/// `count` dots per guide.
pub fn generate(
    guides: &[Guide],
    count: usize,
    seed: u64,
    settings: &Settings,
) -> Outcome<Particles> {
    if !settings.alpha.is_finite() {
        return Err(Failure::new("the wisp's alpha must be finite"));
    }
    let dots = guides
        .len()
        .checked_mul(count)
        .ok_or_else(|| Failure::new("too many dots"))?;
    let widths: &[usize] = if settings.color.is_some() { &[3] } else { &[] };
    super::check_memory(dots, widths, "wisp dots")?;
    let mut lengths = Vec::new();
    let mut chains = Vec::new();
    for g in 0..guides.len() {
        for (c, start) in (0..count).step_by(CHAIN).enumerate() {
            lengths.push(CHAIN.min(count - start));
            chains.push((g, c));
        }
    }
    let mut positions = vec![[0f32; 3]; dots];
    let colored = settings.color.is_some();
    let mut colors = vec![[0f32; 3]; if colored { dots } else { 0 }];
    let color_lengths: Vec<usize> = lengths
        .iter()
        .map(|&n| if colored { n } else { 0 })
        .collect();
    split(&mut positions, &lengths)
        .into_par_iter()
        .zip(split(&mut colors, &color_lengths))
        .zip(chains.par_iter())
        .for_each(|((p, c), &(g, chain))| run_chain(&guides[g], g, chain, seed, settings, p, c));
    let mut set = Particles::new(positions);
    if settings.color.is_some() {
        set.set("Cd", Values::Vector(colors))?;
    }
    Ok(set)
}

fn run_chain(
    guide: &Guide,
    g: usize,
    chain: usize,
    seed: u64,
    settings: &Settings,
    positions: &mut [[f32; 3]],
    colors: &mut [[f32; 3]],
) {
    let n = positions.len();
    let mut stream = Stream::new(seed, ((g as u64) << 32) ^ chain as u64);
    let offset = guide.offset.to_array();
    let mut walk = Vec::with_capacity(n);
    let mut x = stream.cube();
    for _ in 0..n {
        x = settings.walk.step(x, &mut stream);
        walk.push(x);
    }
    let sphere: Vec<[f64; 3]> = walk
        .iter()
        .map(|p| {
            let len = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            if len > 0.0 {
                p.map(|c| c / len)
            } else {
                [0.0; 3]
            }
        })
        .collect();
    let mut values = Vec::new();
    let radius: Vec<f64> = match settings.radial {
        Some(f) => {
            let lookup: Vec<[f64; 3]> = sphere
                .iter()
                .map(|p| [p[0] + offset[0], p[1] + offset[1], p[2] + offset[2]])
                .collect();
            at_points(f.evaluator().as_mut(), 1, &lookup, &mut values);
            values
                .iter()
                .map(|&v| {
                    let r = (v as f64).abs().powf(settings.alpha);
                    if r.is_finite() { r } else { 0.0 }
                })
                .collect()
        }
        None => vec![1.0; n],
    };
    let mut world: Vec<[f64; 3]> = sphere
        .iter()
        .zip(&radius)
        .map(|(p, &r)| guide.place(DVec3::from_array(*p) * r).to_array())
        .collect();
    if let Some(d) = settings.displace {
        at_points(d.evaluator().as_mut(), 3, &world, &mut values);
        for (i, w) in world.iter_mut().enumerate() {
            for c in 0..3 {
                let moved = w[c] + values[i * 3 + c] as f64 * guide.scale2;
                if moved.is_finite() {
                    w[c] = moved;
                }
            }
        }
    }
    for (slot, w) in positions.iter_mut().zip(&world) {
        *slot = w.map(|c| c as f32);
    }
    if let Some(f) = settings.color {
        let lookup: Vec<[f64; 3]> = walk
            .iter()
            .map(|p| [p[0] + offset[0], p[1] + offset[1], p[2] + offset[2]])
            .collect();
        at_points(f.evaluator().as_mut(), 3, &lookup, &mut values);
        for (i, slot) in colors.iter_mut().enumerate() {
            *slot = [0, 1, 2].map(|c| {
                let v = values[i * 3 + c];
                if v.is_finite() { v } else { 0.0 }
            });
        }
    }
}
