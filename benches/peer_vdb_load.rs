//! Loading a VDB file: felt's `cacheload` path against OpenVDB's own reader, `pyopenvdb.read`.
//!
//! felt writes the 256³ pyroclastic density once (`cachesave`, zip compression, as in
//! `peer_render`); then both sides read that file, each timed in its own process, best of
//! `RUNS` after a warm-up (the file is in the page cache by then), in wall and in CPU seconds
//! (the process's clock, all threads: steadier when other work shares the machine). felt is timed twice: reading
//! the grid (`vdb::read_grid`: parse, inflate, decode into leaves) and the whole `cacheload`
//! (that plus building the brick cache the renderer reads). OpenVDB's reader is timed as
//! `pyopenvdb.read` does it by default, and again with `OPENVDB_DISABLE_DELAYED_LOAD` set: by
//! default OpenVDB maps the file and inflates each leaf's values only when something first
//! reads them, so the default time leaves most of the decoding undone. The one key decision:
//! the ratio that counts is against the full read, where both sides have every value in memory;
//! the ratio against the default read is printed next to it.
//!
//! Skips with a message when `/usr/bin/python3` cannot import `pyopenvdb` (or `openvdb`). Run
//! with `cargo bench --bench peer_vdb_load`.

use felt::grid::{vdb, vdb_cache};
use std::path::Path;
use std::process::Command;
use std::time::Instant;

#[path = "peer/felt_run.rs"]
#[allow(dead_code)]
mod felt_run;
use felt_run::run_felt;
#[path = "peer/pyroclastic_grid.rs"]
mod pyroclastic_grid;
use pyroclastic_grid::{CELLS, make_grid_script};

const RUNS: usize = 5;
const PYTHON: &str = "/usr/bin/python3";

/// Times `pyopenvdb.read(path, "density")`: the best wall and the best CPU seconds of the runs
/// after one warm-up, with the leaf count as a check that the whole grid was read.
const PEER_SCRIPT: &str = r#"
import sys, time
try:
    import pyopenvdb as vdb
except ImportError:
    import openvdb as vdb
path, runs = sys.argv[1], int(sys.argv[2])
vdb.read(path, "density")
wall, cpu = float("inf"), float("inf")
for _ in range(runs):
    start, start_cpu = time.perf_counter(), time.process_time()
    grid = vdb.read(path, "density")
    wall = min(wall, time.perf_counter() - start)
    cpu = min(cpu, time.process_time() - start_cpu)
print(wall, cpu, grid.leafCount(), vdb.LIBRARY_VERSION)
"#;

/// Best wall and CPU seconds of one reader.
#[derive(Clone, Copy)]
struct Time {
    wall: f64,
    cpu: f64,
}

fn peer_available() -> bool {
    Command::new(PYTHON)
        .args([
            "-c",
            "try:\n import pyopenvdb\nexcept ImportError:\n import openvdb",
        ])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Best `pyopenvdb.read` times and the leaf count, with delayed loading on or off.
fn peer_read(path: &Path, delayed: bool) -> (Time, usize, String) {
    let mut command = Command::new(PYTHON);
    command
        .args(["-c", PEER_SCRIPT])
        .arg(path)
        .arg(RUNS.to_string());
    if !delayed {
        command.env("OPENVDB_DISABLE_DELAYED_LOAD", "1");
    }
    let output = command.output().expect("python runs");
    let text = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(
        output.status.success(),
        "pyopenvdb failed: {text}{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let mut words = text.split_whitespace();
    let mut number = || words.next().and_then(|w| w.parse().ok());
    let wall = number().unwrap_or(f64::NAN);
    let cpu = number().unwrap_or(f64::NAN);
    let leaves = number().map_or(0, |n: f64| n as usize);
    (
        Time { wall, cpu },
        leaves,
        words.collect::<Vec<_>>().join(" "),
    )
}

/// CPU seconds of this process, all threads, from the kernel's per-process clock (finer
/// than the 1/100 s ticks of `/proc/self/stat`).
fn process_cpu() -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid timespec for the call to fill.
    unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut t) };
    t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
}

/// Best wall and CPU seconds of `RUNS` runs after a warm-up.
fn best_of(mut run: impl FnMut()) -> Time {
    run();
    let mut best = Time {
        wall: f64::INFINITY,
        cpu: f64::INFINITY,
    };
    for _ in 0..RUNS {
        let (start, start_cpu) = (Instant::now(), process_cpu());
        run();
        best.wall = best.wall.min(start.elapsed().as_secs_f64());
        best.cpu = best.cpu.min(process_cpu() - start_cpu);
    }
    best
}

fn main() {
    if !peer_available() {
        println!(
            "peer_vdb_load skipped: {PYTHON} cannot import pyopenvdb (OpenVDB's Python module)"
        );
        return;
    }
    let dir = tempfile::tempdir().expect("a temporary directory");
    let grid_path = dir.path().join("pyroclastic.vdb");
    let script = dir.path().join("make_grid.felt");
    std::fs::write(&script, make_grid_script(&grid_path)).expect("write the felt script");
    run_felt(&script);
    let bytes = std::fs::metadata(&grid_path).map(|m| m.len()).unwrap_or(0);

    let mut leaves = 0;
    let read = best_of(|| {
        let grid = vdb::read_grid(&grid_path, "density").expect("felt reads its own file");
        leaves = grid.leaves.len();
    });
    let load = best_of(|| {
        let (cache, _, _) = vdb_cache::load(&grid_path, "density", 1).expect("felt loads the grid");
        assert_eq!(cache.width(), 1);
    });
    let (full, peer_leaves, version) = peer_read(&grid_path, false);
    let (delayed, _, _) = peer_read(&grid_path, true);
    assert_eq!(leaves, peer_leaves, "both readers see the same leaves");

    println!(
        "## loading a {CELLS}^3 density VDB ({leaves} leaves, {:.1} MB, zip), best of {RUNS} after a warm-up; felt on {} threads (rayon), OpenVDB on its own",
        bytes as f64 / 1e6,
        rayon::current_num_threads()
    );
    println!("| reader | wall s | CPU s | felt cacheload / it, wall | felt cacheload / it, CPU |");
    println!("|---|---|---|---|---|");
    let row = |name: &str, t: Time| {
        println!(
            "| {name} | {:.4} | {:.4} | {:.2} | {:.2} |",
            t.wall,
            t.cpu,
            load.wall / t.wall,
            load.cpu / t.cpu
        )
    };
    row(
        &format!("pyopenvdb.read, OpenVDB {version}, every leaf read"),
        full,
    );
    row(
        "pyopenvdb.read, default (leaf values inflated on first use)",
        delayed,
    );
    row("felt vdb::read_grid (parse, inflate, decode)", read);
    row("felt cacheload (read_grid + brick cache)", load);
}
