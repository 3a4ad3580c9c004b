//! The study's plots, as SVG: each error against time with the Pareto fronts marked, and each
//! error against each swept param.
//!
//! Errors and times span decades, so both are drawn on log axes; the axes are linear charts
//! of the base-10 logarithms, labelled with the values, which keeps one chart type for log,
//! linear and categorical (non-numeric params) axes. `plotters` draws the axes; the series,
//! labels and legend are drawn over them (`svg`).
//!
//! The key decisions, each what a reader of several plots relies on:
//! - A Pareto front is drawn among settings that differ only in the traded param
//!   (`Plan::trade`): one front per setting of the other swept params, each in its colour, so
//!   "SELMA at 1 frame" never sits on one front with "gridded at 16 frames".
//! - Colours are keyed by a series' setting of the other params ("method=selma"), from one
//!   table per study built from the plan alone, so a method has one colour in every plot
//!   whichever settings failed or are missing from a plot.
//! - A setting whose error is exactly 0 cannot sit on a log axis: it is drawn on the axis
//!   floor with a triangle, and the legend says "exact: error 0".

use super::axes::{AxesSpec, SIZE, axes, log_label, log_or_floor, range, write, y_range};
use super::compare::Measure;
use super::svg::{Entry, Marker, Overlay};
use super::{Outcome, Plan, Row};
use plotters::style::RGBColor;
use std::path::{Path, PathBuf};

const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 55, 94),
    RGBColor(188, 189, 34),
];
/// Grey is kept for what is not a series (dominated settings, exact ones, in the legend).
const GREY: RGBColor = RGBColor(120, 120, 120);

/// Draws every plot of the study into `folder`; returns the files written.
pub fn all(folder: &Path, plan: &Plan, rows: &[Row]) -> Result<Vec<PathBuf>, String> {
    let colours = Colours::of(plan);
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
        if pareto(&path, plan, rows, name, &colours)? {
            written.push(path);
        }
        for (index, sweep) in plan.sweeps.iter().enumerate() {
            let path = folder.join(format!("{}-vs-{}.svg", slug(name), slug(&sweep.name)));
            let plot = Against {
                plan,
                rows,
                name,
                index,
                colours: &colours,
            };
            if plot.draw(&path, &|r| error_of(r, name))? {
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
            let plot = Against {
                plan,
                rows,
                name: label,
                index,
                colours: &colours,
            };
            if plot.draw(&path, value)? {
                written.push(path);
            }
        }
    }
    Ok(written)
}

/// The colour of every series key a plot of the study can have, from the plan alone. The keys
/// of one family (the settings of every sweep but one) take the palette in plan order; the
/// families never share a plot, so they may share colours.
struct Colours {
    keys: Vec<(String, usize)>,
}

impl Colours {
    fn of(plan: &Plan) -> Colours {
        let mut keys: Vec<(String, usize)> = Vec::new();
        for index in 0..plan.sweeps.len() {
            let mut family = 0;
            for setting in &plan.settings {
                let key = plan.group(setting, index);
                if !keys.iter().any(|(k, _)| *k == key) {
                    keys.push((key, family));
                    family += 1;
                }
            }
        }
        Colours { keys }
    }

    fn of_key(&self, key: &str) -> RGBColor {
        match self.keys.iter().find(|(k, _)| k == key) {
            Some((_, k)) => PALETTE[k % PALETTE.len()],
            None => GREY,
        }
    }
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

/// The size of a row's error `name`, where it has one: a signed error the script printed is
/// drawn by its magnitude; 0 is drawn on the axis floor.
fn error_of(row: &Row, name: &str) -> Option<f64> {
    let e = measure(row, name)?.value.abs();
    e.is_finite().then_some(e)
}

fn seconds(row: &Row) -> Option<f64> {
    match &row.outcome {
        Outcome::Compared { timing, .. } => Some(timing.seconds),
        _ => None,
    }
}

/// The legend line of settings with an error of exactly 0.
fn exact_entry() -> Entry {
    Entry {
        colour: GREY,
        line: false,
        marker: Some(Marker::Exact),
        text: String::from("exact: error 0"),
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

/// One setting on a Pareto plot: log seconds, log error (`None` for 0) and its label.
struct Point {
    t: f64,
    e: Option<f64>,
    label: String,
}

fn pareto(
    path: &Path,
    plan: &Plan,
    rows: &[Row],
    name: &str,
    colours: &Colours,
) -> Result<bool, String> {
    let traded = &plan.sweeps[plan.trade];
    let mut groups: Vec<(String, Vec<Point>)> = Vec::new();
    for row in rows {
        let (Some(t), Some(e)) = (seconds(row), error_of(row, name)) else {
            continue;
        };
        if t <= 0.0 {
            continue;
        }
        let key = plan.group(&row.setting, plan.trade);
        let label = if plan.sweeps.len() == 1 {
            plan.describe(&row.setting)
        } else {
            format!("{}={}", traded.name, row.setting.values[plan.trade])
        };
        let point = Point {
            t: t.log10(),
            e: log_or_floor(e),
            label,
        };
        match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, points)) => points.push(point),
            None => groups.push((key, vec![point])),
        }
    }
    if groups.is_empty() {
        return Ok(false);
    }
    let all = || groups.iter().flat_map(|(_, p)| p.iter());
    let others: Vec<&str> = plan
        .sweeps
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != plan.trade)
        .map(|(_, s)| s.name.as_str())
        .collect();
    let caption = if others.is_empty() {
        format!("{name} against time")
    } else {
        format!(
            "{name} against time: a front over {} per {}",
            traded.name,
            others.join(" and ")
        )
    };
    let axes = axes(AxesSpec {
        caption,
        x: range(all().map(|p| p.t)),
        y: y_range(all().filter_map(|p| p.e)),
        x_desc: String::from("seconds (log)"),
        y_desc: format!("{name} (log)"),
        x_label: &log_label,
        x_labels: None,
    })?;
    let mut overlay = Overlay::new(axes.area, SIZE);
    let mut entries = Vec::new();
    let (mut front_labels, mut other_labels) = (Vec::new(), Vec::new());
    let (mut dominated, mut exact) = (false, false);
    for (key, points) in &groups {
        let colour = colours.of_key(key);
        let scores: Vec<(f64, f64)> = points
            .iter()
            .map(|p| (p.t, p.e.unwrap_or(f64::NEG_INFINITY)))
            .collect();
        let front = pareto_front(&scores);
        let line: Vec<(f64, f64)> = front
            .iter()
            .map(|&i| axes.pixel(points[i].t, points[i].e))
            .collect();
        let mut marks = Vec::new();
        for (i, p) in points.iter().enumerate() {
            let at = axes.pixel(p.t, p.e);
            let kind = if p.e.is_none() {
                exact = true;
                Marker::Exact
            } else if front.contains(&i) {
                Marker::Filled
            } else {
                dominated = true;
                Marker::Hollow
            };
            marks.push((at, kind));
            if front.contains(&i) {
                front_labels.push((at, p.label.clone()));
            } else {
                other_labels.push((at, p.label.clone()));
            }
        }
        overlay.series(key, colour, &line, &marks);
        entries.push(Entry {
            colour,
            line: true,
            marker: Some(Marker::Filled),
            text: if key.is_empty() {
                String::from("Pareto front")
            } else {
                format!("{key}: Pareto front")
            },
        });
    }
    if dominated {
        entries.push(Entry {
            colour: GREY,
            line: false,
            marker: Some(Marker::Hollow),
            text: String::from("beaten in time and error"),
        });
    }
    if exact {
        entries.push(exact_entry());
    }
    overlay.legend(&entries);
    front_labels.extend(other_labels);
    overlay.labels(&front_labels);
    write(path, &axes, overlay)?;
    Ok(true)
}

