//! `felt study` end to end: a study whose error law is known in closed form, the CSV and the
//! plots it writes, failing settings, outputs that cannot be compared, the cached reference,
//! image and grid comparisons, and bad input; in `study/`, grids on other voxels resampled
//! (`grids`), the Pareto fronts and the plots' labels, markers and colours (`plots`), and
//! repeated runs (`repeats`).
//!
//! Studies here run each setting once (`--repeat 1`) unless a test is about the repeats.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

#[path = "study/grids.rs"]
mod grids;
#[path = "study/plots.rs"]
mod plots;
#[path = "study/repeats.rs"]
mod repeats;

/// The midpoint rule for ∫₀¹ eˣ dx with `n` intervals: its error is (e − 1)/(24 n²) to leading
/// order, so the error against a far finer reference falls as h² with h = 1/n.
const MIDPOINT: &str = "\
param int n = 4;
float h = 1.0 / n;
float sum = 0;
for (int i = 0; i < n; i++) {
    sum = sum + exp((i + 0.5) * h) * h;
}
print(\"integral\", sum);
print(\"exact error\", abs(sum - (exp(1.0) - 1)));
";

fn script(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn study(dir: &Path, args: &[&str]) -> Output {
    let mut all = args.to_vec();
    if !args.contains(&"--repeat") {
        all.extend(["--repeat", "1"]);
    }
    study_as_given(dir, &all, &[])
}

/// `felt study` with exactly `args`, and `env` set for it and the runs it starts.
fn study_as_given(dir: &Path, args: &[&str], env: &[(&str, &Path)]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_felt"));
    command.current_dir(dir).arg("study").args(args);
    for (name, value) in env {
        command.env(name, value);
    }
    command.output().unwrap()
}

fn text(output: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}

/// The CSV as rows of fields (no field in these tests needs quoting).
fn csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, rows)
}

fn column(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
}

/// Least-squares slope of log y against log x.
fn slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (lx, ly): (Vec<f64>, Vec<f64>) = points.iter().map(|(x, y)| (x.ln(), y.ln())).unzip();
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let sxy: f64 = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = lx.iter().map(|x| (x - mx).powi(2)).sum();
    sxy / sxx
}

#[test]
fn midpoint_errors_follow_the_second_order_law() {
    let dir = tempfile::tempdir().unwrap();
    script(dir.path(), "midpoint.felt", MIDPOINT);
    let out = study(
        dir.path(),
        &[
            "midpoint.felt",
            "--sweep",
            "n=2,4,8,16,32",
            "--reference",
            "n=4096",
            "--out",
            "s",
        ],
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let (header, rows) = csv(&dir.path().join("s/study.csv"));
    assert_eq!(rows.len(), 5, "one row per setting");
    let (n, rel, exact) = (
        column(&header, "n"),
        column(&header, "integral rel"),
        column(&header, "exact error"),
    );
    let points: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (1.0 / r[n].parse::<f64>().unwrap(), r[rel].parse().unwrap()))
        .collect();
    let fitted = slope(&points);
    assert!((fitted - 2.0).abs() < 0.2, "slope {fitted}: {points:?}");
    // The error against the reference is the exact error less the reference's own, which is
    // (e − 1)/(24 · 4096²) ≈ 4e-9: at n = 2 the two agree to that.
    let e2: f64 = rows[0][exact].parse().unwrap();
    let r2: f64 = rows[0][rel].parse::<f64>().unwrap() * (1f64.exp() - 1.0);
    assert!((e2 - r2).abs() < 1e-8, "{e2} vs {r2}");
    // Times, CPU times and peaks are measured (a felt process needs some memory).
    for r in &rows {
        assert_eq!(r[column(&header, "status")], "ok");
        assert!(r[column(&header, "seconds")].parse::<f64>().unwrap() > 0.0);
        assert!(r[column(&header, "peak_mib")].parse::<f64>().unwrap() > 1.0);
    }
    // The plots are SVG documents with a point per setting.
    let pareto = std::fs::read_to_string(dir.path().join("s/pareto-integral-rel.svg")).unwrap();
    assert!(pareto.trim_start().starts_with("<svg") && pareto.trim_end().ends_with("</svg>"));
    assert!(pareto.matches("<circle").count() >= 5, "{pareto}");
    let against = std::fs::read_to_string(dir.path().join("s/integral-rel-vs-n.svg")).unwrap();
    assert!(against.trim_end().ends_with("</svg>"));
    assert!(dir.path().join("s/exact-error-vs-n.svg").is_file());
    // The table names every setting and the reference.
    let shown = String::from_utf8_lossy(&out.stdout);
    assert!(shown.contains("integral rel") && shown.contains("reference n=4096"));
}

