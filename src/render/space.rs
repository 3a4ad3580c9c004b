//! Empty-space skipping: which stretches of a ray can hold anything visible.
//!
//! The marched box is divided into a coarse grid of bricks, and each brick asks the fields for a
//! conservative range of their values over it (interval evaluation, `FieldSampler::range`). A
//! brick where density and emission are both certainly zero is empty; a ray walks the brick grid
//! (a 3D DDA) and is marched only over runs of possibly non-empty bricks. The one key decision:
//! the bricks are classified top-down, halving boxes whose range is not zero, so a large empty
//! region costs one range query rather than one per brick, and a field whose range is unknown
//! (a closure) simply leaves every brick occupied.

use super::camera::Ray;
use crate::space::{Aabb, FieldSampler};
use glam::DVec3;

/// The most bricks along one axis of the box.
const MAX_BRICKS_PER_AXIS: usize = 64;
/// A brick is at least this many march steps across, so a ray visits several samples per brick.
const MIN_STEPS_PER_BRICK: f64 = 4.0;

/// Where along a ray `[t0, t1]` it crosses `bounds`, if at all (slab test).
pub fn clip_to_box(ray: &Ray, bounds: &Aabb) -> Option<(f64, f64)> {
    let mut t0 = 0.0f64;
    let mut t1 = f64::INFINITY;
    for axis in 0..3 {
        let o = ray.origin[axis];
        let d = ray.direction[axis];
        let (lo, hi) = (bounds.min[axis], bounds.max[axis]);
        if d == 0.0 {
            if o < lo || o > hi {
                return None;
            }
            continue;
        }
        let (a, b) = ((lo - o) / d, (hi - o) / d);
        let (near, far) = if a < b { (a, b) } else { (b, a) };
        t0 = t0.max(near);
        t1 = t1.min(far);
    }
    (t0 < t1).then_some((t0, t1))
}

/// The brick grid over the marched box, each brick marked empty or occupied.
pub struct Occupancy {
    bounds: Aabb,
    counts: [usize; 3],
    brick: DVec3,
    occupied: Vec<bool>,
    /// Bricks proven empty.
    pub empty_bricks: usize,
    /// Range queries made to classify them.
    pub queries: usize,
}

/// How a region of the box stands: proven empty, proven to matter everywhere (a density
/// positive throughout), or neither.
#[derive(Clone, Copy, PartialEq)]
enum Standing {
    Empty,
    Mixed,
    Full,
}

/// May `field` be non-zero in `region`? Density counts only where positive (negative density is
/// treated as zero); any other field wherever its range is not exactly [0, 0].
fn may_matter(field: &dyn FieldSampler, region: &Aabb, positive_only: bool) -> bool {
    standing(field, region, positive_only) != Standing::Empty
}

/// As `may_matter`, also saying where a density is positive throughout `region`: every brick
/// inside it would be marked occupied, so none need be asked (an interval range holds the
/// field's values, so no sub-box of a box whose density is at least `lo > 0` is empty).
fn standing(field: &dyn FieldSampler, region: &Aabb, positive_only: bool) -> Standing {
    let ranges = field.range(region);
    let matters = ranges.iter().any(|&(lo, hi)| {
        let certainly_zero = if positive_only {
            hi <= 0.0
        } else {
            lo == 0.0 && hi == 0.0
        };
        !certainly_zero
    });
    if !matters {
        Standing::Empty
    } else if positive_only && ranges.iter().all(|&(lo, _)| lo > 0.0) {
        Standing::Full
    } else {
        Standing::Mixed
    }
}