/// A point of a line plot: the param's position, and the log of the value (`None` for 0).
type LinePoint = (f64, Option<f64>);

/// One number of a row, where it has one.
type RowValue<'a> = dyn Fn(&Row) -> Option<f64> + 'a;

/// A value (called `name`) against sweep `index`, one series per setting of the other sweeps.
struct Against<'a> {
    plan: &'a Plan,
    rows: &'a [Row],
    name: &'a str,
    index: usize,
    colours: &'a Colours,
}

impl Against<'_> {
    fn draw(&self, path: &Path, value: &RowValue<'_>) -> Result<bool, String> {
        let (plan, name, index) = (self.plan, self.name, self.index);
        let sweep = &plan.sweeps[index];
        if sweep.values.len() < 2 {
            return Ok(false);
        }
        let numbers: Option<Vec<f64>> =
            sweep.values.iter().map(|v| v.trim().parse().ok()).collect();
        // A numeric param spanning a factor of ten or more is drawn on a log axis, as steps
        // and cell sizes usually are; other params by their position in the sweep.
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
        // Series keyed by the other sweeps' values; `None` is an exact 0.
        let mut series: Vec<(String, Vec<LinePoint>)> = Vec::new();
        for row in self.rows {
            let Some(v) = value(row) else {
                continue;
            };
            let key = plan.group(&row.setting, index);
            let point = (position(&row.setting.values[index]), log_or_floor(v));
            match series.iter_mut().find(|(k, _)| *k == key) {
                Some((_, points)) => points.push(point),
                None => series.push((key, vec![point])),
            }
        }
        if series.is_empty() {
            return Ok(false);
        }
        let all = || series.iter().flat_map(|(_, p)| p.iter());
        let x = match axis {
            Axis::Categories => -0.5..(sweep.values.len() as f64 - 0.5),
            _ => range(all().map(|p| p.0)),
        };
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
        let axes = axes(AxesSpec {
            caption: format!("{name} against {}", sweep.name),
            x,
            y: y_range(all().filter_map(|p| p.1)),
            x_desc: match axis {
                Axis::Log => format!("{} (log)", sweep.name),
                _ => sweep.name.clone(),
            },
            y_desc: format!("{name} (log)"),
            x_label: &x_label,
            x_labels: (axis == Axis::Categories).then_some(sweep.values.len() * 2 + 1),
        })?;
        let mut overlay = Overlay::new(axes.area, SIZE);
        let mut entries = Vec::new();
        let mut exact = false;
        for (key, points) in series.iter_mut() {
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            let colour = self.colours.of_key(key);
            // The line joins the values a log axis can show; exact zeros sit on the floor.
            let line: Vec<(f64, f64)> = points
                .iter()
                .filter(|p| p.1.is_some())
                .map(|p| axes.pixel(p.0, p.1))
                .collect();
            let marks: Vec<((f64, f64), Marker)> = points
                .iter()
                .map(|p| {
                    let kind = if p.1.is_some() {
                        Marker::Filled
                    } else {
                        exact = true;
                        Marker::Exact
                    };
                    (axes.pixel(p.0, p.1), kind)
                })
                .collect();
            overlay.series(key, colour, &line, &marks);
            entries.push(Entry {
                colour,
                line: true,
                marker: Some(Marker::Filled),
                text: if key.is_empty() {
                    name.to_string()
                } else {
                    key.clone()
                },
            });
        }
        if exact {
            entries.push(exact_entry());
        }
        overlay.legend(&entries);
        write(path, &axes, overlay)?;
        Ok(true)
    }
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
