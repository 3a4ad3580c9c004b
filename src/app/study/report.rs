//! The study's table on the terminal and its `study.csv`.
//!
//! The CSV has one row per setting and every measure as a column (absent measures, and every
//! measure of a failed setting, are empty; the `status` column says why: `ok`, `partial: ...`
//! naming the outputs that could not be compared, or `failed: ...`). `runs` is how many runs
//! the median times are of, and `notes` says which grids were resampled onto the reference's
//! voxels. The terminal table shows the columns a reader compares first: for images RMSE, PSNR
//! and SSIM, for grids RMSE and the largest error, for printed numbers the value and the
//! relative error; a resampled grid's cells carry a † explained under the table.

use super::compare::{Kind, Measure};
use super::{Outcome, Plan, Row};

/// Every measure name that any row has, in the order they first appear.
pub fn measure_names(rows: &[Row]) -> Vec<(String, Kind)> {
    let mut names: Vec<(String, Kind)> = Vec::new();
    for row in rows {
        if let Outcome::Compared { measures, .. } = &row.outcome {
            for m in measures {
                if !names.iter().any(|(n, _)| *n == m.name) {
                    names.push((m.name.clone(), m.kind));
                }
            }
        }
    }
    names
}

fn find<'a>(measures: &'a [Measure], name: &str) -> Option<&'a Measure> {
    measures.iter().find(|m| m.name == name)
}

/// Whether the terminal table shows a measure (the CSV has them all).
fn shown(name: &str, kind: Kind) -> bool {
    match kind {
        Kind::Printed | Kind::Similarity => true,
        Kind::Error => name.ends_with(" rmse") || name.ends_with(" max") || name.ends_with(" rel"),
    }
}

/// A number in a table cell: short, and exact enough to compare rows.
fn cell(value: f64, kind: Kind, name: &str) -> String {
    if value.is_infinite() && kind == Kind::Similarity {
        return String::from("∞");
    }
    if name.ends_with(" ssim") {
        return format!("{value:.5}");
    }
    if name.ends_with(" psnr") {
        return format!("{value:.2}");
    }
    if value == 0.0 {
        return String::from("0");
    }
    if (1e-3..1e5).contains(&value.abs()) && kind == Kind::Printed {
        return format!("{value:.6}")
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_string();
    }
    format!("{value:.3e}")
}

pub fn table(plan: &Plan, rows: &[Row]) -> String {
    let names: Vec<(String, Kind)> = measure_names(rows)
        .into_iter()
        .filter(|(n, k)| shown(n, *k))
        .collect();
    let mut header: Vec<String> = plan.sweeps.iter().map(|s| s.name.clone()).collect();
    header.extend(["seconds", "CPU s", "peak MiB"].map(String::from));
    header.extend(names.iter().map(|(n, _)| n.clone()));
    let mut lines: Vec<Vec<String>> = Vec::new();
    let mut notes = Vec::new();
    let mut resampled = false;
    let mut runs: Vec<u32> = Vec::new();
    for row in rows {
        let mut line: Vec<String> = row.setting.values.clone();
        match &row.outcome {
            Outcome::Compared {
                timing,
                measures,
                problems,
            } => {
                if !runs.contains(&timing.runs) {
                    runs.push(timing.runs);
                }
                for why in problems {
                    notes.push(format!(
                        "{}: not compared: {why}",
                        plan.describe(&row.setting)
                    ));
                }
                line.push(format!("{:.3}", timing.seconds));
                line.push(format!("{:.3}", timing.cpu_seconds));
                line.push(format!(
                    "{:.1}",
                    timing.peak_bytes as f64 / (1 << 20) as f64
                ));
                for (name, kind) in &names {
                    line.push(
                        find(measures, name)
                            .map(|m| {
                                resampled |= m.resampled;
                                let mark = if m.resampled { " †" } else { "" };
                                cell(m.value, *kind, name) + mark
                            })
                            .unwrap_or_default(),
                    );
                }
            }
            Outcome::Failed(why) | Outcome::Incomparable(why) => {
                line.push(String::from("failed"));
                notes.push(format!("{}: {why}", plan.describe(&row.setting)));
            }
        }
        lines.push(line);
    }
    let columns = header.len();
    let mut widths: Vec<usize> = header.iter().map(|h| h.chars().count()).collect();
    for line in &lines {
        for (i, c) in line.iter().enumerate().take(columns) {
            widths[i] = widths[i].max(c.chars().count());
        }
    }
    let format_line = |cells: &[String]| {
        let mut text = String::new();
        for (i, c) in cells.iter().enumerate() {
            let pad = widths[i].saturating_sub(c.chars().count());
            if i > 0 {
                text.push_str("  ");
            }
            // Params read left-aligned, numbers right-aligned.
            if i < plan.sweeps.len() {
                text.push_str(c);
                text.push_str(&" ".repeat(pad));
            } else {
                text.push_str(&" ".repeat(pad));
                text.push_str(c);
            }
        }
        text.trim_end().to_string() + "\n"
    };
    let mut out = format_line(&header);
    out.push_str(&format_line(
        &widths.iter().map(|w| "─".repeat(*w)).collect::<Vec<_>>(),
    ));
    for line in &lines {
        out.push_str(&format_line(line));
    }
    runs.sort_unstable();
    if !runs.is_empty() {
        let counts: Vec<String> = runs.iter().map(u32::to_string).collect();
        out.push_str(&format!(
            "  seconds and CPU s: medians of {} runs per setting (wall time, and user plus system \
             time of the run's process)\n",
            counts.join(" or ")
        ));
    }
    if resampled {
        out.push_str(&format!("  † {RESAMPLED}\n"));
    }
    for note in notes {
        out.push_str(&format!("  {note}\n"));
    }
    out
}

