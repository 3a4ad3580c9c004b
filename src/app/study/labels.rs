//! Where the plots put their point labels: inside the plot area, clear of one another, of the
//! markers and of the legend.
//!
//! The key decision: a greedy placement with collision checks. Labels are placed one at a time,
//! the Pareto front's first; each tries positions around its point, nearest first (sixteen
//! directions, right and left first, then the same farther out), and takes the first whose box is
//! inside the area and meets no box already taken. A label that finds no place is left out and
//! counted (the plot says how many; `study.csv` names every point). Text is measured with a
//! width of 0.7 em per character, wider than the average advance of digits and lower-case
//! letters in the usual sans-serif faces, so a box holds its text in any of them.

/// A box in page pixels, y down.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
}

impl Rect {
    pub fn around(x: f64, y: f64, radius: f64) -> Rect {
        Rect {
            x0: x - radius,
            y0: y - radius,
            x1: x + radius,
            y1: y + radius,
        }
    }

    fn overlaps(&self, other: &Rect) -> bool {
        self.x0 < other.x1 && other.x0 < self.x1 && self.y0 < other.y1 && other.y0 < self.y1
    }

    fn inside(&self, area: &Rect) -> bool {
        self.x0 >= area.x0 && self.x1 <= area.x1 && self.y0 >= area.y0 && self.y1 <= area.y1
    }

    /// The point of the box nearest to `(x, y)`: where a leader line from the point ends.
    pub fn nearest(&self, x: f64, y: f64) -> (f64, f64) {
        (x.clamp(self.x0, self.x1), y.clamp(self.y0, self.y1))
    }
}

/// The labels' font size in pixels.
pub const FONT_SIZE: f64 = 11.0;

/// Width of one character, in em, that the boxes allow.
const EM_PER_CHAR: f64 = 0.7;

/// The box of `text` with its baseline starting at `(x, y)`: from an ascent of one em above the
/// baseline to a descent of 0.3 em below it.
pub fn text_box(text: &str, x: f64, y: f64) -> Rect {
    Rect {
        x0: x,
        y0: y - FONT_SIZE,
        x1: x + text.chars().count() as f64 * EM_PER_CHAR * FONT_SIZE,
        y1: y + 0.3 * FONT_SIZE,
    }
}

/// Unit directions in which a label is tried, nearest the usual right-hand place first.
const DIRECTIONS: [(f64, f64); 16] = {
    const D: f64 = std::f64::consts::FRAC_1_SQRT_2;
    const C: f64 = 0.923_879_532_511_286_7; // cos 22.5°
    const S: f64 = 0.382_683_432_365_089_8; // sin 22.5°
    [
        (1.0, 0.0),
        (-1.0, 0.0),
        (0.0, -1.0),
        (0.0, 1.0),
        (D, -D),
        (D, D),
        (-D, -D),
        (-D, D),
        (C, -S),
        (C, S),
        (-C, -S),
        (-C, S),
        (S, -C),
        (S, C),
        (-S, -C),
        (-S, C),
    ]
};

/// A placed label: its text's baseline start, and its box.
#[derive(Clone, Debug)]
pub struct Placed {
    pub x: f64,
    pub y: f64,
    pub rect: Rect,
}

/// Places a label for each `(point, text)` in order inside `area`, clear of `taken` (markers,
/// the legend), which the placed boxes join. `None` for a label that finds no place.
pub fn place(
    labels: &[((f64, f64), String)],
    area: &Rect,
    taken: &mut Vec<Rect>,
) -> Vec<Option<Placed>> {
    const GAP: f64 = 2.0;
    labels
        .iter()
        .map(|((px, py), text)| {
            let probe = text_box(text, 0.0, 0.0);
            let (w, h) = (probe.x1 - probe.x0, probe.y1 - probe.y0);
            let ascent = -probe.y0;
            for distance in [7.0, 14.0, 24.0, 38.0, 56.0, 80.0, 110.0, 150.0] {
                // Sixteen directions, right first, then left, above, below and between; the
                // box sits beyond `distance` in that direction.
                let candidates = DIRECTIONS.iter().map(|&(dx, dy)| {
                    let cx = px + dx * (distance + w / 2.0);
                    let cy = py + dy * (distance + h / 2.0);
                    (cx - w / 2.0, cy - h / 2.0)
                });
                for (x0, y0) in candidates {
                    let rect = Rect {
                        x0,
                        y0,
                        x1: x0 + w,
                        y1: y0 + h,
                    };
                    let padded = Rect {
                        x0: rect.x0 - GAP,
                        y0: rect.y0 - GAP,
                        x1: rect.x1 + GAP,
                        y1: rect.y1 + GAP,
                    };
                    if rect.inside(area) && !taken.iter().any(|t| t.overlaps(&padded)) {
                        taken.push(rect);
                        return Some(Placed {
                            x: x0,
                            y: y0 + ascent,
                            rect,
                        });
                    }
                }
            }
            None
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crowded_labels_spread_out_and_stay_inside() {
        let area = Rect {
            x0: 0.0,
            y0: 0.0,
            x1: 300.0,
            y1: 200.0,
        };
        // Eight points almost on top of one another, one at the right edge.
        let mut labels: Vec<((f64, f64), String)> = (0..8)
            .map(|i| {
                (
                    (150.0 + i as f64, 100.0 + i as f64),
                    format!("n={}", 10 + i),
                )
            })
            .collect();
        labels.push(((299.0, 100.0), String::from("n=1000")));
        let mut taken: Vec<Rect> = labels
            .iter()
            .map(|((x, y), _)| Rect::around(*x, *y, 4.0))
            .collect();
        let markers = taken.clone();
        let placed = place(&labels, &area, &mut taken);
        let boxes: Vec<Rect> = placed.iter().map(|p| p.as_ref().unwrap().rect).collect();
        for (i, a) in boxes.iter().enumerate() {
            assert!(a.inside(&area), "{a:?}");
            assert!(!markers.iter().any(|m| m.overlaps(a)), "{a:?}");
            for b in &boxes[i + 1..] {
                assert!(!a.overlaps(b), "{a:?} {b:?}");
            }
        }
        // The label at the right edge went to the left of its point.
        assert!(boxes[8].x1 < 299.0);
    }
}
