//! felt against OpenVDB AX on the same job: fill a dense 256³ grid over [-1, 1]³ with the
//! five-octave fractal pyroclastic sphere `0.6 + 0.3·|fbm(p̂)| − |p|` (`p̂` the point pushed
//! onto the sphere of radius 0.6, octaves at frequency 2·2ⁱ with weight 0.5ⁱ).
//!
//! felt runs a script (`scalarcache`, `cachewrite`, `cachefill`) in-process; its fill is timed
//! with `clock()` around `cachefill`, and the whole run (parse, check, build, fill) is timed
//! too. AX runs `vdb_ax` on a dense grid with every voxel active in leaves, written beforehand
//! by `benches/peer/make_dense.py` (pyopenvdb), with the same formula on AX's only noise,
//! `simplexnoise` (OpenSimplex, mapped from [0, 1] to [-1, 1]). AX's time includes reading the
//! input and writing the output file; a run with a trivial snippet shows that overhead, and
//! `vdb_ax -v` splits each run into read, compile, execute and write. felt is also run with its
//! own simplex noise, the same noise family as AX's. The one key decision: both sides fill the
//! same 256³ voxel centres, and the bench prints each side's value range and active voxel
//! count so a wrong snippet or an empty grid cannot pass for a fast one.
//!
//! Skips with a message when `vdb_ax` or pyopenvdb is missing. Run with
//! `cargo bench --bench peer_ax`.

use felt::field::noise::{self, NoiseKind, NoiseOutput};
use felt::space::BLOCK;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

#[path = "peer/felt_run.rs"]
mod felt_run;
use felt_run::{cpu_seconds, median, printed, run_felt};

const CELLS: usize = 256;
const RUNS: usize = 3;
const OCTAVES: usize = 5;

/// The AX snippet: the felt stdlib's `pyroclastic` and `fbm`, written out for AX. The octave
/// offsets are the ones felt's `fbm` uses, so the two differ only in the noise itself.
const AX_PYROCLASTIC: &str = "
vec3d p = getvoxelpws();
double r = length(p);
vec3d s = p * (0.6 / r);
double n = 0.0;
double amp = 1.0;
double freq = 2.0;
for (int i = 0; i < 5; ++i) {
    vec3d q = s * freq + {17.31, -41.47, 29.83} * double(i);
    n += amp * (2.0 * simplexnoise(q) - 1.0);
    freq *= 2.0;
    amp *= 0.5;
}
@density = float(0.6 + 0.3 * abs(n) - r);
";

/// Writes every voxel without computing anything: the cost of AX's file reading and writing,
/// compilation and voxel iteration.
const AX_TRIVIAL: &str = "@density = 0.5f;";

fn felt_script(noise: &str) -> String {
    format!(
        "domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 2.0 / {CELLS});
scalarcache c(d);
cachewrite(c, pyroclastic((0, 0, 0), 0.6, fbm({noise}, {OCTAVES}, scalarfield(2.0), scalarfield(2.0), scalarfield(0.5)), 0.3));
float t0 = clock();
cachefill(c);
float t1 = clock();
print(\"fill_seconds\", t1 - t0);
"
    )
}

/// The same script plus the value range over the cells, for the sanity rows (not timed).
fn felt_stats_script(noise: &str) -> String {
    felt_script(noise) + "print(\"stats\", stats(cacheread(c), d));\n"
}

struct FeltResult {
    fill: f64,
    whole: f64,
    whole_cpu: f64,
    stats: String,
}

fn felt_runs(dir: &Path, name: &str, noise: &str) -> FeltResult {
    let path = dir.join(format!("{name}.felt"));
    std::fs::write(&path, felt_script(noise)).expect("write the felt script");
    // Warm-up: page faults of the first large allocation, thread pool start.
    run_felt(&path);
    let mut fills = Vec::new();
    let mut wholes = Vec::new();
    let mut cpus = Vec::new();
    for _ in 0..RUNS {
        let (whole, cpu, text) = run_felt(&path);
        fills.push(printed(&text, "fill_seconds").expect("the script prints its fill time"));
        wholes.push(whole);
        cpus.push(cpu);
    }
    let stats_path = dir.join(format!("{name}_stats.felt"));
    std::fs::write(&stats_path, felt_stats_script(noise)).expect("write the felt script");
    let (_, _, text) = run_felt(&stats_path);
    let stats = text
        .lines()
        .find_map(|l| l.strip_prefix("stats "))
        .unwrap_or("?")
        .to_string();
    FeltResult {
        fill: median(fills),
        whole: median(wholes),
        whole_cpu: median(cpus),
        stats,
    }
}

/// A duration as OpenVDB prints it: `237.9ms`, `4.2s`, `1m 3.2s`.
fn parse_duration(text: &str) -> Option<f64> {
    let mut total = 0.0;
    let mut any = false;
    for token in text.split_whitespace() {
        let (number, scale) = if let Some(n) = token.strip_suffix("ms") {
            (n, 1e-3)
        } else if let Some(n) = token.strip_suffix('s') {
            (n, 1.0)
        } else if let Some(n) = token.strip_suffix('m') {
            (n, 60.0)
        } else if let Some(n) = token.strip_suffix('h') {
            (n, 3600.0)
        } else {
            return None;
        };
        total += number.parse::<f64>().ok()? * scale;
        any = true;
    }
    any.then_some(total)
}

/// The time `vdb_ax -v` reports for the phase announced by `marker`: the first `| <time>`
/// after it.
fn ax_phase(log: &str, marker: &str) -> Option<f64> {
    let after = &log[log.find(marker)? + marker.len()..];
    after.split("[INFO]").find_map(|chunk| {
        let timing = chunk.trim().strip_prefix('|')?.trim();
        let timing = timing.rsplit(':').next()?.trim();
        parse_duration(timing)
    })
}

#[derive(Default)]
struct AxRun {
    wall: f64,
    cpu: f64,
    read: f64,
    compile: f64,
    execute: f64,
    write: f64,
}

fn run_ax(dense: &Path, out: &Path, code: &Path) -> AxRun {
    let (start, cpu_start) = (Instant::now(), cpu_seconds().1);
    let output = Command::new("vdb_ax")
        .arg("execute")
        .arg("-i")
        .arg(dense)
        .arg("-o")
        .arg(out)
        .arg("-f")
        .arg(code)
        .args(["--opt", "O3", "--threads", "0", "-v"])
        .output()
        .expect("vdb_ax runs");
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu_seconds().1 - cpu_start;
    let log = String::from_utf8_lossy(&output.stdout).into_owned()
        + &String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "vdb_ax failed:\n{log}");
    assert!(
        log.contains("Execution success"),
        "vdb_ax did not execute:\n{log}"
    );
    let phase = |m| ax_phase(&log, m).unwrap_or(f64::NAN);
    AxRun {
        wall,
        cpu,
        read: phase("Reading VDB data"),
        compile: phase("Compilation successful"),
        execute: phase("Execution success"),
        write: phase("Writing results"),
    }
}

