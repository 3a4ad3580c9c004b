//! Test fields with known answers: sums of constant-density balls whose interval
//! range is exact, and which count how many points they were asked to evaluate (and how many of
//! those fell inside a box the test declares off-limits, e.g. one that is certainly empty).

use super::path::majorant::Majorants;
use crate::base::test_random::SplitMix;
use crate::field::CompiledField;
use crate::space::{Aabb, BlockEval, FieldSampler};
use glam::DVec3;
use std::sync::atomic::{AtomicUsize, Ordering};

/// A ball of constant density.
#[derive(Clone, Copy, Debug)]
pub struct Ball {
    pub centre: DVec3,
    pub radius: f64,
    pub value: f64,
}

impl Ball {
    fn contains(&self, p: DVec3) -> bool {
        (p - self.centre).length_squared() <= self.radius * self.radius
    }

    fn touches(&self, region: &Aabb) -> bool {
        (self.centre.clamp(region.min, region.max) - self.centre).length() <= self.radius
    }

    fn bounds(&self) -> Aabb {
        let r = DVec3::splat(self.radius);
        Aabb::new(self.centre - r, self.centre + r)
    }
}

/// Sum of balls, replicated into `width` equal components (or scaled per component by `tint`).
pub struct Pieces {
    pub pieces: Vec<Ball>,
    pub tint: Vec<f64>,
    pub bounds: Option<Aabb>,
    pub forbidden: Option<Aabb>,
    pub evaluated: AtomicUsize,
    pub evaluated_forbidden: AtomicUsize,
}

impl Pieces {
    pub fn new(pieces: Vec<Ball>) -> Pieces {
        let bounds = pieces.iter().map(|p| p.bounds()).reduce(|a, b| a.union(&b));
        Pieces {
            pieces,
            tint: vec![1.0],
            bounds,
            forbidden: None,
            evaluated: AtomicUsize::new(0),
            evaluated_forbidden: AtomicUsize::new(0),
        }
    }

    pub fn forbidding(mut self, region: Aabb) -> Pieces {
        self.forbidden = Some(region);
        self
    }

    pub fn tinted(mut self, tint: &[f64]) -> Pieces {
        self.tint = tint.to_vec();
        self
    }

    pub fn value_at(&self, p: DVec3) -> f64 {
        self.pieces
            .iter()
            .filter(|q| q.contains(p))
            .map(|q| q.value)
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
        let mut forbidden = 0;
        for i in 0..n {
            let p = DVec3::new(xs[i], ys[i], zs[i]);
            let v = self.0.value_at(p);
            if self.0.forbidden.is_some_and(|f| f.contains(p)) {
                forbidden += 1;
            }
            for (c, t) in self.0.tint.iter().enumerate() {
                out[c * n + i] = v * t;
            }
        }
        self.0.evaluated.fetch_add(n, Ordering::Relaxed);
        self.0
            .evaluated_forbidden
            .fetch_add(forbidden, Ordering::Relaxed);
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
            .map(|p| p.value.max(0.0))
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

/// A scene of `density` alone (no colour, emission, holdout or motion) seen by `camera` under
/// `lights`: what most render tests draw.
pub fn plain_scene<'a>(
    density: &'a dyn crate::space::FieldSampler,
    camera: super::Camera,
    lights: Vec<super::Light>,
) -> super::Scene<'a> {
    super::Scene {
        density,
        color: None,
        emission: None,
        holdout: None,
        velocity: None,
        camera,
        lights,
    }
}

/// Checks the majorants' soundness for `field` over one random box (corner in
/// `[-1.2, lo_max]³`, sides 0.1 to 1.5, 1 to `max_cells` cells a side): at `points` points in
/// it, on its faces and at its corners, the density read in single precision (what the tracker
/// reads) is at most the bound of its cell.
pub fn check_majorants_over_a_random_box(
    field: &CompiledField,
    random: &mut SplitMix,
    lo_max: f64,
    max_cells: usize,
    points: usize,
    case: usize,
) {
    let lo = random.vector(-1.2, lo_max);
    let size = DVec3::new(
        random.range(0.1, 1.5),
        random.range(0.1, 1.5),
        random.range(0.1, 1.5),
    );
    let bounds = Aabb::new(lo, lo + size);
    let majorants = Majorants::build(field, None, bounds, 1 + random.below(max_cells)).unwrap();
    let mut eval = field.evaluator();
    let mut value = [0f32];
    for _ in 0..points {
        // Points anywhere in the box, and on its faces and corners.
        let mut p = bounds.min + size * DVec3::new(random.unit(), random.unit(), random.unit());
        for axis in 0..3 {
            match random.below(8) {
                0 => p[axis] = bounds.min[axis],
                1 => p[axis] = bounds.max[axis],
                _ => {}
            }
        }
        eval.eval_f32(&[p.x], &[p.y], &[p.z], &mut value);
        let bound = majorants.at(p);
        assert!(
            f64::from(value[0]) <= bound,
            "case {case}: density {} at {p} above its cell's bound {bound}",
            value[0]
        );
    }
}