impl Occupancy {
    /// Classifies the bricks of `bounds` for a march with steps of `step`.
    pub fn build(
        density: &dyn FieldSampler,
        emission: Option<&dyn FieldSampler>,
        bounds: Aabb,
        step: f64,
    ) -> Occupancy {
        let size = bounds.size();
        let mut counts = [1usize; 3];
        for (axis, count) in counts.iter_mut().enumerate() {
            let wanted = (size[axis] / (MIN_STEPS_PER_BRICK * step)).floor();
            *count = (wanted.max(1.0) as usize).min(MAX_BRICKS_PER_AXIS);
        }
        let brick = size / DVec3::new(counts[0] as f64, counts[1] as f64, counts[2] as f64);
        let mut grid = Occupancy {
            bounds,
            counts,
            brick,
            occupied: vec![false; counts[0] * counts[1] * counts[2]],
            empty_bricks: 0,
            queries: 0,
        };
        let matters = |region: &Aabb| match standing(density, region, true) {
            Standing::Empty if emission.is_some_and(|e| may_matter(e, region, false)) => {
                Standing::Mixed
            }
            density => density,
        };
        let mut leaves = Vec::new();
        grid.queries = classify(&grid, [0, 0, 0], counts, &matters, &mut leaves);
        for index in leaves {
            grid.occupied[index] = true;
        }
        grid.empty_bricks = grid.occupied.iter().filter(|o| !**o).count();
        grid
    }

    /// How many bricks the box is divided into.
    pub fn bricks(&self) -> usize {
        self.occupied.len()
    }

    fn region(&self, lo: [usize; 3], hi: [usize; 3]) -> Aabb {
        lattice_region(&self.bounds, self.brick, self.counts, lo, hi)
    }

    /// The runs of occupied bricks along `ray` within `[t0, t1]`, appended to `out` in order.
    #[cfg(test)]
    pub fn intervals(&self, ray: &Ray, t0: f64, t1: f64, out: &mut Vec<(f64, f64)>) {
        let mut walk = self.walk(ray, t0, t1);
        while let Some(run) = self.next_run(&mut walk) {
            out.push(run);
        }
    }

    /// A walk along `ray` over `[t0, t1]` that `next_run` takes one run at a time, so a ray
    /// that turns opaque in its first run never walks the bricks behind it.
    pub fn walk(&self, ray: &Ray, t0: f64, t1: f64) -> BrickWalk {
        let n = self.counts;
        let start = ray.at(t0);
        let mut cell = [0i64; 3];
        let mut t_next = [f64::INFINITY; 3];
        let mut t_delta = [f64::INFINITY; 3];
        let mut step = [0i64; 3];
        for axis in 0..3 {
            let local = (start[axis] - self.bounds.min[axis]) / self.brick[axis];
            let c = (local.floor() as i64).clamp(0, n[axis] as i64 - 1);
            cell[axis] = c;
            let d = ray.direction[axis];
            if d > 0.0 {
                step[axis] = 1;
                let edge = self.bounds.min[axis] + (c + 1) as f64 * self.brick[axis];
                t_next[axis] = t0 + (edge - start[axis]) / d;
                t_delta[axis] = self.brick[axis] / d;
            } else if d < 0.0 {
                step[axis] = -1;
                let edge = self.bounds.min[axis] + c as f64 * self.brick[axis];
                t_next[axis] = t0 + (edge - start[axis]) / d;
                t_delta[axis] = -self.brick[axis] / d;
            }
        }
        // The walk keeps the brick's flat index and, per axis, the bricks left before the
        // ray leaves the grid, so a step is a few adds.
        let stride = [1, n[0] as i64, (n[0] * n[1]) as i64];
        BrickWalk {
            t: t0,
            t1,
            t_next,
            t_delta,
            index: cell[0] + stride[1] * cell[1] + stride[2] * cell[2],
            index_step: [0, 1, 2].map(|a| step[a] * stride[a]),
            left: [0, 1, 2].map(|a| match step[a] {
                1 => n[a] as i64 - 1 - cell[a],
                -1 => cell[a],
                _ => i64::MAX,
            }),
            done: t0 >= t1,
        }
    }

    /// The walk's next run of occupied bricks `(begin, end)`, or `None` once it has left the
    /// box.
    pub fn next_run(&self, walk: &mut BrickWalk) -> Option<(f64, f64)> {
        let w = walk;
        let mut run: Option<f64> = None;
        while !w.done {
            // The axis to cross is picked without branches (the smallest `t_next`, the lowest
            // axis on ties), which the processor cannot predict along a ray.
            let first = usize::from(w.t_next[1] < w.t_next[0]);
            let axis = if w.t_next[2] < w.t_next[first] {
                2
            } else {
                first
            };
            let exit = w.t_next[axis].min(w.t1);
            if self.occupied[w.index as usize] {
                run.get_or_insert(w.t);
            } else if let Some(begin) = run.take()
                && w.t > begin
            {
                // The walk stays on this empty brick; the next call passes over it.
                return Some((begin, w.t));
            }
            w.t = exit;
            if w.t >= w.t1 {
                w.done = true;
            } else if w.left[axis] == 0 {
                // Leaving the brick grid is leaving the box, which `t1` marks exactly.
                w.t = w.t1;
                w.done = true;
            } else {
                w.left[axis] -= 1;
                w.index += w.index_step[axis];
                w.t_next[axis] += w.t_delta[axis];
            }
        }
        run.map(|begin| (begin, w.t.min(w.t1)))
            .filter(|&(begin, end)| end > begin)
    }
}