/// What a † in the table means.
const RESAMPLED: &str = "the run's grid is on other voxels than the reference's: it was resampled \
                         onto the reference's voxels (trilinear, in world space)";

/// A CSV field, quoted when it holds a comma, a quote or a line break.
fn field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

pub fn csv(plan: &Plan, rows: &[Row]) -> String {
    let names = measure_names(rows);
    let mut header: Vec<String> = plan.sweeps.iter().map(|s| s.name.clone()).collect();
    header.extend(
        [
            "status",
            "runs",
            "seconds",
            "cpu_seconds",
            "peak_mib",
            "notes",
        ]
        .map(String::from),
    );
    header.extend(names.iter().map(|(n, _)| n.clone()));
    let mut out = header
        .iter()
        .map(|h| field(h))
        .collect::<Vec<_>>()
        .join(",")
        + "\n";
    for row in rows {
        let mut cells: Vec<String> = row.setting.values.iter().map(|v| field(v)).collect();
        match &row.outcome {
            Outcome::Compared {
                timing,
                measures,
                problems,
            } => {
                cells.push(if problems.is_empty() {
                    String::from("ok")
                } else {
                    field(&format!("partial: {}", problems.join("; ")))
                });
                cells.push(format!("{}", timing.runs));
                cells.push(format!("{}", timing.seconds));
                cells.push(format!("{}", timing.cpu_seconds));
                cells.push(format!("{}", timing.peak_bytes as f64 / (1 << 20) as f64));
                let grids: Vec<&str> = measures
                    .iter()
                    .filter(|m| m.resampled)
                    .filter_map(|m| m.name.rsplit_once(' ').map(|(grid, _)| grid))
                    .fold(Vec::new(), |mut all, g| {
                        if !all.contains(&g) {
                            all.push(g);
                        }
                        all
                    });
                cells.push(if grids.is_empty() {
                    String::new()
                } else {
                    field(&format!(
                        "{} resampled onto the reference's voxels",
                        grids.join(" and ")
                    ))
                });
                for (name, _) in &names {
                    cells.push(
                        find(measures, name)
                            .map(|m| format!("{}", m.value))
                            .unwrap_or_default(),
                    );
                }
            }
            Outcome::Failed(why) | Outcome::Incomparable(why) => {
                cells.push(field(&format!("failed: {why}")));
                cells.extend(std::iter::repeat_n(String::new(), 5 + names.len()));
            }
        }
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::plan;
    use super::super::{Setting, Timing};
    use super::*;

    #[test]
    fn csv_has_a_row_per_setting_and_quotes_what_needs_it() {
        let plan = plan::plan(
            &[(String::from("v"), crate::check::types::Type::Vector)],
            &[(String::from("v"), String::from("(1,2,3),(4,5,6)"))],
            &[(String::from("v"), String::from("(0,0,0)"))],
            &[],
            None,
        )
        .unwrap();
        let rows = vec![
            Row {
                setting: Setting {
                    values: vec![String::from("(1,2,3)")],
                },
                outcome: Outcome::Compared {
                    timing: Timing {
                        seconds: 1.5,
                        cpu_seconds: 2.5,
                        peak_bytes: 3 << 20,
                        runs: 3,
                    },
                    measures: vec![Measure {
                        name: String::from("x rel"),
                        value: 0.25,
                        kind: Kind::Error,
                        resampled: false,
                    }],
                    problems: Vec::new(),
                },
            },
            Row {
                setting: Setting {
                    values: vec![String::from("(4,5,6)")],
                },
                outcome: Outcome::Failed(String::from("exit 1: error: \"x\", oops")),
            },
        ];
        let text = csv(&plan, &rows);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[0],
            "v,status,runs,seconds,cpu_seconds,peak_mib,notes,x rel"
        );
        assert_eq!(lines[1], "\"(1,2,3)\",ok,3,1.5,2.5,3,,0.25");
        assert_eq!(
            lines[2],
            "\"(4,5,6)\",\"failed: exit 1: error: \"\"x\"\", oops\",,,,,,"
        );
        assert_eq!(lines.len(), 3);
        let shown = table(&plan, &rows);
        assert!(
            shown.contains("2.500e-1") && shown.contains("failed") && shown.contains("of 3 runs"),
            "{shown}"
        );
    }
}
