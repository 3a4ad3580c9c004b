//! Point-attribute fields (000 §3.6): each point adds a sphere of its attribute value, so
//! cloud parameters (amplitude, billow) can be painted onto the points of a base shape.
//!
//! The key decision: the sphere has a smooth profile, `K(s) = (1 − s²)³` for `s = d/radius
//! < 1` (0 beyond), so the field and its gradient are continuous, and `K(0) = 1` so a lone
//! point gives exactly its value at its centre. `"sum"` adds the spheres as the chapter
//! does; `"average"` divides by the summed weights (Σ aK / ΣK, 0 where no sphere reaches), a
//! blend of the nearby values that never exceeds them. Points are binned in a uniform hash
//! grid of cell `radius`, so a lookup visits the 27 cells around it. The field is exposed as
//! a grid source, so it composes with every other field and is bounded by the points' box.

use super::Particles;
use crate::base::failure::{Failure, Outcome};
use crate::space::{Aabb, GridSource, Interp};
use glam::DVec3;
use std::collections::HashMap;
use std::fmt;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Blend {
    Sum,
    Average,
}

impl Blend {
    pub fn parse(name: &str) -> Outcome<Blend> {
        match name {
            "sum" => Ok(Blend::Sum),
            "average" => Ok(Blend::Average),
            other => Err(Failure::new(format!(
                "mode must be \"sum\" or \"average\", found \"{other}\""
            ))),
        }
    }
}

/// The spheres of one attribute.
pub struct PointField {
    centres: Vec<DVec3>,
    /// `width` values per point.
    values: Vec<f64>,
    width: usize,
    radius: f64,
    blend: Blend,
    bins: HashMap<[i64; 3], Vec<u32>>,
    bounds: Aabb,
    identity: u64,
    label: String,
}

impl fmt::Debug for PointField {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.label)
    }
}

/// The smooth sphere profile and its derivative with respect to `s²`.
fn kernel(s2: f64) -> (f64, f64) {
    if s2 >= 1.0 {
        return (0.0, 0.0);
    }
    let t = 1.0 - s2;
    (t * t * t, -3.0 * t * t)
}

impl PointField {
    pub fn new(
        particles: &Particles,
        attribute: &str,
        radius: f64,
        blend: Blend,
    ) -> Outcome<PointField> {
        if !(radius.is_finite() && radius > 0.0) {
            return Err(Failure::new(format!(
                "pointfield radius must be a positive length, found {radius}"
            )));
        }
        particles.check_finite("pointfield")?;
        let (width, values): (usize, Vec<f64>) = match particles.require(attribute)? {
            super::Values::Float(v) => (1, v.iter().map(|&x| x as f64).collect()),
            super::Values::Vector(v) => (3, v.iter().flatten().map(|&x| x as f64).collect()),
        };
        if particles.len() > u32::MAX as usize {
            return Err(Failure::new("pointfield takes at most 4 billion points"));
        }
        crate::engine::budget::check(
            particles.len() as f64 * (24.0 + 8.0 * width as f64 + 16.0),
            "a pointfield",
        )?;
        let centres: Vec<DVec3> = particles
            .positions
            .iter()
            .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
            .collect();
        let mut bins: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for (i, c) in centres.iter().enumerate() {
            bins.entry(bin_of(*c, radius)).or_default().push(i as u32);
        }
        let bounds = match particles.bounds() {
            Some((lo, hi)) => Aabb::new(
                DVec3::from_array(lo.map(|c| c as f64)) - DVec3::splat(radius),
                DVec3::from_array(hi.map(|c| c as f64)) + DVec3::splat(radius),
            ),
            None => Aabb::new(DVec3::ZERO, DVec3::ZERO),
        };
        Ok(PointField {
            centres,
            values,
            width,
            radius,
            blend,
            bins,
            bounds,
            identity: crate::grid::next_identity(),
            label: format!(
                "pointfield of \"{attribute}\" over {} points",
                particles.len()
            ),
        })
    }

