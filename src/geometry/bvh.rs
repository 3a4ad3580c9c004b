//! A bounding-volume hierarchy over a mesh's triangles, and the nearest-triangle query on it.
//!
//! Built once per mesh by splitting at the median centroid along the longest axis, down to
//! leaves of at most `LEAF` triangles. The one key decision: the triangles are stored in tree
//! order, each as its three corners, so that every node covers one contiguous run of them —
//! a leaf test reads consecutive memory, and the winding-number moments of any node can be
//! computed straight from its run.

use glam::DVec3;

/// The most triangles in a leaf.
const LEAF: usize = 8;

/// A box and a run of triangles `first..first + count`. An inner node's children are the
/// nodes `child` and `child + 1`; a leaf has `child == 0` (the root is never a child).
#[derive(Clone, Copy, Debug)]
pub struct Node {
    pub min: DVec3,
    pub max: DVec3,
    pub first: u32,
    pub count: u32,
    pub child: u32,
}

impl Node {
    pub fn is_leaf(&self) -> bool {
        self.child == 0
    }

    pub fn run(&self) -> std::ops::Range<usize> {
        self.first as usize..(self.first + self.count) as usize
    }

    /// Squared distance from `p` to the box (zero inside).
    pub fn distance_squared(&self, p: DVec3) -> f64 {
        let d = (self.min - p).max(p - self.max).max(DVec3::ZERO);
        d.length_squared()
    }
}

pub struct Bvh {
    pub nodes: Vec<Node>,
    /// Triangle corners in tree order.
    pub triangles: Vec<[DVec3; 3]>,
    /// For each triangle in tree order, its index in the mesh it was built from.
    pub order: Vec<u32>,
    /// Cheap lower bounds on each triangle's distance, tried before the exact one.
    bounds: Vec<TriangleBound>,
    /// The largest coordinate magnitude of the mesh, for the size of rounding errors.
    magnitude: f64,
}

impl Bvh {
    /// The tree over `triangles` (at least one).
    pub fn new(mut triangles: Vec<[DVec3; 3]>) -> Bvh {
        let centroids: Vec<DVec3> = triangles
            .iter()
            .map(|t| (t[0] + t[1] + t[2]) / 3.0)
            .collect();
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * triangles.len().div_ceil(LEAF));
        nodes.push(leaf(&triangles, &order, 0, triangles.len()));
        // Split nodes breadth-first; children are appended in pairs.
        let mut next = 0;
        while next < nodes.len() {
            let node = nodes[next];
            if node.count as usize > LEAF {
                let run = node.run();
                let (lo, hi) = centroids_bounds(&centroids, &order[run.clone()]);
                let axis = (hi - lo).max_position();
                let half = run.len() / 2;
                order[run.clone()].select_nth_unstable_by(half, |&a, &b| {
                    centroids[a as usize][axis]
                        .total_cmp(&centroids[b as usize][axis])
                        .then(a.cmp(&b))
                });
                let mid = run.start + half;
                nodes[next].child = nodes.len() as u32;
                nodes.push(leaf(&triangles, &order, run.start, mid));
                nodes.push(leaf(&triangles, &order, mid, run.end));
            }
            next += 1;
        }
        let original = std::mem::take(&mut triangles);
        triangles = order.iter().map(|&i| original[i as usize]).collect();
        let bounds = triangles.iter().map(TriangleBound::new).collect();
        let magnitude = nodes[0].min.abs().max(nodes[0].max.abs()).max_element();
        Bvh {
            nodes,
            triangles,
            order,
            bounds,
            magnitude,
        }
    }

    /// The squared distance from `p` to the nearest triangle, and that triangle's index (in
    /// tree order). `hint` is a triangle whose distance starts the search as an upper bound.
    /// The distance returned is the least computed distance over all triangles whatever the
    /// hint: a node or triangle is skipped only when its lower bound exceeds the best so far by
    /// more than any rounding error (`slack`), so the true minimiser is never skipped and the
    /// result is bit-identical for any order of queries.
    pub fn nearest(&self, p: DVec3, hint: usize, stack: &mut Vec<(u32, f64)>) -> (f64, usize) {
        let slack = 1e-9 * (self.magnitude + p.abs().max_element());
        let mut best = (distance_squared(p, &self.triangles[hint]), hint);
        let mut reach = best.0.sqrt() + slack;
        let mut limit = reach * reach;
        stack.clear();
        stack.push((0, self.nodes[0].distance_squared(p)));
        while let Some((index, gap)) = stack.pop() {
            // The bound may have tightened since the node was pushed.
            if gap >= limit {
                continue;
            }
            let node = &self.nodes[index as usize];
            if node.is_leaf() {
                for t in node.run() {
                    if self.bounds[t].beyond(p, reach) {
                        continue;
                    }
                    let d = distance_squared(p, &self.triangles[t]);
                    if d < best.0 {
                        best = (d, t);
                        reach = d.sqrt() + slack;
                        limit = reach * reach;
                    }
                }
            } else {
                let (a, b) = (node.child, node.child + 1);
                let da = self.nodes[a as usize].distance_squared(p);
                let db = self.nodes[b as usize].distance_squared(p);
                // Visit the nearer child first: it most likely tightens the bound.
                let ((near, dn), (far, df)) = if da <= db {
                    ((a, da), (b, db))
                } else {
                    ((b, db), (a, da))
                };
                if df < limit {
                    stack.push((far, df));
                }
                if dn < limit {
                    stack.push((near, dn));
                }
            }
        }
        best
    }
}

