//! felt against numpy on one gridded hot/cold frame of the FELT chapter: hot gas injected at the
//! bottom rises, cold gas at the top sinks. Per frame, on N³ cells over [-1, 1]³: both densities
//! advected (first-order semi-Lagrangian, trilinear) plus a ball of injection, cached; the
//! velocity self-advected plus buoyancy; then projected to zero central-difference divergence
//! by periodic FFTs (wavenumber sin(kh)/h, Nyquist modes kept).
//!
//! felt runs `benches/fluids/hotcold.felt`; numpy runs `benches/fluids/hotcold_numpy.py`, the
//! same algorithm written as a numpy expert would (vectorised gathers with shared corner
//! weights, work arrays reused, numpy.fft's rfftn), and once more with
//! `scipy.ndimage.map_coordinates` (the textbook form) for reference. Each program times its
//! own frames (felt: `clock()` around each frame, forced by a probe of the projected velocity;
//! python: `time.perf_counter()`), so process start-up, parsing and imports do not count; the
//! whole processes are timed too (wall, CPU, peak memory, from `wait4`). Reported per frame:
//! the median of the timed frames after a few warm-up frames, from the faster of two
//! processes per program (run interleaved; the machine is shared, and CPU / wall in the
//! process table shows how many cores a run actually got).
//!
//! The one key decision: both programs print the same figures after their timed frames (min,
//! max and mean of each density over the cells, the velocity at two points), and the bench
//! compares them at every size, so a fast program that computes something else cannot pass.
//! A 32³ run of a few frames is the agreement check proper. felt's second run (`parts = true`)
//! splits its frame into the density cache fills, the velocity solve, and a solve of a field
//! that costs nothing to sample (the FFT projection and its storage alone).
//!
//! Skips with a message when python3 with numpy is missing (`pip install numpy scipy`); the
//! scipy row is skipped alone when scipy is missing. Run with
//! `cargo bench --bench peer_fluids`.

use std::path::{Path, PathBuf};
use std::process::Command;

#[path = "peer/felt_run.rs"]
#[allow(dead_code)]
mod felt_run;
use felt_run::median;

#[path = "fluids/process.rs"]
#[allow(dead_code)]
mod process;
use process::{Finished, mib, numbers, series};

/// (cells per side, warm-up frames, timed frames).
const SIZES: [(usize, usize, usize); 2] = [(64, 3, 8), (128, 2, 5)];
/// The agreement check: cells per side and frames.
const CHECK: (usize, usize) = (32, 8);
/// Processes per program and size; the fastest is reported.
const PROCESSES: usize = 2;
const TARGET: f64 = 0.3;
const AIM: f64 = 0.15;

fn here(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("benches/fluids")
        .join(file)
}

fn python_with(module: &str) -> Option<PathBuf> {
    ["python3", "/usr/bin/python3"].iter().find_map(|p| {
        let ok = Command::new(p)
            .args(["-c", &format!("import {module}")])
            .output()
            .is_ok_and(|o| o.status.success());
        ok.then(|| PathBuf::from(p))
    })
}

fn felt(res: usize, warmup: usize, frames: usize, parts: bool) -> Finished {
    let run = process::run(
        Command::new(env!("CARGO_BIN_EXE_felt"))
            .arg("run")
            .arg(here("hotcold.felt"))
            .args(["--set", &format!("res={res}")])
            .args(["--set", &format!("warmup={warmup}")])
            .args(["--set", &format!("frames={frames}")])
            .args(["--set", &format!("parts={parts}")]),
    );
    assert!(run.success, "felt failed:\n{}\n{}", run.stdout, run.stderr);
    run
}

fn numpy(python: &Path, res: usize, warmup: usize, frames: usize, edges: &str) -> Finished {
    let run = process::run(
        Command::new(python)
            .arg(here("hotcold_numpy.py"))
            .args(["--res", &res.to_string()])
            .args(["--warmup", &warmup.to_string()])
            .args(["--frames", &frames.to_string()])
            .args(["--edges", edges]),
    );
    assert!(
        run.success,
        "hotcold_numpy.py failed:\n{}\n{}",
        run.stdout, run.stderr
    );
    run
}

/// The figures of the agreement check, as both programs print them.
struct Figures {
    hot: Vec<f64>,
    cold: Vec<f64>,
    probe_a: Vec<f64>,
    probe_b: Vec<f64>,
}

