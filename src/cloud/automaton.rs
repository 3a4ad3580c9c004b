//! One state of the cloud automaton and the step to the next (seed 003, §2.3, eqs. 2.1–2.10).
//!
//! A step applies, in this order, to every cell at once:
//!
//! ```text
//! growth       hum₁ = hum ∧ ¬act      cld₁ = cld ∨ act      act₁ = ¬act ∧ hum ∧ f_act   (2.1–2.3)
//! f_act        act at x±1, x±2, z±1, z±2, y±1 and y−2 (y is up: nothing from y+2)      (2.4)
//! extinction   cld₂ = cld₁ ∧ ¬(r_ext < p_ext)                                          (2.5)
//! regeneration hum₂ = hum₁ ∨ (r_hum < p_hum)   act₂ = act₁ ∨ (r_act < p_act)           (2.6, 2.7)
//! wind         every bit of layer y moves by that layer's shift along x and z          (2.8–2.10)
//! ```
//!
//! Cells outside the domain read as empty in `f_act`. The draws `r` are hashes of (seed, step,
//! cell) taken at the cell's place before the wind moves it. The wind's shift for layer `y` at
//! step `s` is `⌊(s+1)·v_y⌋ − ⌊s·v_y⌋` cells for a speed `v_y` in cells per step, so slow winds
//! move a cell every few steps and the shift depends only on the step number. Bits that the
//! wind carries out of the domain are lost and empty cells enter (the source's eqs. 2.8–2.10),
//! or, with `wrap`, they enter again at the other side.

use super::bits::Planes;
use super::random::{self, ACT, EXT, HUM};
use super::region::Probabilities;
use crate::space::domain::Domain;
use rayon::prelude::*;
use std::fmt;
use std::sync::Arc;

/// Earlier `cld` planes a state keeps for smoothing over time.
pub const HISTORY: usize = 3;

/// Wind per height layer, in cells per step along the domain's x and z: `bottom` at the lowest
/// layer, `top` at the highest, linear between.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wind {
    pub bottom: [f64; 2],
    pub top: [f64; 2],
    pub wrap: bool,
}

impl Wind {
    pub const CALM: Wind = Wind {
        bottom: [0.0, 0.0],
        top: [0.0, 0.0],
        wrap: false,
    };

    /// Speed of layer `j` of `ny`, per axis (x, z).
    pub fn speed(&self, j: usize, ny: usize) -> [f64; 2] {
        let t = if ny > 1 {
            j as f64 / (ny - 1) as f64
        } else {
            0.0
        };
        [0, 1].map(|a| self.bottom[a] + (self.top[a] - self.bottom[a]) * t)
    }

    /// Whole cells layer `j` moves during step `step`, per axis (x, z).
    pub fn shift(&self, j: usize, ny: usize, step: u64) -> [i64; 2] {
        self.speed(j, ny).map(|v| {
            let s = step as f64;
            ((s + 1.0) * v).floor() as i64 - (s * v).floor() as i64
        })
    }
}

/// One state of the automaton over a domain's cells.
#[derive(Clone, Debug)]
pub struct CloudState {
    pub domain: Domain,
    pub planes: Planes,
    pub seed: u64,
    /// Steps taken since the initial state.
    pub step: u64,
    pub hum: Arc<Vec<u64>>,
    pub act: Arc<Vec<u64>>,
    pub cld: Arc<Vec<u64>>,
    /// `cld` of the previous states, newest first, at most `HISTORY`.
    pub history: Vec<Arc<Vec<u64>>>,
}