    /// Value (and, when asked, gradient `d value_c / dx_j` at `c * 3 + j`) at `p`.
    fn at(&self, p: DVec3, value: &mut [f64], gradient: Option<&mut [f64]>) {
        let w = self.width;
        let mut sum = [0.0f64; 3];
        let mut dsum = [DVec3::ZERO; 3];
        let mut weight = 0.0f64;
        let mut dweight = DVec3::ZERO;
        let inv_r2 = 1.0 / (self.radius * self.radius);
        let home = bin_of(p, self.radius);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let Some(points) = self.bins.get(&[home[0] + dx, home[1] + dy, home[2] + dz])
                    else {
                        continue;
                    };
                    for &i in points {
                        let d = p - self.centres[i as usize];
                        let (k, dk) = kernel(d.length_squared() * inv_r2);
                        if k == 0.0 {
                            continue;
                        }
                        // d K / d p = dK/ds² · 2 d / r².
                        let grad_k = d * (2.0 * dk * inv_r2);
                        weight += k;
                        dweight += grad_k;
                        for c in 0..w {
                            let a = self.values[i as usize * w + c];
                            sum[c] += a * k;
                            dsum[c] += grad_k * a;
                        }
                    }
                }
            }
        }
        let average = self.blend == Blend::Average;
        for c in 0..w {
            value[c] = if !average {
                sum[c]
            } else if weight > 0.0 {
                sum[c] / weight
            } else {
                0.0
            };
        }
        if let Some(g) = gradient {
            for c in 0..w {
                let d = if !average {
                    dsum[c]
                } else if weight > 0.0 {
                    (dsum[c] * weight - dweight * sum[c]) / (weight * weight)
                } else {
                    DVec3::ZERO
                };
                g[c * 3..c * 3 + 3].copy_from_slice(&d.to_array());
            }
        }
    }
}

fn bin_of(p: DVec3, radius: f64) -> [i64; 3] {
    (p / radius).floor().to_array().map(|c| c as i64)
}

impl GridSource for PointField {
    fn width(&self) -> usize {
        self.width
    }

    fn identity(&self) -> u64 {
        self.identity
    }

    fn label(&self) -> String {
        self.label.clone()
    }

    fn sample(&self, _: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        let n = xs.len();
        let mut v = [0.0; 3];
        for i in 0..n {
            self.at(DVec3::new(xs[i], ys[i], zs[i]), &mut v, None);
            for c in 0..self.width {
                out[c * n + i] = v[c];
            }
        }
    }

    fn sample_gradient(&self, _: Interp, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        let n = xs.len();
        let (mut v, mut g) = ([0.0; 3], [0.0; 9]);
        for i in 0..n {
            self.at(DVec3::new(xs[i], ys[i], zs[i]), &mut v, Some(&mut g));
            for k in 0..self.width * 3 {
                out[k * n + i] = g[k];
            }
        }
    }

    fn bounds(&self) -> Aabb {
        self.bounds
    }

    fn background(&self) -> Vec<f64> {
        vec![0.0; self.width]
    }

    fn cell_size(&self) -> DVec3 {
        DVec3::splat(self.radius / 4.0)
    }

    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        // Every point whose sphere can reach the region contributes at most its value.
        let grown = Aabb::new(
            region.min - DVec3::splat(self.radius),
            region.max + DVec3::splat(self.radius),
        );
        let mut ranges = vec![(0.0f64, 0.0f64); self.width];
        let mut extremes = vec![(f64::INFINITY, f64::NEG_INFINITY); self.width];
        let mut any = false;
        for (i, c) in self.centres.iter().enumerate() {
            if !grown.contains(*c) {
                continue;
            }
            any = true;
            for k in 0..self.width {
                let a = self.values[i * self.width + k];
                ranges[k].0 += a.min(0.0);
                ranges[k].1 += a.max(0.0);
                extremes[k] = (extremes[k].0.min(a), extremes[k].1.max(a));
            }
        }
        if !any {
            return vec![(0.0, 0.0); self.width];
        }
        match self.blend {
            Blend::Sum => ranges,
            Blend::Average => extremes
                .into_iter()
                .map(|(lo, hi)| (lo.min(0.0), hi.max(0.0)))
                .collect(),
        }
    }
}
