//! The study's plots, as SVG: each error against time with the Pareto front marked, and each
//! error against each swept param.
//!
//! Errors and times span decades, so both are drawn on log axes; the axes are linear charts
//! of the base-10 logarithms, labelled with the values, which keeps one chart type for log,
//! linear and categorical (non-numeric params) axes. Settings whose error is zero or missing
//! cannot sit on a log axis and are left out of that plot.

use super::compare::Measure;
use super::{Outcome, Plan, Row};
use plotters::prelude::*;
use std::path::{Path, PathBuf};

const SIZE: (u32, u32) = (760, 500);
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
];

/// Draws every plot of the study into `folder`; returns the files written.
pub fn all(folder: &Path, plan: &Plan, rows: &[Row]) -> Result<Vec<PathBuf>, String> {
    let mut written = Vec::new();
    let names: Vec<String> = super::report::measure_names(rows)
        .into_iter()
        .map(|(n, _)| n)
        .filter(|n| {
            rows.iter()
                .any(|r| measure(r, n).is_some_and(|m| m.plotted()))
        })
        .filter(|n| !constant(rows, n))
        .collect();
    for name in &names {
        let path = folder.join(format!("pareto-{}.svg", slug(name)));
        if pareto(&path, plan, rows, name)? {
            written.push(path);
        }
        for (index, sweep) in plan.sweeps.iter().enumerate() {
            let path = folder.join(format!("{}-vs-{}.svg", slug(name), slug(&sweep.name)));
            if against(&path, plan, rows, name, index, &|r| error_of(r, name))? {
                written.push(path);
            }
        }
    }
    // What each setting costs, against each param: the chapter's time and memory figures.
    let costs: [(&str, &RowValue<'_>); 2] = [
        ("seconds", &|r| seconds(r).filter(|t| *t > 0.0)),
        ("peak MiB", &|r| match &r.outcome {
            Outcome::Compared { timing, .. } if timing.peak_bytes > 0 => {
                Some(timing.peak_bytes as f64 / (1 << 20) as f64)
            }
            _ => None,
        }),
    ];
    for (label, value) in costs {
        for (index, sweep) in plan.sweeps.iter().enumerate() {
            let path = folder.join(format!("{}-vs-{}.svg", slug(label), slug(&sweep.name)));
            if against(&path, plan, rows, label, index, value)? {
                written.push(path);
            }
        }
    }
    Ok(written)
}

fn measure<'a>(row: &'a Row, name: &str) -> Option<&'a Measure> {
    match &row.outcome {
        Outcome::Compared { measures, .. } => measures.iter().find(|m| m.name == name),
        _ => None,
    }
}

/// Whether every setting has the same value of `name` (a floor the script prints, say): such
/// a measure is in the table but says nothing as a plot.
fn constant(rows: &[Row], name: &str) -> bool {
    let mut values = rows
        .iter()
        .filter_map(|r| measure(r, name))
        .map(|m| m.value);
    let first = values.next();
    first.is_none_or(|f| values.all(|v| v == f))
}

/// The size of a row's error `name`, where it has one a log axis can show: a signed error the
/// script printed is drawn by its magnitude.
fn error_of(row: &Row, name: &str) -> Option<f64> {
    let e = measure(row, name)?.value.abs();
    (e > 0.0 && e.is_finite()).then_some(e)
}

fn seconds(row: &Row) -> Option<f64> {
    match &row.outcome {
        Outcome::Compared { timing, .. } => Some(timing.seconds),
        _ => None,
    }
}

/// A file-name-safe form of a measure or param name.
fn slug(name: &str) -> String {
    let mut out = String::new();
    for c in name.chars() {
        if c.is_ascii_alphanumeric() {
            out.push(c.to_ascii_lowercase());
        } else if !out.ends_with('-') {
            out.push('-');
        }
    }
    out.trim_matches('-').to_string()
}

/// The indices of the points no other point beats in both time and error.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in order {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

/// A log axis's label: the value at the logarithm `v`, to two significant digits.
fn log_label(v: &f64) -> String {
    let x = 10f64.powf(*v);
    if (0.01..10000.0).contains(&x) {
        let decimals = 1 - x.log10().floor() as i32;
        let scale = 10f64.powi(decimals);
        let rounded = (x * scale).round() / scale;
        format!("{rounded:.*}", decimals.max(0) as usize)
    } else {
        format!("{x:.1e}")
    }
}

/// An axis range around `values` with a margin, never empty.
fn range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
        (l.min(v), h.max(v))
    });
    let pad = ((hi - lo) * 0.08).max(0.05);
    (lo - pad)..(hi + pad)
}