impl CloudState {
    /// The initial state: each bit set with its probability (`hum` from `p.hum`, `act` from
    /// `p.act`, `cld` from `p.ext`, read here as the initial cloud probability).
    pub fn initial(
        domain: Domain,
        resolution: [usize; 3],
        seed: u64,
        p: &Probabilities,
    ) -> CloudState {
        let planes = Planes::new(resolution);
        let mut hum = vec![0u64; planes.len()];
        let mut act = vec![0u64; planes.len()];
        let mut cld = vec![0u64; planes.len()];
        let words = planes.words;
        let slice = planes.ny * words;
        hum.par_chunks_mut(slice)
            .zip(act.par_chunks_mut(slice))
            .zip(cld.par_chunks_mut(slice))
            .enumerate()
            .for_each(|(k, ((hum, act), cld))| {
                for j in 0..planes.ny {
                    for w in 0..words {
                        let at = j * words + w;
                        let word = planes.row(j, k) * words + w;
                        let mask = planes.mask(w);
                        let candidates =
                            (p.hum.nonzero(word) | p.act.nonzero(word) | p.ext.nonzero(word))
                                & mask;
                        let (h, a, c) =
                            draws(&planes, seed, random::INITIAL, j, k, w, candidates, p);
                        hum[at] = h & p.hum.nonzero(word);
                        act[at] = a & p.act.nonzero(word);
                        cld[at] = c & p.ext.nonzero(word);
                    }
                }
            });
        CloudState {
            domain,
            planes,
            seed,
            step: 0,
            hum: Arc::new(hum),
            act: Arc::new(act),
            cld: Arc::new(cld),
            history: Vec::new(),
        }
    }

    /// The next state under probabilities `p` and `wind`.
    pub fn step(&self, p: &Probabilities, wind: &Wind) -> CloudState {
        let planes = self.planes;
        let (words, ny) = (planes.words, planes.ny);
        let slice = ny * words;
        let mut hum = vec![0u64; planes.len()];
        let mut act = vec![0u64; planes.len()];
        let mut cld = vec![0u64; planes.len()];
        let (hum0, act0, cld0) = (&self.hum[..], &self.act[..], &self.cld[..]);
        // Growth, extinction and regeneration, in place: slice k of the output from slices
        // k−2..k+2 of the input.
        hum.par_chunks_mut(slice)
            .zip(act.par_chunks_mut(slice))
            .zip(cld.par_chunks_mut(slice))
            .enumerate()
            .for_each(|(k, ((hum, act), cld))| {
                let mut neighbours = vec![0u64; words];
                let mut shifted = vec![0u64; words];
                for j in 0..ny {
                    let row = planes.row(j, k) * words;
                    let here = &act0[row..row + words];
                    // f_act: along x by shifts of the row itself, across rows by their words.
                    neighbours.fill(0);
                    for s in [-2, -1, 1, 2] {
                        planes.shift_row(here, s, false, &mut shifted);
                        for (n, s) in neighbours.iter_mut().zip(&shifted) {
                            *n |= s;
                        }
                    }
                    let mut across = |jj: Option<usize>, kk: Option<usize>| {
                        if let (Some(jj), Some(kk)) = (jj, kk)
                            && jj < ny
                            && kk < planes.nz
                        {
                            let r = planes.row(jj, kk) * words;
                            for (n, a) in neighbours.iter_mut().zip(&act0[r..r + words]) {
                                *n |= a;
                            }
                        }
                    };
                    across(j.checked_add(1), Some(k));
                    across(j.checked_sub(1), Some(k));
                    across(j.checked_sub(2), Some(k));
                    across(Some(j), k.checked_add(1));
                    across(Some(j), k.checked_sub(1));
                    across(Some(j), k.checked_add(2));
                    across(Some(j), k.checked_sub(2));
                    for w in 0..words {
                        let (h, a, c) = (hum0[row + w], act0[row + w], cld0[row + w]);
                        let hum1 = h & !a;
                        let cld1 = c | a;
                        let act1 = !a & h & neighbours[w];
                        let word = row + w;
                        let candidates = ((!hum1 & p.hum.nonzero(word))
                            | (!act1 & p.act.nonzero(word))
                            | (cld1 & p.ext.nonzero(word)))
                            & planes.mask(w);
                        let (rh, ra, re) =
                            draws(&planes, self.seed, self.step, j, k, w, candidates, p);
                        let at = j * words + w;
                        hum[at] = hum1 | rh;
                        act[at] = act1 | ra;
                        cld[at] = cld1 & !re;
                    }
                }
            });
        let moves = (0..ny).any(|j| wind.shift(j, ny, self.step) != [0, 0]);
        let (hum, act, cld) = if moves {
            (
                advect(&planes, &hum, wind, self.step),
                advect(&planes, &act, wind, self.step),
                advect(&planes, &cld, wind, self.step),
            )
        } else {
            (hum, act, cld)
        };
        let mut history = Vec::with_capacity(HISTORY);
        history.push(self.cld.clone());
        history.extend(self.history.iter().take(HISTORY - 1).cloned());
        CloudState {
            domain: self.domain.clone(),
            planes,
            seed: self.seed,
            step: self.step + 1,
            hum: Arc::new(hum),
            act: Arc::new(act),
            cld: Arc::new(cld),
            history,
        }
    }

