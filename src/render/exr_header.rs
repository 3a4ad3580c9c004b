//! What a compositor reads from a render's OpenEXR header besides its pixels: the camera, as
//! the standard `worldToCamera` and `worldToNDC` attributes, and where the image came from.
//!
//! Nuke (`exr/worldToCamera`, `exr/worldToNDC`) and Houdini read these two `m44f` attributes
//! to rebuild the render camera, so they follow OpenEXR's definitions exactly, not felt's own
//! conventions. The one key decision, taken from those definitions: matrices are Imath's, for
//! row vectors (`p' = p · M`, translation in the last row); camera space is left-handed with
//! x right, y up and z the viewing direction (points in front have positive z); NDC has (0, 0)
//! at the top-left corner of the image and (1, 1) at the bottom-right, reached by `p · M`
//! followed by the division by w (the depth, for a perspective camera). NDC's z is 1/depth
//! (1 for an orthographic camera); it is not part of the standard and readers discard it.

use super::camera::Camera;
use super::image::{ExrOptions, HeaderValue};

/// OpenEXR's (Imath's) 4×4 matrix layout: `m[row][column]`, points as row vectors.
pub type RowMatrix = [[f64; 4]; 4];

/// The world-to-camera matrix of `camera`.
pub fn world_to_camera(camera: &Camera) -> RowMatrix {
    let (right, up, forward) = camera.axes();
    let mut m = [[0.0; 4]; 4];
    for (column, axis) in [right, up, forward].into_iter().enumerate() {
        for row in 0..3 {
            m[row][column] = axis[row];
        }
        m[3][column] = -axis.dot(camera.eye);
    }
    m[3][3] = 1.0;
    m
}

/// The world-to-NDC matrix of `camera` rendering `width × height` pixels.
pub fn world_to_ndc(camera: &Camera, width: usize, height: usize) -> RowMatrix {
    let (half_width, half_height) = camera.half_extent(width, height);
    // Camera space to NDC, for row vectors: u = (x / (2 hw) + w / 2) / w, v = (-y / (2 hh) +
    // w / 2) / w, with w = z for a perspective camera and 1 for an orthographic one.
    let projection: RowMatrix = if camera.is_orthographic() {
        [
            [0.5 / half_width, 0.0, 0.0, 0.0],
            [0.0, -0.5 / half_height, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0],
            [0.5, 0.5, 1.0, 1.0],
        ]
    } else {
        [
            [0.5 / half_width, 0.0, 0.0, 0.0],
            [0.0, -0.5 / half_height, 0.0, 0.0],
            [0.5, 0.5, 0.0, 1.0],
            [0.0, 0.0, 1.0, 0.0],
        ]
    };
    multiply(&world_to_camera(camera), &projection)
}

