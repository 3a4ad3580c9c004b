//! The study's plots: one Pareto front per setting of the params not traded, a colour per
//! series key kept in every plot, exact rows on the axis floor, labels inside and apart.

use super::{MIDPOINT, Table, column, script, study, text};
use std::path::Path;

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