    /// Set bits of `hum`, `act` and `cld`.
    pub fn counts(&self) -> [u64; 3] {
        [&self.hum, &self.act, &self.cld].map(|p| Planes::count(p))
    }

    /// `cld` now and before, newest first: up to `frames` planes.
    pub fn cloud_frames(&self, frames: usize) -> Vec<Arc<Vec<u64>>> {
        std::iter::once(&self.cld)
            .chain(self.history.iter())
            .take(frames)
            .cloned()
            .collect()
    }
}

/// The random events of one word of 64 cells: bits where humidity and activation are
/// regenerated and where clouds go extinct. Only `candidates` are drawn; the others are zero.
#[allow(clippy::too_many_arguments)]
#[inline]
fn draws(
    planes: &Planes,
    seed: u64,
    step: u64,
    j: usize,
    k: usize,
    w: usize,
    mut candidates: u64,
    p: &Probabilities,
) -> (u64, u64, u64) {
    let (mut hum, mut act, mut ext) = (0u64, 0u64, 0u64);
    let first = 64 * w + planes.nx * (j + planes.ny * k);
    let word = planes.row(j, k) * planes.words + w;
    while candidates != 0 {
        let b = candidates.trailing_zeros() as usize;
        candidates &= candidates - 1;
        let cell = first + b;
        let h = random::draw(seed, step, cell as u64);
        let bit = 1u64 << b;
        if random::fires(h, HUM, p.hum.at(word, b, cell)) {
            hum |= bit;
        }
        if random::fires(h, ACT, p.act.at(word, b, cell)) {
            act |= bit;
        }
        if random::fires(h, EXT, p.ext.at(word, b, cell)) {
            ext |= bit;
        }
    }
    (hum, act, ext)
}

/// A plane after one step of wind: row (j, k) of the result is row (j, k − s_z) of `plane`
/// moved s_x cells along x.
fn advect(planes: &Planes, plane: &[u64], wind: &Wind, step: u64) -> Vec<u64> {
    let (words, ny, nz) = (planes.words, planes.ny, planes.nz);
    let shifts: Vec<[i64; 2]> = (0..ny).map(|j| wind.shift(j, ny, step)).collect();
    let mut out = vec![0u64; plane.len()];
    out.par_chunks_mut(ny * words)
        .enumerate()
        .for_each(|(k, slice)| {
            for (j, [sx, sz]) in shifts.iter().copied().enumerate() {
                let from = k as i64 - sz;
                let from = if wind.wrap {
                    Some(from.rem_euclid(nz as i64) as usize)
                } else if (0..nz as i64).contains(&from) {
                    Some(from as usize)
                } else {
                    None
                };
                let Some(from) = from else { continue };
                let r = planes.row(j, from) * words;
                planes.shift_row(
                    &plane[r..r + words],
                    sx,
                    wind.wrap,
                    &mut slice[j * words..(j + 1) * words],
                );
            }
        });
    out
}

impl fmt::Display for CloudState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Planes { nx, ny, nz, .. } = self.planes;
        let [hum, act, cld] = self.counts();
        let total = self.planes.cells().max(1) as f64;
        write!(
            f,
            "cloudsim ({nx}x{ny}x{nz} cells, step {}, hum {:.1}%, act {:.1}%, cld {:.1}%)",
            self.step,
            100.0 * hum as f64 / total,
            100.0 * act as f64 / total,
            100.0 * cld as f64 / total
        )
    }
}
