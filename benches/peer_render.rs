//! felt's raymarcher against `vdb_render` on the same 256³ density grid at 640×360.
//!
//! felt writes the grid once (`cachesave` of the smoothed five-octave pyroclastic sphere over
//! [-1, 1]³, voxel 2/256, zero voxels inactive); both renderers read that file. The scene is
//! matched term by term to `vdb_render`'s single-scattering model (OpenVDB `VolumeRender`):
//! - camera: `-translate eye -lookat target -up` with `-fov` = felt's angle; both are
//!   horizontal fields of view (OpenVDB's `fov` sets the focal length against the horizontal
//!   aperture), rays through pixel centres;
//! - extinction: `vdb_render` works in voxel units, `exp(−(σa+σs)·ρ·Δt)` with `Δt` in voxels,
//!   so felt's `kappa` is `(σa+σs)/voxel` per world unit (1.6 per voxel = 204.8);
//! - light: `vdb_render`'s `-light` points *towards* the light, felt's `distantlight` gives the
//!   direction the light travels, so the vectors are opposite. `vdb_render` adds
//!   `C·σs/(σa+σs)·T_L·T·(1−ΔT)` per step and felt `L·T_L·T·(1−ΔT)/κ` (isotropic phase, 4π·p = 1),
//!   so felt's strength is `L = C·σs/voxel`. `-gain 0` turns off `vdb_render`'s shadow-ray
//!   brightening, which felt has no counterpart of;
//! - camera-ray step: one voxel for both;
//! - termination: `vdb_render` stops when `|T|² < cutoff` over three channels and skips
//!   densities below `cutoff`; `-cutoff 3e-6` makes that `T < 1e-3`, felt's default threshold.
//!
//! Shadows are where the two differ by design: `vdb_render` marches a shadow ray per sample
//! (3-voxel steps by default, 1 voxel also timed), felt reads a precomputed transmissivity grid
//! by default (`shadows = "march"` also timed). Alpha depends only on the camera-ray march, so
//! the alpha difference checks that the setups match; lighting is scored against an independent
//! reference, `vdb_render` with quarter-voxel shadow steps. The step study renders felt at
//! several steps against a felt render at 1/8 voxel. The one key decision: every number
//! compares images each renderer wrote itself, read back with the `exr` crate.
//!
//! Skips with a message when `vdb_render` is missing. Run with `cargo bench --bench peer_render`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

#[path = "peer/felt_run.rs"]
mod felt_run;
use felt_run::{cpu_seconds, median, printed, run_felt};
#[path = "peer/pyroclastic_grid.rs"]
mod pyroclastic_grid;
use pyroclastic_grid::{CELLS, make_grid_script};

const WIDTH: usize = 640;
const HEIGHT: usize = 360;
const RUNS: usize = 3;
/// Extinction per voxel, `vdb_render`'s defaults: absorption 0.1 + scattering 1.5.
const ABSORB: f64 = 0.1;
const SCATTER: f64 = 1.5;
/// `vdb_render`'s default light colour.
const LIGHT_COLOR: f64 = 0.7;
/// Direction towards the light (`vdb_render`'s convention).
const TOWARDS_LIGHT: [f64; 3] = [0.5, 1.0, 0.6];
const EYE: [f64; 3] = [0.0, 0.4, 3.2];
const FOV: f64 = 45.0;

fn voxel() -> f64 {
    2.0 / CELLS as f64
}