fn pareto(path: &Path, plan: &Plan, rows: &[Row], name: &str) -> Result<bool, String> {
    let mut labels = Vec::new();
    let mut points = Vec::new();
    for row in rows {
        if let (Some(t), Some(e)) = (seconds(row), error_of(row, name))
            && t > 0.0
        {
            labels.push(plan.describe(&row.setting));
            points.push((t.log10(), e.log10()));
        }
    }
    if points.is_empty() {
        return Ok(false);
    }
    let front = pareto_front(&points);
    let legend_points = points.clone();
    let root = SVGBackend::new(path, SIZE).into_drawing_area();
    let fail = |e: &dyn std::fmt::Display| e.to_string();
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("{name} against time"), ("sans-serif", 20))
        .margin(16)
        .margin_right(48)
        .x_label_area_size(44)
        .y_label_area_size(72)
        .build_cartesian_2d(
            range(points.iter().map(|p| p.0)),
            range(points.iter().map(|p| p.1)),
        )
        .map_err(|e| fail(&e))?;
    chart
        .configure_mesh()
        .x_desc("seconds (log)")
        .y_desc(format!("{name} (log)"))
        .x_label_formatter(&log_label)
        .y_label_formatter(&log_label)
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(|e| fail(&e))?;
    let grey = RGBColor(150, 150, 150);
    chart
        .draw_series(points.iter().map(|p| Circle::new(*p, 4, grey.filled())))
        .map_err(|e| fail(&e))?
        .label("setting")
        .legend(move |(x, y)| Circle::new((x + 10, y), 4, grey.filled()));
    let line: Vec<(f64, f64)> = front.iter().map(|&i| points[i]).collect();
    let accent = PALETTE[1];
    chart
        .draw_series(LineSeries::new(line.clone(), accent.stroke_width(2)))
        .map_err(|e| fail(&e))?
        .label("Pareto front")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], accent.stroke_width(2)));
    chart
        .draw_series(line.iter().map(|p| Circle::new(*p, 5, accent.filled())))
        .map_err(|e| fail(&e))?;
    chart
        .draw_series(points.iter().zip(&labels).map(|(p, l)| {
            EmptyElement::at(*p) + Text::new(l.clone(), (7, -14), ("sans-serif", 11).into_font())
        }))
        .map_err(|e| fail(&e))?;
    finish(&mut chart, &root, &legend_points)?;
    Ok(true)
}

/// A chart over log (or position) coordinates on an SVG page.
type Chart<'a, 'b> = ChartContext<
    'a,
    SVGBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// Draws the legend in the corner farthest from the points and writes the page.
fn finish<'a>(
    chart: &mut Chart<'a, 'a>,
    root: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    points: &[(f64, f64)],
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .position(emptiest_corner(points))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())?;
    root.present().map_err(|e| e.to_string())
}

/// One number of a row, where it has one.
type RowValue<'a> = dyn Fn(&Row) -> Option<f64> + 'a;