#[test]
fn the_reference_is_cached_until_the_script_changes() {
    let dir = tempfile::tempdir().unwrap();
    let path = script(dir.path(), "midpoint.felt", MIDPOINT);
    let args = [
        "midpoint.felt",
        "--sweep",
        "n=2,4",
        "--reference",
        "n=512",
        "--out",
        "s",
    ];
    let first = study(dir.path(), &args);
    assert_eq!(first.status.code(), Some(0), "{}", text(&first));
    assert!(!text(&first).contains("cached"));
    let references: Vec<PathBuf> = std::fs::read_dir(dir.path().join("s/reference"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(references.len(), 1);
    let measured = references[0].join("measured.txt");
    let before = std::fs::read_to_string(&measured).unwrap();
    // More settings: the reference is reused, not rerun.
    let second = study(
        dir.path(),
        &[
            "midpoint.felt",
            "--sweep",
            "n=2,4,8",
            "--reference",
            "n=512",
            "--out",
            "s",
        ],
    );
    assert_eq!(second.status.code(), Some(0), "{}", text(&second));
    assert!(
        text(&second).contains("reference n=512: cached"),
        "{}",
        text(&second)
    );
    assert_eq!(std::fs::read_to_string(&measured).unwrap(), before);
    assert_eq!(csv(&dir.path().join("s/study.csv")).1.len(), 3);
    // An edited script is a new reference.
    std::fs::write(&path, format!("{MIDPOINT}// edited\n")).unwrap();
    let third = study(dir.path(), &args);
    assert_eq!(third.status.code(), Some(0), "{}", text(&third));
    assert!(!text(&third).contains("cached"), "{}", text(&third));
    assert_eq!(
        std::fs::read_dir(dir.path().join("s/reference"))
            .unwrap()
            .count(),
        2
    );
}

#[test]
fn a_failing_setting_is_reported_and_the_study_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    script(
        dir.path(),
        "fails.felt",
        "param int n = 1;\nint[] values = {10, 20, 30};\nprint(\"value\", values[n]);\n",
    );
    let out = study(
        dir.path(),
        &["fails.felt", "--sweep", "n=0,5,1", "--reference", "n=2"],
    );
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(
        text(&out).contains("✗ n=5: the run failed (exit 1"),
        "{}",
        text(&out)
    );
    let (header, rows) = csv(&dir.path().join("fails-study/study.csv"));
    assert_eq!(rows.len(), 3);
    let status = column(&header, "status");
    assert_eq!(rows[0][status], "ok");
    assert!(
        rows[1][status].starts_with("failed: exit 1"),
        "{:?}",
        rows[1]
    );
    assert_eq!(rows[2][status], "ok");
    assert_eq!(rows[2][column(&header, "value abs")], "10");
}

#[test]
fn a_failing_reference_stops_the_study() {
    let dir = tempfile::tempdir().unwrap();
    script(
        dir.path(),
        "fails.felt",
        "param int n = 1;\nint[] values = {10, 20, 30};\nprint(\"value\", values[n]);\n",
    );
    let out = study(
        dir.path(),
        &["fails.felt", "--sweep", "n=0,1", "--reference", "n=9"],
    );
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(
        text(&out).contains("the reference setting (n=9) failed"),
        "{}",
        text(&out)
    );
    assert!(!dir.path().join("fails-study/study.csv").exists());
}

#[test]
fn outputs_that_differ_from_the_reference_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    // The cache's file name depends on the swept param.
    script(
        dir.path(),
        "named.felt",
        "param int n = 1;\ndomain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.25);\n\
         scalarcache c(d);\ncachewrite(c, scalarfield(n));\n\
         cachesave(c, \"density_\" + str(n) + \".vdb\");\n",
    );
    let out = study(
        dir.path(),
        &["named.felt", "--sweep", "n=1,2", "--reference", "n=3"],
    );
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(
        text(&out).contains("did not write density_3.vdb (the reference did)")
            && text(&out).contains("wrote density_1.vdb, which the reference did not"),
        "{}",
        text(&out)
    );
}