/// Loads the grid and renders it once at `step` (world units) into `out`, with `shadows`
/// "cache" or "march" and, where given, the light cache's cell size `shadow_cell`.
fn render_script(
    grid: &Path,
    out: &Path,
    step: f64,
    shadows: &str,
    shadow_cell: Option<f64>,
) -> String {
    let v = voxel();
    let kappa = (ABSORB + SCATTER) / v;
    let strength = LIGHT_COLOR * SCATTER / v;
    let [lx, ly, lz] = TOWARDS_LIGHT;
    let [ex, ey, ez] = EYE;
    let cell = shadow_cell.map_or(String::new(), |c| format!(", shadowcell = {c}"));
    format!(
        "scalarfield rho = cacheload(\"{grid}\", \"density\");
camera cam = camera(({ex}, {ey}, {ez}), (0, 0, 0), (0, 1, 0), {FOV});
light key = distantlight(({}, {}, {}), ({strength}, {strength}, {strength}));
float t0 = clock();
render(\"{out}\", density = rho, camera = cam, lights = {{key}}, kappa = {kappa}, step = {step},
       width = {WIDTH}, height = {HEIGHT}, shadows = \"{shadows}\"{cell});
float t1 = clock();
print(\"render_seconds\", t1 - t0);
",
        -lx,
        -ly,
        -lz,
        grid = grid.display(),
        out = out.display(),
    )
}

/// Writes `text` as script `name` in `dir` and runs it; returns the wall and CPU seconds of
/// `run_file` and the number it printed after `render_seconds`, if any.
fn run_script(dir: &Path, name: &str, text: &str) -> (f64, f64, Option<f64>) {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write the felt script");
    let (seconds, cpu, printed_text) = run_felt(&path);
    (seconds, cpu, printed(&printed_text, "render_seconds"))
}

struct Rgba {
    width: usize,
    height: usize,
    pixels: Vec<[f32; 4]>,
}

fn read_rgba(path: &Path) -> Rgba {
    use exr::prelude::read_first_rgba_layer_from_file;
    let image = read_first_rgba_layer_from_file(
        path,
        |resolution, _| Rgba {
            width: resolution.width(),
            height: resolution.height(),
            pixels: vec![[0.0; 4]; resolution.width() * resolution.height()],
        },
        |image: &mut Rgba, position, (r, g, b, a): (f32, f32, f32, f32)| {
            let index = position.y() * image.width + position.x();
            image.pixels[index] = [r, g, b, a];
        },
    )
    .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    image.layer_data.channel_data.pixels
}

/// RMSE over the channels in `channels`, and the largest absolute difference.
fn compare(a: &Rgba, b: &Rgba, channels: std::ops::Range<usize>) -> (f64, f64) {
    assert_eq!(
        (a.width, a.height),
        (b.width, b.height),
        "image sizes differ"
    );
    let mut sum = 0.0;
    let mut worst: f64 = 0.0;
    let mut count = 0usize;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        for c in channels.clone() {
            let d = (p[c] - q[c]) as f64;
            sum += d * d;
            worst = worst.max(d.abs());
            count += 1;
        }
    }
    ((sum / count as f64).sqrt(), worst)
}

fn mean_alpha(image: &Rgba) -> f64 {
    image.pixels.iter().map(|p| p[3] as f64).sum::<f64>() / image.pixels.len() as f64
}

#[derive(Clone, Copy)]
struct VdbConfig {
    /// Density and transmittance cutoff.
    cutoff: f64,
    /// Shadow-ray step in voxels.
    shadow_step: f64,
}

struct VdbRun {
    wall: f64,
    cpu: f64,
    trace: f64,
}

/// One `vdb_render` run; returns its process wall time and the ray-tracing time it reports.
fn run_vdb_render(grid: &Path, out: &Path, config: VdbConfig) -> VdbRun {
    let v = |x: [f64; 3]| format!("{},{},{}", x[0], x[1], x[2]);
    let [lx, ly, lz] = TOWARDS_LIGHT;
    let c = LIGHT_COLOR;
    let (start, cpu_start) = (Instant::now(), cpu_seconds().1);
    let output = Command::new("vdb_render")
        .arg(grid)
        .arg(out)
        .args(["-res", &format!("{WIDTH}x{HEIGHT}")])
        .args(["-translate", &v(EYE)])
        .args(["-lookat", "0,0,0", "-up", "0,1,0"])
        .args(["-fov", &FOV.to_string()])
        .args(["-absorb", &v([ABSORB; 3]), "-scatter", &v([SCATTER; 3])])
        .args(["-light", &format!("{lx},{ly},{lz},{c},{c},{c}")])
        .args(["-gain", "0", "-step", "1"])
        .args(["-shadowstep", &config.shadow_step.to_string()])
        .args(["-cutoff", &config.cutoff.to_string()])
        .args(["-cpus", "0", "-compression", "zip", "-v"])
        .output()
        .expect("vdb_render runs");
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu_seconds().1 - cpu_start;
    let log = String::from_utf8_lossy(&output.stdout).into_owned()
        + &String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "vdb_render failed:\n{log}");
    // "ray-tracing density...\n vdb_render: ...completed in 1.23 sec"
    let trace = log
        .split("ray-tracing")
        .nth(1)
        .and_then(|rest| rest.split("completed in").nth(1))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|s| s.parse().ok())
        .unwrap_or(f64::NAN);
    VdbRun { wall, cpu, trace }
}

