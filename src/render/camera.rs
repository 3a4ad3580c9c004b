//! The camera: where rays start and which way they go.
//!
//! A pinhole (or orthographic) camera described the way a TD places one: an eye, a point looked
//! at, an up hint and a *horizontal* field of view, as Houdini and `vdb_render` do. The image's
//! vertical extent follows from the aspect ratio (the image's width/height unless overridden).
//! The one key decision: pixel `(x, y)` covers `[x, x+1) × [y, y+1)` in raster space with `y = 0`
//! the top row, and a sample at raster offset `(jx, jy)` inside it is the ray through that point;
//! one sample per pixel goes through the pixel's centre.

use crate::base::failure::vector_text;
use crate::base::failure::{Failure, Outcome};
use glam::DVec3;

/// `v`'s length, without overflow or underflow for components near the float range's ends.
fn robust_length(v: DVec3) -> f64 {
    let scale = v.abs().max_element();
    if scale == 0.0 {
        return 0.0;
    }
    scale * (v / scale).length()
}

/// `v` itself when its length is an ordinary float, else `v` scaled to unit size, so that
/// `normalize` and `cross` neither overflow (1e300 squared) nor underflow; the directions
/// taken from either agree.
fn tame(v: DVec3) -> DVec3 {
    let length = v.length();
    let scale = v.abs().max_element();
    if (1e-150..1e150).contains(&length) || scale == 0.0 {
        v
    } else {
        v / scale
    }
}

/// A ray `origin + t · direction`, `direction` of unit length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: DVec3,
    pub direction: DVec3,
}

impl Ray {
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.direction * t
    }
}

/// A camera looking from `eye` towards `lookat`.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub eye: DVec3,
    pub lookat: DVec3,
    pub up: DVec3,
    /// Horizontal field of view in degrees, in (0, 180). Unused by an orthographic camera.
    pub fov_degrees: f64,
    /// Width / height of the image plane; `None` takes the rendered image's pixel aspect.
    pub aspect: Option<f64>,
    /// `Some(width)`: an orthographic camera whose view is `width` world units across.
    pub ortho_width: Option<f64>,
    forward: DVec3,
    right: DVec3,
    true_up: DVec3,
}

impl Camera {
    /// A perspective camera. Fails when the eye sits on the point looked at, when `up` is
    /// parallel to the view direction, or when the field of view is outside (0, 180) degrees.
    pub fn new(eye: DVec3, lookat: DVec3, up: DVec3, fov_degrees: f64) -> Outcome<Camera> {
        for (what, v) in [("eye", eye), ("lookat", lookat), ("up", up)] {
            if !v.is_finite() {
                return Err(Failure::new(format!(
                    "camera {what} must be finite, got {v}"
                )));
            }
        }
        if !(fov_degrees > 0.0 && fov_degrees < 180.0) {
            return Err(Failure::new(format!(
                "camera field of view must be between 0 and 180 degrees (exclusive), got {fov_degrees}"
            ))
            .with_help("the field of view is the horizontal angle in degrees, e.g. 45"));
        }
        let view = lookat - eye;
        if !view.is_finite() {
            return Err(Failure::new(format!(
                "camera eye {} is too far from lookat {}: the distance between them is beyond \
                 the range of floating-point numbers",
                vector_text(eye),
                vector_text(lookat)
            ))
            .with_help("move the eye and lookat nearer each other and the world origin"));
        }
        let distance = robust_length(view);
        let reach = eye.abs().max_element().max(lookat.abs().max_element());
        if distance == 0.0 {
            return Err(
                Failure::new(format!("camera eye and lookat are the same point {eye}"))
                    .with_help("move the eye away from the point it looks at"),
            );
        }
        if distance <= 1e-12 * (1.0 + reach) {
            return Err(Failure::new(format!(
                "camera eye {} and lookat {} are only {distance:e} apart, too close to give a \
                 view direction {reach:e} from the world origin",
                vector_text(eye),
                vector_text(lookat)
            ))
            .with_help("move the eye away from the point it looks at"));
        }
        let forward = tame(view).normalize();
        let up_hint = tame(up);
        let side = forward.cross(up_hint);
        if up_hint.length() == 0.0 || side.length() <= 1e-9 * up_hint.length() {
            return Err(Failure::new(format!(
                "camera up {up} is parallel to the view direction {forward}"
            ))
            .with_help("choose an up vector that is not along the line from eye to lookat"));
        }
        let right = side.normalize();
        let true_up = right.cross(forward);
        Ok(Camera {
            eye,
            lookat,
            up,
            fov_degrees,
            aspect: None,
            ortho_width: None,
            forward,
            right,
            true_up,
        })
    }

    /// How far a ray's positions can be trusted: the spacing of floating-point numbers at the
    /// farthest of the eye and `bounds`'s corners. A render whose step is not well above it
    /// would sample noise.
    pub fn precision_over(&self, bounds: &crate::space::Aabb) -> f64 {
        let farthest = [self.eye, bounds.min, bounds.max]
            .iter()
            .map(|p| p.abs().max_element())
            .fold(0.0, f64::max);
        let distance =
            (bounds.center() - self.eye).abs().max_element() + bounds.size().max_element();
        (farthest + distance) * f64::EPSILON
    }