fn multiply(a: &RowMatrix, b: &RowMatrix) -> RowMatrix {
    let mut m = [[0.0; 4]; 4];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = (0..4).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

/// `p · M` with the division by w, as Imath's `multVecMatrix` does.
pub fn transform_point(m: &RowMatrix, p: glam::DVec3) -> glam::DVec3 {
    let row = [p.x, p.y, p.z, 1.0];
    let out: [f64; 4] = std::array::from_fn(|j| (0..4).map(|k| row[k] * m[k][j]).sum());
    glam::DVec3::new(out[0], out[1], out[2]) / out[3]
}

/// OpenEXR text is Latin-1: each character as its byte, anything beyond as '?'.
pub fn latin1(text: &str) -> Vec<u8> {
    text.chars()
        .map(|c| u8::try_from(u32::from(c)).unwrap_or(b'?'))
        .collect()
}

/// The header of a render: the camera's matrices, then the `provenance` text pairs.
pub fn options(
    camera: &Camera,
    width: usize,
    height: usize,
    half: bool,
    provenance: Vec<(String, String)>,
) -> ExrOptions {
    let single = |m: RowMatrix| HeaderValue::Matrix(m.map(|row| row.map(|v| v as f32)));
    let mut attributes = vec![
        ("worldToCamera".to_string(), single(world_to_camera(camera))),
        (
            "worldToNDC".to_string(),
            single(world_to_ndc(camera, width, height)),
        ),
    ];
    attributes.extend(
        provenance
            .into_iter()
            .map(|(name, value)| (name, HeaderValue::Text(value))),
    );
    ExrOptions { half, attributes }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn close(a: DVec3, b: DVec3, what: &str) {
        assert!((a - b).length() < 1e-12, "{what}: {a} against {b}");
    }

    #[test]
    fn a_camera_down_the_z_axis_maps_points_as_worked_by_hand() {
        // Eye at z = 5 looking at the origin: camera x is world x, camera y world y, and
        // camera z (forward) is 5 − world z. At 90° the image half-width is 1 at unit
        // distance; 200 × 100 pixels make the half-height 0.5.
        let camera = Camera::new(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 90.0).unwrap();
        let to_camera = world_to_camera(&camera);
        close(
            transform_point(&to_camera, DVec3::new(1.0, 0.5, 0.0)),
            DVec3::new(1.0, 0.5, 5.0),
            "camera",
        );
        close(
            transform_point(&to_camera, DVec3::new(0.0, 0.0, 5.0)),
            DVec3::ZERO,
            "the eye",
        );
        let to_ndc = world_to_ndc(&camera, 200, 100);
        // (1, 0.5) at depth 5: screen x = 1 / 5 / 1 = 0.2 → u = 0.6; screen y = 0.5 / 5 /
        // 0.5 = 0.2 → v = (1 − 0.2) / 2 = 0.4.
        let ndc = transform_point(&to_ndc, DVec3::new(1.0, 0.5, 0.0));
        assert!(
            (ndc.x - 0.6).abs() < 1e-12 && (ndc.y - 0.4).abs() < 1e-12,
            "{ndc}"
        );
        let centre = transform_point(&to_ndc, DVec3::new(0.0, 0.0, -3.0));
        assert!((centre.x - 0.5).abs() < 1e-12 && (centre.y - 0.5).abs() < 1e-12);
    }

    #[test]
    fn points_along_a_pixels_ray_land_on_that_pixel() {
        // The raster's own rays, an independent route: a point at any distance along the ray
        // through raster position (x + jx, y + jy) has NDC ((x + jx) / W, (y + jy) / H) and
        // camera z equal to its depth.
        let cameras = [
            Camera::new(
                DVec3::new(3.0, 2.0, -4.0),
                DVec3::new(0.2, -0.1, 0.3),
                DVec3::Y,
                40.0,
            )
            .unwrap(),
            Camera::new(
                DVec3::new(-1.0, 6.0, 2.0),
                DVec3::ZERO,
                DVec3::new(0.3, 0.2, 1.0),
                70.0,
            )
            .unwrap()
            .with_aspect(1.25)
            .unwrap(),
            Camera::new(DVec3::new(0.0, 1.0, 9.0), DVec3::ZERO, DVec3::Y, 30.0)
                .unwrap()
                .orthographic(3.0)
                .unwrap(),
        ];
        let (width, height) = (64, 36);
        for camera in &cameras {
            let raster = camera.raster(width, height);
            let to_camera = world_to_camera(camera);
            let to_ndc = world_to_ndc(camera, width, height);
            for (x, y, jx, jy, t) in [
                (0, 0, 0.0, 0.0, 2.0),
                (63, 35, 0.99, 0.5, 7.5),
                (20, 11, 0.25, 0.75, 0.6),
                (32, 18, 0.0, 0.0, 12.0),
            ] {
                let p = raster.ray(x, y, jx, jy).at(t);
                let ndc = transform_point(&to_ndc, p);
                let expected = (
                    (x as f64 + jx) / width as f64,
                    (y as f64 + jy) / height as f64,
                );
                assert!(
                    (ndc.x - expected.0).abs() < 1e-12 && (ndc.y - expected.1).abs() < 1e-12,
                    "{ndc} against {expected:?}"
                );
                let in_camera = transform_point(&to_camera, p);
                assert!((in_camera.z - camera.depth(p)).abs() < 1e-12);
                // Right-handed world axes become x right, y up: the camera frame's
                // handedness flips, as OpenEXR's left-handed camera space wants.
                let (right, up, _) = camera.axes();
                assert!((in_camera.x - (p - camera.eye).dot(right)).abs() < 1e-12);
                assert!((in_camera.y - (p - camera.eye).dot(up)).abs() < 1e-12);
            }
        }
    }
}
