//! Noticing a map read outside its domain into a zero background.
//!
//! A SELMA map `X(x)` (chapter 8: `map = advect(map, velocity, dt)` from `map = identity()`,
//! cached every frame) is close to the identity everywhere, so the default read — the zero
//! background beyond the domain's faces — sends every back-trace that leaves the box to the
//! origin, and the density composed with the map floods in from the borders. The script is
//! legal and runs as printed; what the user needs is to be told, with a count, and the fix
//! (`outside = "extrapolate"`). docs/language.md ("Gridless and SELMA densities") states the
//! rule.
//!
//! The one key decision: *which* vector caches are maps is judged from their values, not from
//! how they were written — a map's graph is ordinary arithmetic on `x`, `y`, `z` once
//! `advect` has substituted it. A cache counts its default reads that land outside its domain
//! (free on the trilinear path, which tests the box anyway; one box test per point on the
//! others; only vector caches with a zero background written by `cachewrite`), and when
//! the count is settled (the cache is dropped, or the run ends) the cells on the domain's
//! faces that reads have already filled are compared with their own positions: when most of
//! them hold a value within a quarter of its distance from the origin of their position, the
//! cache is a map, and its count goes to the tally of the `cachewrite` line that made it.
//! Only filled bricks are looked at, so judging never computes anything, and the set of filled
//! bricks does not depend on the thread count, so neither does the warning. A velocity field
//! would need to equal the position to pass, which no flow does.

use super::{BRICK, Cache, local_index};
use glam::DVec3;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// Reads of a vector cache outside its domain, waiting to be judged.
#[derive(Debug)]
pub struct MapWatch {
    reads_outside: AtomicU64,
    /// Where a judged map's reads are added: one tally per `cachewrite` line.
    tally: Arc<AtomicU64>,
}

impl MapWatch {
    pub fn new(tally: Arc<AtomicU64>) -> MapWatch {
        MapWatch {
            reads_outside: AtomicU64::new(0),
            tally,
        }
    }
}

impl Cache {
    /// Watches this cache's default reads outside its domain for `tally` (vector caches with a
    /// zero background only; others are left unwatched).
    pub fn watch_map_reads(mut self, tally: Arc<AtomicU64>) -> Cache {
        if self.width == 3 && self.background.iter().all(|&b| b == 0.0) {
            self.map_watch = Some(MapWatch::new(tally));
        }
        self
    }

    /// Counts the points of a default read that lie outside the domain box.
    pub(super) fn count_reads_outside(&self, xs: &[f64], ys: &[f64], zs: &[f64]) {
        let Some(watch) = &self.map_watch else {
            return;
        };
        let outside = (0..xs.len())
            .filter(|&i| self.index_coords(DVec3::new(xs[i], ys[i], zs[i])).is_none())
            .count();
        if outside > 0 {
            watch
                .reads_outside
                .fetch_add(outside as u64, Ordering::Relaxed);
        }
    }

    /// Adds `outside` points a read already found outside the domain box.
    #[inline]
    pub(super) fn add_reads_outside(&self, outside: u64) {
        if let (Some(watch), 1..) = (&self.map_watch, outside) {
            watch.reads_outside.fetch_add(outside, Ordering::Relaxed);
        }
    }

    /// Hands the reads counted so far to the tally when this cache is a map; called when the
    /// run ends and when the cache is dropped (each read is handed on at most once).
    pub fn settle_map_reads(&self) {
        let Some(watch) = &self.map_watch else {
            return;
        };
        let reads = watch.reads_outside.swap(0, Ordering::Relaxed);
        if reads > 0 && self.looks_like_a_map() {
            watch.tally.fetch_add(reads, Ordering::Relaxed);
        }
    }

    /// Whether most filled cells on the domain's faces hold (close to) their own position.
    fn looks_like_a_map(&self) -> bool {
        let cells = self.shape.cells;
        let on_face = |i: usize, j: usize, k: usize| {
            i == 0
                || j == 0
                || k == 0
                || i + 1 == cells[0]
                || j + 1 == cells[1]
                || k + 1 == cells[2]
        };
        let (mut near, mut judged) = (0u64, 0u64);
        for bz in 0..self.shape.bricks[2] {
            for by in 0..self.shape.bricks[1] {
                for bx in 0..self.shape.bricks[0] {
                    let index = self.shape.brick_index([bx, by, bz]);
                    // Only bricks some read already filled: judging computes nothing.
                    let Some(brick) = self.bricks[index].get() else {
                        continue;
                    };
                    let values = brick.values.as_deref().unwrap_or(&self.background_brick);
                    for k in bz * BRICK..((bz + 1) * BRICK).min(cells[2]) {
                        for j in by * BRICK..((by + 1) * BRICK).min(cells[1]) {
                            for i in bx * BRICK..((bx + 1) * BRICK).min(cells[0]) {
                                if !on_face(i, j, k) {
                                    continue;
                                }
                                let at = local_index(i % BRICK, j % BRICK, k % BRICK) * 3;
                                let value = DVec3::new(
                                    f64::from(values[at]),
                                    f64::from(values[at + 1]),
                                    f64::from(values[at + 2]),
                                );
                                let position = self.domain.cell_center(i, j, k);
                                judged += 1;
                                if (value - position).length() <= 0.25 * position.length() {
                                    near += 1;
                                }
                            }
                        }
                    }
                }
            }
        }
        judged > 0 && 2 * near > judged
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::space::domain::Domain;
    use crate::space::{FnField, GridSource, Interp};

    /// A cache of the vector field `value` (a function of the position), watched by `tally`.
    fn watched(
        value: impl Fn(DVec3) -> DVec3 + Send + Sync + 'static,
        tally: &Arc<AtomicU64>,
    ) -> Cache {
        let domain = Domain::with_cells(
            DVec3::splat(-1.0),
            DVec3::splat(2.0),
            DVec3::ZERO,
            0.25,
            0.25,
        )
        .unwrap();
        Cache::from_field(
            domain,
            3,
            Arc::new(FnField::new(3, move |p: DVec3, out: &mut [f64]| {
                out.copy_from_slice(&value(p).to_array())
            })),
            vec![0.0; 3],
            String::new(),
        )
        .unwrap()
        .watch_map_reads(tally.clone())
    }

    /// Reads one point inside (to fill a face brick) and `outside` points beyond the faces.
    fn read(cache: &Cache, outside: usize) {
        let mut xs = vec![-0.9];
        xs.extend((0..outside).map(|i| 1.5 + i as f64));
        let ys = vec![0.0; xs.len()];
        let zs = ys.clone();
        let mut out = vec![0.0; 3 * xs.len()];
        cache.sample(Interp::Linear, &xs, &ys, &zs, &mut out);
    }

    #[test]
    fn a_map_read_outside_is_tallied_once() {
        let tally = Arc::new(AtomicU64::new(0));
        let map = watched(|p| p, &tally);
        read(&map, 7);
        map.settle_map_reads();
        assert_eq!(tally.load(Ordering::Relaxed), 7);
        // Settling again hands on nothing new; dropping hands on what came since.
        map.settle_map_reads();
        read(&map, 2);
        drop(map);
        assert_eq!(tally.load(Ordering::Relaxed), 9);
    }

    #[test]
    fn a_velocity_read_outside_is_not_a_map() {
        let tally = Arc::new(AtomicU64::new(0));
        let velocity = watched(|_| DVec3::new(0.0, 0.3, 0.0), &tally);
        read(&velocity, 5);
        drop(velocity);
        assert_eq!(tally.load(Ordering::Relaxed), 0);
    }
}