/// A ball around a triangle and the plane through it: a point farther than `reach` from
/// either is farther than `reach` from the triangle. The ball rejects triangles off to the
/// side, the plane those seen face on.
struct TriangleBound {
    centre: DVec3,
    radius: f64,
    /// Unit normal (zero for a triangle without area) and its offset `normal · corner`.
    normal: DVec3,
    offset: f64,
}

impl TriangleBound {
    fn new(t: &[DVec3; 3]) -> TriangleBound {
        let centre = (t[0] + t[1] + t[2]) / 3.0;
        let radius = t
            .iter()
            .map(|p| (*p - centre).length_squared())
            .fold(0.0, f64::max)
            .sqrt();
        let normal = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
        TriangleBound {
            centre,
            radius,
            normal,
            offset: normal.dot(t[0]),
        }
    }

    fn beyond(&self, p: DVec3, reach: f64) -> bool {
        let ball = reach + self.radius;
        (self.normal.dot(p) - self.offset).abs() >= reach
            || (p - self.centre).length_squared() >= ball * ball
    }
}

fn leaf(triangles: &[[DVec3; 3]], order: &[u32], start: usize, end: usize) -> Node {
    let mut min = DVec3::INFINITY;
    let mut max = DVec3::NEG_INFINITY;
    for &i in &order[start..end] {
        for p in &triangles[i as usize] {
            min = min.min(*p);
            max = max.max(*p);
        }
    }
    Node {
        min,
        max,
        first: start as u32,
        count: (end - start) as u32,
        child: 0,
    }
}

fn centroids_bounds(centroids: &[DVec3], order: &[u32]) -> (DVec3, DVec3) {
    order
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| {
            (lo.min(centroids[i as usize]), hi.max(centroids[i as usize]))
        })
}

/// Squared distance from `p` to the triangle `t`, by the region of the triangle's plane that
/// `p` projects into (vertex, edge or face; Ericson, Real-Time Collision Detection §5.1.5).
/// Triangles without area fall back to their three edges.
pub fn distance_squared(p: DVec3, t: &[DVec3; 3]) -> f64 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length_squared();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length_squared();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return segment_distance_squared(p, a, b);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length_squared();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return segment_distance_squared(p, a, c);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return segment_distance_squared(p, b, c);
    }
    let sum = va + vb + vc;
    if sum.is_nan() || sum <= 0.0 {
        return segment_distance_squared(p, a, b)
            .min(segment_distance_squared(p, b, c))
            .min(segment_distance_squared(p, c, a));
    }
    // Inside the face region: distance to the plane.
    let (v, w) = (vb / sum, vc / sum);
    (a + ab * v + ac * w - p).length_squared()
}

/// Squared distance from `p` to the segment from `a` to `b`.
fn segment_distance_squared(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let length = ab.length_squared();
    let t = if length > 0.0 {
        ((p - a).dot(ab) / length).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t - p).length_squared()
}
