//! Test fields with known answers: unions of constant-density balls and boxes whose interval
//! range is exact, and which count how many points they were asked to evaluate (and how many of
//! those fell where the field is certainly empty).

use crate::sample::{Aabb, BlockEval, FieldSampler};
use glam::DVec3;
use std::sync::atomic::{AtomicUsize, Ordering};

/// A piece of constant density.
#[derive(Clone, Copy, Debug)]
pub enum Piece {
    Ball {
        centre: DVec3,
        radius: f64,
        value: f64,
    },
    Box {
        min: DVec3,
        max: DVec3,
        value: f64,
    },
}

impl Piece {
    fn contains(&self, p: DVec3) -> bool {
        match *self {
            Piece::Ball { centre, radius, .. } => (p - centre).length_squared() <= radius * radius,
            Piece::Box { min, max, .. } => p.cmpge(min).all() && p.cmple(max).all(),
        }
    }

    fn touches(&self, region: &Aabb) -> bool {
        match *self {
            Piece::Ball { centre, radius, .. } => {
                (centre.clamp(region.min, region.max) - centre).length() <= radius
            }
            Piece::Box { min, max, .. } => !Aabb::new(min, max).intersection(region).is_empty(),
        }
    }

    fn value(&self) -> f64 {
        match *self {
            Piece::Ball { value, .. } | Piece::Box { value, .. } => value,
        }
    }

    fn bounds(&self) -> Aabb {
        match *self {
            Piece::Ball { centre, radius, .. } => {
                Aabb::new(centre - DVec3::splat(radius), centre + DVec3::splat(radius))
            }
            Piece::Box { min, max, .. } => Aabb::new(min, max),
        }
    }
}

/// Sum of pieces, replicated into `width` equal components (or scaled per component by `tint`).
pub struct Pieces {
    pub pieces: Vec<Piece>,
    pub tint: Vec<f64>,
    pub bounds: Option<Aabb>,
    pub evaluated: AtomicUsize,
    pub evaluated_empty: AtomicUsize,
}

impl Pieces {
    pub fn new(pieces: Vec<Piece>) -> Pieces {
        let bounds = pieces.iter().map(|p| p.bounds()).reduce(|a, b| a.union(&b));
        Pieces {
            pieces,
            tint: vec![1.0],
            bounds,
            evaluated: AtomicUsize::new(0),
            evaluated_empty: AtomicUsize::new(0),
        }
    }

    pub fn tinted(mut self, tint: &[f64]) -> Pieces {
        self.tint = tint.to_vec();
        self
    }

    pub fn value_at(&self, p: DVec3) -> f64 {
        self.pieces
            .iter()
            .filter(|q| q.contains(p))
            .map(|q| q.value())
            .sum()
    }
}

struct PiecesEval<'a>(&'a Pieces);

impl BlockEval for PiecesEval<'_> {
    fn eval_f32(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f32]) {
        let n = xs.len();
        let mut buffer = vec![0f64; out.len()];
        self.eval_f64(xs, ys, zs, &mut buffer);
        for (o, v) in out[..n * self.0.tint.len()].iter_mut().zip(&buffer) {
            *o = *v as f32;
        }
    }

    fn eval_f64(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        let n = xs.len();
        let mut empty = 0;
        for i in 0..n {
            let v = self.0.value_at(DVec3::new(xs[i], ys[i], zs[i]));
            if v == 0.0 {
                empty += 1;
            }
            for (c, t) in self.0.tint.iter().enumerate() {
                out[c * n + i] = v * t;
            }
        }
        self.0.evaluated.fetch_add(n, Ordering::Relaxed);
        self.0.evaluated_empty.fetch_add(empty, Ordering::Relaxed);
    }
}

impl FieldSampler for Pieces {
    fn width(&self) -> usize {
        self.tint.len()
    }

    fn evaluator(&self) -> Box<dyn BlockEval + '_> {
        Box::new(PiecesEval(self))
    }

    fn bounds(&self) -> Option<Aabb> {
        self.bounds
    }

    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        let hi: f64 = self
            .pieces
            .iter()
            .filter(|p| p.touches(region))
            .map(|p| p.value().max(0.0))
            .sum();
        self.tint.iter().map(|t| (0.0, hi * t)).collect()
    }
}

/// Length of the part of the ray `origin + t·dir`, `t >= 0`, inside the ball.
pub fn chord_in_ball(origin: DVec3, dir: DVec3, centre: DVec3, radius: f64) -> f64 {
    let oc = origin - centre;
    let b = oc.dot(dir);
    let c = oc.length_squared() - radius * radius;
    let disc = b * b - c;
    if disc <= 0.0 {
        return 0.0;
    }
    let root = disc.sqrt();
    let (t0, t1) = ((-b - root).max(0.0), -b + root);
    (t1 - t0).max(0.0)
}