fn ax_runs(dense: &Path, out: &Path, code: &Path) -> AxRun {
    run_ax(dense, out, code);
    let runs: Vec<AxRun> = (0..RUNS).map(|_| run_ax(dense, out, code)).collect();
    let med = |f: fn(&AxRun) -> f64| median(runs.iter().map(f).collect());
    AxRun {
        wall: med(|r| r.wall),
        cpu: med(|r| r.cpu),
        read: med(|r| r.read),
        compile: med(|r| r.compile),
        execute: med(|r| r.execute),
        write: med(|r| r.write),
    }
}

/// Active voxel count and value range of a grid, as `vdb_print -l` reports them.
fn vdb_summary(path: &Path) -> String {
    let Ok(output) = Command::new("vdb_print").arg("-l").arg(path).output() else {
        return "vdb_print not found".into();
    };
    let text = String::from_utf8_lossy(&output.stdout);
    let field = |key: &str| {
        text.lines()
            .find_map(|l| l.trim().strip_prefix(key))
            .map(|v| v.trim().replace(',', ""))
            .unwrap_or_else(|| "?".into())
    };
    format!(
        "active voxels {}, active tiles {}, min {}, max {}",
        field("Number of active voxels:"),
        field("Number of active tiles:"),
        field("Min value:"),
        field("Max value:")
    )
}

fn python() -> Option<PathBuf> {
    ["/usr/bin/python3", "python3"].iter().find_map(|p| {
        let ok = Command::new(p)
            .args(["-c", "import pyopenvdb"])
            .output()
            .is_ok_and(|o| o.status.success());
        ok.then(|| PathBuf::from(p))
    })
}

/// Noise samples per second of felt's `f32` noise kernel alone, one thread, values only, on
/// blocks of points spread over a few lattice cells as an octave's points on the sphere are.
/// The fill takes `OCTAVES` samples per cell, so this bounds what the fill can reach.
fn noise_kernel_rate(kind: NoiseKind) -> f64 {
    let blocks = (1usize << 23) / BLOCK;
    let lane = |i: usize, step: f32| i as f32 * step;
    let xs: Vec<f32> = (0..BLOCK).map(|i| lane(i, 0.011)).collect();
    let ys: Vec<f32> = (0..BLOCK).map(|i| lane(i, 0.003)).collect();
    let zs: Vec<f32> = (0..BLOCK).map(|i| lane(i, 0.007)).collect();
    let mut out = vec![0.0f32; BLOCK];
    let mut run = || {
        for b in 0..blocks {
            let base = [b as f64 * 0.37, 1.5 - b as f64 * 0.11, 0.25];
            noise::eval_f32(kind, 0, base, &xs, &ys, &zs, NoiseOutput::value(&mut out));
        }
        std::hint::black_box(&out);
    };
    run();
    let start = Instant::now();
    run();
    (blocks * BLOCK) as f64 / start.elapsed().as_secs_f64()
}

