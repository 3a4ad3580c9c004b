//! Writes a `DeepImage` as a single-part deep scanline OpenEXR file (OpenEXR's "File Layout",
//! deep data), the form Nuke's DeepRead and every deep compositor read.
//!
//! The file: the magic number; the version field 2 with the non-image (deep) flag; a header
//! with the required attributes (`channels` A, B, G, R, Z, ZBack, all 32-bit float and sorted
//! as OpenEXR requires; `compression`; the windows; `lineOrder`; the screen window;
//! `name`; `type` = "deepscanline"; `version` = 1; `chunkCount`; `maxSamplesPerPixel`)
//! plus the `chromaticities` and camera matrices a flat render carries (`exr_header`); the
//! offset table; then one chunk per scanline: its `y`, the packed sizes of its sample-count
//! table and sample data and the unpacked size of the data, the cumulative sample counts of
//! its pixels, and its samples channel by channel.
//!
//! The one key decision: scanline, not tiled, and one line per chunk with ZIPS compression
//! (zlib over OpenEXR's byte split and delta predictor), since Nuke reads deep scanline files
//! only and ZIPS is the best deep scanline compression every reader has. The `exr` crate
//! writes no deep data, so the layout is written here; a block that zlib would grow is
//! stored raw, which readers tell by its packed size equalling its unpacked size.

use super::deep::DeepImage;
use super::image::{ExrOptions, HeaderValue};
use crate::base::failure::{Failure, Outcome};
use std::io::Write;
use std::path::Path;

/// OpenEXR's magic number, little-endian.
const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
/// File format version 2 with the "non-image" (deep data) flag, bit 11.
const VERSION_DEEP: u32 = 2 | 0x800;
/// Flag for attribute names longer than 31 bytes.
const LONG_NAMES: u32 = 0x400;
/// `ZIPS_COMPRESSION`: zlib, one scanline per chunk.
const ZIPS: u8 = 2;
/// OpenEXR's FLOAT pixel type.
const FLOAT: i32 = 2;
/// The channels in the order OpenEXR requires (sorted by name).
pub const CHANNELS: [&str; 6] = ["A", "B", "G", "R", "Z", "ZBack"];

/// Writes `image` to `path` (atomically) as deep scanline OpenEXR, with `options`' header
/// attributes. Refused under a farm band: `felt merge` joins flat bands only.
pub fn write_deep(path: &Path, image: &DeepImage, options: &ExrOptions) -> Outcome<()> {
    if image.width == 0 || image.height == 0 || image.width > i32::MAX as usize / 2 {
        return Err(Failure::new(format!(
            "cannot write a deep image of {} x {} pixels",
            image.width, image.height
        )));
    }
    if let Some(band) = crate::engine::band::active() {
        return Err(Failure::new(format!(
            "deep images cannot be written in bands (this is band {} of {})",
            band.index, band.count
        ))
        .with_help("render the deep frame whole: leave out --tile for it"));
    }
    let chunks = encode_lines(image);
    let bytes: usize = chunks.iter().map(Vec::len).sum();
    let _file = crate::engine::budget::reserve(
        bytes as f64,
        &format!("writing a {} x {} deep image", image.width, image.height),
    )?;
    crate::io::output::write_atomically(path, |file| {
        let mut out = std::io::BufWriter::new(file);
        let header = header(image, options);
        out.write_all(&header).map_err(|e| e.to_string())?;
        // Offsets are absolute: past the header and the table itself.
        let mut at = (header.len() + 8 * chunks.len()) as u64;
        for chunk in &chunks {
            out.write_all(&at.to_le_bytes())
                .map_err(|e| e.to_string())?;
            at += chunk.len() as u64;
        }
        for chunk in &chunks {
            out.write_all(chunk).map_err(|e| e.to_string())?;
        }
        out.flush().map_err(|e| e.to_string())
    })
    .map_err(|e| Failure::new(format!("cannot write image '{}': {e}", path.display())))
}