/// Where a ray's walk through the brick grid stands (see `Occupancy::walk`).
#[derive(Clone, Copy, Debug, Default)]
pub struct BrickWalk {
    t: f64,
    t1: f64,
    t_next: [f64; 3],
    t_delta: [f64; 3],
    index: i64,
    index_step: [i64; 3],
    left: [i64; 3],
    done: bool,
}

impl BrickWalk {
    /// A walk with nothing left: that of a ray that misses the box, or one that has stopped.
    pub fn spent() -> BrickWalk {
        BrickWalk {
            done: true,
            ..BrickWalk::default()
        }
    }
}

/// Top-down classification of the bricks in `[lo, hi)`: returns the range queries made and
/// appends the indices of occupied bricks to `leaves`.
fn classify(
    grid: &Occupancy,
    lo: [usize; 3],
    hi: [usize; 3],
    matters: &(dyn Fn(&Aabb) -> Standing + Sync),
    leaves: &mut Vec<usize>,
) -> usize {
    let standing = matters(&grid.region(lo, hi));
    if standing == Standing::Empty {
        return 1;
    }
    let extent = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    if extent == [1, 1, 1] || standing == Standing::Full {
        let n = grid.counts;
        for k in lo[2]..hi[2] {
            for j in lo[1]..hi[1] {
                leaves.extend((lo[0]..hi[0]).map(|i| i + n[0] * (j + n[1] * k)));
            }
        }
        return 1;
    }
    let axis = (0..3).max_by_key(|&a| (extent[a], 3 - a)).unwrap_or(0);
    let mid = lo[axis] + extent[axis] / 2;
    let (mut hi_a, mut lo_b) = (hi, lo);
    hi_a[axis] = mid;
    lo_b[axis] = mid;
    let mut right = Vec::new();
    let (qa, qb) = rayon::join(
        || classify(grid, lo, hi_a, matters, leaves),
        || classify(grid, lo_b, hi, matters, &mut right),
    );
    leaves.extend(right);
    1 + qa + qb
}

