//! What the study's plots draw over the axes: the series, their markers, the legend, the point
//! labels and notes, written as SVG elements into the page `plotters` drew the axes on.
//!
//! The key decision: these are drawn here rather than by `plotters`, because the labels must
//! be placed knowing every box on the page (`labels`), and because each series is a group
//! (`<g class="series" data-key="method=selma">`) whose colour a reader — or a test — can find
//! by its key in every plot of a study.

use super::labels::{self, Rect};
use plotters::style::RGBColor;

/// How a point is marked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Marker {
    /// A setting on its group's Pareto front, or any point of a line plot.
    Filled,
    /// A setting some other setting of its group beats in both time and error.
    Hollow,
    /// An error of exactly 0, drawn on the floor of the log axis.
    Exact,
}

/// One line of the legend.
pub struct Entry {
    pub colour: RGBColor,
    pub line: bool,
    pub marker: Option<Marker>,
    pub text: String,
}

/// The elements drawn over one page's axes.
pub struct Overlay {
    area: Rect,
    size: (u32, u32),
    body: String,
    taken: Vec<Rect>,
    notes: Vec<String>,
}

pub fn hex(colour: RGBColor) -> String {
    format!("#{:02X}{:02X}{:02X}", colour.0, colour.1, colour.2)
}

/// `text` with the characters XML gives meaning to escaped.
pub fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

const RADIUS: f64 = 4.0;

