//! Reads of a sampled grid (a cache, a file, an FFT result) at the position given by the
//! kernel's three arguments: its value, or the gradient of its interpolant.
//!
//! The one key decision: a value read is differentiated through the interpolant's exact
//! gradient (a second read kernel), and only what the interpolants have piecewise (the
//! derivative of that gradient) or what the user asked for (`GridDerivative::Central`) is a
//! central difference, at one cell size.

use crate::base::failure::Outcome;
use crate::field::interval::{ALL, Interval};
use crate::field::kernel::{Central, FieldKernel, KernelAt, KernelBlock};
use crate::field::node::{self, NodeRef, Op};
use crate::field::program::Reg;
use crate::space::{Aabb, GridDerivative, GridSource, Interp};
use glam::DVec3;
use std::fmt;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

/// What a grid read gives.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Reading {
    /// The grid's components; the variant says how `grad` of this read is taken.
    Value(GridDerivative),
    /// Output `c * 3 + j`: d(component c)/dx_j of the interpolant.
    Gradient,
}

/// A read of `grid` with `interp`.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct GridRead {
    pub grid: SameGrid,
    pub interp: Interp,
    pub reading: Reading,
}

/// A grid compared and hashed by its identity, so that reads derive theirs.
#[derive(Clone, Debug)]
pub struct SameGrid(pub Arc<dyn GridSource>);

impl PartialEq for SameGrid {
    fn eq(&self, other: &SameGrid) -> bool {
        self.0.identity() == other.0.identity()
    }
}

impl Eq for SameGrid {}

impl Hash for SameGrid {
    fn hash<H: Hasher>(&self, state: &mut H) {
        self.0.identity().hash(state)
    }
}

impl GridRead {
    pub fn new(grid: Arc<dyn GridSource>, interp: Interp, reading: Reading) -> GridRead {
        GridRead {
            grid: SameGrid(grid),
            interp,
            reading,
        }
    }

    /// The grid read.
    pub fn grid(&self) -> &Arc<dyn GridSource> {
        &self.grid.0
    }

    /// Whether the read gives the grid's values (not its gradient).
    pub fn is_value(&self) -> bool {
        matches!(self.reading, Reading::Value(_))
    }
}

impl FieldKernel for GridRead {
    fn outputs(&self) -> usize {
        match self.reading {
            Reading::Value(_) => self.grid().width(),
            Reading::Gradient => self.grid().width() * 3,
        }
    }

    fn describe(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (label, interp) = (self.grid().label(), self.interp);
        match self.reading {
            Reading::Value(_) => write!(f, "read {label} {interp:?}"),
            Reading::Gradient => write!(f, "gradient of {label} {interp:?}"),
        }
    }

    fn run(&self, block: &mut KernelBlock<'_>, args: &[Reg], outs: &[Reg]) {
        let n = block.n;
        let row = |r| KernelBlock::row(block.regs, r, n);
        let (xs, ys, zs) = (row(args[0]), row(args[1]), row(args[2]));
        let out = &mut block.scratch.grid_out[..outs.len() * n];
        match self.reading {
            Reading::Value(_) => self.grid().sample(self.interp, xs, ys, zs, out),
            Reading::Gradient => self.grid().sample_gradient(self.interp, xs, ys, zs, out),
        }
        KernelBlock::store_rows(block.regs, outs, &block.scratch.grid_out, n);
    }

    fn scratch_rows(&self) -> usize {
        self.outputs()
    }

    fn difference_step(&self) -> f64 {
        self.grid().cell_size().min_element()
    }

    fn derivative(&self, at: &KernelAt<'_>) -> Outcome<Vec<Vec<NodeRef>>> {
        Ok(match self.reading {
            Reading::Value(GridDerivative::Interpolant) => {
                let gradient = node::mk(Op::Kernel(
                    Arc::new(GridRead {
                        reading: Reading::Gradient,
                        ..self.clone()
                    }),
                    at.args.to_vec(),
                ));
                (0..self.grid().width())
                    .map(|c| at.chain(&|k| node::output_of(&gradient, c * 3 + k)))
                    .collect()
            }
            // A read that asks for central differences, and the second derivative of a read
            // (the interpolants have it only piecewise): differences at one cell size.
            Reading::Value(GridDerivative::Central) | Reading::Gradient => {
                let central = Central::new(at.kernel, at.args, self.difference_step());
                (0..self.outputs())
                    .map(|o| at.chain(&|k| central.partial(o, k)))
                    .collect()
            }
        })
    }

    fn ranges(&self, args: &[Interval], held: bool, out: &mut [Interval]) {
        if !self.is_value() {
            out.fill(ALL);
            return;
        }
        let grid = self.grid();
        let region = Aabb::new(
            DVec3::new(args[0].lo, args[1].lo, args[2].lo),
            DVec3::new(args[0].hi, args[1].hi, args[2].hi),
        );
        let inside = region.intersection(&grid.bounds());
        let background = grid.background();
        let outside_possible =
            !(grid.bounds().contains(region.min) && grid.bounds().contains(region.max));
        let within = if inside.is_empty() {
            vec![]
        } else if held {
            grid.range_held(&inside, self.interp)
        } else {
            grid.range_read(&inside, self.interp)
        };
        for (c, o) in out.iter_mut().enumerate() {
            let mut r: Option<Interval> = within.get(c).map(|&(lo, hi)| Interval::new(lo, hi));
            if outside_possible || r.is_none() {
                let b = Interval::point(background.get(c).copied().unwrap_or(0.0));
                r = Some(r.map_or(b, |r| r.union(b)));
            }
            *o = r.unwrap_or(ALL);
        }
    }

    fn grid_read(&self) -> Option<&GridRead> {
        Some(self)
    }
}