    /// Overrides the image-plane aspect ratio (width / height).
    pub fn with_aspect(mut self, aspect: f64) -> Outcome<Camera> {
        if !(aspect.is_finite() && aspect > 0.0) {
            return Err(Failure::new(format!(
                "camera aspect must be positive, got {aspect}"
            )));
        }
        self.aspect = Some(aspect);
        Ok(self)
    }

    /// Makes the camera orthographic, `width` world units across.
    pub fn orthographic(mut self, width: f64) -> Outcome<Camera> {
        if !(width.is_finite() && width > 0.0) {
            return Err(Failure::new(format!(
                "orthographic camera width must be positive, got {width}"
            )));
        }
        self.ortho_width = Some(width);
        Ok(self)
    }

    /// The unit view direction.
    pub fn forward(&self) -> DVec3 {
        self.forward
    }

    /// Depth of a world point along the view axis (what a `Z` channel holds).
    pub fn depth(&self, p: DVec3) -> f64 {
        (p - self.eye).dot(self.forward)
    }

    /// The camera's right, up and forward unit vectors, perpendicular to each other.
    pub fn axes(&self) -> (DVec3, DVec3, DVec3) {
        (self.right, self.true_up, self.forward)
    }

    /// Half the image plane's width and height for an image of `width × height` pixels: at
    /// unit distance from the eye for a perspective camera, in world units for an
    /// orthographic one.
    pub fn half_extent(&self, width: usize, height: usize) -> (f64, f64) {
        let aspect = self.aspect.unwrap_or(width as f64 / height.max(1) as f64);
        let half_width = match self.ortho_width {
            Some(w) => 0.5 * w,
            None => (0.5 * self.fov_degrees.to_radians()).tan(),
        };
        (half_width, half_width / aspect)
    }

    /// Whether the camera is orthographic.
    pub fn is_orthographic(&self) -> bool {
        self.ortho_width.is_some()
    }

    /// What a frustum cache of `width × height` pixels needs of the camera.
    pub fn frustum_view(&self, width: usize, height: usize) -> crate::grid::frustum::View {
        let (half_width, half_height) = self.half_extent(width, height);
        crate::grid::frustum::View {
            eye: self.eye,
            right: self.right,
            up: self.true_up,
            forward: self.forward,
            half_width,
            half_height,
            orthographic: self.is_orthographic(),
        }
    }

    /// A ray generator for an image of `width × height` pixels.
    pub fn raster(&self, width: usize, height: usize) -> Raster {
        let (half_width, half_height) = self.half_extent(width, height);
        Raster {
            eye: self.eye,
            forward: self.forward,
            right: self.right,
            up: self.true_up,
            half_width,
            half_height,
            inv_width: 1.0 / width.max(1) as f64,
            inv_height: 1.0 / height.max(1) as f64,
            ortho: self.ortho_width.is_some(),
        }
    }
}

/// Maps raster positions to rays for one image size.
#[derive(Clone, Copy, Debug)]
pub struct Raster {
    eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    half_width: f64,
    half_height: f64,
    inv_width: f64,
    inv_height: f64,
    ortho: bool,
}

impl Raster {
    /// The ray through raster point `(x + jx, y + jy)`; `jx, jy` in [0, 1), 0.5 is the centre.
    pub fn ray(&self, x: usize, y: usize, jx: f64, jy: f64) -> Ray {
        // Normalised device coordinates: -1 at the left/bottom edge, +1 at the right/top.
        let ndc_x = 2.0 * (x as f64 + jx) * self.inv_width - 1.0;
        let ndc_y = 1.0 - 2.0 * (y as f64 + jy) * self.inv_height;
        let offset = self.right * (ndc_x * self.half_width) + self.up * (ndc_y * self.half_height);
        if self.ortho {
            Ray {
                origin: self.eye + offset,
                direction: self.forward,
            }
        } else {
            Ray {
                origin: self.eye,
                direction: (self.forward + offset).normalize(),
            }
        }
    }
}

