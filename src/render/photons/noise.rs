//! When a photon tally has traced enough: two independent halves of it compared where the
//! camera would see them. The one key decision: the comparison is made on coarse bins of the
//! image, each cell weighed by how much the camera sees of it, so a thin medium, whose pixels
//! average many cells along their rays, stops sooner than a dense one, whose pixels see a skin.

use super::super::camera::Camera;
use glam::DVec3;

/// The relative noise the camera would see in the sum of two independent halves of a tally:
/// each half's cells summed into coarse bins of the image (each cell weighed by how much the
/// camera sees of it, so a bin sums roughly what its pixels see along their rays), and half the
/// relative RMS of the halves' difference over the bins. A half holds half the photons: its
/// noise is `√2` times the sum's, and the difference of two halves `√2` times a half's.
pub(super) fn relative_noise(
    halves: &[Vec<DVec3>; 2],
    direct: &[f64],
    bins: &[Option<(usize, f64)>],
    count: usize,
) -> f64 {
    let mut sums = vec![(0.0, 0.0, 0.0); count];
    for (((a, b), d), bin) in halves[0].iter().zip(&halves[1]).zip(direct).zip(bins) {
        if let Some((bin, w)) = *bin {
            sums[bin].0 += w * a.element_sum();
            sums[bin].1 += w * b.element_sum();
            sums[bin].2 += w * d;
        }
    }
    let (mut difference, mut level) = (0.0, 0.0);
    for (a, b, d) in sums {
        difference += (a - b) * (a - b);
        level += (a + b + d) * (a + b + d);
    }
    if level > 0.0 {
        (difference / level).sqrt()
    } else {
        0.0
    }
}

/// Coarse bins of the image, a quarter of its resolution along each side (at most
/// `MOST_BINS`): where a point lands on the camera's film.
pub(super) struct ViewBins {
    eye: DVec3,
    axes: (DVec3, DVec3, DVec3),
    half: (f64, f64),
    orthographic: bool,
    size: (usize, usize),
}

const MOST_BINS: usize = 64;

impl ViewBins {
    pub(super) fn new(camera: &Camera, (width, height): (usize, usize)) -> ViewBins {
        let side = |n: usize| (n / 4).clamp(1, MOST_BINS);
        ViewBins {
            eye: camera.eye,
            axes: camera.axes(),
            half: camera.half_extent(width, height),
            orthographic: camera.is_orthographic(),
            size: (side(width), side(height)),
        }
    }

    pub(super) fn count(&self) -> usize {
        self.size.0 * self.size.1
    }

    /// The bin `p` falls in, if the camera sees it.
    pub(super) fn bin(&self, p: DVec3) -> Option<usize> {
        let d = p - self.eye;
        let (right, up, forward) = self.axes;
        let depth = if self.orthographic {
            1.0
        } else {
            d.dot(forward)
        };
        if depth <= 0.0 {
            return None;
        }
        let x = d.dot(right) / (depth * self.half.0);
        let y = d.dot(up) / (depth * self.half.1);
        if !(x.abs() < 1.0 && y.abs() < 1.0) {
            return None;
        }
        let i = ((0.5 * (x + 1.0) * self.size.0 as f64) as usize).min(self.size.0 - 1);
        let j = ((0.5 * (1.0 - y) * self.size.1 as f64) as usize).min(self.size.1 - 1);
        Some(j * self.size.0 + i)
    }
}
