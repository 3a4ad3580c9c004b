//! What grid-producing work a run did, for `felt run --profile`.
//!
//! Every operation that produces a grid (`cachewrite`, and later FFT solves, splats, light
//! transmissivity) registers under a kind and a label that carries its source location, and
//! gets shared counters, [`GridStats`], that it bumps as it works: instances made, bricks
//! filled or skipped of how many, seconds spent, bytes allocated and still alive.
//! The one key decision: counters are keyed by `(kind, label)`, so the thousand states that
//! one `cachewrite` line produces over a simulation share one row and the registry stays the
//! same size however long the run; and the registry holds only counters, never the grids, so
//! it keeps nothing alive. Each engine (`crate::engine`) has its own rows, so a session's
//! profile lists only its own grids; the free functions here use the current engine.

use crate::base::text::human_bytes;
use std::fmt::Write;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

/// Counters for one kind of grid work at one place in a script. All updates are atomic, so
/// any thread may bump them.
#[derive(Debug, Default)]
pub struct GridStats {
    instances: AtomicU64,
    evaluated: AtomicU64,
    bricks_total: AtomicU64,
    bricks_filled: AtomicU64,
    bricks_skipped: AtomicU64,
    nanos: AtomicU64,
    bytes_allocated: AtomicU64,
    bytes_live: AtomicU64,
}

impl GridStats {
    /// A new grid (or solve) of `bricks` bricks was made here.
    pub fn add_instance(&self, bricks: u64) {
        self.instances.fetch_add(1, Ordering::Relaxed);
        self.bricks_total.fetch_add(bricks, Ordering::Relaxed);
    }

    /// One of the grids made here was evaluated: its first brick filled or skipped, its solve
    /// run, or its work done when it was made. Called once per grid, so the profile counts
    /// the grids a run made and never used, not the lines.
    pub fn add_evaluated(&self) {
        self.evaluated.fetch_add(1, Ordering::Relaxed);
    }

    /// One brick was computed, taking `nanos` and keeping `bytes`.
    pub fn add_filled(&self, nanos: u64, bytes: u64) {
        self.bricks_filled.fetch_add(1, Ordering::Relaxed);
        self.add_work(nanos, bytes);
    }

    /// Bricks that arrived already resolved (a grid made from data): `filled` with values,
    /// `skipped` known to be background.
    pub fn add_resolved(&self, filled: u64, skipped: u64) {
        self.bricks_filled.fetch_add(filled, Ordering::Relaxed);
        self.bricks_skipped.fetch_add(skipped, Ordering::Relaxed);
    }

    /// One brick was found empty without computing it, taking `nanos`.
    pub fn add_skipped(&self, nanos: u64) {
        self.bricks_skipped.fetch_add(1, Ordering::Relaxed);
        self.nanos.fetch_add(nanos, Ordering::Relaxed);
    }

    /// Work not counted in bricks (an FFT solve, a splat pass): time taken and bytes kept.
    pub fn add_work(&self, nanos: u64, bytes: u64) {
        self.nanos.fetch_add(nanos, Ordering::Relaxed);
        self.bytes_allocated.fetch_add(bytes, Ordering::Relaxed);
        self.bytes_live.fetch_add(bytes, Ordering::Relaxed);
    }

    /// A grid made here was dropped, returning `bytes`.
    pub fn release(&self, bytes: u64) {
        // Saturate rather than wrap if a producer releases more than it reported.
        let _ = self
            .bytes_live
            .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |live| {
                Some(live.saturating_sub(bytes))
            });
    }

    fn snapshot(&self, kind: &str, label: &str) -> ProfileEntry {
        ProfileEntry {
            kind: kind.to_string(),
            label: label.to_string(),
            instances: self.instances.load(Ordering::Relaxed),
            evaluated: self.evaluated.load(Ordering::Relaxed),
            bricks_total: self.bricks_total.load(Ordering::Relaxed),
            bricks_filled: self.bricks_filled.load(Ordering::Relaxed),
            bricks_skipped: self.bricks_skipped.load(Ordering::Relaxed),
            seconds: self.nanos.load(Ordering::Relaxed) as f64 * 1e-9,
            bytes_allocated: self.bytes_allocated.load(Ordering::Relaxed),
            bytes_live: self.bytes_live.load(Ordering::Relaxed),
        }
    }
}

/// One row of the profile: the totals of every grid made by one operation at one place.
#[derive(Clone, Debug, PartialEq)]
pub struct ProfileEntry {
    /// What produced the grids: `cachewrite`, `fftdivfree`, `splat`, `transmissivity`, ...
    pub kind: String,
    /// Where in the script, as the interpreter labelled it.
    pub label: String,
    /// Grids (or solves) made.
    pub instances: u64,
    /// Of those, the grids evaluated at all.
    pub evaluated: u64,
    pub bricks_total: u64,
    /// Bricks computed.
    pub bricks_filled: u64,
    /// Bricks known to be background without computing them.
    pub bricks_skipped: u64,
    /// Time spent computing, summed over threads.
    pub seconds: f64,
    /// Bytes ever allocated for values.
    pub bytes_allocated: u64,
    /// Bytes still held by grids alive now.
    pub bytes_live: u64,
}

struct Registration {
    kind: String,
    label: String,
    stats: Arc<GridStats>,
}

/// One engine's profile rows (see `crate::engine`).
#[derive(Default)]
pub struct Profile {
    registry: Mutex<Vec<Registration>>,
}

impl std::fmt::Debug for Profile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Profile({} rows)", self.rows().len())
    }
}