/// A number in [0, 1) from a counter hash of `(seed, pixel, sample, dimension)`: the same
/// sample always gets the same jitter, whichever thread draws it and in whatever order.
pub fn jitter(seed: u64, pixel: u64, sample: u64, dimension: u64) -> f64 {
    let mut h = mix(seed ^ 0x243f_6a88_85a3_08d3);
    h = mix(h ^ pixel);
    h = mix(h ^ sample.wrapping_mul(0x9e37_79b9_7f4a_7c15));
    h = mix(h ^ dimension.wrapping_mul(0xbf58_476d_1ce4_e5b9));
    // The top 53 bits as a fraction: exactly representable, never 1.
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// SplitMix64's finaliser: a bijection that scatters nearby counters across all 64 bits.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn horizontal_fov_spans_the_image_width() {
        let cam = Camera::new(DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0), DVec3::Y, 90.0).unwrap();
        let raster = cam.raster(200, 100);
        // The left edge of the image at a 90-degree horizontal field of view is 45 degrees off axis.
        let left = raster.ray(0, 50, 0.0, 0.0).direction;
        assert!((left - DVec3::new(-1.0, 0.0, -1.0).normalize()).length() < 1e-12);
        // The top edge: half height = tan(45°) / aspect 2 = 0.5.
        let top = raster.ray(100, 0, 0.0, 0.0).direction;
        assert!((top - DVec3::new(0.0, 0.5, -1.0).normalize()).length() < 1e-12);
        // Centre pixel of an odd-sized image looks straight ahead.
        let centre = cam.raster(101, 51).ray(50, 25, 0.5, 0.5).direction;
        assert!((centre - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12);
    }

    #[test]
    fn far_and_huge_vectors_give_a_camera_or_say_what_is_wrong() {
        // 1e300 apart used to overflow the distance to infinity: "the same point".
        let far = Camera::new(
            DVec3::splat(1e300),
            DVec3::ZERO,
            DVec3::new(0.0, 1e300, 0.0),
            40.0,
        )
        .unwrap();
        let expected = DVec3::splat(-1.0).normalize();
        assert!((far.forward() - expected).length() < 1e-15);
        assert!(far.right.is_finite() && far.true_up.is_finite());
        let box_ = crate::space::Aabb::new(DVec3::splat(-1.0), DVec3::ONE);
        assert!(far.precision_over(&box_) > 1e284);
        let near = Camera::new(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 40.0).unwrap();
        assert!(near.precision_over(&box_) < 1e-14);
        let apart = Camera::new(
            DVec3::X * 1e308,
            DVec3::new(-1e308, 0.0, 0.0),
            DVec3::Y,
            40.0,
        );
        assert!(
            apart.unwrap_err().message.starts_with(
                "camera eye (1e308, 0.0, 0.0) is too far from lookat (-1e308, 0.0, 0.0)"
            )
        );
        let close = Camera::new(DVec3::X * 1e15, DVec3::X * (1e15 + 0.5), DVec3::Y, 40.0);
        assert_eq!(
            close.unwrap_err().message,
            "camera eye (1000000000000000.0, 0.0, 0.0) and lookat (1000000000000000.5, 0.0, 0.0) \
             are only 5e-1 apart, too close to give a view direction 1.0000000000000005e15 from \
             the world origin"
        );
        let same = Camera::new(DVec3::ONE, DVec3::ONE, DVec3::Y, 40.0).unwrap_err();
        assert!(
            same.message
                .starts_with("camera eye and lookat are the same point")
        );
    }

    #[test]
    fn aspect_override_and_ortho() {
        let cam = Camera::new(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 60.0)
            .unwrap()
            .with_aspect(1.0)
            .unwrap()
            .orthographic(4.0)
            .unwrap();
        let raster = cam.raster(200, 100);
        let corner = raster.ray(0, 0, 0.0, 0.0);
        assert!((corner.origin - DVec3::new(-2.0, 2.0, 5.0)).length() < 1e-12);
        assert_eq!(corner.direction, DVec3::new(0.0, 0.0, -1.0));
        assert!((cam.depth(DVec3::new(3.0, 1.0, 1.0)) - 4.0).abs() < 1e-12);
    }

    #[test]
    fn jitter_is_uniform_and_decorrelated() {
        // Mean 1/2 and variance 1/12 of a uniform variable, and neighbouring counters unrelated.
        let n = 100_000u64;
        let xs: Vec<f64> = (0..n).map(|i| jitter(7, i, 0, 2)).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 0.005 && (var - 1.0 / 12.0).abs() < 0.002);
        let lag: f64 = xs
            .windows(2)
            .map(|w| (w[0] - 0.5) * (w[1] - 0.5))
            .sum::<f64>()
            / n as f64;
        assert!(lag.abs() < 0.002, "lag-1 covariance {lag}");
        assert!(xs.iter().all(|x| (0.0..1.0).contains(x)));
        assert_ne!(jitter(7, 3, 0, 2), jitter(8, 3, 0, 2));
        assert_ne!(jitter(7, 3, 0, 2), jitter(7, 3, 1, 2));
    }

    #[test]
    fn bad_cameras_are_errors() {
        let p = DVec3::new(1.0, 2.0, 3.0);
        assert!(
            Camera::new(p, p, DVec3::Y, 45.0)
                .unwrap_err()
                .message
                .contains("same point")
        );
        let err = Camera::new(DVec3::ZERO, DVec3::Y, DVec3::Y, 45.0).unwrap_err();
        assert!(err.message.contains("parallel"));
        assert!(Camera::new(DVec3::ZERO, DVec3::X, DVec3::Y, 180.0).is_err());
        assert!(Camera::new(DVec3::ZERO, DVec3::X, DVec3::Y, 0.0).is_err());
        assert!(Camera::new(DVec3::ZERO, DVec3::X, DVec3::Y, f64::NAN).is_err());
        assert!(Camera::new(DVec3::ZERO, DVec3::X, DVec3::ZERO, 45.0).is_err());
    }
}