/// `runs` timed runs (after a warm-up when `runs > 1`); medians.
fn vdb_render_runs(grid: &Path, out: &Path, config: VdbConfig, runs: usize) -> VdbRun {
    if runs > 1 {
        run_vdb_render(grid, out, config);
    }
    let runs: Vec<VdbRun> = (0..runs)
        .map(|_| run_vdb_render(grid, out, config))
        .collect();
    VdbRun {
        wall: median(runs.iter().map(|r| r.wall).collect()),
        cpu: median(runs.iter().map(|r| r.cpu).collect()),
        trace: median(runs.iter().map(|r| r.trace).collect()),
    }
}

struct FeltRun {
    whole: f64,
    cpu: f64,
    render: f64,
}

/// `runs` timed runs (after a warm-up when `runs > 1`); medians.
fn felt_runs(
    dir: &Path,
    grid: &Path,
    out: &Path,
    step: f64,
    (shadows, shadow_cell): (&str, Option<f64>),
    runs: usize,
) -> FeltRun {
    let script = render_script(grid, out, step, shadows, shadow_cell);
    if runs > 1 {
        run_script(dir, "render.felt", &script);
    }
    let (mut wholes, mut cpus, mut renders) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..runs {
        let (whole, cpu, render) = run_script(dir, "render.felt", &script);
        wholes.push(whole);
        cpus.push(cpu);
        renders.push(render.expect("the script prints its render time"));
    }
    FeltRun {
        whole: median(wholes),
        cpu: median(cpus),
        render: median(renders),
    }
}