impl Profile {
    fn rows(&self) -> MutexGuard<'_, Vec<Registration>> {
        // Counters stay meaningful even if a thread panicked while holding the lock.
        self.registry
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// The counters for grids of `kind` made at `label`; the same pair always gets the same
    /// counters.
    pub fn register(&self, kind: &str, label: &str) -> Arc<GridStats> {
        let mut registry = self.rows();
        if let Some(found) = registry.iter().find(|r| r.kind == kind && r.label == label) {
            return found.stats.clone();
        }
        let stats = Arc::new(GridStats::default());
        registry.push(Registration {
            kind: kind.to_string(),
            label: label.to_string(),
            stats: stats.clone(),
        });
        stats
    }

    /// Every registered row, in the order they were first registered.
    pub fn report(&self) -> Vec<ProfileEntry> {
        self.rows()
            .iter()
            .map(|r| r.stats.snapshot(&r.kind, &r.label))
            .collect()
    }

    /// Forgets every row (for a REPL `:reset`).
    pub fn clear(&self) {
        self.rows().clear();
    }
}

/// `Profile::register` on the current engine's profile.
pub fn register(kind: &str, label: &str) -> Arc<GridStats> {
    crate::engine::with(|e| e.profile.register(kind, label))
}

/// `Profile::report` of the current engine's profile.
pub fn report() -> Vec<ProfileEntry> {
    crate::engine::with(|e| e.profile.report())
}

/// `Profile::clear` of the current engine's profile.
pub fn clear() {
    crate::engine::with(|e| e.profile.clear());
}

/// A plain-text table of `entries`, one line each, aligned, with a header.
pub fn format_table(entries: &[ProfileEntry]) -> String {
    let header = [
        "kind", "label", "grids", "bricks", "filled", "skipped", "seconds", "memory", "live",
    ];
    let rows: Vec<[String; 9]> = entries
        .iter()
        .map(|e| {
            [
                e.kind.clone(),
                e.label.clone(),
                e.instances.to_string(),
                e.bricks_total.to_string(),
                e.bricks_filled.to_string(),
                e.bricks_skipped.to_string(),
                format!("{:.3}", e.seconds),
                human_bytes(e.bytes_allocated as f64),
                human_bytes(e.bytes_live as f64),
            ]
        })
        .collect();
    let mut widths = header.map(str::len);
    for row in &rows {
        for (width, cell) in widths.iter_mut().zip(row) {
            *width = (*width).max(cell.chars().count());
        }
    }
    let mut text = String::new();
    let mut line = |cells: &[&str]| {
        let mut out = String::new();
        for (column, (cell, width)) in cells.iter().zip(widths).enumerate() {
            if column > 0 {
                out.push_str("  ");
            }
            // Names read left-aligned, numbers right-aligned.
            if column < 2 {
                let _ = write!(out, "{cell:<width$}");
            } else {
                let _ = write!(out, "{cell:>width$}");
            }
        }
        text.push_str(out.trim_end());
        text.push('\n');
    };
    line(&header);
    for row in &rows {
        let cells: Vec<&str> = row.iter().map(String::as_str).collect();
        line(&cells);
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_place_shares_counters() {
        let a = register("cachewrite", "profile test: line 3");
        let b = register("cachewrite", "profile test: line 3");
        let other = register("splat", "profile test: line 3");
        assert!(Arc::ptr_eq(&a, &b));
        assert!(!Arc::ptr_eq(&a, &other));
        a.add_instance(8);
        b.add_instance(8);
        a.add_filled(1_500_000_000, 2048);
        b.add_skipped(500_000_000);
        b.release(1024);
        let row = report()
            .into_iter()
            .find(|e| e.kind == "cachewrite" && e.label == "profile test: line 3")
            .unwrap();
        assert_eq!(row.instances, 2);
        assert_eq!(row.bricks_total, 16);
        assert_eq!(row.bricks_filled, 1);
        assert_eq!(row.bricks_skipped, 1);
        assert!((row.seconds - 2.0).abs() < 1e-9);
        assert_eq!(row.bytes_allocated, 2048);
        assert_eq!(row.bytes_live, 1024);
        a.release(1 << 20);
        assert_eq!(a.snapshot("", "").bytes_live, 0);
    }

    #[test]
    fn table_lines_up() {
        let entries = vec![
            ProfileEntry {
                kind: "cachewrite".into(),
                label: "scene.felt:12".into(),
                instances: 1,
                evaluated: 1,
                bricks_total: 4096,
                bricks_filled: 517,
                bricks_skipped: 80,
                seconds: 0.25,
                bytes_allocated: 517 * 2048,
                bytes_live: 517 * 2048,
            },
            ProfileEntry {
                kind: "fftdivfree".into(),
                label: "fluid.felt:40".into(),
                instances: 12,
                evaluated: 12,
                bricks_total: 0,
                bricks_filled: 0,
                bricks_skipped: 0,
                seconds: 3.5,
                bytes_allocated: 3 << 30,
                bytes_live: 0,
            },
        ];
        let table = format_table(&entries);
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(lines.len(), 3);
        assert!(lines[0].starts_with("kind        label"));
        assert!(lines[1].contains("4096"));
        assert!(lines[1].contains("1.0 MiB"));
        assert!(lines[2].contains("3.0 GiB"));
        assert!(lines[2].ends_with("0 B"));
        // Right-aligned numeric columns end at the same place.
        let end = |line: &str, word: &str| line.find(word).unwrap() + word.len();
        assert_eq!(end(lines[1], "0.250"), end(lines[2], "3.500"));
    }
}
