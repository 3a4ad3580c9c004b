//! Fields, domains and helpers shared by the cache tests.

use super::*;
use crate::space::{Aabb, BlockEval, FnField, GridSource, Interp};

pub(super) fn domain(origin: DVec3, lengths: DVec3, orientation: DVec3, cell: f64) -> Domain {
    Domain::with_cells(origin, lengths, orientation, cell, cell).unwrap()
}

pub(super) fn scalar_cache(
    domain: Domain,
    f: impl Fn(DVec3) -> f64 + Send + Sync + 'static,
) -> Cache {
    let field = FnField::new(1, move |p, out: &mut [f64]| out[0] = f(p));
    Cache::from_field(domain, 1, Arc::new(field), vec![0.0], "test".into()).unwrap()
}

/// Deterministic points spread over a box (a 3D additive recurrence, steps 1/g, 1/g², 1/g³
/// for g the real root of x⁴ = x + 1; the plastic number's powers, which serve in 2D, add up
/// to 1 in their last two, which would put every point on one family of planes).
pub(super) fn points_in(lo: DVec3, hi: DVec3, count: usize) -> Vec<DVec3> {
    let step = DVec3::new(0.819_172_513_4, 0.671_043_606_7, 0.549_700_477_9);
    (0..count)
        .map(|n| {
            let t = (step * (n as f64 + 0.5)).fract();
            lo + (hi - lo) * t
        })
        .collect()
}

pub(super) fn sample(cache: &Cache, interp: Interp, points: &[DVec3]) -> Vec<f64> {
    let xs: Vec<f64> = points.iter().map(|p| p.x).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.y).collect();
    let zs: Vec<f64> = points.iter().map(|p| p.z).collect();
    let mut out = vec![0.0; points.len() * cache.width()];
    cache.sample(interp, &xs, &ys, &zs, &mut out);
    out
}

pub(super) fn gradient(cache: &Cache, interp: Interp, points: &[DVec3]) -> Vec<f64> {
    let xs: Vec<f64> = points.iter().map(|p| p.x).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.y).collect();
    let zs: Vec<f64> = points.iter().map(|p| p.z).collect();
    let mut out = vec![0.0; points.len() * cache.width() * 3];
    cache.sample_gradient(interp, &xs, &ys, &zs, &mut out);
    out
}

/// Points inside an oriented domain, from its local frame.
pub(super) fn points_inside(d: &Domain, count: usize) -> Vec<DVec3> {
    points_in(DVec3::ZERO, d.lengths, count)
        .into_iter()
        .map(|local| d.local_to_world(local))
        .collect()
}

pub(super) fn all_cells(cache: &Cache) -> Vec<u32> {
    let [nx, ny, nz] = cache.resolution();
    let mut bits = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let value = cache.value_at_cell(i, j, k).unwrap();
                bits.extend(value.iter().map(|v| v.to_bits()));
            }
        }
    }
    bits
}

pub(super) fn busy_field(p: DVec3) -> f64 {
    (p.x * 7.1).sin() * (p.y * 5.3 + p.z).cos() + (p - DVec3::new(0.2, 0.1, -0.3)).length()
}

pub(super) fn busy_domain() -> Domain {
    Domain::with_cells(
        DVec3::new(-1.0, -0.8, -0.6),
        DVec3::new(2.0, 1.8, 1.4),
        DVec3::new(0.1, 0.2, -0.3),
        0.05,
        0.05,
    )
    .unwrap()
}

/// A ball of density with an exact interval form, as the field engine would provide.
pub(super) struct Ball {
    pub(super) centre: DVec3,
    pub(super) radius: f64,
}

impl Ball {
    pub(super) fn density(&self, p: DVec3) -> f64 {
        (1.0 - (p - self.centre).length() / self.radius).max(0.0)
    }
}

pub(super) struct BallEval<'a>(&'a Ball);

impl BlockEval for BallEval<'_> {
    fn eval_f32(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f32]) {
        for i in 0..xs.len() {
            out[i] = self.0.density(DVec3::new(xs[i], ys[i], zs[i])) as f32;
        }
    }

    fn eval_f64(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        for i in 0..xs.len() {
            out[i] = self.0.density(DVec3::new(xs[i], ys[i], zs[i]));
        }
    }
}

impl FieldSampler for Ball {
    fn width(&self) -> usize {
        1
    }

    fn evaluator(&self) -> Box<dyn BlockEval + '_> {
        Box::new(BallEval(self))
    }

    fn bounds(&self) -> Option<Aabb> {
        Some(Aabb::new(
            self.centre - self.radius,
            self.centre + self.radius,
        ))
    }

    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        let nearest = self.centre.clamp(region.min, region.max);
        let farthest = DVec3::select(
            (self.centre - region.min).cmpgt(region.max - self.centre),
            region.min,
            region.max,
        );
        let near = (nearest - self.centre).length();
        let far = (farthest - self.centre).length();
        vec![(
            (1.0 - far / self.radius).max(0.0),
            (1.0 - near / self.radius).max(0.0),
        )]
    }
}
