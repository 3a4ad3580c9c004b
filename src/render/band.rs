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

use crate::failure::{Failure, Outcome};
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Rows per band edge: the march's largest tile side.
pub const ROW_GROUP: usize = 16;

/// Header attribute: this band's index, from 0.
pub const BAND_ATTRIBUTE: &str = "feltBand";
/// Header attribute: how many bands the image was split into.
pub const BANDS_ATTRIBUTE: &str = "feltBands";

/// Band `index` of `count`, counted from the top.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Band {
    pub index: usize,
    pub count: usize,
}

/// Most bands an image may be split into.
pub const MAX_BANDS: usize = 4096;

impl std::str::FromStr for Band {
    type Err = String;

    /// `I/N`, with `0 <= I < N`.
    fn from_str(text: &str) -> Result<Band, String> {
        let (index, count) = text
            .split_once('/')
            .ok_or_else(|| format!("expected I/N (band I of N, from 0), found `{text}`"))?;
        let number = |s: &str| s.trim().parse::<usize>().ok();
        let (Some(index), Some(count)) = (number(index), number(count)) else {
            return Err(format!("expected I/N with whole numbers, found `{text}`"));
        };
        if count == 0 || count > MAX_BANDS {
            return Err(format!(
                "the band count must be 1 to {MAX_BANDS}, found {count}"
            ));
        }
        if index >= count {
            return Err(format!(
                "band {index} of {count} does not exist: bands are numbered 0 to {}",
                count - 1
            ));
        }
        Ok(Band { index, count })
    }
}

/// Makes every render of the current engine (`crate::engine`) draw only `band`.
pub fn set(band: Band) {
    crate::engine::with(|e| {
        let _ = e.band.set(band);
    });
}

/// The band the current engine renders, if it renders one.
pub fn active() -> Option<Band> {
    crate::engine::with(|e| e.band.get().copied())
}

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

    /// Where this band of the image `target` is written.
    pub fn path(self, target: &Path) -> PathBuf {
        let name = target.to_string_lossy();
        let stem = match name.len().checked_sub(4) {
            Some(cut) if name.is_char_boundary(cut) && name[cut..].eq_ignore_ascii_case(".exr") => {
                &name[..cut]
            }
            _ => &name[..],
        };
        PathBuf::from(format!("{stem}.tile-{}-of-{}.exr", self.index, self.count))
    }
}

/// The rows of the active band, or every row.
pub fn rows(height: usize) -> Outcome<Range<usize>> {
    match active() {
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

    #[test]
    fn band_names_are_predictable() {
        let band = Band { index: 2, count: 4 };
        assert_eq!(
            band.path(Path::new("out/a.0012.exr")),
            Path::new("out/a.0012.tile-2-of-4.exr")
        );
        assert_eq!(
            band.path(Path::new("a.####.EXR")),
            Path::new("a.####.tile-2-of-4.exr")
        );
        assert_eq!(
            band.path(Path::new("a.png")),
            Path::new("a.png.tile-2-of-4.exr")
        );
    }

    #[test]
    fn band_arguments_are_checked() {
        assert_eq!("1/4".parse::<Band>(), Ok(Band { index: 1, count: 4 }));
        for (text, says) in [
            ("4/4", "numbered 0 to 3"),
            ("0/0", "1 to"),
            ("x/2", "whole numbers"),
            ("3", "expected I/N"),
        ] {
            let error = text.parse::<Band>().unwrap_err();
            assert!(error.contains(says), "{text}: {error}");
        }
    }
}