/// `value` (called `name`) against sweep `index`, one line per combination of the other
/// sweeps' values.
fn against(
    path: &Path,
    plan: &Plan,
    rows: &[Row],
    name: &str,
    index: usize,
    value: &RowValue<'_>,
) -> Result<bool, String> {
    let sweep = &plan.sweeps[index];
    if sweep.values.len() < 2 {
        return Ok(false);
    }
    let numbers: Option<Vec<f64>> = sweep.values.iter().map(|v| v.trim().parse().ok()).collect();
    // A numeric param spanning a factor of four or more is drawn on a log axis, as steps and cell
    // sizes usually are; other params by their position in the sweep.
    let axis = match &numbers {
        Some(n) if n.iter().all(|x| *x > 0.0) => {
            let (lo, hi) = n
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(l, h), x| (l.min(*x), h.max(*x)));
            if hi / lo >= 10.0 {
                Axis::Log
            } else {
                Axis::Linear
            }
        }
        Some(_) => Axis::Linear,
        None => Axis::Categories,
    };
    let position = |value: &str| -> f64 {
        let k = sweep.values.iter().position(|v| v == value).unwrap_or(0);
        match (&axis, &numbers) {
            (Axis::Log, Some(n)) => n[k].log10(),
            (Axis::Linear, Some(n)) => n[k],
            _ => k as f64,
        }
    };
    // Series keyed by the other sweeps' values.
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for row in rows {
        let Some(e) = value(row) else {
            continue;
        };
        let key = plan
            .sweeps
            .iter()
            .zip(&row.setting.values)
            .enumerate()
            .filter(|(i, _)| *i != index)
            .map(|(_, (s, v))| format!("{}={v}", s.name))
            .collect::<Vec<_>>()
            .join(", ");
        let point = (position(&row.setting.values[index]), e.log10());
        match series.iter_mut().find(|(k, _)| *k == key) {
            Some((_, points)) => points.push(point),
            None => series.push((key, vec![point])),
        }
    }
    if series.is_empty() {
        return Ok(false);
    }
    let legend_points: Vec<(f64, f64)> = series.iter().flat_map(|(_, p)| p.clone()).collect();
    let root = SVGBackend::new(path, SIZE).into_drawing_area();
    let fail = |e: &dyn std::fmt::Display| e.to_string();
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let all = || series.iter().flat_map(|(_, p)| p.iter());
    let x_range = match axis {
        Axis::Categories => -0.5..(sweep.values.len() as f64 - 0.5),
        _ => range(all().map(|p| p.0)),
    };
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("{name} against {}", sweep.name), ("sans-serif", 20))
        .margin(16)
        .margin_right(48)
        .x_label_area_size(44)
        .y_label_area_size(72)
        .build_cartesian_2d(x_range, range(all().map(|p| p.1)))
        .map_err(|e| fail(&e))?;
    let categories = sweep.values.clone();
    let x_label = move |v: &f64| -> String {
        match axis {
            Axis::Log => log_label(v),
            Axis::Linear => format!("{}", (v * 1e6).round() / 1e6),
            Axis::Categories => {
                let k = v.round();
                if (v - k).abs() < 1e-6 && k >= 0.0 && (k as usize) < categories.len() {
                    categories[k as usize].clone()
                } else {
                    String::new()
                }
            }
        }
    };
    let x_desc = match axis {
        Axis::Log => format!("{} (log)", sweep.name),
        _ => sweep.name.clone(),
    };
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(x_desc)
        .y_desc(format!("{name} (log)"))
        .x_label_formatter(&x_label)
        .y_label_formatter(&log_label)
        .light_line_style(WHITE.mix(0.0));
    if axis == Axis::Categories {
        mesh.x_labels(sweep.values.len() * 2 + 1);
    }
    mesh.draw().map_err(|e| fail(&e))?;
    for (k, (key, points)) in series.iter_mut().enumerate() {
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        let colour = PALETTE[k % PALETTE.len()];
        let label = if key.is_empty() {
            name.to_string()
        } else {
            key.clone()
        };
        chart
            .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
            .map_err(|e| fail(&e))?
            .label(label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        chart
            .draw_series(points.iter().map(|p| Circle::new(*p, 4, colour.filled())))
            .map_err(|e| fail(&e))?;
    }
    finish(&mut chart, &root, &legend_points)?;
    Ok(true)
}

/// The corner of the plot with the fewest points near it, for the legend.
fn emptiest_corner(points: &[(f64, f64)]) -> SeriesLabelPosition {
    let x = range(points.iter().map(|p| p.0));
    let y = range(points.iter().map(|p| p.1));
    let near = |right: bool, top: bool| {
        points
            .iter()
            .filter(|p| {
                let u = (p.0 - x.start) / (x.end - x.start);
                let v = (p.1 - y.start) / (y.end - y.start);
                (if right { u > 0.55 } else { u < 0.45 }) && (if top { v > 0.6 } else { v < 0.4 })
            })
            .count()
    };
    let corners = [
        (near(true, true), SeriesLabelPosition::UpperRight),
        (near(false, true), SeriesLabelPosition::UpperLeft),
        (near(true, false), SeriesLabelPosition::LowerRight),
        (near(false, false), SeriesLabelPosition::LowerLeft),
    ];
    corners
        .into_iter()
        .min_by_key(|(count, _)| *count)
        .map(|(_, corner)| corner)
        .unwrap_or(SeriesLabelPosition::UpperRight)
}

#[derive(Clone, Copy, PartialEq)]
enum Axis {
    Log,
    Linear,
    Categories,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pareto_front_keeps_only_undominated_points() {
        // (time, error): the second is beaten by the first on both; the last is slowest but
        // most accurate.
        let points = [(1.0, 5.0), (2.0, 6.0), (3.0, 1.0), (0.5, 9.0), (4.0, 0.5)];
        assert_eq!(pareto_front(&points), vec![3, 0, 2, 4]);
    }

    #[test]
    fn log_labels_have_two_significant_digits() {
        let at = |x: f64| log_label(&x.log10());
        assert_eq!(at(2.512), "2.5");
        assert_eq!(at(15.849), "16");
        assert_eq!(at(0.0056), "5.6e-3");
        assert_eq!(at(0.25), "0.25");
        assert_eq!(at(3e-5), "3.0e-5");
    }

    #[test]
    fn slugs_are_file_names() {
        assert_eq!(slug("image.exr rmse"), "image-exr-rmse");
        assert_eq!(slug("area error [2]"), "area-error-2");
    }
}
