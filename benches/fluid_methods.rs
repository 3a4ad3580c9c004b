//! Gridded, gridless and SELMA densities as the number of frames grows: the analogue of the FELT
//! chapter's Figs. 7.9 and 8.2.
//!
//! One velocity simulation (hot/cold on 32³ cells, projected by `fftdivfree` every frame, never
//! reading the density) moves a density of three spheres for F frames, three ways
//! (`benches/fluids/methods.felt`):
//! - gridded: `density = advect(density, velocity, dt)`, cached on 64³ cells every frame;
//! - gridless: `density = advect(density, velocity, dt)`, never cached;
//! - SELMA: `map = selmastep(map, velocity, dt, mapdomain)` on 64³ cells,
//!   `density = compose(density0, map)`.
//!
//! Each (method, F) runs felt as its own process. Measured: the time to evaluate the final
//! density at the 64³ cell centres of a query box (`stats`, timed with `clock()`, median of
//! three), the time of the F frames, the process's peak resident memory (from `wait4`, that
//! child's alone), and the memory `--profile` reports still live at the end for the fftdivfree
//! grids and for all grids. The one key decision: every frame is forced during the loop (a
//! velocity probe; the gridded cache and the SELMA map filled), so the query measures only the
//! final density's evaluation, not work the laziness deferred to it. Expected: gridless query
//! time and memory grow linearly with F (a chain of F advections, each reading its own velocity
//! grid, all kept alive); gridded and SELMA stay flat.
//!
//! Run with `cargo bench --bench fluid_methods`.

use std::path::Path;
use std::process::Command;

#[path = "peer/felt_run.rs"]
#[allow(dead_code)]
mod felt_run;
use felt_run::median;

#[path = "fluids/process.rs"]
#[allow(dead_code)]
mod process;
use process::{Finished, mib, numbers, parse_bytes, series};

const FRAMES: [usize; 5] = [5, 10, 20, 40, 60];
const METHODS: [&str; 3] = ["gridded", "gridless", "selma"];

fn felt(method: &str, frames: usize) -> Finished {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/fluids/methods.felt");
    let run = process::run(
        Command::new(env!("CARGO_BIN_EXE_felt"))
            .arg("run")
            .arg(script)
            .args(["--set", &format!("method={method}")])
            .args(["--set", &format!("frames={frames}")])
            .arg("--profile"),
    );
    assert!(run.success, "felt failed:\n{}\n{}", run.stdout, run.stderr);
    run
}

/// Live bytes of the `--profile` rows whose kind is `kind` (all rows for `None`): the last
/// column, `<number> <unit>`.
fn live(profile: &str, kind: Option<&str>) -> f64 {
    let kinds = ["cachewrite", "fftdivfree"];
    profile
        .lines()
        .filter(|l| {
            let first = l.split_whitespace().next().unwrap_or("");
            kinds.contains(&first) && kind.is_none_or(|k| k == first)
        })
        .filter_map(|l| {
            let tokens: Vec<&str> = l.split_whitespace().collect();
            let n = tokens.len();
            (n >= 2).then(|| parse_bytes(tokens[n - 2], tokens[n - 1]))?
        })
        .sum()
}

struct Row {
    method: &'static str,
    frames: usize,
    query: f64,
    simulate: f64,
    peak: f64,
    live_velocity: f64,
    live_all: f64,
    mean: f64,
}

fn main() {
    println!(
        "threads: felt {} (rayon, all cores); one process per row",
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    println!("load average at the start: {}", process::load_average());
    let mut rows = Vec::new();
    for method in METHODS {
        for frames in FRAMES {
            let run = felt(method, frames);
            let density = numbers(&run.stdout, "density")
                .pop()
                .filter(|v| v.len() == 3)
                .unwrap_or_else(|| panic!("no density line in:\n{}", run.stdout));
            rows.push(Row {
                method,
                frames,
                query: median(series(&run.stdout, "query_seconds")),
                simulate: series(&run.stdout, "frames_seconds")[0],
                peak: run.max_rss,
                live_velocity: live(&run.stderr, Some("fftdivfree")),
                live_all: live(&run.stderr, None),
                mean: density[2],
            });
        }
    }

    println!(
        "\n## final density at 64³ query points after F frames (velocity 32³; gridded cache and SELMA map 64³)"
    );
    println!(
        "| method | F | query s | F frames s | peak memory MiB | fftdivfree live MiB | all grids live MiB | density mean |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for r in &rows {
        println!(
            "| {} | {} | {:.4} | {:.2} | {:.1} | {:.2} | {:.2} | {:.6} |",
            r.method,
            r.frames,
            r.query,
            r.simulate,
            mib(r.peak),
            mib(r.live_velocity),
            mib(r.live_all),
            r.mean
        );
    }

    println!("\nload average at the end: {}", process::load_average());
    let (first, last) = (FRAMES[0], FRAMES[FRAMES.len() - 1]);
    println!(
        "\n## growth from F = {first} to F = {last} (F grew {:.0}×)",
        last as f64 / first as f64
    );
    println!("| method | query time | peak memory | fftdivfree live |");
    println!("|---|---|---|---|");
    for method in METHODS {
        let at = |f: usize| {
            rows.iter()
                .find(|r| r.method == method && r.frames == f)
                .expect("every (method, F) was run")
        };
        let (a, b) = (at(first), at(last));
        println!(
            "| {method} | {:.1}× | {:.1}× | {:.1}× |",
            b.query / a.query,
            b.peak / a.peak,
            b.live_velocity / a.live_velocity
        );
    }
}
