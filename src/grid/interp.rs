//! Interpolation kernels for cell-centred grids, with their exact derivatives.
//!
//! A grid sample sits at each cell centre; in continuous *index* coordinates `u` the centre of
//! cell `i` is at `u = i`, and the domain box spans `u ∈ [-½, n - ½]`. Interpolation is a
//! tensor product of one-dimensional rules, so this module works one axis at a time and hands
//! the cache an [`AxisStencil`]: a run of at most four consecutive cells with a value weight and
//! a slope weight (derivative with respect to `u`) for each.
//!
//! The one key decision is what happens near the edges, where a stencil would need cells that do
//! not exist. Clamping (repeating the edge cell) would flatten every field at the boundary and
//! bend even a linear ramp. Instead:
//! - in the half-cell border between the outermost cell centre and the domain face, both rules
//!   extrapolate *linearly* from the two edge cells;
//! - the cubic rule, where its 4-cell stencil hangs one cell over the edge, uses a ghost sample
//!   made by linear extrapolation, `f(-1) = 2 f(0) - f(1)` (and the mirror image at the far
//!   end), folded into the weights of the real cells.
//!
//! Both choices are exact for linear data, so a cache of a linear field reproduces it (to the
//! `f32` rounding of the stored samples) everywhere in the domain box, with either rule. The
//! cubic rule and the border extrapolation meet with matching value and slope at the edge cell
//! centre, because the ghost makes the Catmull–Rom slope there equal `f(1) - f(0)`.
//! An axis with a single cell is constant along that axis.
//!
//! `Linear` is trilinear between the eight nearest centres (second-order accurate).
//! `Cubic` is Catmull–Rom, the Keys cubic convolution kernel with `a = -½`, over the 4×4×4
//! nearest centres: it reproduces quadratics exactly and is third-order accurate.

use crate::space::Interp;

/// One axis of an interpolation stencil: cells `start .. start + len` with their weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisStencil {
    /// First cell index along the axis.
    pub start: usize,
    /// Number of cells used (1 to 4).
    pub len: usize,
    /// Value weights; they sum to one.
    pub weight: [f64; 4],
    /// Derivative of the weights with respect to the index coordinate; they sum to zero.
    pub slope: [f64; 4],
}

/// Largest sum of absolute weights of one axis of the cubic rule between the outermost cell
/// centres (reached at `t = ½`: weights `-1/16, 9/16, 9/16, -1/16`). The ghost-folded edge
/// stencils stay below it (about 1.148), and the linear rule's sum is 1.
pub const CUBIC_WEIGHT_BOUND: f64 = 1.25;

/// The same bound in the half-cell border, where values are extrapolated: weights
/// `(1 - u, u)` with `u ≥ -½` sum in absolute value to at most 2.
pub const BORDER_WEIGHT_BOUND: f64 = 2.0;

/// Linear weights `(1 - t, t)` and their slopes.
#[inline]
pub fn linear_weights(t: f64) -> ([f64; 2], [f64; 2]) {
    ([1.0 - t, t], [-1.0, 1.0])
}

/// Catmull–Rom weights for the samples at offsets `-1, 0, 1, 2` from the cell at or below the
/// point, at fraction `t` past it, and their slopes.
#[inline]
pub fn catmull_rom_weights(t: f64) -> ([f64; 4], [f64; 4]) {
    let t2 = t * t;
    let t3 = t2 * t;
    let weight = [
        -0.5 * t3 + t2 - 0.5 * t,
        1.5 * t3 - 2.5 * t2 + 1.0,
        -1.5 * t3 + 2.0 * t2 + 0.5 * t,
        0.5 * t3 - 0.5 * t2,
    ];
    let slope = [
        -1.5 * t2 + 2.0 * t - 0.5,
        4.5 * t2 - 5.0 * t,
        -4.5 * t2 + 4.0 * t + 0.5,
        1.5 * t2 - t,
    ];
    (weight, slope)
}

/// The stencil along one axis of `cells` cells for index coordinate `u` (meant to lie in
/// `[-½, cells - ½]`; values beyond extrapolate linearly too).
#[inline(always)]
pub fn axis_stencil(interp: Interp, u: f64, cells: usize) -> AxisStencil {
    if cells <= 1 {
        return AxisStencil {
            start: 0,
            len: 1,
            weight: [1.0, 0.0, 0.0, 0.0],
            slope: [0.0; 4],
        };
    }
    let last = (cells - 1) as f64;
    // The cell at or below u, kept so that cell + 1 exists. Truncation is the floor for
    // u >= 0, and below zero the clamp wins anyway (`as` saturates, NaN becomes 0); it avoids
    // a library call for `floor` on targets without SSE4.1.
    // Through i64: x86 converts signed integers in one instruction, unsigned ones not.
    let cell = (u.max(0.0) as i64).min(cells as i64 - 2);
    let below = cell as usize;
    let t = u - cell as f64;
    let extrapolating = !(u >= 0.0 && u <= last);
    if interp == Interp::Linear || extrapolating {
        let (w, s) = linear_weights(t);
        return AxisStencil {
            start: below,
            len: 2,
            weight: [w[0], w[1], 0.0, 0.0],
            slope: [s[0], s[1], 0.0, 0.0],
        };
    }
    let (w, s) = catmull_rom_weights(t);
    if below >= 1 && below + 2 < cells {
        return AxisStencil {
            start: below - 1,
            len: 4,
            weight: w,
            slope: s,
        };
    }
    let len = cells.min(4);
    let start = below.saturating_sub(1).min(cells - len);
    let mut stencil = AxisStencil {
        start,
        len,
        weight: [0.0; 4],
        slope: [0.0; 4],
    };
    for offset in 0..4 {
        let logical = below as isize - 1 + offset as isize;
        // Ghost samples beyond the edge are 2 f(edge) - f(next in), spread onto those cells.
        let parts: [(usize, f64); 2] = if logical < 0 {
            [(0, 2.0), (1, -1.0)]
        } else if logical as usize >= cells {
            [(cells - 1, 2.0), (cells - 2, -1.0)]
        } else {
            [(logical as usize, 1.0), (logical as usize, 0.0)]
        };
        for (cell, factor) in parts {
            stencil.weight[cell - start] += factor * w[offset];
            stencil.slope[cell - start] += factor * s[offset];
        }
    }
    stencil
}

