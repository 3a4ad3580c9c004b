//! felt's colour working space, stated once: linear Rec.709 (ITU-R BT.709 primaries) with the
//! D65 white, as scene-linear values. Blackbody colours are taken into it, views take it to a
//! display, and every EXR declares it in OpenEXR's standard `chromaticities` attribute, so a
//! compositor (Nuke, OCIO) that reads the attribute interprets the pixels as felt meant them.

use glam::{DMat3, DVec3};

/// CIE 1931 xy chromaticities of felt's red, green and blue primaries (ITU-R BT.709).
pub const PRIMARIES: [(f64, f64); 3] = [(0.64, 0.33), (0.30, 0.60), (0.15, 0.06)];

/// CIE 1931 xy chromaticity of felt's white (D65, as BT.709 and IEC 61966-2-1 state it).
pub const WHITE: (f64, f64) = (0.3127, 0.3290);

/// Rec.2020's primaries (ITU-R BT.2020), the space AgX works in.
pub const REC2020_PRIMARIES: [(f64, f64); 3] = [(0.708, 0.292), (0.170, 0.797), (0.131, 0.046)];

/// The RGB → XYZ matrix of primaries `p` with the D65 white, so RGB (1, 1, 1) is the white at
/// Y = 1 (the derivation of SMPTE RP 177).
pub fn rgb_to_xyz(p: [(f64, f64); 3]) -> DMat3 {
    let xyz = |(x, y): (f64, f64)| DVec3::new(x / y, 1.0, (1.0 - x - y) / y);
    let primaries = DMat3::from_cols(xyz(p[0]), xyz(p[1]), xyz(p[2]));
    let scale = primaries.inverse() * xyz(WHITE);
    DMat3::from_cols(
        primaries.x_axis * scale.x,
        primaries.y_axis * scale.y,
        primaries.z_axis * scale.z,
    )
}

/// XYZ → felt's linear Rec.709.
pub fn xyz_to_working() -> DMat3 {
    rgb_to_xyz(PRIMARIES).inverse()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// IEC 61966-2-1 prints the sRGB (Rec.709, D65) RGB → XYZ matrix to four digits.
    #[test]
    fn the_matrix_is_the_one_srgb_publishes() {
        let published = [
            [0.4124, 0.3576, 0.1805],
            [0.2126, 0.7152, 0.0722],
            [0.0193, 0.1192, 0.9505],
        ];
        let m = rgb_to_xyz(PRIMARIES);
        for (row, values) in published.iter().enumerate() {
            for (column, &v) in values.iter().enumerate() {
                assert!((m.col(column)[row] - v).abs() < 6e-5, "{row} {column}: {m}");
            }
        }
    }
}