fn main() {
    if Command::new("vdb_ax").arg("--help").output().is_err() {
        println!("peer_ax skipped: vdb_ax (OpenVDB AX) is not installed");
        return;
    }
    let Some(python) = python() else {
        println!("peer_ax skipped: python3 with pyopenvdb is needed to write the dense input grid");
        return;
    };
    let dir = tempfile::tempdir().expect("a temporary directory");
    let dir = dir.path();
    println!(
        "threads: felt {} (rayon), vdb_ax all",
        rayon::current_num_threads()
    );

    let perlin = felt_runs(dir, "pyro_perlin", "perlin()");
    let simplex = felt_runs(dir, "pyro_simplex", "simplex()");

    let dense = dir.join("dense.vdb");
    let out = dir.join("out.vdb");
    let start = Instant::now();
    let made = Command::new(&python)
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/peer/make_dense.py"))
        .arg(&dense)
        .arg(CELLS.to_string())
        .output()
        .expect("python runs");
    assert!(
        made.status.success(),
        "make_dense.py failed: {}",
        String::from_utf8_lossy(&made.stderr)
    );
    let make_seconds = start.elapsed().as_secs_f64();
    let input_summary = vdb_summary(&dense);

    let pyro_code = dir.join("pyroclastic.ax");
    let trivial_code = dir.join("trivial.ax");
    std::fs::write(&pyro_code, AX_PYROCLASTIC).expect("write the AX snippet");
    std::fs::write(&trivial_code, AX_TRIVIAL).expect("write the AX snippet");
    let trivial = ax_runs(&dense, &out, &trivial_code);
    let ax = ax_runs(&dense, &out, &pyro_code);
    let output_summary = vdb_summary(&out);
    let perlin_kernel = noise_kernel_rate(NoiseKind::Perlin);
    let simplex_kernel = noise_kernel_rate(NoiseKind::Simplex);

    let cells = CELLS.pow(3);
    println!(
        "\n## pyroclastic sphere, {OCTAVES} octaves, dense {CELLS}^3 = {cells} voxels, median of {RUNS} after a warm-up"
    );
    println!("| run | seconds | Mvoxels/s | CPU seconds | what the time covers |");
    println!("|---|---|---|---|---|");
    let rate = |s: f64| cells as f64 / s * 1e-6;
    for (name, r) in [("perlin", &perlin), ("simplex", &simplex)] {
        println!(
            "| felt, {name}: cachefill | {:.3} | {:.1} | | clock() around cachefill |",
            r.fill,
            rate(r.fill)
        );
        println!(
            "| felt, {name}: whole script | {:.3} | {:.1} | {:.2} | Session::run_file: parse, check, build, fill (no file written) |",
            r.whole,
            rate(r.whole),
            r.whole_cpu
        );
    }
    for (name, r) in [
        ("pyroclastic", &ax),
        ("trivial `@density = 0.5f`", &trivial),
    ] {
        println!(
            "| vdb_ax, {name}: whole process | {:.3} | {:.1} | {:.2} | read + compile + execute + write |",
            r.wall,
            rate(r.wall),
            r.cpu
        );
        println!(
            "| vdb_ax, {name}: execute only | {:.3} | {:.1} | | `vdb_ax -v`: read {:.3}, compile {:.3}, write {:.3} |",
            r.execute,
            rate(r.execute),
            r.read,
            r.compile,
            r.write
        );
    }
    println!(
        "\n| ratio | value |\n|---|---|\n\
         | vdb_ax whole / felt cachefill (perlin) | {:.1} |\n\
         | vdb_ax whole / felt whole script (perlin) | {:.1} |\n\
         | vdb_ax execute / felt cachefill (perlin) | {:.1} |\n\
         | vdb_ax execute / felt cachefill (simplex, same noise family) | {:.1} |\n\
         | (vdb_ax whole − trivial whole) / felt cachefill (perlin) | {:.1} |\n\
         | vdb_ax whole CPU / felt whole script CPU (perlin) | {:.1} |\n\
         | vdb_ax whole CPU / felt whole script CPU (simplex) | {:.1} |",
        ax.wall / perlin.fill,
        ax.wall / perlin.whole,
        ax.execute / perlin.fill,
        ax.execute / simplex.fill,
        (ax.wall - trivial.wall) / perlin.fill,
        ax.cpu / perlin.whole_cpu,
        ax.cpu / simplex.whole_cpu,
    );
    println!(
        "\n## felt's f32 noise kernel alone (noise::eval_f32, values only, 1 thread)\n\
         | noise | Msamples/s | fill lower bound at this rate, {OCTAVES} samples per cell, 2 threads |\n\
         |---|---|---|"
    );
    for (name, rate) in [("perlin", perlin_kernel), ("simplex", simplex_kernel)] {
        println!(
            "| {name} | {:.1} | {:.2} s |",
            rate * 1e-6,
            (cells * OCTAVES) as f64 / rate / 2.0
        );
    }
    println!("\nsanity (values over the {cells} cells):");
    println!("  felt perlin (min, max, mean): {}", perlin.stats);
    println!("  felt simplex (min, max, mean): {}", simplex.stats);
    println!("  AX input grid: {input_summary} (written in {make_seconds:.1} s, not timed)");
    println!("  AX output grid: {output_summary}");
}
