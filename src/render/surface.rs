//! The surface AOVs of the march: where the visible medium lies (`position.X/Y/Z`, world
//! space), which way its density falls off (`normal.X/Y/Z`, world space, unit length) and how
//! it moves across the image (`forward.u/v`, pixels per frame: Nuke's `forward` layer of its
//! `motion` channel set, +u right and +v up, which VectorBlur reads).
//!
//! The one key decision: like `depth`, each is a mean over a ray's samples weighted by the
//! opacity each sample adds, and then over the pixel's rays, so a pixel describes the medium
//! it shows in proportion to how much of it shows; where nothing shows the channels are 0. The
//! normal is `−∇ρ/|∇ρ|` (pointing out of the medium, towards thinner density), the gradient by
//! central differences half a march step either side of the sample, where the medium was at the
//! sample's time; the opacity-weighted sum of those unit normals is normalised again per
//! pixel. The motion of a sample is where the camera sees the point one frame later, moved by
//! the velocity there, less where it sees it now.

use super::camera::Camera;
use super::exr_header::{RowMatrix, transform_point, world_to_ndc};
use super::settings::Aovs;
use crate::space::BlockEval;
use glam::DVec3;

/// The channel names of the surface AOVs asked for, in the order `Surface::pixel` writes them.
pub fn channel_names(aovs: &Aovs) -> Vec<String> {
    let mut names = Vec::new();
    if aovs.position {
        names.extend(["position.X", "position.Y", "position.Z"].map(String::from));
    }
    if aovs.normal {
        names.extend(["normal.X", "normal.Y", "normal.Z"].map(String::from));
    }
    if aovs.motion {
        names.extend(["forward.u", "forward.v"].map(String::from));
    }
    names
}

/// What one sample adds to its ray's surface AOVs.
pub struct SurfaceSample {
    /// The sample's point on the ray.
    pub point: DVec3,
    /// The density's gradient there (zero where the density is zero or not asked for).
    pub gradient: DVec3,
    /// The medium's velocity there, world units per frame (zero without motion).
    pub velocity: DVec3,
}

/// Per ray, the opacity-weighted sums of position, normal and screen motion.
pub struct Surface {
    aovs: Aovs,
    to_ndc: RowMatrix,
    pixels: DVec3,
    sums: Vec<[DVec3; 3]>,
}

impl Surface {
    /// Empty sums for `rays` rays of an image `width × height` seen by `camera`.
    pub fn new(aovs: Aovs, camera: &Camera, width: usize, height: usize, rays: usize) -> Surface {
        Surface {
            aovs,
            to_ndc: world_to_ndc(camera, width, height),
            pixels: DVec3::new(width as f64, height as f64, 0.0),
            sums: vec![[DVec3::ZERO; 3]; rays],
        }
    }

    /// Whether any surface AOV is asked for.
    pub fn wanted(aovs: &Aovs) -> bool {
        aovs.position || aovs.normal || aovs.motion
    }

    /// Adds a sample of opacity `weight` to ray `r`.
    pub fn add(&mut self, r: usize, weight: f64, sample: &SurfaceSample) {
        if weight <= 0.0 {
            return;
        }
        let mut added = [DVec3::ZERO; 3];
        if self.aovs.position {
            added[0] = weight * sample.point;
        }
        if self.aovs.normal {
            let length = sample.gradient.length();
            if length > 0.0 && length.is_finite() {
                added[1] = -(weight / length) * sample.gradient;
            }
        }
        if self.aovs.motion && sample.velocity != DVec3::ZERO {
            let moved = self.raster(sample.point + sample.velocity) - self.raster(sample.point);
            if moved.is_finite() {
                // Raster y grows down the image; Nuke's v grows up.
                added[2] = weight * DVec3::new(moved.x, -moved.y, 0.0);
            }
        }
        for (sum, a) in self.sums[r].iter_mut().zip(added) {
            *sum += a;
        }
    }

    /// Where the camera sees `p`, in pixels from the image's top-left corner.
    fn raster(&self, p: DVec3) -> DVec3 {
        let ndc = transform_point(&self.to_ndc, p);
        DVec3::new(ndc.x, ndc.y, 0.0) * self.pixels
    }

    /// Ray `r`'s sums, to rewind to.
    pub fn sums(&self, r: usize) -> [DVec3; 3] {
        self.sums[r]
    }

    /// Puts ray `r`'s sums back.
    pub fn restore(&mut self, r: usize, sums: [DVec3; 3]) {
        self.sums[r] = sums;
    }

    /// The pixel made of `rays`, whose opacities sum to `opacity`: its channels, in the order
    /// of `channel_names`.
    pub fn pixel(&self, rays: std::ops::Range<usize>, opacity: f64, out: &mut Vec<f32>) {
        let mut total = [DVec3::ZERO; 3];
        for r in rays {
            for (t, s) in total.iter_mut().zip(self.sums[r]) {
                *t += s;
            }
        }
        let mean = |v: DVec3| {
            if opacity > 0.0 {
                v / opacity
            } else {
                DVec3::ZERO
            }
        };
        let finite = |v: f64| if v.is_finite() { v as f32 } else { 0.0 };
        if self.aovs.position {
            out.extend(mean(total[0]).to_array().map(finite));
        }
        if self.aovs.normal {
            out.extend(total[1].normalize_or_zero().to_array().map(finite));
        }
        if self.aovs.motion {
            let motion = mean(total[2]);
            out.extend([finite(motion.x), finite(motion.y)]);
        }
    }
}

/// The gradient of the density at each of `points`, by central differences `h` either side,
/// into `out` (six evaluations of the density per point).
pub fn gradients(density: &mut dyn BlockEval, points: &[DVec3], h: f64, out: &mut Vec<DVec3>) {
    let n = points.len();
    out.clear();
    out.resize(n, DVec3::ZERO);
    let mut xs = vec![0.0; n];
    let mut ys = vec![0.0; n];
    let mut zs = vec![0.0; n];
    let mut values = vec![0.0; n];
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            let offset = DVec3::AXES[axis] * (sign * h);
            for (k, p) in points.iter().enumerate() {
                let q = *p + offset;
                (xs[k], ys[k], zs[k]) = (q.x, q.y, q.z);
            }
            density.eval_f64(&xs, &ys, &zs, &mut values);
            for (g, v) in out.iter_mut().zip(&values) {
                g[axis] += sign * v / (2.0 * h);
            }
        }
    }
}
