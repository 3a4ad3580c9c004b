//! Reading a grid at a block of points: the loop every grid kind shares.
//!
//! A grid kind (a brick cache, a dense solve result, a cache read that extrapolates) says how a
//! world point maps to its index coordinates and how it interpolates there; this module runs
//! that over a block of points, writes the component-major output the field evaluator expects,
//! and turns index-space slopes into world gradients. The one key decision: everything is
//! generic over the grid kind and the number of components, so each combination compiles to
//! its own tight loop, with no per-point dispatch.

use crate::space::Interp;
use glam::{DMat3, DVec3};

/// How one kind of grid reads a single point.
pub trait PointRead {
    /// Continuous index coordinates of a world point, or `None` where the grid reads its
    /// background (outside its box).
    fn index_of(&self, p: DVec3) -> Option<DVec3>;
    /// The interpolated value at index coordinates `u` and, when `GRADIENT`, its derivatives
    /// with respect to the index coordinates (added to `value` and `gradient`, which start at
    /// zero).
    fn read<const W: usize, const GRADIENT: bool>(
        &self,
        interp: Interp,
        u: DVec3,
        value: &mut [f64; W],
        gradient: &mut [[f64; 3]; W],
    );
    /// The value outside the box, per component.
    fn outside(&self) -> &[f64];
    /// The grid's axes in world space (columns) and the reciprocal of its cell size.
    fn placement(&self) -> (DMat3, DVec3);
}

/// Values at `xs.len()` world points, `out[c * n + i]`.
pub fn values<R: PointRead, const W: usize>(
    grid: &R,
    interp: Interp,
    xs: &[f64],
    ys: &[f64],
    zs: &[f64],
    out: &mut [f64],
) {
    let n = xs.len();
    let mut unused = [[0.0; 3]; W];
    for i in 0..n {
        let mut value = [0.0; W];
        match grid.index_of(DVec3::new(xs[i], ys[i], zs[i])) {
            Some(u) => grid.read::<W, false>(interp, u, &mut value, &mut unused),
            None => value.copy_from_slice(&grid.outside()[..W]),
        }
        for c in 0..W {
            out[c * n + i] = value[c];
        }
    }
}

/// World-space derivatives of the interpolant, `out[(c * 3 + j) * n + i]`; zero outside.
pub fn gradients<R: PointRead, const W: usize>(
    grid: &R,
    interp: Interp,
    xs: &[f64],
    ys: &[f64],
    zs: &[f64],
    out: &mut [f64],
) {
    let n = xs.len();
    // d(index u_a)/d(world x_j) = rotation[j][a] / cell_a: the chain rule through the grid's
    // placement, applied once per point to the index-space derivative.
    let (rotation, inverse_cell) = grid.placement();
    for i in 0..n {
        let mut value = [0.0; W];
        let mut gradient = [[0.0; 3]; W];
        if let Some(u) = grid.index_of(DVec3::new(xs[i], ys[i], zs[i])) {
            grid.read::<W, true>(interp, u, &mut value, &mut gradient);
        }
        for (c, g) in gradient.iter().enumerate() {
            let world = rotation * (DVec3::from_array(*g) * inverse_cell);
            for j in 0..3 {
                out[(c * 3 + j) * n + i] = world[j];
            }
        }
    }
}

/// [`values`] for a grid of `width` components (1, 3 or 9).
pub fn values_of<R: PointRead>(
    grid: &R,
    width: usize,
    interp: Interp,
    xs: &[f64],
    ys: &[f64],
    zs: &[f64],
    out: &mut [f64],
) {
    match width {
        1 => values::<R, 1>(grid, interp, xs, ys, zs, out),
        3 => values::<R, 3>(grid, interp, xs, ys, zs, out),
        _ => values::<R, 9>(grid, interp, xs, ys, zs, out),
    }
}

/// [`gradients`] for a grid of `width` components (1, 3 or 9).
pub fn gradients_of<R: PointRead>(
    grid: &R,
    width: usize,
    interp: Interp,
    xs: &[f64],
    ys: &[f64],
    zs: &[f64],
    out: &mut [f64],
) {
    match width {
        1 => gradients::<R, 1>(grid, interp, xs, ys, zs, out),
        3 => gradients::<R, 3>(grid, interp, xs, ys, zs, out),
        _ => gradients::<R, 9>(grid, interp, xs, ys, zs, out),
    }
}
