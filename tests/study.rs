//! `felt study` end to end: a study whose error law is known in closed form, the CSV and the
//! plots it writes, failing settings, outputs that cannot be compared, the cached reference,
//! image and grid comparisons (grids on other voxels resampled), the Pareto fronts, the plots'
//! labels, markers and colours, repeated runs, and bad input.
//!
//! Studies here run each setting once (`--repeat 1`) unless a test is about the repeats.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

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

/// A density of x² on the unit cube at `res` cells a side, and an image whose size follows
/// `res` (so it cannot be compared with the reference's).
const RESOLUTION: &str = "\
param int res = 4;
domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 1.0 / res);
vectorfield p = identity();
scalarcache k(d);
cachewrite(k, p.x * p.x);
cachesave(k, \"density.vdb\");
render(\"image.exr\", density = cacheread(k),
       camera = camera((0.5, 0.5, 3), (0.5, 0.5, 0.5), (0, 1, 0), 40),
       kappa = 2.0, step = 0.05, emission = vectorfield((1.0, 0.6, 0.3)),
       width = 2 * res, height = 2 * res);
";

/// The RMSE and largest error of x² sampled at the centres of `n` cells a side of the unit
/// cube, resampled trilinearly (0 beyond the outermost centres) at the centres of `r` cells a
/// side, against x² there. The field is a product of one-axis factors, so the resampled value
/// is too: the interpolant of x² along x times the weight of the nodes inside the grid along y
/// and along z.
fn resampled_square(n: usize, r: usize) -> (f64, f64) {
    let node = |i: i64| (i as f64 + 0.5) / n as f64;
    // (weighted sum of f at the nodes inside, sum of the weights inside) at x.
    let along = |x: f64, f: &dyn Fn(f64) -> f64| -> f64 {
        let u = x * n as f64 - 0.5;
        let i = u.floor() as i64;
        let t = u - i as f64;
        [(i, 1.0 - t), (i + 1, t)]
            .iter()
            .filter(|(c, _)| (0..n as i64).contains(c))
            .map(|(c, w)| w * f(node(*c)))
            .sum()
    };
    let centres: Vec<f64> = (0..r).map(|j| (j as f64 + 0.5) / r as f64).collect();
    let (mut squared, mut max) = (0.0f64, 0.0f64);
    for &x in &centres {
        let lx = along(x, &|v| (v * v) as f32 as f64);
        for &y in &centres {
            let wy = along(y, &|_| 1.0);
            for &z in &centres {
                let wz = along(z, &|_| 1.0);
                let d = lx * wy * wz - (x * x) as f32 as f64;
                squared += d * d;
                max = max.max(d.abs());
            }
        }
    }
    ((squared / (r * r * r) as f64).sqrt(), max)
}

#[test]
fn grids_on_other_voxels_are_resampled_and_the_rest_still_compared() {
    let dir = tempfile::tempdir().unwrap();
    script(dir.path(), "res.felt", RESOLUTION);
    let out = study(
        dir.path(),
        &[
            "res.felt",
            "--sweep",
            "res=4,8,16",
            "--reference",
            "res=32",
            "--out",
            "s",
        ],
    );
    // The images are of other sizes than the reference's: that, and only that, is refused.
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    let table = Table::read(&dir.path().join("s/study.csv"));
    let status = column(&table.header, "status");
    let mut errors = Vec::new();
    for res in [4usize, 8, 16] {
        let setting = res.to_string();
        let row = table.rows.iter().find(|r| r[0] == setting).unwrap();
        assert!(
            row[status].starts_with("partial: image.exr: it is")
                && !row[status].contains("density"),
            "{row:?}"
        );
        let notes = column(&table.header, "notes");
        assert_eq!(
            row[notes],
            "density.vdb resampled onto the reference's voxels"
        );
        let (rmse, max) = (
            table.at(&[&setting], "density.vdb rmse"),
            table.at(&[&setting], "density.vdb max"),
        );
        let (expected_rmse, expected_max) = resampled_square(res, 32);
        assert!(
            (rmse - expected_rmse).abs() < 1e-5 * expected_rmse,
            "res={res}: {rmse} vs {expected_rmse}"
        );
        assert!(
            (max - expected_max).abs() < 1e-5 * expected_max,
            "res={res}: {max} vs {expected_max}"
        );
        errors.push(rmse);
    }
    assert!(errors[0] > errors[1] && errors[1] > errors[2], "{errors:?}");
    // The table marks the resampled cells and says what the mark means.
    let shown = String::from_utf8_lossy(&out.stdout);
    assert!(
        shown.contains(" †") && shown.contains("resampled onto the reference's voxels"),
        "{shown}"
    );
    assert!(shown.contains("not compared: image.exr"), "{shown}");
}

/// A method and a count: "value" is exact for method a, "other" is not; b and c are off in
/// both, by amounts that fall with n. The reference is method `ref`.
const METHODS: &str = "\
param string method = \"ref\";
param int n = 4;
float k = 0;
float m = 0;
if (method == \"a\") { m = 1; }
if (method == \"b\") { k = 1; m = 2; }
if (method == \"c\") { k = 3; m = 3; }
print(\"value\", 1 + k / (n * n));
print(\"other\", 2 + m / n);
";

fn methods_study(dir: &Path) -> Table {
    script(dir, "methods.felt", METHODS);
    let out = study(
        dir,
        &[
            "methods.felt",
            "--sweep",
            "method=a,b,c",
            "--sweep",
            "n=2,3,4,6,8",
            "--reference",
            "method=ref",
            "--out",
            "s",
        ],
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    Table::read(&dir.join("s/study.csv"))
}

/// The `<g class="series" data-key="KEY" ...>` groups of an SVG: (key, stroke colour, body).
fn series(svg: &str) -> Vec<(String, String, String)> {
    svg.split("<g class=\"series\" ")
        .skip(1)
        .map(|part| {
            let attr = |name: &str| {
                let start = part.find(&format!("{name}=\"")).unwrap() + name.len() + 2;
                part[start..start + part[start..].find('"').unwrap()].to_string()
            };
            let body = part[..part.find("</g>").unwrap()].to_string();
            (attr("data-key"), attr("stroke"), body)
        })
        .collect()
}

#[test]
fn pareto_fronts_are_drawn_per_setting_of_the_untraded_params() {
    let dir = tempfile::tempdir().unwrap();
    let table = methods_study(dir.path());
    let svg = std::fs::read_to_string(dir.path().join("s/pareto-other-rel.svg")).unwrap();
    assert!(svg.contains("a front over n per method"), "{svg}");
    let groups = series(&svg);
    let keys: Vec<&str> = groups.iter().map(|g| g.0.as_str()).collect();
    assert_eq!(keys, ["method=a", "method=b", "method=c"]);
    let (seconds, error) = (
        column(&table.header, "seconds"),
        column(&table.header, "other rel"),
    );
    for (key, _, body) in &groups {
        let method = key.strip_prefix("method=").unwrap();
        // Each method's own front, from the CSV: the settings no other of the same method
        // beats in both time and error.
        let points: Vec<(f64, f64)> = table
            .rows
            .iter()
            .filter(|r| r[0] == method)
            .map(|r| (r[seconds].parse().unwrap(), r[error].parse().unwrap()))
            .collect();
        let on_front = points
            .iter()
            .filter(|(t, e)| {
                !points
                    .iter()
                    .any(|(u, f)| u <= t && f <= e && (u < t || f < e))
            })
            .count();
        let filled = body.matches("<circle").count() - body.matches("fill=\"white\"").count();
        assert_eq!(filled, on_front, "{key}: {body}");
        assert_eq!(body.matches("<circle").count(), points.len(), "{key}");
        if on_front > 1 {
            assert_eq!(
                body.split("<polyline points=\"")
                    .nth(1)
                    .unwrap()
                    .split('"')
                    .next()
                    .unwrap()
                    .split(' ')
                    .count(),
                on_front,
                "{key}"
            );
        }
    }
}

#[test]
fn each_series_keeps_its_colour_in_every_plot_and_exact_rows_are_marked() {
    let dir = tempfile::tempdir().unwrap();
    let table = methods_study(dir.path());
    assert_eq!(table.at(&["a", "2"], "value rel"), 0.0);
    let read = |name: &str| std::fs::read_to_string(dir.path().join("s").join(name)).unwrap();
    let colour = |svg: &str, key: &str| {
        series(svg)
            .into_iter()
            .find(|g| g.0 == key)
            .unwrap_or_else(|| panic!("no series {key}"))
            .1
    };
    // "value" is exact for method a, so in its plots a sits on the floor; in "other" it does
    // not. Method b keeps one colour whichever.
    let plots = [
        read("value-rel-vs-n.svg"),
        read("other-rel-vs-n.svg"),
        read("pareto-value-rel.svg"),
        read("pareto-other-rel.svg"),
    ];
    for key in ["method=a", "method=b", "method=c"] {
        let first = colour(&plots[0], key);
        for svg in &plots[1..] {
            assert_eq!(colour(svg, key), first, "{key}");
        }
    }
    assert_ne!(colour(&plots[0], "method=a"), colour(&plots[0], "method=b"));
    // The exact rows: one triangle per n for method a, and the legend says what it means.
    for svg in [&plots[0], &plots[2]] {
        let a = series(svg).into_iter().find(|g| g.0 == "method=a").unwrap();
        assert_eq!(a.2.matches("class=\"exact\"").count(), 5, "{}", a.2);
        assert!(svg.contains("exact: error 0"));
    }
    assert!(!plots[1].contains("exact: error 0"));
}

/// `(x0, y0, x1, y1)` of each `<text x=".." y=".." [dy="..em"] font-size="..">n=...</text>`,
/// the labels of a study sweeping `n`: from the baseline start (`dy` moves the baseline), 0.65
/// em wide per character, 0.95 em up and 0.25 em down.
fn label_boxes(svg: &str) -> Vec<(f64, f64, f64, f64)> {
    svg.split("<text ")
        .skip(1)
        .filter_map(|part| {
            let part = format!(" {part}");
            let text = part[part.find('>')? + 1..part.find("</text>")?].trim();
            if !text.starts_with("n=") {
                return None;
            }
            let attr = |name: &str| -> Option<f64> {
                let start = part.find(&format!(" {name}=\""))? + name.len() + 3;
                let value = &part[start..start + part[start..].find('"')?];
                value.trim_end_matches("em").parse().ok()
            };
            let (x, y, size) = (attr("x")?, attr("y")?, attr("font-size")?);
            let baseline = y + attr("dy").unwrap_or(0.0) * size;
            let width = text.chars().count() as f64 * 0.65 * size;
            Some((x, baseline - 0.95 * size, x + width, baseline + 0.25 * size))
        })
        .collect()
}

#[test]
fn crowded_labels_stay_inside_the_page_and_apart() {
    let dir = tempfile::tempdir().unwrap();
    script(dir.path(), "midpoint.felt", MIDPOINT);
    // Fourteen settings whose errors differ by a few per cent each, at nearly the same time,
    // and one far slower and more accurate: the fourteen crowd into one corner.
    let mut values: Vec<String> = (100..114).map(|n| n.to_string()).collect();
    values.push(String::from("200000"));
    let sweep = format!("n={}", values.join(","));
    let out = study(
        dir.path(),
        &[
            "midpoint.felt",
            "--sweep",
            &sweep,
            "--reference",
            "n=4096",
            "--out",
            "s",
        ],
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let svg = std::fs::read_to_string(dir.path().join("s/pareto-integral-rel.svg")).unwrap();
    let view: Vec<f64> = svg
        .split("viewBox=\"")
        .nth(1)
        .unwrap()
        .split('"')
        .next()
        .unwrap()
        .split(' ')
        .map(|v| v.parse().unwrap())
        .collect();
    let boxes = label_boxes(&svg);
    let left_out: usize = svg
        .split("<text class=\"note\"")
        .nth(1)
        .and_then(|n| n.split('>').nth(1))
        .and_then(|n| n.split(" label").next())
        .map_or(0, |n| n.trim().parse().unwrap());
    assert_eq!(boxes.len() + left_out, 15, "{svg}");
    assert!(boxes.len() >= 12, "only {} labels placed", boxes.len());
    for (i, a) in boxes.iter().enumerate() {
        assert!(
            a.0 >= view[0]
                && a.1 >= view[1]
                && a.2 <= view[0] + view[2]
                && a.3 <= view[1] + view[3],
            "{a:?} outside {view:?}"
        );
        for b in &boxes[i + 1..] {
            let apart = a.2 <= b.0 || b.2 <= a.0 || a.3 <= b.1 || b.3 <= a.1;
            assert!(apart, "{a:?} overlaps {b:?}");
        }
    }
}

/// Adds one to the counter grid in the file `$COUNTER`, so the test can count the runs.
const COUNTED: &str = "\
param int n = 1;
domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.5);
scalarcache k(d);
cachewrite(k, cacheload(\"$COUNTER\", \"count\") + 1);
cachesave(k, \"$COUNTER#count\");
print(\"value\", n * 2);
";

#[test]
fn settings_are_run_three_times_unless_told_and_cpu_time_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let counter = dir.path().join("counter.vdb");
    script(
        dir.path(),
        "zero.felt",
        "domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.5);\nscalarcache k(d);\n\
         cachewrite(k, scalarfield(0));\ncachesave(k, \"$COUNTER#count\");\n",
    );
    script(dir.path(), "counted.felt", COUNTED);
    let zero = Command::new(env!("CARGO_BIN_EXE_felt"))
        .current_dir(dir.path())
        .args(["run", "zero.felt"])
        .env("COUNTER", &counter)
        .output()
        .unwrap();
    assert!(zero.status.success(), "{}", text(&zero));
    let count = || -> f64 {
        let probe = script(
            dir.path(),
            "probe.felt",
            "print(\"count\", probe(cacheload(\"$COUNTER\", \"count\"), (0.25, 0.25, 0.25)));\n",
        );
        let out = Command::new(env!("CARGO_BIN_EXE_felt"))
            .arg("run")
            .arg(probe)
            .env("COUNTER", &counter)
            .output()
            .unwrap();
        let shown = String::from_utf8_lossy(&out.stdout).to_string();
        shown
            .trim()
            .strip_prefix("count ")
            .unwrap()
            .parse()
            .unwrap()
    };
    let env = [("COUNTER", counter.as_path())];
    // Two settings and their reference: three settings to run, three times each by default.
    let args = ["counted.felt", "--sweep", "n=1,2", "--reference", "n=3"];
    let out = study_as_given(
        dir.path(),
        &[&args[..], &["--out", "three"][..]].concat(),
        &env,
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert_eq!(count(), 9.0);
    let table = Table::read(&dir.path().join("three/study.csv"));
    let (runs, cpu, seconds) = (
        column(&table.header, "runs"),
        column(&table.header, "cpu_seconds"),
        column(&table.header, "seconds"),
    );
    for row in &table.rows {
        assert_eq!(row[runs], "3");
        let cpu: f64 = row[cpu].parse().unwrap();
        let wall: f64 = row[seconds].parse().unwrap();
        assert!(cpu.is_finite() && cpu >= 0.0 && wall > 0.0, "{row:?}");
    }
    let shown = String::from_utf8_lossy(&out.stdout);
    assert!(
        shown.contains("CPU s") && shown.contains("medians of 3 runs"),
        "{shown}"
    );
    // `--repeat 2`, in a new folder (so the reference is run again): six more runs.
    let out = study_as_given(
        dir.path(),
        &[&args[..], &["--out", "two", "--repeat", "2"][..]].concat(),
        &env,
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert_eq!(count(), 15.0);
    let table = Table::read(&dir.path().join("two/study.csv"));
    assert!(
        table.rows.iter().all(|r| r[runs] == "2"),
        "{:?}",
        table.rows
    );
}
