//! The axes of a study plot: `plotters` draws them into an SVG document, and this module
//! says where chart coordinates land on the page so the series can be drawn over them.
//!
//! The key decision: charts are linear in the base-10 logarithms of errors and times, with
//! tick labels giving the values, so one chart type serves log, linear and categorical axes.

use super::labels::Rect;
use super::svg::Overlay;
use plotters::prelude::*;
use std::path::Path;

/// The page size in pixels.
pub const SIZE: (u32, u32) = (760, 500);

/// A value on a log axis: its logarithm, or `None` for 0 (drawn on the floor).
pub fn log_or_floor(value: f64) -> Option<f64> {
    (value > 0.0).then(|| value.log10())
}

/// A y range over the logarithms of the positive values, and its floor.
pub fn y_range(logs: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let logs: Vec<f64> = logs.collect();
    if logs.is_empty() {
        return -1.0..1.0;
    }
    range(logs.into_iter())
}

/// The axes of one page: the document `plotters` drew and where its coordinates land.
pub struct Axes {
    pub svg: String,
    pub area: Rect,
    pub x: std::ops::Range<f64>,
    pub y: std::ops::Range<f64>,
    /// Page pixels of the chart corners `(x.start, y.start)` and `(x.end, y.end)`.
    pub corners: ((f64, f64), (f64, f64)),
}

impl Axes {
    /// The page pixel of chart coordinates `(x, y)`; `None` for `y` is the floor.
    pub fn pixel(&self, x: f64, y: Option<f64>) -> (f64, f64) {
        let ((x0, y0), (x1, y1)) = self.corners;
        let y = y.unwrap_or(self.y.start);
        (
            x0 + (x - self.x.start) / (self.x.end - self.x.start) * (x1 - x0),
            y0 + (y - self.y.start) / (self.y.end - self.y.start) * (y1 - y0),
        )
    }
}

/// What the axes of a page say.
pub struct AxesSpec<'a> {
    pub caption: String,
    pub x: std::ops::Range<f64>,
    pub y: std::ops::Range<f64>,
    pub x_desc: String,
    pub y_desc: String,
    pub x_label: &'a dyn Fn(&f64) -> String,
    pub x_labels: Option<usize>,
}

pub fn axes(spec: AxesSpec<'_>) -> Result<Axes, String> {
    let mut svg = String::new();
    let fail = |e: &dyn std::fmt::Display| e.to_string();
    let (area, corners) = {
        let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| fail(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(&spec.caption, ("sans-serif", 18))
            .margin(16)
            .margin_right(32)
            // A line below the axes for the page's notes.
            .margin_bottom(30)
            .x_label_area_size(44)
            .y_label_area_size(72)
            .build_cartesian_2d(spec.x.clone(), spec.y.clone())
            .map_err(|e| fail(&e))?;
        let mut mesh = chart.configure_mesh();
        mesh.x_desc(spec.x_desc.as_str())
            .y_desc(spec.y_desc.as_str())
            .x_label_formatter(spec.x_label)
            .y_label_formatter(&log_label)
            .light_line_style(WHITE.mix(0.0));
        if let Some(n) = spec.x_labels {
            mesh.x_labels(n);
        }
        mesh.draw().map_err(|e| fail(&e))?;
        let (xs, ys) = chart.plotting_area().get_pixel_range();
        let area = Rect {
            x0: xs.start as f64,
            y0: ys.start as f64,
            x1: xs.end as f64,
            y1: ys.end as f64,
        };
        let a = chart.backend_coord(&(spec.x.start, spec.y.start));
        let b = chart.backend_coord(&(spec.x.end, spec.y.end));
        root.present().map_err(|e| fail(&e))?;
        (area, ((a.0 as f64, a.1 as f64), (b.0 as f64, b.1 as f64)))
    };
    Ok(Axes {
        svg,
        area,
        x: spec.x,
        y: spec.y,
        corners,
    })
}

pub fn write(path: &Path, axes: &Axes, overlay: Overlay) -> Result<(), String> {
    std::fs::write(path, overlay.finish(&axes.svg))
        .map_err(|e| format!("cannot write '{}': {e}", path.display()))
}

/// A log axis's label: the value at the logarithm `v`, to two significant digits.
pub fn log_label(v: &f64) -> String {
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
pub fn range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
        (l.min(v), h.max(v))
    });
    let pad = ((hi - lo) * 0.08).max(0.05);
    (lo - pad)..(hi + pad)
}