/// The magic number, version field and header, through its closing null byte.
fn header(image: &DeepImage, options: &ExrOptions) -> Vec<u8> {
    let mut h = Header::default();
    let mut channels = Vec::new();
    for name in CHANNELS {
        channels.extend_from_slice(name.as_bytes());
        channels.push(0);
        channels.extend_from_slice(&FLOAT.to_le_bytes());
        // pLinear, three reserved bytes, then x and y sampling.
        channels.extend_from_slice(&[0, 0, 0, 0]);
        channels.extend_from_slice(&1i32.to_le_bytes());
        channels.extend_from_slice(&1i32.to_le_bytes());
    }
    channels.push(0);
    h.attribute("channels", "chlist", &channels);
    h.attribute("compression", "compression", &[ZIPS]);
    let window = ints(&[0, 0, image.width as i32 - 1, image.height as i32 - 1]);
    h.attribute("dataWindow", "box2i", &window);
    h.attribute("displayWindow", "box2i", &window);
    // INCREASING_Y: the top line first.
    h.attribute("lineOrder", "lineOrder", &[0]);
    h.attribute("pixelAspectRatio", "float", &1f32.to_le_bytes());
    h.attribute("screenWindowCenter", "v2f", &floats(&[0.0, 0.0]));
    h.attribute("screenWindowWidth", "float", &1f32.to_le_bytes());
    h.attribute("name", "string", b"deep");
    h.attribute("type", "string", b"deepscanline");
    h.attribute("version", "int", &1i32.to_le_bytes());
    h.attribute("chunkCount", "int", &(image.height as i32).to_le_bytes());
    let most = image.max_samples().min(i32::MAX as u32) as i32;
    h.attribute("maxSamplesPerPixel", "int", &most.to_le_bytes());
    let [red, green, blue] = super::working_space::PRIMARIES;
    let white = super::working_space::WHITE;
    let xy: Vec<f32> = [red, green, blue, white]
        .iter()
        .flat_map(|&(x, y)| [x as f32, y as f32])
        .collect();
    h.attribute("chromaticities", "chromaticities", &floats(&xy));
    for (name, value) in &options.attributes {
        let name = super::exr_header::latin1(name);
        match value {
            HeaderValue::Text(text) => {
                h.attribute_bytes(&name, "string", &super::exr_header::latin1(text))
            }
            HeaderValue::Matrix(rows) => {
                let flat: Vec<f32> = rows.iter().flatten().copied().collect();
                h.attribute_bytes(&name, "m44f", &floats(&flat));
            }
        }
    }
    let mut out = Vec::with_capacity(h.bytes.len() + 9);
    out.extend_from_slice(&MAGIC);
    let version = VERSION_DEEP | if h.long_names { LONG_NAMES } else { 0 };
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&h.bytes);
    out.push(0);
    out
}

/// Header attributes as bytes, and whether any name needs the long-names flag.
#[derive(Default)]
struct Header {
    bytes: Vec<u8>,
    long_names: bool,
}

impl Header {
    fn attribute(&mut self, name: &str, kind: &str, value: &[u8]) {
        self.attribute_bytes(name.as_bytes(), kind, value);
    }

    fn attribute_bytes(&mut self, name: &[u8], kind: &str, value: &[u8]) {
        // A name with a null byte in it would end early: its attribute is left out.
        if name.is_empty() || name.contains(&0) {
            return;
        }
        self.long_names |= name.len() > 31;
        self.bytes.extend_from_slice(name);
        self.bytes.push(0);
        self.bytes.extend_from_slice(kind.as_bytes());
        self.bytes.push(0);
        self.bytes
            .extend_from_slice(&(value.len() as i32).to_le_bytes());
        self.bytes.extend_from_slice(value);
    }
}

fn ints(values: &[i32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

fn floats(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// Every scanline's chunk, top line first.
fn encode_lines(image: &DeepImage) -> Vec<Vec<u8>> {
    let mut first = 0usize;
    let mut chunks = Vec::with_capacity(image.height);
    for y in 0..image.height {
        let counts = &image.counts[y * image.width..(y + 1) * image.width];
        let mut table = Vec::with_capacity(4 * image.width);
        let mut running = 0u32;
        for &count in counts {
            running += count;
            table.extend_from_slice(&running.to_le_bytes());
        }
        let samples = &image.samples[first..first + running as usize];
        first += running as usize;
        let mut data = Vec::with_capacity(4 * CHANNELS.len() * samples.len());
        // Channel by channel, each over the line's pixels and their samples in order.
        let channel: [fn(&super::deep::DeepSample) -> f32; 6] = [
            |s| s.alpha,
            |s| s.color[2],
            |s| s.color[1],
            |s| s.color[0],
            |s| s.front,
            |s| s.back,
        ];
        for value in channel {
            for s in samples {
                data.extend_from_slice(&value(s).to_le_bytes());
            }
        }
        let packed_table = zips(&table);
        let packed_data = zips(&data);
        let mut chunk = Vec::with_capacity(28 + packed_table.len() + packed_data.len());
        chunk.extend_from_slice(&(y as i32).to_le_bytes());
        chunk.extend_from_slice(&(packed_table.len() as u64).to_le_bytes());
        chunk.extend_from_slice(&(packed_data.len() as u64).to_le_bytes());
        chunk.extend_from_slice(&(data.len() as u64).to_le_bytes());
        chunk.extend_from_slice(&packed_table);
        chunk.extend_from_slice(&packed_data);
        chunks.push(chunk);
    }
    chunks
}

/// OpenEXR's ZIP compressor on one block: bytes split into even and odd halves, each byte
/// replaced by its difference from the one before plus 128, then zlib. A block zlib does not
/// shrink is kept raw.
pub fn zips(raw: &[u8]) -> Vec<u8> {
    if raw.is_empty() {
        return Vec::new();
    }
    let mut split: Vec<u8> = Vec::with_capacity(raw.len());
    split.extend(raw.iter().step_by(2).copied());
    split.extend(raw.iter().skip(1).step_by(2).copied());
    let mut previous = split[0];
    for byte in &mut split[1..] {
        let current = *byte;
        *byte = current.wrapping_sub(previous).wrapping_add(128);
        previous = current;
    }
    let mut encoder = flate2::write::ZlibEncoder::new(
        Vec::with_capacity(raw.len() / 2),
        flate2::Compression::default(),
    );
    // Writing to a vector cannot fail.
    let packed = encoder
        .write_all(&split)
        .and_then(|()| encoder.finish())
        .unwrap_or_default();
    if packed.is_empty() || packed.len() >= raw.len() {
        raw.to_vec()
    } else {
        packed
    }
}
