//! Worley (cellular) noise F1: the distance from a point to the nearest feature point, with
//! one hashed feature point per lattice cell.
//!
//! The one key decision: the distance is capped at 1, `worley(p) = min(F1(p), 1)`. Searching
//! the 27 cells around a point finds every feature closer than 1 (anything outside that block
//! is at least one cell away), so the capped value is exactly the capped true F1, whichever
//! cell the point falls in: continuous across cell faces, with range exactly [0, 1] and
//! Lipschitz constant 1. An uncapped 27-cell search would instead jump where the nearest
//! feature lies outside the block. Where the cap holds (about 0.3% of space at worst, near
//! lattice corners) the gradient and Hessian are 0; elsewhere the gradient is the unit vector
//! `n = (p − f)/|p − f|` and the Hessian `(I − n nᵀ)/|p − f|`, both 0 at the feature itself.
//! Inverted (`1 − worley`) and Perlin-Worley forms are built from this at the field level.

use super::hash::{PRIME_X, PRIME_Y, PRIME_Z, axis_terms, corner};
use super::lattice::{Located, Real, Sample, select};

/// Bits per coordinate of a feature point inside its cell (positions on a 1/1024 grid).
const JITTER_BITS: u32 = 10;
const JITTER_MASK: u32 = (1 << JITTER_BITS) - 1;

/// Capped F1 noise at a located point.
#[inline(always)]
pub(crate) fn sample<R: Real, const G: bool, const H: bool>(p: Located<R>, key: u32) -> Sample<R> {
    let [x0, y0, z0] = axis_terms(p.cell);
    let xs = [x0.wrapping_sub(PRIME_X), x0, x0.wrapping_add(PRIME_X)];
    let ys = [y0.wrapping_sub(PRIME_Y), y0, y0.wrapping_add(PRIME_Y)];
    let zs = [z0.wrapping_sub(PRIME_Z), z0, z0.wrapping_add(PRIME_Z)];
    let unit = R::lit(1.0 / (1u32 << JITTER_BITS) as f64);
    let centre = R::lit(0.5 / (1u32 << JITTER_BITS) as f64);

    // Nearest feature so far, as the vector from it to p; starting at distance² 1 with a zero
    // vector is what makes the cap and its zero gradient fall out of the search.
    let mut best = R::ONE;
    let mut to_p = [R::ZERO; 3];
    let mut visit = |i: usize, j: usize, k: usize| {
        let h = corner(xs[i], ys[j], zs[k], key);
        let jitter = |shift: u32| R::from_i32(((h >> shift) & JITTER_MASK) as i32) * unit + centre;
        let v = [
            p.frac[0] - (R::from_i32(i as i32 - 1) + jitter(0)),
            p.frac[1] - (R::from_i32(j as i32 - 1) + jitter(JITTER_BITS)),
            p.frac[2] - (R::from_i32(k as i32 - 1) + jitter(2 * JITTER_BITS)),
        ];
        let d2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        let closer = d2 < best;
        best = select(closer, d2, best);
        to_p = [0, 1, 2].map(|axis| select(closer, v[axis], to_p[axis]));
    };
    // The 27 cells written out: a loop here would stay a loop inside the block loop, and
    // LLVM vectorises only innermost loops.
    macro_rules! row {
        ($j:literal, $k:literal) => {
            visit(0, $j, $k);
            visit(1, $j, $k);
            visit(2, $j, $k);
        };
    }
    row!(0, 0);
    row!(1, 0);
    row!(2, 0);
    row!(0, 1);
    row!(1, 1);
    row!(2, 1);
    row!(0, 2);
    row!(1, 2);
    row!(2, 2);

    let mut out = Sample::zero();
    let distance = best.sqrt();
    out.value = distance;
    if G || H {
        // Guard the feature point itself (d = 0): its derivatives are defined as 0.
        let has_direction = distance > R::ZERO;
        let inverse = select(has_direction, distance, R::ONE).recip();
        let inverse = select(has_direction, inverse, R::ZERO);
        let n = to_p.map(|c| c * inverse);
        out.gradient = n;
        if H {
            // Capped points have to_p = 0, hence n = 0, but I/d would not vanish: mask it.
            let curvature = select(best < R::ONE, inverse, R::ZERO);
            let pairs = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];
            for (slot, (a, b)) in pairs.into_iter().enumerate() {
                let identity = if a == b { R::ONE } else { R::ZERO };
                out.hessian[slot] = (identity - n[a] * n[b]) * curvature;
            }
        }
    }
    out
}
