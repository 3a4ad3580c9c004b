//! Certificates for the constants behind [`value_range`](super::value_range) and
//! [`lipschitz`](super::lipschitz).
//!
//! Perlin and simplex noise are sums over lattice corners of a weight times a ramp `g·d`,
//! where `d` is the offset from the corner and `g` one of the twelve edge gradients, picked
//! per corner by the hash. Corners pick independently, so the largest value any seed can
//! produce at a point is the *envelope* `Σ w·M(d)` with `M(d) = max_g g·d`, the sum of the two
//! largest `|dᵢ|`. The one key decision: certify the envelope, not the noise of some seeds, so
//! the constants hold for every seed at every point. Each certificate is a branch and bound
//! over the lattice cell: interval arithmetic encloses the envelope on a box, a box whose
//! enclosure is below the claimed bound is done, any other box is halved along its widest
//! side. The symmetries of the cube (reflections `f → 1 − f`, permutations of the axes) cut
//! the Perlin cell to `0 ≤ f_z ≤ f_y ≤ f_x ≤ ½`; the simplex cell is cut by the permutations.
//! Intervals are rounded to nearest, not outward: each enclosure is off by ~1e-15 relative,
//! far below the margins (≥ 0.3 %) left between the true suprema and the constants.
//!
//! For gradients, the envelope of the slope along a direction `u` is `D(f, u) = Σ M(A·u)`,
//! a convex and positively homogeneous function of `u`. Directions are covered by patches
//! of the three cube faces `v_a = 1` (enough, since `D(f, −u) = D(f, u)`); on a patch, `D`
//! is at most its largest value at the patch's corners, divided by the patch's smallest `|v|`.

use super::perlin::fade;
use super::simplex::{SCALE, UNSKEW};
use super::{PERLIN_BOUND, PERLIN_LIPSCHITZ, SIMPLEX_BOUND, SIMPLEX_LIPSCHITZ};
use rayon::prelude::*;

/// A closed interval `[lo, hi]`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Interval {
    lo: f64,
    hi: f64,
}

impl Interval {
    fn new(lo: f64, hi: f64) -> Interval {
        Interval { lo, hi }
    }
    fn point(v: f64) -> Interval {
        Interval { lo: v, hi: v }
    }
    fn mid(self) -> f64 {
        0.5 * (self.lo + self.hi)
    }
    fn width(self) -> f64 {
        self.hi - self.lo
    }
    fn abs(self) -> Interval {
        if self.lo >= 0.0 {
            self
        } else if self.hi <= 0.0 {
            Interval::new(-self.hi, -self.lo)
        } else {
            Interval::new(0.0, self.hi.max(-self.lo))
        }
    }
    fn square(self) -> Interval {
        let a = self.abs();
        Interval::new(a.lo * a.lo, a.hi * a.hi)
    }
    fn max(self, other: Interval) -> Interval {
        Interval::new(self.lo.max(other.lo), self.hi.max(other.hi))
    }
}

impl std::ops::Add for Interval {
    type Output = Interval;
    fn add(self, o: Interval) -> Interval {
        Interval::new(self.lo + o.lo, self.hi + o.hi)
    }
}

impl std::ops::Sub for Interval {
    type Output = Interval;
    fn sub(self, o: Interval) -> Interval {
        Interval::new(self.lo - o.hi, self.hi - o.lo)
    }
}

