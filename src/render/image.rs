//! Rendered images and the files they are written to.
//!
//! An `Image` holds premultiplied RGBA in linear light, one `[f32; 4]` per pixel (row-major,
//! top row first), plus named AOV channels. `.exr` files get every channel as 32-bit float
//! (or 16-bit half on request, depth excepted), scanline blocks with ZIP compression (every compositor reads them quickly; the `exr` crate's
//! default, tiled RLE, is avoided). `.png` files are 8-bit previews: the premultiplied colour is
//! clipped to [0, 1]; the alpha is raised where needed to at least the largest colour channel
//! (emission in a thin medium can be brighter than it is opaque); the colour is divided by that
//! alpha (PNG stores straight colour) and encoded with the sRGB curve. Composited over black
//! such a PNG shows exactly the clipped premultiplied colour; another view (`render::view`)
//! maps the colour first. Files are written
//! through `output::write_atomically`, so a crash or a full disk never leaves a half-written
//! image under the requested name.

use crate::base::failure::{Failure, Outcome};
use crate::render::view::View;
use std::collections::HashSet;
use std::io::{BufWriter, Write};
use std::path::Path;

/// A rendered image.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    /// Premultiplied linear RGBA, `y * width + x` with `y = 0` the top row.
    pub rgba: Vec<[f32; 4]>,
    /// Extra channels by full name (`depth.Z`, `emission.R`, ...), each `width * height` values.
    pub aovs: Vec<(String, Vec<f32>)>,
}

impl Image {
    /// A transparent black image without AOVs.
    pub fn new(width: usize, height: usize) -> Image {
        Image {
            width,
            height,
            rgba: vec![[0.0; 4]; width * height],
            aovs: Vec::new(),
        }
    }

    /// The AOV channel called `name`, if there is one.
    pub fn aov(&self, name: &str) -> Option<&[f32]> {
        self.aovs
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    fn check(&self) -> Outcome<()> {
        let pixels = self.width * self.height;
        if self.width == 0 || self.height == 0 {
            return Err(Failure::new(format!(
                "cannot write an image of {} x {} pixels",
                self.width, self.height
            )));
        }
        if self.rgba.len() != pixels {
            return Err(Failure::new(format!(
                "image of {} x {} pixels has {} colour values",
                self.width,
                self.height,
                self.rgba.len()
            )));
        }
        let mut names: HashSet<&str> = ["R", "G", "B", "A"].into_iter().collect();
        for (name, values) in &self.aovs {
            if name.is_empty() || !names.insert(name) {
                return Err(Failure::new(format!(
                    "image channel name '{name}' is empty or used twice"
                )));
            }
            if values.len() != pixels {
                return Err(Failure::new(format!(
                    "image channel '{name}' has {} values for {pixels} pixels",
                    values.len()
                )));
            }
        }
        Ok(())
    }
}

/// How an OpenEXR file is written: its sample precision and the header attributes beyond
/// the ones the format requires (see `exr_header`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExrOptions {
    /// Colour and AOV channels as 16-bit halves, as most compositing is done; depth stays
    /// 32-bit, since a half's 11 bits cannot hold a depth far from the camera.
    pub half: bool,
    pub attributes: Vec<(String, HeaderValue)>,
}

/// A header attribute value.
#[derive(Clone, Debug, PartialEq)]
pub enum HeaderValue {
    Text(String),
    /// An `m44f`, row by row in OpenEXR's (Imath's) order: points are row vectors, the
    /// translation is the last row.
    Matrix([[f32; 4]; 4]),
}

/// The largest finite half float.
const HALF_MAX: f32 = 65504.0;

/// Writes `image` to `path`: OpenEXR for `.exr`, an 8-bit preview for `.png`.
pub fn write_image(path: &Path, image: &Image) -> Outcome<()> {
    write_image_with(path, image, &ExrOptions::default()).map(|_| ())
}

/// `write_image` with OpenEXR options (a PNG ignores them). Returns how many samples were
/// above the largest half float and written as it.
pub fn write_image_with(path: &Path, image: &Image, options: &ExrOptions) -> Outcome<u64> {
    write_image_viewed(path, image, options, View::Standard)
}

/// `write_image_with`, a PNG shown through `view` (an EXR stays scene-linear).
pub fn write_image_viewed(
    path: &Path,
    image: &Image,
    options: &ExrOptions,
    view: View,
) -> Outcome<u64> {
    // The writers lay the channels out again before encoding them.
    let channels = 4 + image.aovs.len();
    let _copy = crate::engine::budget::reserve(
        (image.width * image.height * channels * 4) as f64,
        &format!("writing a {} x {} image", image.width, image.height),
    )?;
    image.check()?;
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let mut clamped = 0;
    if let Some(band) = crate::engine::band::active()
        && matches!(extension.as_deref(), Some("exr" | "png"))
    {
        let (cropped, placement) = super::band::crop(image, band)?;
        atomically(&band.path(path), |file| {
            write_exr(file, &cropped, options, Some(&placement), &mut clamped)
        })?;
        return Ok(clamped);
    }
    match extension.as_deref() {
        Some("exr") => atomically(path, |file| {
            write_exr(file, image, options, None, &mut clamped)
        })?,
        Some("png") => atomically(path, |file| write_png(file, image, view))?,
        _ => Err(Failure::new(format!(
            "cannot tell the image format of '{}'",
            path.display()
        ))
        .with_help("end the file name in .exr (full float channels) or .png (8-bit preview)"))?,
    }
    Ok(clamped)
}