#[test]
fn grids_and_images_are_compared_by_their_measures() {
    let dir = tempfile::tempdir().unwrap();
    // A constant density c everywhere in the domain: every voxel is active, so the RMSE and
    // the largest error against the reference's constant are both |c − c_ref| (in f32).
    script(
        dir.path(),
        "grid.felt",
        "param float c = 1.0;\ndomain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.125);\n\
         scalarcache k(d);\ncachewrite(k, scalarfield(c));\ncachesave(k, \"density.vdb\");\n\
         camera cam = camera((0.5, 0.5, 3), (0.5, 0.5, 0.5), (0, 1, 0), 40);\n\
         render(\"image.exr\", density = cacheread(k), camera = cam, kappa = 2.0, step = 0.02,\n\
                emission = vectorfield((1.0, 0.6, 0.3)),\n\
                width = 24, height = 16);\n",
    );
    let out = study(
        dir.path(),
        &["grid.felt", "--sweep", "c=1.5,0.75", "--reference", "c=1"],
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let (header, rows) = csv(&dir.path().join("grid-study/study.csv"));
    let value =
        |row: usize, name: &str| -> f64 { rows[row][column(&header, name)].parse().unwrap() };
    assert!((value(0, "density.vdb rmse") - 0.5).abs() < 1e-6);
    assert!((value(0, "density.vdb max") - 0.5).abs() < 1e-6);
    assert!((value(1, "density.vdb rmse") - 0.25).abs() < 1e-6);
    // A denser glowing cube renders brighter and more opaque: the images differ, and SSIM
    // (16 rows, so it is measured) and PSNR say by how much.
    assert!(value(0, "image.exr rmse") > 0.0);
    assert!(value(0, "image.exr ssim") < 1.0);
    assert!(value(0, "image.exr psnr").is_finite());
}

#[test]
fn bad_input_is_a_clear_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    script(dir.path(), "midpoint.felt", MIDPOINT);
    let cases: &[(&[&str], &str)] = &[
        (
            &["midpoint.felt", "--sweep", "m=1,2", "--reference", "n=8"],
            "no param named `m`",
        ),
        (
            &["midpoint.felt", "--sweep", "n=1,two", "--reference", "n=8"],
            "--sweep n=two: expected an int",
        ),
        (
            &["midpoint.felt", "--sweep", "n=", "--reference", "n=8"],
            "has no values",
        ),
        (
            &["midpoint.felt", "--sweep", "n=1,2", "--reference", "n=0.5"],
            "--reference n=0.5: expected an int",
        ),
        (
            &["missing.felt", "--sweep", "n=1", "--reference", "n=8"],
            "missing.felt",
        ),
        (&["midpoint.felt", "--sweep", "n=1,2"], "--reference"),
    ];
    for (args, expected) in cases {
        let out = study(dir.path(), args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", text(&out));
        assert!(text(&out).contains(expected), "{args:?}: {}", text(&out));
        assert!(!text(&out).contains("panicked"), "{}", text(&out));
    }
    // A script with errors is a script error.
    script(dir.path(), "broken.felt", "param int n = 1;\nprint(m);\n");
    let out = study(
        dir.path(),
        &["broken.felt", "--sweep", "n=1", "--reference", "n=2"],
    );
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(text(&out).contains("broken.felt:2"), "{}", text(&out));
}

#[test]
fn help_documents_the_command() {
    let out = Command::new(env!("CARGO_BIN_EXE_felt"))
        .args(["study", "--help"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    let help = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "--sweep",
        "--reference",
        "--repeat",
        "--trade",
        "resampled",
        "medians",
        "exact: error 0",
        "SSIM",
        "study.csv",
        "Pareto",
        "cached",
    ] {
        assert!(help.contains(needle), "{needle}: {help}");
    }
}

/// The rows of a study's CSV as (header, rows), and one value by setting and column.
struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    fn read(path: &Path) -> Table {
        let (header, rows) = csv(path);
        Table { header, rows }
    }

    /// The value of `measure` in the row whose swept values are `setting`.
    fn at(&self, setting: &[&str], measure: &str) -> f64 {
        let column = column(&self.header, measure);
        let row = self
            .rows
            .iter()
            .find(|r| r.iter().zip(setting).all(|(a, b)| a == b))
            .unwrap_or_else(|| panic!("no row {setting:?}"));
        row[column]
            .parse()
            .unwrap_or_else(|_| panic!("{measure} of {setting:?}: {:?}", row[column]))
    }
}

/// Runs a published study at its tiny size (the README lists the full commands).
fn tiny_study(args: &[&str]) -> Table {
    let dir = tempfile::tempdir().unwrap();
    let examples = std::fs::canonicalize("examples/studies").unwrap();
    let script = examples.join(args[0]);
    let mut all: Vec<&str> = vec![script.to_str().unwrap()];
    all.extend(&args[1..]);
    all.extend(["--out", "s"]);
    let out = study(dir.path(), &all);
    assert_eq!(out.status.code(), Some(0), "{args:?}: {}", text(&out));
    Table::read(&dir.path().join("s/study.csv"))
}

#[test]
fn published_studies_run_at_tiny_size() {
    // Study 1: gridless is the reference, so its own rows are exact; gridded blurs.
    let fluids = tiny_study(&[
        "fluid_methods.felt",
        "--sweep",
        "method=gridded,gridless,selma",
        "--sweep",
        "frames=1,2",
        "--reference",
        "method=gridless",
        "--set",
        "res=16",
        "--set",
        "warmup=4",
        "--set",
        "measure=32",
        "--set",
        "width=64",
        "--set",
        "step=0.05",
    ]);
    assert_eq!(fluids.at(&["gridless", "2"], "density.vdb rmse"), 0.0);
    assert!(fluids.at(&["gridded", "2"], "density.vdb rmse") > 0.0);
    // Study 2: a finer step is closer to the reference image.
    let step = tiny_study(&[
        "raymarch_step.felt",
        "--sweep",
        "scene=cloud,gridless",
        "--sweep",
        "step=0.08,0.04",
        "--reference",
        "step=0.02",
        "--set",
        "width=64",
        "--set",
        "height=36",
    ]);
    for scene in ["cloud", "gridless"] {
        let (coarse, fine) = (
            step.at(&[scene, "0.08"], "image.exr rmse"),
            step.at(&[scene, "0.04"], "image.exr rmse"),
        );
        assert!(coarse > fine && fine > 0.0, "{scene}: {coarse} {fine}");
    }
    // Study 3: finer layer caches are closer to the procedural cloud.
    let cumulo = tiny_study(&[
        "cumulo_cache.felt",
        "--sweep",
        "mode=cached",
        "--sweep",
        "res=16,32",
        "--reference",
        "mode=procedural",
        "--reference",
        "res=32",
        "--set",
        "width=32",
        "--set",
        "height=18",
        "--set",
        "measure=32",
        "--set",
        "step=0.08",
    ]);
    assert!(
        cumulo.at(&["cached", "16"], "image.exr rmse")
            > cumulo.at(&["cached", "32"], "image.exr rmse")
    );
    // Study 4: exact normals are exact; cached and differenced ones are not.
    let normals = tiny_study(&[
        "normals.felt",
        "--sweep",
        "method=exact,interpolant,central,finite",
        "--set",
        "res=32",
        "--set",
        "fill=48",
        "--reference",
        "method=exact",
    ]);
    assert!(normals.at(&["exact"], "mean normal error") < 1e-3);
    for method in ["interpolant", "central", "finite"] {
        assert!(
            normals.at(&[method], "mean normal error") > 1e-3,
            "{method}"
        );
    }
    // Study 5: first-order (semi-Lagrangian) advection of Zalesak's disk is more accurate in
    // fewer, larger steps, since each step interpolates once.
    let zalesak = tiny_study(&[
        "zalesak.felt",
        "--sweep",
        "scheme=semilagrangian,bfecc",
        "--sweep",
        "steps=10,40",
        "--set",
        "res=50",
        "--set",
        "sample=200",
        "--reference",
        "scheme=selma",
    ]);
    assert!(
        zalesak.at(&["semilagrangian", "10"], "shape error")
            < zalesak.at(&["semilagrangian", "40"], "shape error")
    );
    let vortex = tiny_study(&[
        "vortex.felt",
        "--sweep",
        "scheme=semilagrangian,maccormack",
        "--sweep",
        "steps=16,32",
        "--set",
        "res=32",
        "--set",
        "sample=200",
        "--reference",
        "scheme=selma",
    ]);
    assert!(vortex.at(&["maccormack", "32"], "shape error") > 0.0);
    let deformation = tiny_study(&[
        "deformation.felt",
        "--sweep",
        "scheme=semilagrangian,bfecc",
        "--sweep",
        "steps=5,10",
        "--set",
        "res=24",
        "--set",
        "sample=48",
        "--reference",
        "scheme=selma",
    ]);
    // On a grid this coarse semi-Lagrangian smears the sheet away: the whole sphere,
    // 4/3 π 0.15³, is lost. BFECC brings part of it back.
    let sphere = 4.0 / 3.0 * std::f64::consts::PI * 0.15f64.powi(3);
    assert!((deformation.at(&["semilagrangian", "10"], "volume error") + sphere).abs() < 1e-4);
    assert!(deformation.at(&["bfecc", "10"], "volume error").abs() < 0.9 * sphere);
}

#[test]
fn the_light_study_runs_at_tiny_size() {
    // The fast render with its indirect grid against a path trace at 2 paths per pixel, both
    // compared with a 64-path trace: at this budget the march is the closer of the two.
    let light = tiny_study(&[
        "light_transport.felt",
        "--sweep",
        "integrator=march,path",
        "--set",
        "scene=thin",
        "--set",
        "spp=2",
        "--set",
        "res=24",
        "--set",
        "width=48",
        "--set",
        "height=27",
        "--reference",
        "integrator=path",
        "--reference",
        "spp=64",
        "--repeat",
        "1",
    ]);
    let (march, path) = (
        light.at(&["march"], "image.exr rmse"),
        light.at(&["path"], "image.exr rmse"),
    );
    assert!(march > 0.0 && march < path, "march {march}, path {path}");
}