fn figures(text: &str) -> Figures {
    let last = |key: &str| {
        numbers(text, key)
            .pop()
            .filter(|v| v.len() == 3)
            .unwrap_or_else(|| panic!("no `{key}` line of three numbers in:\n{text}"))
    };
    Figures {
        hot: last("hot"),
        cold: last("cold"),
        probe_a: last("probe_a"),
        probe_b: last("probe_b"),
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// |a − b| / |b| of two vectors.
fn relative(a: &[f64], b: &[f64]) -> f64 {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    norm(&d) / norm(b)
}

/// Worst relative difference of felt's figures from numpy's: density max and mean, velocity
/// probes as vectors.
fn worst(f: &Figures, n: &Figures) -> (f64, f64) {
    let scalar = |a: f64, b: f64| (a - b).abs() / b.abs();
    let density = [
        scalar(f.hot[1], n.hot[1]),
        scalar(f.hot[2], n.hot[2]),
        scalar(f.cold[1], n.cold[1]),
        scalar(f.cold[2], n.cold[2]),
    ]
    .into_iter()
    .fold(0.0, f64::max);
    let velocity = relative(&f.probe_a, &n.probe_a).max(relative(&f.probe_b, &n.probe_b));
    (density, velocity)
}

fn agreement(python: &Path, scipy: bool) {
    let (res, frames) = CHECK;
    let f = figures(&felt(res, 0, frames, false).stdout);
    let n = figures(&numpy(python, res, 0, frames, "felt").stdout);
    let s = scipy.then(|| figures(&numpy(python, res, 0, frames, "scipy").stdout));
    println!("\n## agreement, {res}^3 cells, {frames} frames (figures after the last frame)");
    println!("| figure | felt | numpy | felt − numpy | numpy, map_coordinates edges |");
    println!("|---|---|---|---|---|");
    let row = |name: &str, a: f64, b: f64, c: Option<f64>| {
        let c = c.map_or("skipped".to_string(), |c| format!("{c:.9e}"));
        println!("| {name} | {a:.9e} | {b:.9e} | {:.2e} | {c} |", a - b);
    };
    for (name, fv, nv, sv) in [
        ("hot", &f.hot, &n.hot, s.as_ref().map(|s| &s.hot)),
        ("cold", &f.cold, &n.cold, s.as_ref().map(|s| &s.cold)),
        (
            "velocity at (0.1, 0.2, 0.3)",
            &f.probe_a,
            &n.probe_a,
            s.as_ref().map(|s| &s.probe_a),
        ),
        (
            "velocity at (0, -0.3, 0.05)",
            &f.probe_b,
            &n.probe_b,
            s.as_ref().map(|s| &s.probe_b),
        ),
    ] {
        let labels: [&str; 3] = if name.starts_with("velocity") {
            ["x", "y", "z"]
        } else {
            ["min", "max", "mean"]
        };
        for (i, label) in labels.iter().enumerate() {
            row(&format!("{name} {label}"), fv[i], nv[i], sv.map(|v| v[i]));
        }
    }
    let (density, velocity) = worst(&f, &n);
    println!(
        "\nfelt vs numpy (felt's edges): density max/mean within {density:.1e} (relative), velocity probes within {velocity:.1e} (|Δv|/|v|)"
    );
    if let Some(s) = &s {
        let (density, velocity) = worst(&n, s);
        println!(
            "numpy, felt's edges vs map_coordinates edges: density within {density:.1e}, velocity probes within {velocity:.1e} (the edge rule alone)"
        );
    }
}

struct Timed {
    frame: f64,
    run: Finished,
}

fn timed(run: Finished) -> Timed {
    let frames = series(&run.stdout, "frame_seconds");
    assert!(!frames.is_empty(), "no frame times in:\n{}", run.stdout);
    Timed {
        frame: median(frames),
        run,
    }
}

/// The run with the smallest median frame.
fn best(runs: Vec<Timed>) -> Timed {
    runs.into_iter()
        .min_by(|a, b| a.frame.total_cmp(&b.frame))
        .expect("at least one run")
}

/// A `parts = true` run's median frame: cache fills + solve + the FFT-only solve.
fn part_seconds(run: &Finished) -> f64 {
    ["caches_seconds", "solve_seconds", "fft_seconds"]
        .iter()
        .map(|k| median(series(&run.stdout, k)))
        .sum()
}

fn main() {
    let Some(python) = python_with("numpy") else {
        println!(
            "peer_fluids skipped: no python3 that can import numpy (install with `pip install numpy scipy`)"
        );
        return;
    };
    let scipy = python_with("scipy.ndimage").is_some_and(|p| p == python);
    if !scipy {
        println!("scipy is not importable: the map_coordinates rows are skipped");
    }
    println!(
        "threads: felt {} (rayon, all cores); numpy 1 (numpy ufuncs, np.take and numpy.fft are single-threaded)",
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    println!("load average at the start: {}", process::load_average());
    agreement(&python, scipy);

    let mut rows = Vec::new();
    for (res, warmup, frames) in SIZES {
        // Each program runs PROCESSES times, interleaved, and the run with the smallest
        // median frame is kept: other work on the machine slows runs, it never speeds one up.
        let (mut f, mut n, mut s, mut parts) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for _ in 0..PROCESSES {
            f.push(timed(felt(res, warmup, frames, false)));
            n.push(timed(numpy(&python, res, warmup, frames, "felt")));
            if scipy {
                s.push(timed(numpy(&python, res, warmup, frames, "scipy")));
            }
            parts.push(felt(res, warmup, frames, true));
        }
        let parts = parts
            .into_iter()
            .min_by(|a, b| part_seconds(a).total_cmp(&part_seconds(b)))
            .expect("PROCESSES > 0");
        rows.push((
            res,
            warmup,
            frames,
            best(f),
            parts,
            best(n),
            (!s.is_empty()).then(|| best(s)),
        ));
    }

    println!(
        "\n## one hot/cold frame, median of the timed frames after the warm-up (best of {PROCESSES} processes)"
    );
    println!(
        "| N | frames (warm-up + timed) | felt s/frame | numpy s/frame | felt / numpy | numpy map_coordinates s/frame | felt / that |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (res, warmup, frames, f, _, n, s) in &rows {
        let (sf, sr) = s.as_ref().map_or(("skipped".into(), "".into()), |s| {
            (
                format!("{:.3}", s.frame),
                format!("{:.2}", f.frame / s.frame),
            )
        });
        println!(
            "| {res}³ | {warmup} + {frames} | {:.3} | {:.3} | **{:.2}** | {sf} | {sr} |",
            f.frame,
            n.frame,
            f.frame / n.frame
        );
    }

    println!(
        "\n## whole processes, for reference (start-up, parse or imports, all frames, the check)"
    );
    println!("| N | program | wall s | CPU s | CPU / wall | peak memory MiB |");
    println!("|---|---|---|---|---|---|");
    for (res, _, _, f, p, n, s) in &rows {
        let mut programs = vec![
            ("felt", &f.run),
            ("felt, parts = true", p),
            ("numpy", &n.run),
        ];
        if let Some(s) = s {
            programs.push(("numpy, map_coordinates", &s.run));
        }
        for (name, r) in programs {
            println!(
                "| {res}³ | {name} | {:.2} | {:.2} | {:.2} | {:.0} |",
                r.wall,
                r.cpu,
                r.cpu / r.wall,
                mib(r.max_rss)
            );
        }
    }

    println!("\n## where each frame's time goes (medians, s/frame)");
    println!(
        "| N | felt: both density cache fills | felt: velocity solve (sample + FFT + store) | felt: FFT projection + store alone | felt: sampling (solve − FFT alone) | numpy: five advections | numpy: rfftn + project + irfftn |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (res, _, _, _, p, n, _) in &rows {
        let m = |text: &str, key: &str| median(series(text, key));
        let caches = m(&p.stdout, "caches_seconds");
        let solve = m(&p.stdout, "solve_seconds");
        let fft = m(&p.stdout, "fft_seconds");
        println!(
            "| {res}³ | {caches:.3} | {solve:.3} | {fft:.3} | {:.3} | {:.3} | {:.3} |",
            solve - fft,
            m(&n.run.stdout, "advect_seconds"),
            m(&n.run.stdout, "project_seconds"),
        );
    }

    if let Some((res, ..)) = rows.last() {
        // Twice, keeping each piece's faster time (the pieces are short, contention is bursty).
        let mut pieces: Vec<(String, f64)> = Vec::new();
        for _ in 0..PROCESSES {
            let reads = process::run(
                Command::new(env!("CARGO_BIN_EXE_felt"))
                    .arg("run")
                    .arg(here("hotcold_reads.felt"))
                    .args(["--set", &format!("res={res}")]),
            );
            assert!(
                reads.success,
                "felt failed:\n{}\n{}",
                reads.stdout, reads.stderr
            );
            for line in reads.stdout.lines() {
                let Some((name, seconds)) = line
                    .strip_prefix("part ")
                    .and_then(|rest| rest.rsplit_once(' '))
                else {
                    continue;
                };
                let seconds: f64 = seconds.parse().unwrap_or(f64::NAN);
                match pieces.iter_mut().find(|(n, _)| n == name) {
                    Some((_, s)) => *s = s.min(seconds),
                    None => pieces.push((name.to_string(), seconds)),
                }
            }
        }
        println!(
            "\n## felt's velocity solve at {res}³ piece by piece (benches/fluids/hotcold_reads.felt: each piece over all cell centres with stats(), median of 3 in a process, faster of {PROCESSES} processes)"
        );
        println!("| piece | seconds | N³ cells / seconds, M/s (the fills skip empty bricks) |");
        println!("|---|---|---|");
        let cells = (res * res * res) as f64;
        for (name, seconds) in &pieces {
            println!("| {name} | {seconds:.3} | {:.1} |", cells / seconds * 1e-6);
        }
    }

    println!("\n## the same figures at the timed sizes (after warm-up + timed frames)");
    println!(
        "| N | density max/mean, worst relative difference | velocity probes, worst |Δv|/|v| |"
    );
    println!("|---|---|---|");
    for (res, _, _, f, _, n, _) in &rows {
        let (density, velocity) = worst(&figures(&f.run.stdout), &figures(&n.run.stdout));
        println!("| {res}³ | {density:.1e} | {velocity:.1e} |");
    }

    println!("\nload average at the end: {}", process::load_average());
    if let Some((res, _, _, f, _, n, _)) = rows.last() {
        let ratio = f.frame / n.frame;
        let verdict = if ratio <= AIM {
            "meets the aim"
        } else if ratio <= TARGET {
            "meets the target, not the aim"
        } else {
            "MISSES the target"
        };
        println!(
            "\ntarget: felt ≤ {TARGET}× numpy's time per frame at {res}³ (aim {AIM}×): measured {ratio:.2}×, {verdict}"
        );
    }
}