/// Writes through `output::write_atomically`, with the image's own message on failure.
fn atomically(
    path: &Path,
    write: impl FnOnce(&mut std::fs::File) -> Result<(), String>,
) -> Outcome<()> {
    crate::io::output::write_atomically(path, write)
        .map_err(|e| Failure::new(format!("cannot write image '{}': {e}", path.display())))
}

/// Writes `image` as OpenEXR; a band (`placement`) is written where it sits in its image.
fn write_exr(
    file: &mut std::fs::File,
    image: &Image,
    options: &ExrOptions,
    placement: Option<&super::band::Placement>,
    clamped: &mut u64,
) -> Result<(), String> {
    use exr::prelude::{
        AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Image as ExrImage, Layer,
        LayerAttributes, Text, WritableImage, f16,
    };
    let mut samples = |name: &str, values: Vec<f32>| {
        if options.half && name != "depth.Z" {
            let halves = values
                .into_iter()
                .map(|v| {
                    if v > HALF_MAX {
                        *clamped += 1;
                    }
                    f16::from_f32(v.min(HALF_MAX))
                })
                .collect();
            FlatSamples::F16(halves)
        } else {
            FlatSamples::F32(values)
        }
    };
    let component = |c: usize| image.rgba.iter().map(|p| p[c]).collect::<Vec<f32>>();
    let mut channels = Vec::new();
    for (c, name) in ["R", "G", "B", "A"].into_iter().enumerate() {
        channels.push(AnyChannel::new(name, samples(name, component(c))));
    }
    for (name, values) in &image.aovs {
        channels.push(AnyChannel::new(
            name.as_str(),
            samples(name, values.clone()),
        ));
    }
    let mut attributes = LayerAttributes::default();
    for (name, value) in &options.attributes {
        let latin1 = |text: &str| Text::from_slice_unchecked(&super::exr_header::latin1(text));
        let value = match value {
            HeaderValue::Text(text) => AttributeValue::Text(latin1(text)),
            HeaderValue::Matrix(rows) => {
                let mut flat = [0f32; 16];
                for (i, v) in rows.iter().flatten().enumerate() {
                    flat[i] = *v;
                }
                // The standard attributes have fields of their own in the writer.
                match name.as_str() {
                    "worldToCamera" => attributes.world_to_camera = Some(flat),
                    "worldToNDC" => attributes.world_to_normalized_device = Some(flat),
                    _ => {
                        attributes
                            .other
                            .insert(latin1(name), AttributeValue::Matrix4x4(flat));
                    }
                }
                continue;
            }
        };
        attributes.other.insert(latin1(name), value);
    }
    let layer = Layer::new(
        (image.width, image.height),
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels.into()),
    );
    let mut encoded = ExrImage::from_layer(layer);
    // The pixels' colour space, in the standard attribute compositors read.
    let xy = |(x, y): (f64, f64)| exr::math::Vec2(x as f32, y as f32);
    let [red, green, blue] = super::working_space::PRIMARIES;
    encoded.attributes.chromaticities = Some(exr::meta::attribute::Chromaticities {
        red: xy(red),
        green: xy(green),
        blue: xy(blue),
        white: xy(super::working_space::WHITE),
    });
    if let Some(placement) = placement {
        placement.apply(&mut encoded);
    }
    super::exr_order::write_sorted(file, |buffer| {
        encoded
            .write()
            .to_buffered(buffer)
            .map_err(|e| e.to_string())
    })
}

/// The sRGB transfer curve (OETF) from linear [0, 1].
fn srgb(linear: f32) -> f32 {
    if linear <= 0.003_130_8 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// The 8-bit straight-alpha sRGB pixel for a premultiplied linear one (see the module notes).
pub fn preview_pixel(rgba: [f32; 4]) -> [u8; 4] {
    let clip = |v: f32| {
        if v.is_finite() {
            v.clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    let color = [clip(rgba[0]), clip(rgba[1]), clip(rgba[2])];
    let alpha = clip(rgba[3]).max(color[0]).max(color[1]).max(color[2]);
    if alpha == 0.0 {
        return [0, 0, 0, 0];
    }
    let byte = |v: f32| (v * 255.0).round().clamp(0.0, 255.0) as u8;
    [
        byte(srgb((color[0] / alpha).min(1.0))),
        byte(srgb((color[1] / alpha).min(1.0))),
        byte(srgb((color[2] / alpha).min(1.0))),
        byte(alpha),
    ]
}

fn write_png(file: &mut std::fs::File, image: &Image, view: View) -> Result<(), String> {
    let (width, height) = (
        u32::try_from(image.width).map_err(|e| e.to_string())?,
        u32::try_from(image.height).map_err(|e| e.to_string())?,
    );
    let mut buffer = BufWriter::new(file);
    let mut encoder = png::Encoder::new(&mut buffer, width, height);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
    let bytes: Vec<u8> = image
        .rgba
        .iter()
        .flat_map(|p| preview_pixel(view.apply(*p)))
        .collect();
    writer.write_image_data(&bytes).map_err(|e| e.to_string())?;
    writer.finish().map_err(|e| e.to_string())?;
    buffer.flush().map_err(|e| e.to_string())
}

#[cfg(test)]
#[path = "image_tests.rs"]
mod tests;
