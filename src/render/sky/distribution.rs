//! A piecewise-constant density over the unit square, sampled by inverting its cumulative
//! distributions: the marginal over rows, then the conditional over the columns of the row
//! drawn (pbrt-v4 §A.5.6).
//!
//! The one key decision: the density is exactly constant over each cell and a sample is spread
//! uniformly within its cell, so `pdf(sample(u1, u2).point)` is the density of what `sample`
//! draws, to rounding, and an estimator `f/pdf` is unbiased for any `f` that is zero wherever
//! the weights are.

/// The weights of a grid of cells, `width` columns by `height` rows, with their sums.
#[derive(Clone, Debug)]
pub struct Distribution2D {
    width: usize,
    height: usize,
    /// Each row's cumulative sums, `width + 1` per row, starting at 0.
    conditional: Vec<f64>,
    /// The rows' cumulative sums, `height + 1`, starting at 0.
    marginal: Vec<f64>,
}

/// A point drawn from a [`Distribution2D`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drawn {
    /// Where in the unit square, `u` along a row, `v` down the rows.
    pub u: f64,
    pub v: f64,
    /// The density there with respect to area in the unit square.
    pub pdf: f64,
}

impl Distribution2D {
    /// The distribution proportional to `weights` (row by row, each finite and non-negative),
    /// or `None` when they add up to zero.
    pub fn new(width: usize, height: usize, weights: &[f64]) -> Option<Distribution2D> {
        debug_assert_eq!(weights.len(), width * height);
        let mut conditional = Vec::with_capacity((width + 1) * height);
        let mut marginal = Vec::with_capacity(height + 1);
        marginal.push(0.0);
        for row in weights.chunks_exact(width) {
            let mut sum = 0.0;
            conditional.push(0.0);
            for &w in row {
                sum += w.max(0.0);
                conditional.push(sum);
            }
            marginal.push(marginal[marginal.len() - 1] + sum);
        }
        let total = marginal[height];
        (total > 0.0 && total.is_finite()).then_some(Distribution2D {
            width,
            height,
            conditional,
            marginal,
        })
    }

    fn row(&self, y: usize) -> &[f64] {
        &self.conditional[y * (self.width + 1)..(y + 1) * (self.width + 1)]
    }

    /// A point drawn with density `pdf`, from two uniform numbers in [0, 1).
    pub fn sample(&self, u1: f64, u2: f64) -> Drawn {
        let (y, dv) = invert(&self.marginal, u2);
        let row = self.row(y);
        let (x, du) = invert(row, u1);
        let cell = (row[x + 1] - row[x]) / self.marginal[self.height];
        Drawn {
            u: (x as f64 + du) / self.width as f64,
            v: (y as f64 + dv) / self.height as f64,
            pdf: cell * (self.width * self.height) as f64,
        }
    }

    /// The density at `(u, v)` in the unit square.
    pub fn pdf(&self, u: f64, v: f64) -> f64 {
        let x = ((u * self.width as f64) as usize).min(self.width - 1);
        let y = ((v * self.height as f64) as usize).min(self.height - 1);
        let row = self.row(y);
        (row[x + 1] - row[x]) / self.marginal[self.height] * (self.width * self.height) as f64
    }
}

/// The cell whose share of the cumulative sums `sums` holds the fraction `u`, and where within
/// it (in [0, 1)); cells of zero weight are never chosen.
fn invert(sums: &[f64], u: f64) -> (usize, f64) {
    let cells = sums.len() - 1;
    let target = u * sums[cells];
    // The first cell whose upper sum exceeds the target; it has a positive weight.
    let i = sums[1..].partition_point(|&s| s <= target).min(cells - 1);
    let (lo, hi) = (sums[i], sums[i + 1]);
    let within = if hi > lo {
        ((target - lo) / (hi - lo)).clamp(0.0, 1.0 - f64::EPSILON)
    } else {
        0.5
    };
    (i, within)
}