fn marker(kind: Marker, (x, y): (f64, f64), colour: &str) -> String {
    match kind {
        Marker::Filled => {
            format!(r#"<circle cx="{x:.1}" cy="{y:.1}" r="{RADIUS}" fill="{colour}"/>"#)
        }
        Marker::Hollow => format!(
            r#"<circle cx="{x:.1}" cy="{y:.1}" r="{RADIUS}" fill="white" stroke="{colour}" stroke-width="1.5"/>"#
        ),
        // A downward triangle pointing at the floor: the error is below anything the axis
        // can show.
        Marker::Exact => format!(
            r#"<path class="exact" d="M {:.1} {:.1} L {:.1} {:.1} L {:.1} {:.1} Z" fill="{colour}" stroke="black" stroke-width="0.8"/>"#,
            x - 5.0,
            y - 9.0,
            x + 5.0,
            y - 9.0,
            x,
            y - 1.0
        ),
    }
}

impl Overlay {
    /// An overlay for a page of `size` whose plot area is `area`.
    pub fn new(area: Rect, size: (u32, u32)) -> Overlay {
        Overlay {
            area,
            size,
            body: String::new(),
            taken: Vec::new(),
            notes: Vec::new(),
        }
    }

    /// One series: a line through `line` and a marker at each of `points`, in page pixels.
    pub fn series(
        &mut self,
        key: &str,
        colour: RGBColor,
        line: &[(f64, f64)],
        points: &[((f64, f64), Marker)],
    ) {
        let c = hex(colour);
        self.body.push_str(&format!(
            "<g class=\"series\" data-key=\"{}\" stroke=\"{c}\" fill=\"{c}\">\n",
            escape(key)
        ));
        if line.len() > 1 {
            let path: Vec<String> = line.iter().map(|(x, y)| format!("{x:.1},{y:.1}")).collect();
            self.body.push_str(&format!(
                "<polyline points=\"{}\" fill=\"none\" stroke=\"{c}\" stroke-width=\"2\"/>\n",
                path.join(" ")
            ));
        }
        for &(p, kind) in points {
            self.body.push_str(&marker(kind, p, &c));
            self.body.push('\n');
            let centre = if kind == Marker::Exact {
                p.1 - 5.0
            } else {
                p.1
            };
            self.taken.push(Rect::around(p.0, centre, RADIUS + 2.0));
        }
        self.body.push_str("</g>\n");
    }

    /// The legend, where it covers the fewest markers: a corner of the plot area if one is
    /// as clear as anywhere, else the middle of a side or the centre.
    pub fn legend(&mut self, entries: &[Entry]) {
        if entries.is_empty() {
            return;
        }
        const ROW: f64 = 16.0;
        let text_width = entries
            .iter()
            .map(|e| {
                let b = labels::text_box(&e.text, 0.0, 0.0);
                b.x1 - b.x0
            })
            .fold(0.0, f64::max);
        let (w, h) = (text_width + 38.0, entries.len() as f64 * ROW + 8.0);
        let a = self.area;
        let (right, left) = (a.x1 - w - 8.0, a.x0 + 8.0);
        let (top, bottom) = (a.y0 + 8.0, a.y1 - h - 8.0);
        let (middle, centre) = (0.5 * (top + bottom), 0.5 * (left + right));
        // The corners first, then the middles of the sides, then the centre.
        let corners = [
            (right, top),
            (left, top),
            (right, bottom),
            (left, bottom),
            (right, middle),
            (left, middle),
            (centre, top),
            (centre, bottom),
            (centre, middle),
        ];
        let covered = |(x0, y0): (f64, f64)| {
            let r = Rect {
                x0,
                y0,
                x1: x0 + w,
                y1: y0 + h,
            };
            self.taken
                .iter()
                .filter(|t| t.x0 < r.x1 && r.x0 < t.x1 && t.y0 < r.y1 && r.y0 < t.y1)
                .count()
        };
        let (x0, y0) = corners
            .iter()
            .copied()
            .min_by_key(|c| covered(*c))
            .unwrap_or(corners[0]);
        self.body.push_str(&format!(
            "<g class=\"legend\">\n<rect x=\"{x0:.1}\" y=\"{y0:.1}\" width=\"{w:.1}\" height=\"{h:.1}\" fill=\"white\" fill-opacity=\"0.85\" stroke=\"black\"/>\n"
        ));
        for (i, e) in entries.iter().enumerate() {
            let y = y0 + 4.0 + ROW * (i as f64 + 0.5);
            let c = hex(e.colour);
            if e.line {
                self.body.push_str(&format!(
                    "<line x1=\"{:.1}\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{y:.1}\" stroke=\"{c}\" stroke-width=\"2\"/>\n",
                    x0 + 6.0,
                    x0 + 26.0
                ));
            }
            if let Some(kind) = e.marker {
                self.body.push_str(&marker(kind, (x0 + 16.0, y), &c));
                self.body.push('\n');
            }
            self.body.push_str(&format!(
                "<text x=\"{:.1}\" y=\"{:.1}\" font-family=\"sans-serif\" font-size=\"{}\">{}</text>\n",
                x0 + 32.0,
                y + 0.35 * labels::FONT_SIZE,
                labels::FONT_SIZE,
                escape(&e.text)
            ));
        }
        self.body.push_str("</g>\n");
        self.taken.push(Rect {
            x0,
            y0,
            x1: x0 + w,
            y1: y0 + h,
        });
    }

    /// Labels for points, placed clear of everything drawn so far; a note counts those that
    /// found no place.
    pub fn labels(&mut self, wanted: &[((f64, f64), String)]) {
        let placed = labels::place(wanted, &self.area, &mut self.taken);
        let mut left_out = 0;
        for (((px, py), text), spot) in wanted.iter().zip(placed) {
            let Some(spot) = spot else {
                left_out += 1;
                continue;
            };
            let (lx, ly) = spot.rect.nearest(*px, *py);
            if (lx - px).hypot(ly - py) > 12.0 {
                self.body.push_str(&format!(
                    "<line x1=\"{px:.1}\" y1=\"{py:.1}\" x2=\"{lx:.1}\" y2=\"{ly:.1}\" stroke=\"#999999\" stroke-width=\"0.8\"/>\n"
                ));
            }
            self.body.push_str(&format!(
                "<text class=\"label\" x=\"{:.1}\" y=\"{:.1}\" font-family=\"sans-serif\" font-size=\"{}\">{}</text>\n",
                spot.x,
                spot.y,
                labels::FONT_SIZE,
                escape(text)
            ));
        }
        if left_out > 0 {
            self.notes.push(format!(
                "{left_out} label{} left out for space; study.csv lists every setting",
                if left_out == 1 { "" } else { "s" }
            ));
        }
    }

    /// The page `svg` (a whole document) with the overlay drawn on top.
    pub fn finish(self, svg: &str) -> String {
        let mut extra = self.body;
        if !self.notes.is_empty() {
            // The page keeps a line free below the axes for it.
            extra.push_str(&format!(
                "<text class=\"note\" x=\"8\" y=\"{:.1}\" font-family=\"sans-serif\" font-size=\"10\">{}</text>\n",
                self.size.1 as f64 - 6.0,
                escape(&self.notes.join("; "))
            ));
        }
        match svg.rfind("</svg>") {
            Some(end) => format!("{}{extra}{}", &svg[..end], &svg[end..]),
            None => format!("{svg}{extra}"),
        }
    }
}
