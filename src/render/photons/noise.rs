//! When a photon tally has traced enough: two independent halves of it compared where the
//! camera would see them. The one key decision: the comparison is made on coarse bins of the
//! image, each cell weighed by how much the camera sees of it and spread over the bins its
//! footprint on the film covers, so a thin medium, whose pixels average many cells along their
//! rays, stops sooner than a dense one, whose pixels see a skin; and coarse cells, whose
//! trilinear read spreads each cell's photons over its neighbours' pixels, stop sooner than
//! fine ones.

use super::super::camera::Camera;
use glam::DVec3;

/// The bins a cell's footprint covers and its share in each (zero shares unused).
pub(super) type Splat = [(usize, f64); 4];

/// The relative noise the camera would see in the sum of two independent halves of a tally:
/// each half's cells summed into coarse bins of the image (each cell weighed by how much the
/// camera sees of it, so a bin sums roughly what its pixels see along their rays), and half the
/// relative RMS of the halves' difference over the bins. A half holds half the photons: its
/// noise is `√2` times the sum's, and the difference of two halves `√2` times a half's.
pub(super) fn relative_noise(
    halves: &[Vec<DVec3>; 2],
    direct: &[f64],
    bins: &[Splat],
    count: usize,
) -> f64 {
    let mut sums = vec![(0.0, 0.0, 0.0); count];
    for (((a, b), d), splat) in halves[0].iter().zip(&halves[1]).zip(direct).zip(bins) {
        let (a, b) = (a.element_sum(), b.element_sum());
        for &(bin, w) in splat.iter().filter(|(_, w)| *w > 0.0) {
            sums[bin].0 += w * a;
            sums[bin].1 += w * b;
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

    /// The bins a cell of side `side` centred at `p` covers on the film, each with the share
    /// of the cell's footprint in it (a square `side` across at the cell's depth, no wider than
    /// a bin, so it covers at most two bins along each axis); empty where the camera does not
    /// see `p`. The shares sum to 1.
    pub(super) fn splat(&self, p: DVec3, side: f64) -> Splat {
        let mut splat = [(0, 0.0); 4];
        let d = p - self.eye;
        let (right, up, forward) = self.axes;
        let depth = if self.orthographic {
            1.0
        } else {
            d.dot(forward)
        };
        if depth <= 0.0 {
            return splat;
        }
        let x = d.dot(right) / (depth * self.half.0);
        let y = d.dot(up) / (depth * self.half.1);
        if !(x.abs() < 1.0 && y.abs() < 1.0) {
            return splat;
        }
        // Film position and footprint in bins along each axis.
        let axis = |film: f64, half: f64, count: usize| {
            let at = 0.5 * (film + 1.0) * count as f64;
            let width = (side / (depth * 2.0 * half) * count as f64).min(1.0);
            let lo = at - 0.5 * width;
            let first = lo.floor();
            let split = if width > 0.0 {
                ((first + 1.0 - lo) / width).min(1.0)
            } else {
                1.0
            };
            let clamp = |b: f64| (b.max(0.0) as usize).min(count - 1);
            [(clamp(first), split), (clamp(first + 1.0), 1.0 - split)]
        };
        let across = axis(x, self.half.0, self.size.0);
        let down = axis(-y, self.half.1, self.size.1);
        for (n, ((i, wi), (j, wj))) in across
            .into_iter()
            .flat_map(|a| down.into_iter().map(move |d| (a, d)))
            .enumerate()
        {
            splat[n] = (j * self.size.0 + i, wi * wj);
        }
        splat
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cells_shares_cover_its_footprint_and_sum_to_one() {
        let camera = Camera::new(DVec3::new(0.0, 0.0, 3.0), DVec3::ZERO, DVec3::Y, 35.0).unwrap();
        let view = ViewBins::new(&camera, (64, 64));
        let shares = |p: DVec3, side: f64| -> Vec<(usize, f64)> {
            let mut s: Vec<_> = view
                .splat(p, side)
                .into_iter()
                .filter(|(_, w)| *w > 0.0)
                .collect();
            s.sort_by_key(|(bin, _)| *bin);
            s
        };
        // A point cell falls in one bin; a cell wider than a bin is spread over at most four.
        let point = shares(DVec3::new(0.013, 0.021, 0.0), 1e-9);
        assert_eq!(point.len(), 1);
        assert!((point[0].1 - 1.0).abs() < 1e-9);
        let wide = shares(DVec3::new(0.013, 0.021, 0.0), 0.5);
        assert!(wide.len() > 1 && wide.len() <= 4, "{wide:?}");
        let total: f64 = wide.iter().map(|(_, w)| w).sum();
        assert!((total - 1.0).abs() < 1e-12, "shares sum to {total}");
        // The shares go where the point lands: the same bins as a point cell's neighbours.
        assert!(wide.iter().any(|(bin, _)| *bin == point[0].0));
        // Behind the camera or outside the frame: no bin.
        assert!(shares(DVec3::new(0.0, 0.0, 4.0), 0.1).is_empty());
        assert!(shares(DVec3::new(10.0, 0.0, 0.0), 0.1).is_empty());
    }
}
