//! Bands: one horizontal strip of every image a run renders, for `felt run --tile I/N`, so N
//! farm tasks share a frame and `felt merge` puts the strips back together.
//!
//! The one key decision: band edges fall on multiples of 16 rows, the largest tile side the
//! march uses (every smaller side is a power of two dividing it). A band then marches exactly
//! the tiles a whole render marches for those rows, point blocks and all, and since every
//! pixel's samples depend only on the seed and the pixel, the merged image equals a
//! single-machine render bit for bit. Band `I` of `N` covers the row groups
//! `floor(I·G/N) .. floor((I+1)·G/N)` of the `G = ceil(height/16)` groups.
//!
//! A band of `NAME.exr` is written to `NAME.tile-I-of-N.exr`, a band of `NAME.png` to
//! `NAME.png.tile-I-of-N.exr` (bands always keep the full float channels). Its EXR header
//! carries what `felt merge` checks: the display window is the whole image, the data window
//! the band's rows, and `feltBand` / `feltBands` (ints) say which band of how many it is.

use crate::base::failure::{Failure, Outcome};
use crate::engine::band::Band;
use std::ops::Range;

/// Rows per band edge: the march's largest tile side.
pub const ROW_GROUP: usize = 16;

/// Header attribute: this band's index, from 0.
pub const BAND_ATTRIBUTE: &str = "feltBand";
/// Header attribute: how many bands the image was split into.
pub const BANDS_ATTRIBUTE: &str = "feltBands";

impl Band {
    /// The pixel rows of an image `height` rows tall that this band covers.
    pub fn rows(self, height: usize) -> Outcome<Range<usize>> {
        let groups = height.div_ceil(ROW_GROUP);
        if self.count > groups {
            return Err(Failure::new(format!(
                "an image {height} pixels tall splits into at most {groups} bands of \
                 {ROW_GROUP} rows, not {}",
                self.count
            ))
            .with_help("use fewer tiles, or render a taller image"));
        }
        let edge = |i: usize| (i * groups / self.count * ROW_GROUP).min(height);
        Ok(edge(self.index)..edge(self.index + 1))
    }
}

/// The rows of the active band, or every row.
pub fn rows(height: usize) -> Outcome<Range<usize>> {
    match crate::engine::band::active() {
        Some(band) => band.rows(height),
        None => Ok(0..height),
    }
}

/// Where a band sits in its image, for the band file's header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Placement {
    pub band: Band,
    pub first_row: usize,
    pub width: usize,
    pub height: usize,
}

impl Placement {
    /// Sets the data window to the band, the display window to the whole image, and the
    /// band attributes.
    pub fn apply<C>(&self, image: &mut exr::image::Image<exr::image::Layer<C>>) {
        use exr::meta::attribute::{AttributeValue, IntegerBounds, Text};
        image.layer_data.attributes.layer_position = exr::math::Vec2(0, self.first_row as i32);
        image.attributes.display_window = IntegerBounds::new((0, 0), (self.width, self.height));
        let other = &mut image.layer_data.attributes.other;
        other.insert(
            Text::from(BAND_ATTRIBUTE),
            AttributeValue::I32(self.band.index as i32),
        );
        other.insert(
            Text::from(BANDS_ATTRIBUTE),
            AttributeValue::I32(self.band.count as i32),
        );
    }
}

/// The band of `image` that `band` covers, as its own image, and where it sits.
pub fn crop(image: &super::Image, band: Band) -> Outcome<(super::Image, Placement)> {
    let rows = band.rows(image.height)?;
    let pixels = rows.start * image.width..rows.end * image.width;
    let cropped = super::Image {
        width: image.width,
        height: rows.len(),
        rgba: image.rgba[pixels.clone()].to_vec(),
        aovs: image
            .aovs
            .iter()
            .map(|(name, values)| (name.clone(), values[pixels.clone()].to_vec()))
            .collect(),
    };
    let placement = Placement {
        band,
        first_row: rows.start,
        width: image.width,
        height: image.height,
    };
    Ok((cropped, placement))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_tile_the_image_on_row_group_edges() {
        for height in [16usize, 17, 50, 100, 1080] {
            for count in 1..=height.div_ceil(ROW_GROUP).min(9) {
                let mut next = 0;
                for index in 0..count {
                    let rows = Band { index, count }.rows(height).unwrap();
                    assert_eq!(rows.start, next, "height {height}, band {index}/{count}");
                    assert!(!rows.is_empty() && rows.start.is_multiple_of(ROW_GROUP));
                    next = rows.end;
                }
                assert_eq!(next, height);
            }
        }
    }

    #[test]
    fn too_many_bands_for_the_image_is_an_error() {
        let error = Band { index: 0, count: 3 }.rows(24).unwrap_err();
        assert!(
            error.message.contains("at most 2 bands"),
            "{}",
            error.message
        );
    }
}