fn main() {
    if Command::new("vdb_render").arg("-version").output().is_err() {
        println!("peer_render skipped: vdb_render (OpenVDB) is not installed");
        return;
    }
    let dir = tempfile::tempdir().expect("a temporary directory");
    let dir = dir.path();
    let grid: PathBuf = dir.join("pyroclastic.vdb");
    let start = Instant::now();
    run_script(dir, "make_grid.felt", &make_grid_script(&grid));
    println!(
        "grid: felt cachesave of the pyroclastic sphere, {CELLS}^3 over [-1,1]^3, in {:.1} s (not timed below)",
        start.elapsed().as_secs_f64()
    );
    println!(
        "threads: felt {} (rayon), vdb_render all",
        rayon::current_num_threads()
    );

    let v = voxel();
    // T < 1e-3 on all three channels: |T|² < 3e-6.
    let matched = VdbConfig {
        cutoff: 3e-6,
        shadow_step: 3.0,
    };
    let vdb_configs = [
        (
            "vdb_render, shadow step 3 voxels (default), cutoff matched",
            matched,
            RUNS,
        ),
        (
            "vdb_render, shadow step 1 voxel, cutoff matched",
            VdbConfig {
                shadow_step: 1.0,
                ..matched
            },
            RUNS,
        ),
        (
            "vdb_render, all defaults (cutoff 0.005, shadow step 3)",
            VdbConfig {
                cutoff: 0.005,
                ..matched
            },
            RUNS,
        ),
    ];
    let lighting_reference = dir.join("vdb_reference.exr");
    vdb_render_runs(
        &grid,
        &lighting_reference,
        VdbConfig {
            shadow_step: 0.25,
            ..matched
        },
        1,
    );
    let lighting_reference = read_rgba(&lighting_reference);

    struct Row {
        name: String,
        render: f64,
        whole: f64,
        cpu: f64,
        image: Rgba,
    }
    let mut rows = Vec::new();
    for (i, (name, config, runs)) in vdb_configs.into_iter().enumerate() {
        let path = dir.join(format!("vdb_{i}.exr"));
        let r = vdb_render_runs(&grid, &path, config, runs);
        rows.push(Row {
            name: name.to_string(),
            render: r.trace,
            whole: r.wall,
            cpu: r.cpu,
            image: read_rgba(&path),
        });
    }
    for (name, shadows, runs) in [
        ("felt, cached shadows (default)", "cache", RUNS),
        ("felt, marched shadows (1 run)", "march", 1),
    ] {
        let path = dir.join(format!("felt_{shadows}.exr"));
        let r = felt_runs(dir, &grid, &path, v, (shadows, None), runs);
        rows.push(Row {
            name: name.to_string(),
            render: r.render,
            whole: r.whole,
            cpu: r.cpu,
            image: read_rgba(&path),
        });
    }

    println!(
        "\n## {WIDTH}x{HEIGHT}, {CELLS}^3 pyroclastic density, 1 distant light, extinction {} per voxel = {:.1} per unit, camera step 1 voxel; median of {RUNS} after a warm-up",
        ABSORB + SCATTER,
        (ABSORB + SCATTER) / v
    );
    println!(
        "render s: felt clock() around render() (shadow grid, march, EXR write); vdb_render its own ray-tracing timer (-v). whole s: felt Session::run_file (VDB read + render + write); vdb_render the process (VDB read + trace + EXR write)."
    );
    println!(
        "| renderer | render s | whole s | whole CPU s | alpha RMSE / max vs vdb_render row 1 | RGB RMSE vs lighting reference | mean alpha |"
    );
    println!("|---|---|---|---|---|---|---|");
    for row in &rows {
        let (alpha_rmse, alpha_max) = compare(&row.image, &rows[0].image, 3..4);
        let (rgb_rmse, _) = compare(&row.image, &lighting_reference, 0..3);
        println!(
            "| {} | {:.3} | {:.3} | {:.2} | {alpha_rmse:.2e} / {alpha_max:.3} | {rgb_rmse:.2e} | {:.4} |",
            row.name,
            row.render,
            row.whole,
            row.cpu,
            mean_alpha(&row.image)
        );
    }
    println!(
        "lighting reference: vdb_render, shadow step 1/4 voxel, cutoff matched (1 run); its mean alpha {:.4}",
        mean_alpha(&lighting_reference)
    );
    let felt = &rows[3];
    println!(
        "\n| ratio (felt cached shadows / vdb_render) | render s | whole s | whole CPU s |\n|---|---|---|---|"
    );
    for vdb in &rows[..3] {
        println!(
            "| vs {} | {:.2} | {:.2} | {:.2} |",
            vdb.name,
            felt.render / vdb.render,
            felt.whole / vdb.whole,
            felt.cpu / vdb.cpu
        );
    }
    let marched = &rows[4];
    println!(
        "| felt marched shadows vs vdb_render shadow step 1 voxel | {:.2} | {:.2} | {:.2} |",
        marched.render / rows[1].render,
        marched.whole / rows[1].whole,
        marched.cpu / rows[1].cpu
    );

    // What the light cache's resolution costs and buys at the camera step of the comparison.
    println!(
        "\n## felt light-cache study ({WIDTH}x{HEIGHT}, camera step 1 voxel, median of {RUNS}): shadowcell in voxels"
    );
    println!(
        "| shadowcell (voxels) | whole s | whole CPU s | RGB RMSE vs lighting reference | whole s / vdb_render shadow step 1 voxel |"
    );
    println!("|---|---|---|---|---|");
    for voxels in [1.0, 2.0, 4.0] {
        let path = dir.join(format!("cell_{voxels}.exr"));
        let r = felt_runs(dir, &grid, &path, v, ("cache", Some(voxels * v)), RUNS);
        let (lit, _) = compare(&read_rgba(&path), &lighting_reference, 0..3);
        println!(
            "| {voxels} | {:.3} | {:.2} | {lit:.2e} | {:.2} |",
            r.whole,
            r.cpu,
            r.whole / rows[1].whole
        );
    }

    println!(
        "\n## felt step study ({WIDTH}x{HEIGHT}, same scene, cached shadows), reference step = voxel/8 = 2/{}",
        CELLS * 8
    );
    println!(
        "felt's shadow grid cell is max(step, box/256) (1 voxel at the finest), so the coarse steps also have coarser shadow grids."
    );
    println!(
        "| step | voxels | render s | RMSE RGBA vs reference | RMSE alpha vs reference | RGB RMSE vs vdb_render lighting reference |"
    );
    println!("|---|---|---|---|---|---|");
    let reference_path = dir.join("reference.exr");
    let reference_run = felt_runs(dir, &grid, &reference_path, v / 8.0, ("cache", None), 1);
    let reference = read_rgba(&reference_path);
    // (step in voxels, render s, RGB RMSE vs the lighting reference) of each study row.
    let mut study = Vec::new();
    for divisions in [64usize, 128, 256, 512, 1024, 2048] {
        let step = 2.0 / divisions as f64;
        let path = dir.join(format!("step_{divisions}.exr"));
        let (run, image) = if divisions == CELLS * 8 {
            (reference_run.render, read_rgba(&reference_path))
        } else {
            let run = felt_runs(dir, &grid, &path, step, ("cache", None), 1);
            (run.render, read_rgba(&path))
        };
        let (rgba, _) = compare(&image, &reference, 0..4);
        let (alpha, _) = compare(&image, &reference, 3..4);
        let (lit, _) = compare(&image, &lighting_reference, 0..3);
        println!(
            "| 2/{divisions} | {} | {run:.3} | {rgba:.2e} | {alpha:.2e} | {lit:.2e} |",
            step / v
        );
        study.push((step / v, run, lit));
    }

    // The target is a time ratio at equal or better quality: for each vdb_render setting, the
    // fastest felt step whose lighting error is no larger than vdb_render's own.
    println!(
        "\n## equal or better quality: fastest felt step (study above, 1 run) with RGB RMSE <= vdb_render's"
    );
    println!(
        "| vdb_render setting | its render s | its RGB RMSE | felt step (voxels) | felt render s | felt RGB RMSE | felt / vdb_render time |"
    );
    println!("|---|---|---|---|---|---|---|");
    for vdb in &rows[..3] {
        let (vdb_lit, _) = compare(&vdb.image, &lighting_reference, 0..3);
        let best = study
            .iter()
            .filter(|(_, _, lit)| *lit <= vdb_lit)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        match best {
            Some((voxels, run, lit)) => println!(
                "| {} | {:.3} | {vdb_lit:.2e} | {voxels} | {run:.3} | {lit:.2e} | {:.2} |",
                vdb.name,
                vdb.render,
                run / vdb.render
            ),
            None => println!(
                "| {} | {:.3} | {vdb_lit:.2e} | none | | | |",
                vdb.name, vdb.render
            ),
        }
    }
}
