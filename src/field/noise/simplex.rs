//! 3D simplex noise with exact first and second derivatives.
//!
//! Space is cut into tetrahedra by skewing the cube lattice along its main diagonal; a point
//! receives the radial kernels `(r² − |d|²)⁴·g·d` of the four corners of its tetrahedron, each
//! with a hashed cube-edge gradient `g`. The one key decision: the kernel radius is `r² = ½`,
//! the largest for which no lattice point outside a point's own tetrahedron can reach it, so
//! the sum over four corners is the whole sum and the noise is C² everywhere (the common
//! `r² = 0.6` leaves small seams). The sum is scaled by `SCALE`, so the value lies in
//! [-0.9886, 0.9886] and the gradient length is at most 6.9 (both certified in `bounds.rs`).

use super::hash::{PRIME_X, PRIME_Y, PRIME_Z, axis_terms, corner, edge_gradient};
use super::lattice::{Located, Real, Sample, select};

/// Skew factor from space to the simplex lattice: `x' = x + (x + y + z)·SKEW`.
pub(crate) const SKEW: f64 = 1.0 / 3.0;
/// Unskew factor back to space: `x = x' − (x' + y' + z')·UNSKEW`.
pub(crate) const UNSKEW: f64 = 1.0 / 6.0;
/// Kernel radius squared.
const RADIUS2: f64 = 0.5;
/// Brings the largest sum any gradient assignment can produce, 0.0130072 (`bounds.rs`), to
/// 0.98854: a round number just under its reciprocal 76.88, so the range stays inside [-1, 1].
pub(crate) const SCALE: f64 = 76.0;

/// Skews a point of space onto the simplex lattice.
#[inline(always)]
pub(crate) fn skew<R: Real>(p: [R; 3]) -> [R; 3] {
    let s = (p[0] + p[1] + p[2]) * R::lit(SKEW);
    [p[0] + s, p[1] + s, p[2] + s]
}

/// Simplex noise at a point located on the skewed lattice (`p.frac` is the skewed position
/// inside the skewed cube).
#[inline(always)]
pub(crate) fn sample<R: Real, const G: bool, const H: bool>(p: Located<R>, key: u32) -> Sample<R> {
    let [tx, ty, tz] = p.frac;
    // Which tetrahedron of the skewed cube: walk from corner 0 to corner (1,1,1) along the
    // axes in decreasing order of the fractional coordinates (ties go to the lower axis, so
    // exactly one order is chosen).
    let x_ge_y = tx >= ty;
    let x_ge_z = tx >= tz;
    let y_ge_z = ty >= tz;
    let first = [x_ge_y & x_ge_z, !x_ge_y & y_ge_z, !x_ge_z & !y_ge_z];
    let second = [x_ge_y | x_ge_z, !x_ge_y | y_ge_z, !x_ge_z | !y_ge_z];

    let [x0, y0, z0] = axis_terms(p.cell);
    let s = (tx + ty + tz) * R::lit(UNSKEW);
    let d0 = [tx - s, ty - s, tz - s];
    let base = [x0, y0, z0];

    // The four corners are four calls, not a loop: a loop here would stay a loop inside the
    // block loop, and LLVM vectorises only innermost loops.
    let mut out = Sample::zero();
    add_corner::<R, G, H>(&mut out, base, d0, [false; 3], 0.0, key);
    add_corner::<R, G, H>(&mut out, base, d0, first, 1.0, key);
    add_corner::<R, G, H>(&mut out, base, d0, second, 2.0, key);
    add_corner::<R, G, H>(&mut out, base, d0, [true; 3], 3.0, key);
    let scale = R::lit(SCALE);
    out.value = out.value * scale;
    for g in &mut out.gradient {
        *g = *g * scale;
    }
    for h in &mut out.hessian {
        *h = *h * scale;
    }
    out
}

/// Adds the kernel of one corner of the tetrahedron: the corner `c` steps (0 to 3) from the
/// cell's origin, along the axes marked in `step`.
#[inline(always)]
fn add_corner<R: Real, const G: bool, const H: bool>(
    out: &mut Sample<R>,
    base: [u32; 3],
    d0: [R; 3],
    step: [bool; 3],
    c: f64,
    key: u32,
) {
    let primes = [PRIME_X, PRIME_Y, PRIME_Z];
    let term = [0, 1, 2].map(|a| base[a].wrapping_add(if step[a] { primes[a] } else { 0 }));
    let d = [0, 1, 2].map(|a| d0[a] - select(step[a], R::ONE, R::ZERO) + R::lit(UNSKEW * c));
    let g: [R; 3] = edge_gradient(corner(term[0], term[1], term[2], key));
    let reach = R::lit(RADIUS2) - (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    let q = select(reach > R::ZERO, reach, R::ZERO);
    let q2 = q * q;
    let q4 = q2 * q2;
    let ramp = g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
    out.value = out.value + q4 * ramp;
    if !(G || H) {
        return;
    }
    // ∇(q⁴ a) = −8q³a·d + q⁴·g, since ∇q = −2d and ∇a = g.
    let q3 = q2 * q;
    let radial = R::lit(-8.0) * q3 * ramp;
    let [gx, gy, gz] = &mut out.gradient;
    *gx = *gx + radial * d[0] + q4 * g[0];
    *gy = *gy + radial * d[1] + q4 * g[1];
    *gz = *gz + radial * d[2] + q4 * g[2];
    if H {
        // ∂²/∂i∂j = 48q²a·dᵢdⱼ − 8q³(gᵢdⱼ + gⱼdᵢ) − 8q³a·δᵢⱼ.
        let curved = R::lit(48.0) * q2 * ramp;
        let cross = R::lit(-8.0) * q3;
        let entry = |i: usize, j: usize| {
            let h = curved * d[i] * d[j] + cross * (g[i] * d[j] + g[j] * d[i]);
            if i == j { h + radial } else { h }
        };
        let [xx, yy, zz, xy, xz, yz] = &mut out.hessian;
        *xx = *xx + entry(0, 0);
        *yy = *yy + entry(1, 1);
        *zz = *zz + entry(2, 2);
        *xy = *xy + entry(0, 1);
        *xz = *xz + entry(0, 2);
        *yz = *yz + entry(1, 2);
    }
}
