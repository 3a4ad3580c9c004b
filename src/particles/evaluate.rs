//! Evaluating fields at the points a generator makes, in blocks.
//!
//! The key decision: points are evaluated in the fixed blocks the caller hands over (never
//! regrouped by thread), so the `f32` noise inside a field sees the same block bases and gives
//! the same values whatever the thread count.

use crate::space::{BLOCK, BlockEval};

/// Values of a `width`-component field at `points`, point-major into `out`
/// (`out[i * width + c]`).
pub fn at_points(eval: &mut dyn BlockEval, width: usize, points: &[[f64; 3]], out: &mut Vec<f32>) {
    out.clear();
    out.resize(points.len() * width, 0.0);
    let mut xs = Vec::with_capacity(BLOCK);
    let mut ys = Vec::with_capacity(BLOCK);
    let mut zs = Vec::with_capacity(BLOCK);
    let mut values = vec![0f32; BLOCK * width];
    for (b, chunk) in points.chunks(BLOCK).enumerate() {
        xs.clear();
        ys.clear();
        zs.clear();
        for p in chunk {
            xs.push(p[0]);
            ys.push(p[1]);
            zs.push(p[2]);
        }
        let n = chunk.len();
        eval.eval_f32(&xs, &ys, &zs, &mut values[..n * width]);
        for i in 0..n {
            for c in 0..width {
                out[(b * BLOCK + i) * width + c] = values[c * n + i];
            }
        }
    }
}

/// Splits `values` into consecutive runs of the given lengths (which must add up to at most
/// its length).
pub fn split<'a, T>(mut values: &'a mut [T], lengths: &[usize]) -> Vec<&'a mut [T]> {
    let mut runs = Vec::with_capacity(lengths.len());
    for &n in lengths {
        let (head, tail) = values.split_at_mut(n);
        runs.push(head);
        values = tail;
    }
    runs
}