/// The box of cells `[lo, hi)` of a lattice of `counts` cells of size `cell` over `bounds`.
/// The last cell ends exactly on the box, not a rounding error short of it.
pub(super) fn lattice_region(
    bounds: &Aabb,
    cell: DVec3,
    counts: [usize; 3],
    lo: [usize; 3],
    hi: [usize; 3],
) -> Aabb {
    let at = |c: [usize; 3]| bounds.min + cell * DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
    let mut max = at(hi);
    for (axis, &h) in hi.iter().enumerate() {
        if h == counts[axis] {
            max[axis] = bounds.max[axis];
        }
    }
    Aabb::new(at(lo), max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::space::BlockEval;

    /// A ball of density whose range is exact on boxes: zero unless the box meets the ball.
    struct Balls(Vec<(DVec3, f64)>);

    impl FieldSampler for Balls {
        fn width(&self) -> usize {
            1
        }
        fn evaluator(&self) -> Box<dyn BlockEval + '_> {
            unimplemented!("classification never evaluates points")
        }
        fn bounds(&self) -> Option<Aabb> {
            None
        }
        fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
            let touches = self.0.iter().any(|&(c, r)| {
                let nearest = c.clamp(region.min, region.max);
                (nearest - c).length() <= r
            });
            vec![(0.0, if touches { 1.0 } else { 0.0 })]
        }
    }

    #[test]
    fn ray_box_clipping() {
        let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0));
        let ray = Ray {
            origin: DVec3::new(-5.0, 0.0, 0.0),
            direction: DVec3::X,
        };
        assert_eq!(clip_to_box(&ray, &b), Some((4.0, 6.0)));
        let inside = Ray {
            origin: DVec3::ZERO,
            direction: DVec3::new(0.0, 0.0, -1.0),
        };
        assert_eq!(clip_to_box(&inside, &b), Some((0.0, 1.0)));
        let miss = Ray {
            origin: DVec3::new(-5.0, 2.0, 0.0),
            direction: DVec3::X,
        };
        assert_eq!(clip_to_box(&miss, &b), None);
    }

    #[test]
    fn rays_skip_empty_bricks_between_two_balls() {
        let bounds = Aabb::new(DVec3::new(-4.0, -1.0, -1.0), DVec3::new(4.0, 1.0, 1.0));
        let balls = Balls(vec![
            (DVec3::new(-3.0, 0.0, 0.0), 0.5),
            (DVec3::new(3.0, 0.0, 0.0), 0.5),
        ]);
        let grid = Occupancy::build(&balls, None, bounds, 0.125 / 4.0);
        assert_eq!(grid.counts, [64, 16, 16]);
        assert!(grid.empty_bricks > grid.occupied.len() * 9 / 10);
        // Far fewer queries than bricks: empty halves are settled in one query.
        assert!(
            grid.queries < grid.occupied.len() / 4,
            "{} queries",
            grid.queries
        );
        let ray = Ray {
            origin: DVec3::new(-10.0, 0.01, 0.02),
            direction: DVec3::X,
        };
        let (t0, t1) = clip_to_box(&ray, &bounds).unwrap();
        let mut runs = Vec::new();
        grid.intervals(&ray, t0, t1, &mut runs);
        // Two runs, each covering its ball's chord [-3.5, -2.5] / [2.5, 3.5] (t = x + 10) to
        // within a brick of 0.125.
        assert_eq!(runs.len(), 2, "{runs:?}");
        for (&(a, b), centre) in runs.iter().zip([7.0, 13.0]) {
            assert!(a <= centre - 0.5 && a > centre - 0.5 - 0.13, "{a}");
            assert!(b >= centre + 0.5 && b < centre + 0.5 + 0.13, "{b}");
        }
        // The walk is lazy: having given the first run it stands on the empty brick just past
        // it, not across the empty bricks before the second ball; then it gives the second run,
        // then nothing. A spent walk gives nothing.
        let mut walk = grid.walk(&ray, t0, t1);
        assert_eq!(grid.next_run(&mut walk), Some(runs[0]));
        assert_eq!(walk.t, runs[0].1);
        assert!(!walk.done && walk.t < runs[1].0 - 4.0, "{walk:?}");
        assert_eq!(grid.next_run(&mut walk), Some(runs[1]));
        assert_eq!(grid.next_run(&mut walk), None);
        assert!(walk.done);
        assert_eq!(grid.next_run(&mut walk), None);
        assert_eq!(grid.next_run(&mut BrickWalk::spent()), None);
        // A diagonal ray through nothing but empty bricks gets no runs at all.
        let diagonal = Ray {
            origin: DVec3::new(-1.0, -2.0, -2.0),
            direction: DVec3::new(0.5, 1.0, 1.0).normalize(),
        };
        let (t0, t1) = clip_to_box(&diagonal, &bounds).unwrap();
        runs.clear();
        grid.intervals(&diagonal, t0, t1, &mut runs);
        assert!(runs.is_empty(), "{runs:?}");
    }

    #[test]
    fn unknown_range_leaves_one_run_over_the_whole_chord() {
        let field = crate::space::FnField::new(1, |_p: DVec3, out: &mut [f64]| out[0] = 1.0);
        let bounds = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0));
        let grid = Occupancy::build(&field, None, bounds, 0.01);
        assert_eq!(grid.empty_bricks, 0);
        let ray = Ray {
            origin: DVec3::new(-3.0, 0.3, -0.2),
            direction: DVec3::new(1.0, 0.1, 0.05).normalize(),
        };
        let (t0, t1) = clip_to_box(&ray, &bounds).unwrap();
        let mut runs = Vec::new();
        grid.intervals(&ray, t0, t1, &mut runs);
        assert_eq!(runs, vec![(t0, t1)]);
    }
}