impl std::ops::Mul for Interval {
    type Output = Interval;
    fn mul(self, o: Interval) -> Interval {
        let p = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        Interval::new(
            p.iter().copied().fold(f64::INFINITY, f64::min),
            p.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    }
}

/// `M(d) = max_g g·d` over the twelve edge gradients: the largest sum of two `|dᵢ|`.
fn edge_envelope(d: [Interval; 3]) -> Interval {
    let a = d.map(Interval::abs);
    (a[0] + a[1]).max(a[0] + a[2]).max(a[1] + a[2])
}

/// Encloses the fade `s` and its slope `s'` on an interval of `[0, 1]`: `s` increases there,
/// `s'` increases up to ½ and decreases after.
fn fade_interval(t: Interval) -> (Interval, Interval) {
    let (s_lo, ds_lo, _) = fade(t.lo);
    let (s_hi, ds_hi, _) = fade(t.hi);
    let slope_hi = if t.lo < 0.5 && t.hi > 0.5 {
        fade(0.5).1
    } else {
        ds_lo.max(ds_hi)
    };
    (
        Interval::new(s_lo, s_hi),
        Interval::new(ds_lo.min(ds_hi), slope_hi),
    )
}

/// The Perlin envelope on a box of cell positions `f`: of the value (`direction` None) or of
/// the slope along `direction`, `Σ M((u·∇w)·d + w·u)`.
fn perlin_envelope(f: [Interval; 3], direction: Option<[f64; 3]>) -> Interval {
    let fades = f.map(fade_interval);
    let one = Interval::point(1.0);
    let mut total = Interval::point(0.0);
    for corner in 0..8 {
        let side = [corner & 1, (corner >> 1) & 1, corner >> 2];
        let mut weight = one;
        let mut weight_slope = [one; 3];
        let mut d = [Interval::point(0.0); 3];
        for axis in 0..3 {
            let (s, ds) = fades[axis];
            let (w, dw) = if side[axis] == 1 {
                (s, ds)
            } else {
                (one - s, Interval::point(0.0) - ds)
            };
            d[axis] = f[axis] - Interval::point(side[axis] as f64);
            for (other, slope) in weight_slope.iter_mut().enumerate() {
                *slope = *slope * if other == axis { dw } else { w };
            }
            weight = weight * w;
        }
        total = total
            + match direction {
                None => weight * edge_envelope(d),
                Some(u) => {
                    let u = u.map(Interval::point);
                    let along =
                        u[0] * weight_slope[0] + u[1] * weight_slope[1] + u[2] * weight_slope[2];
                    edge_envelope([0, 1, 2].map(|a| along * d[a] + weight * u[a]))
                }
            };
    }
    total
}

/// Offsets `p − c` from a box of skewed cell positions to the lattice point `c`, unskewed.
/// `p − c = unskew(t − c)` is linear in `t`, so each component is enclosed exactly.
fn simplex_offset(t: [Interval; 3], c: [i32; 3]) -> [Interval; 3] {
    let x = [0, 1, 2].map(|a| t[a] - Interval::point(c[a] as f64));
    [0, 1, 2].map(|a| {
        let mut sum = Interval::point(0.0);
        for (b, xb) in x.iter().enumerate() {
            let k = if a == b { 1.0 - UNSKEW } else { -UNSKEW };
            sum = sum + Interval::point(k) * *xb;
        }
        sum
    })
}

/// The lattice points whose kernel may reach a box of skewed positions in the unit cell.
/// Only `cᵢ ∈ {−1, 0, 1, 2}` can: `|unskew(x)|² = |x|² − (Σx)²/4 ≥ 2` as soon as some
/// `|xᵢ| ≥ 2`, far beyond the kernel radius² ½.
fn simplex_reach(t: &[Interval; 3]) -> Vec<[i32; 3]> {
    (0..64)
        .map(|n| [n % 4 - 1, (n / 4) % 4 - 1, n / 16 - 1])
        .filter(|&c| {
            let d = simplex_offset(*t, c);
            (d[0].square() + d[1].square() + d[2].square()).lo < 0.5
        })
        .collect()
}

/// The simplex value envelope `Σ (½ − |d|²)₊⁴·M(d)` (before `SCALE`) on a box of skewed
/// positions, and a bound on its gradient over the box: a term's gradient in space is
/// `−8q³M(d)·d + q⁴∇M` with `|∇M| ≤ √2`, so its length is at most `8q³M(d)|d| + √2q⁴`.
fn simplex_envelope(t: [Interval; 3], reach: &[[i32; 3]]) -> (Interval, f64) {
    let mut total = Interval::point(0.0);
    let mut slope = 0.0;
    for &c in reach {
        let d = simplex_offset(t, c);
        let r2 = d[0].square() + d[1].square() + d[2].square();
        if r2.lo >= 0.5 {
            continue;
        }
        let q = Interval::new((0.5 - r2.hi).max(0.0), 0.5 - r2.lo);
        let q2 = q * q;
        let m = edge_envelope(d);
        total = total + q2 * q2 * m;
        let q = q.hi;
        // Where q = 0 the term is flat, so |d|² beyond ½ never counts.
        let reach = r2.hi.min(0.5).sqrt();
        slope += 8.0 * q * q * q * m.hi * reach + std::f64::consts::SQRT_2 * q * q * q * q;
    }
    (total, slope)
}

/// An upper bound of the simplex gradient length (before `SCALE`) on a box of skewed
/// positions, and a bound on the gradient of that bound. A corner's slope along `u` is `g·y`
/// with `y = −8q³(u·d)·d + q⁴u`, and `|y|² = q⁶((u·d)²(64ρ − 16q) + q²)` with `ρ = |d|²`;
/// linear in `(u·d)² ∈ [0, ρ]`, so `|y| ≤ ψ(ρ) = q³·max(q, |8ρ − q|)`, and `g·y ≤ √2·|y|`.
/// `|ψ'(ρ)| ≤ 3q²|9ρ − ½| + 9q³` and `|∇ρ| = 2|d|` give the second number.
fn simplex_slope_envelope(t: [Interval; 3], reach: &[[i32; 3]]) -> (f64, f64) {
    let mut total = 0.0;
    let mut slope = 0.0;
    for &c in reach {
        let d = simplex_offset(t, c);
        let r2 = d[0].square() + d[1].square() + d[2].square();
        if r2.lo >= 0.5 {
            continue;
        }
        let (lo, hi) = (r2.lo, r2.hi.min(0.5));
        let q = 0.5 - lo;
        // |8ρ − q| = |9ρ − ½| is convex in ρ: largest at an end.
        let radial = (9.0 * lo - 0.5).abs().max((9.0 * hi - 0.5).abs());
        total += q * q * q * q.max(radial);
        slope += (3.0 * q * q * radial + 9.0 * q * q * q) * 2.0 * hi.sqrt();
    }
    (
        std::f64::consts::SQRT_2 * total,
        std::f64::consts::SQRT_2 * slope,
    )
}

/// The centre of a box, as a box of points.
fn centre<const N: usize>(b: &[Interval; N]) -> [Interval; N] {
    b.map(|i| Interval::point(i.mid()))
}

/// Half the diagonal of a box; bounds the distance from its centre in unskewed space too,
/// since unskewing shortens: `|unskew(x)|² = |x|² − (Σx)²/4`.
fn half_diagonal(b: &[Interval; 3]) -> f64 {
    0.5 * b.iter().map(|i| i.width() * i.width()).sum::<f64>().sqrt()
}

/// Perlin's value envelope `F` on a box: the smaller of the interval enclosure and the mean
/// value form `F(centre) + Σ Lᵢ·hᵢ`. Along x, `∂F = s'(f_x)·Σ w_y w_z (M(d₁) − M(d₀)) +
/// Σ w·∂M`; the two corners' `M` differ by at most `||f_x − 1| − |f_x|| = |1 − 2f_x|`, `M` has
/// slope at most 1 in each `|dᵢ|` and the weights sum to 1, so `Lₓ = s'(f_x)·|1 − 2f_x| + 1`.
fn perlin_value_upper(b: &[Interval; 3]) -> f64 {
    let enclosure = perlin_envelope(*b, None).hi;
    let at_centre = perlin_envelope(centre(b), None).hi;
    let mut spread = at_centre;
    for i in b {
        let (_, ds) = fade_interval(*i);
        let tilt = (1.0 - 2.0 * i.lo).abs().max((1.0 - 2.0 * i.hi).abs());
        spread += (ds.hi * tilt + 1.0) * 0.5 * i.width();
    }
    enclosure.min(spread)
}

/// Simplex's scaled value envelope on a box, as for Perlin with a gradient-length bound.
fn simplex_value_upper(b: &[Interval; 3], reach: &[[i32; 3]]) -> f64 {
    let (enclosure, slope) = simplex_envelope(*b, reach);
    let at_centre = simplex_envelope(centre(b), reach).0.hi;
    SCALE * enclosure.hi.min(at_centre + slope * half_diagonal(b))
}

/// Simplex's scaled gradient-length bound on a box.
fn simplex_slope_upper(b: &[Interval; 3], reach: &[[i32; 3]]) -> f64 {
    let (enclosure, slope) = simplex_slope_envelope(*b, reach);
    let at_centre = simplex_slope_envelope(centre(b), reach).0;
    SCALE * enclosure.min(at_centre + slope * half_diagonal(b))
}

/// The largest slope envelope over the unit directions of a face patch: `v` has `v[face] = 1`
/// and the other two coordinates in the given intervals.
fn slope_over_patch(envelope: impl Fn([f64; 3]) -> f64, face: usize, patch: [Interval; 2]) -> f64 {
    let mut nearest2 = 1.0;
    for side in patch {
        if side.lo > 0.0 {
            nearest2 += side.lo * side.lo;
        } else if side.hi < 0.0 {
            nearest2 += side.hi * side.hi;
        }
    }
    let mut largest: f64 = 0.0;
    for corner in 0..4 {
        let free = [
            if corner & 1 == 0 {
                patch[0].lo
            } else {
                patch[0].hi
            },
            if corner & 2 == 0 {
                patch[1].lo
            } else {
                patch[1].hi
            },
        ];
        let mut v = [1.0; 3];
        v[(face + 1) % 3] = free[0];
        v[(face + 2) % 3] = free[1];
        largest = largest.max(envelope(v));
    }
    largest / f64::sqrt(nearest2)
}

/// What a certificate run found.
#[derive(Debug)]
struct Certificate {
    boxes: usize,
    /// The largest enclosure upper bound at a box centre: a lower estimate of the supremum.
    largest_seen: f64,
}

/// Branch and bound: every box of `start` is split until `upper` of each piece is at most
/// `bound`. `prepare` makes the `upper` of one start box (so it can keep what holds on the
/// whole box, like the lattice points in reach). Boxes that `outside` rejects lie outside
/// the fundamental region and are dropped.
fn certify<const N: usize, U: Fn(&[Interval; N]) -> f64>(
    start: Vec<[Interval; N]>,
    bound: f64,
    prepare: impl Fn(&[Interval; N]) -> U + Sync,
    outside: impl Fn(&[Interval; N]) -> bool + Sync,
) -> Result<Certificate, String> {
    let results: Vec<Result<Certificate, String>> = start
        .into_par_iter()
        .filter(|b| !outside(b))
        .map(|b| {
            let upper = prepare(&b);
            let mut stack = vec![b];
            let mut found = Certificate {
                boxes: 0,
                largest_seen: 0.0,
            };
            while let Some(b) = stack.pop() {
                found.boxes += 1;
                if outside(&b) || upper(&b) <= bound {
                    continue;
                }
                found.largest_seen = found.largest_seen.max(upper(&centre(&b)));
                let widest = (0..N)
                    .max_by(|&i, &j| b[i].width().total_cmp(&b[j].width()))
                    .unwrap_or(0);
                if b[widest].width() < 1e-7 || found.boxes > 50_000_000 {
                    return Err(format!("bound {bound} not certified near {b:?}"));
                }
                let (mut low, mut high) = (b, b);
                low[widest].hi = b[widest].mid();
                high[widest].lo = b[widest].mid();
                stack.push(low);
                stack.push(high);
            }
            Ok(found)
        })
        .collect();
    let mut total = Certificate {
        boxes: 0,
        largest_seen: 0.0,
    };
    for r in results {
        let c = r?;
        total.boxes += c.boxes;
        total.largest_seen = total.largest_seen.max(c.largest_seen);
    }
    Ok(total)
}

/// The fundamental region of the cube's symmetries: `f_x ≥ f_y ≥ f_z`.
fn unordered(b: &[Interval]) -> bool {
    b[0].hi < b[1].lo || b[1].hi < b[2].lo
}

/// `pieces³` boxes tiling `[lo, hi]³`, so the search splits across threads.
fn tiles(lo: f64, hi: f64, pieces: usize) -> Vec<[Interval; 3]> {
    let step = (hi - lo) / pieces as f64;
    let edge = |i: usize| Interval::new(lo + i as f64 * step, lo + (i + 1) as f64 * step);
    (0..pieces * pieces * pieces)
        .map(|n| {
            [
                edge(n % pieces),
                edge(n / pieces % pieces),
                edge(n / pieces / pieces),
            ]
        })
        .collect()
}

#[test]
fn perlin_value_bound_is_certified() {
    let c = certify(
        tiles(0.0, 0.5, 4),
        PERLIN_BOUND,
        |_| perlin_value_upper,
        |b| unordered(b),
    )
    .unwrap();
    // The supremum, found by local search, is 1.03635 at f = (0.5, 0.5185, 0.3553).
    assert!(
        c.largest_seen > 1.036 && c.largest_seen < PERLIN_BOUND,
        "{c:?}"
    );
}

#[test]
fn simplex_value_bound_is_certified() {
    let c = certify(
        tiles(0.0, 1.0, 8),
        SIMPLEX_BOUND,
        |tile| {
            let reach = simplex_reach(tile);
            move |b: &[Interval; 3]| simplex_value_upper(b, &reach)
        },
        |b| unordered(b),
    )
    .unwrap();
    // The unscaled supremum is 0.0130072 (local search), so the scaled one is 0.98854.
    assert!(c.largest_seen > 0.988 && c.largest_seen < 0.9886, "{c:?}");
}

#[test]
fn simplex_lipschitz_is_certified() {
    let c = certify(
        tiles(0.0, 1.0, 8),
        SIMPLEX_LIPSCHITZ,
        |tile| {
            let reach = simplex_reach(tile);
            move |b: &[Interval; 3]| simplex_slope_upper(b, &reach)
        },
        |b| unordered(b),
    )
    .unwrap();
    // The bound's own supremum is 7.79 (grid search); the true largest slope is 6.89.
    assert!(
        c.largest_seen > 7.7 && c.largest_seen < SIMPLEX_LIPSCHITZ,
        "{c:?}"
    );
}

/// About 35 s on two threads in release: `cargo test --release --lib
/// field::noise::bounds -- --ignored`.
#[test]
#[ignore]
fn perlin_lipschitz_is_certified() {
    let halves = [Interval::new(-1.0, 0.0), Interval::new(0.0, 1.0)];
    let mut largest: f64 = 0.0;
    for face in 0..3 {
        // Position in the cell (three intervals), then the two free coordinates of v.
        let mut start = Vec::new();
        for cell in tiles(0.0, 0.5, 2) {
            for a in halves {
                for b in halves {
                    start.push([cell[0], cell[1], cell[2], a, b]);
                }
            }
        }
        let c = certify(
            start,
            PERLIN_LIPSCHITZ,
            |_| {
                |b: &[Interval; 5]| {
                    let f = [b[0], b[1], b[2]];
                    slope_over_patch(|v| perlin_envelope(f, Some(v)).hi, face, [b[3], b[4]])
                }
            },
            |b| unordered(b),
        )
        .unwrap();
        largest = largest.max(c.largest_seen);
    }
    // The largest slope is 3.75, along an axis at the cell centre.
    assert!(largest > 3.74 && largest < PERLIN_LIPSCHITZ, "{largest}");
}
