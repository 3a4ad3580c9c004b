//! Grids on other voxels than the reference's (a swept resolution) are resampled onto the
//! reference's voxels, and a setting is compared in every output that can be compared.

use super::{Table, column, script, study, text};

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