#[cfg(test)]
mod tests {
    use super::*;

    fn apply(stencil: &AxisStencil, f: impl Fn(f64) -> f64) -> (f64, f64) {
        let mut value = 0.0;
        let mut slope = 0.0;
        for k in 0..stencil.len {
            let sample = f((stencil.start + k) as f64);
            value += stencil.weight[k] * sample;
            slope += stencil.slope[k] * sample;
        }
        (value, slope)
    }

    fn positions(cells: usize) -> impl Iterator<Item = f64> {
        let steps = 97 * cells;
        (0..=steps).map(move |s| -0.5 + cells as f64 * s as f64 / steps as f64)
    }

    #[test]
    fn both_rules_reproduce_a_line_across_the_whole_box() {
        let line = |u: f64| 3.0 - 1.75 * u;
        for cells in [2, 3, 4, 5, 9] {
            for interp in [Interp::Linear, Interp::Cubic] {
                for u in positions(cells) {
                    let (value, slope) = apply(&axis_stencil(interp, u, cells), line);
                    assert!(
                        (value - line(u)).abs() < 1e-12,
                        "{interp:?} n={cells} u={u}"
                    );
                    assert!((slope + 1.75).abs() < 1e-12, "{interp:?} n={cells} u={u}");
                }
            }
        }
    }

    #[test]
    fn cubic_reproduces_a_parabola_between_interior_centres() {
        // Away from the ghosts the Keys kernel is exact for quadratics (its design property).
        let parabola = |u: f64| 0.5 * u * u - 2.0 * u + 1.0;
        let cells = 10;
        for u in positions(cells).filter(|u| (1.0..=8.0).contains(u)) {
            let (value, slope) = apply(&axis_stencil(Interp::Cubic, u, cells), parabola);
            assert!((value - parabola(u)).abs() < 1e-12);
            assert!((slope - (u - 2.0)).abs() < 1e-12);
        }
    }

    #[test]
    fn rules_pass_through_the_samples() {
        let data = [0.3, -1.2, 2.5, 0.7, 4.1, -0.6];
        let f = |u: f64| data[u as usize];
        for interp in [Interp::Linear, Interp::Cubic] {
            for (i, expected) in data.iter().enumerate() {
                let (value, _) = apply(&axis_stencil(interp, i as f64, data.len()), f);
                assert!((value - expected).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn slopes_match_differences_of_the_interpolant() {
        let data = [0.3, -1.2, 2.5, 0.7, 4.1, -0.6, 1.9];
        let f = |u: f64| data[u as usize];
        let h = 1e-6;
        for interp in [Interp::Linear, Interp::Cubic] {
            for u in positions(data.len()) {
                // Stay off the knots, where the slope jumps for the linear rule.
                if (u - u.round()).abs() < 2e-3 {
                    continue;
                }
                let at = |v: f64| apply(&axis_stencil(interp, v, data.len()), f).0;
                let difference = (at(u + h) - at(u - h)) / (2.0 * h);
                let (_, slope) = apply(&axis_stencil(interp, u, data.len()), f);
                assert!((slope - difference).abs() < 1e-6, "{interp:?} u={u}");
            }
        }
    }

    #[test]
    fn cubic_slope_is_continuous_at_the_edge_centres() {
        let data = [0.3, -1.2, 2.5, 0.7];
        let f = |u: f64| data[u as usize];
        let e = 1e-9;
        for edge in [0.0, 3.0] {
            let inside = if edge == 0.0 { edge + e } else { edge - e };
            let outside = if edge == 0.0 { edge - e } else { edge + e };
            let (v_in, s_in) = apply(&axis_stencil(Interp::Cubic, inside, 4), f);
            let (v_out, s_out) = apply(&axis_stencil(Interp::Cubic, outside, 4), f);
            assert!((v_in - v_out).abs() < 1e-7);
            assert!((s_in - s_out).abs() < 1e-7);
        }
    }

    #[test]
    fn weight_bounds_hold() {
        for cells in [2, 3, 4, 7] {
            for u in positions(cells) {
                let interior = u >= 0.0 && u <= (cells - 1) as f64;
                let bound = if interior {
                    CUBIC_WEIGHT_BOUND
                } else {
                    BORDER_WEIGHT_BOUND
                };
                for interp in [Interp::Linear, Interp::Cubic] {
                    let s = axis_stencil(interp, u, cells);
                    let sum: f64 = s.weight.iter().map(|w| w.abs()).sum();
                    assert!(sum <= bound + 1e-12, "{interp:?} n={cells} u={u} sum={sum}");
                    assert!(s.start + s.len <= cells);
                }
            }
        }
    }
}
