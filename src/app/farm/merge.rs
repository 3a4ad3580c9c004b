//! `felt merge`: the bands that `felt run --tile I/N` wrote, put back together into the image
//! a single machine would have rendered.
//!
//! The one key decision: merging copies samples, it never converts them. Each channel's rows
//! are concatenated in the sample type the bands hold, the header of band 0 is kept (less the
//! band attributes, with the data window grown to the whole image), so the merged file equals
//! the single-machine one pixel for pixel and attribute for attribute. Every band is checked
//! first: all of them present, each once, all of one image size, split the same way, holding
//! the rows its index says and the same channels.

use crate::base::failure::{Failure, Outcome};
use crate::engine::band::Band;
use crate::render::band::{BAND_ATTRIBUTE, BANDS_ATTRIBUTE};
use exr::prelude::traits::*;
use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, FlatSamples, Image as ExrImage, Layer, Text,
};
use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::{Path, PathBuf};

/// Largest band file `felt merge` reads.
const MAX_BAND_BYTES: u64 = 16 << 30;

type Channels = AnyChannels<FlatSamples>;

/// One band file, read and checked against its name.
struct BandFile {
    path: PathBuf,
    /// The band its header says it is, and the one its name says.
    band: Band,
    named: Band,
    image: ExrImage<Layer<Channels>>,
}

/// Assembles the bands of `target` (its frame pattern already filled) and writes it. With
/// `count` the bands must be that many; without, the split is the one found beside `target`.
pub fn merge(target: &Path, count: Option<usize>) -> Outcome<()> {
    let count = match count {
        Some(count) => count,
        None => split_found(target)?,
    };
    let mut bands = Vec::with_capacity(count);
    for index in 0..count {
        let band = Band { index, count };
        let path = crate::engine::output::target(&band.path(target));
        if !path.exists() {
            return Err(Failure::new(format!(
                "band {index} of {count} of '{}' is missing: no file '{}'",
                target.display(),
                path.display()
            ))
            .with_help("render it with felt run --tile I/N, or check that its task finished"));
        }
        bands.push(read_band(&path, band)?);
    }
    check_bands(&bands)?;
    write_merged(&crate::engine::output::target(target), bands)
}

/// The band count of the bands found beside `target`.
fn split_found(target: &Path) -> Outcome<usize> {
    let probe = Band { index: 0, count: 1 }.path(target);
    let probe = crate::engine::output::target(&probe);
    let name = probe
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let prefix = &name[..name.rfind(".tile-0-of-1.exr").unwrap_or(0)];
    let folder = match probe.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut counts = std::collections::BTreeSet::new();
    if let Ok(entries) = std::fs::read_dir(&folder) {
        for entry in entries.flatten() {
            let file = entry.file_name().to_string_lossy().into_owned();
            if let Some(rest) = file
                .strip_prefix(prefix)
                .and_then(|r| r.strip_prefix(".tile-"))
                .and_then(|r| r.strip_suffix(".exr"))
                && let Some((_, count)) = rest.split_once("-of-")
                && let Ok(count) = count.parse::<usize>()
            {
                counts.insert(count);
            }
        }
    }
    let counts: Vec<usize> = counts.into_iter().collect();
    match counts.as_slice() {
        [count] => Ok(*count),
        [] => Err(Failure::new(format!(
            "no bands of '{}' found (band files are named {prefix}.tile-I-of-N.exr in '{}')",
            target.display(),
            folder.display()
        ))),
        several => Err(Failure::new(format!(
            "bands of '{}' from different splits are present: into {}",
            target.display(),
            several
                .iter()
                .map(|c| c.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ))
        .with_help("pass --tiles N to say which split to merge")),
    }
}

fn read_band(path: &Path, named: Band) -> Outcome<BandFile> {
    let cannot =
        |why: String| Failure::new(format!("cannot read band '{}': {why}", path.display()));
    let bytes =
        crate::io::input::read_whole(path, MAX_BAND_BYTES, "a band file").map_err(cannot)?;
    let mut image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| cannot(e.to_string()))?;
    if image.layer_data.len() != 1 {
        return Err(cannot(format!(
            "it has {} layers; a band has one",
            image.layer_data.len()
        )));
    }
    let layer = image.layer_data.remove(0);
    let header = |name: &str| match layer.attributes.other.get(&Text::from(name)) {
        Some(AttributeValue::I32(v)) => usize::try_from(v.to_owned()).ok(),
        _ => None,
    };
    let (Some(index), Some(count)) = (header(BAND_ATTRIBUTE), header(BANDS_ATTRIBUTE)) else {
        return Err(cannot(format!(
            "its header has no {BAND_ATTRIBUTE}/{BANDS_ATTRIBUTE}: it is not a band written by \
             felt run --tile"
        )));
    };
    Ok(BandFile {
        path: path.to_path_buf(),
        band: Band { index, count },
        named,
        image: ExrImage::new(image.attributes, layer),
    })
}

fn check_bands(bands: &[BandFile]) -> Outcome<()> {
    let mut seen: BTreeMap<usize, &Path> = BTreeMap::new();
    let first = &bands[0];
    let size = first.image.attributes.display_window.size;
    for file in bands {
        let Band { index, count } = file.band;
        let here = file.path.display();
        if let Some(other) = seen.insert(index, &file.path) {
            return Err(Failure::new(format!(
                "band {index} appears twice: '{}' and '{here}' both hold it",
                other.display()
            ))
            .with_help("a band file was copied or renamed; render the missing band again"));
        }
        if file.band != file.named {
            return Err(Failure::new(format!(
                "'{here}' holds band {index} of {count}, but its name says band {} of {}",
                file.named.index, file.named.count
            )));
        }
        let display = file.image.attributes.display_window.size;
        if display != size {
            return Err(Failure::new(format!(
                "the bands are of different images: '{}' is {} x {}, '{here}' is {} x {}",
                first.path.display(),
                size.0,
                size.1,
                display.0,
                display.1
            )));
        }
        let rows = file.band.rows(size.1)?;
        let layer = &file.image.layer_data;
        let (top, layer_size) = (layer.attributes.layer_position, layer.size);
        if top.0 != 0
            || top.1 != rows.start as i32
            || layer_size != exr::math::Vec2(size.0, rows.len())
        {
            return Err(Failure::new(format!(
                "'{here}' holds {} x {} pixels at ({}, {}); band {index} of {count} of a {} x {} \
                 image is rows {} to {} across the whole width",
                layer_size.0, layer_size.1, top.0, top.1, size.0, size.1, rows.start, rows.end
            )));
        }
        let names = |f: &BandFile| -> Vec<(String, &'static str)> {
            f.image
                .layer_data
                .channel_data
                .list
                .iter()
                .map(|c| (c.name.to_string(), sample_type(&c.sample_data)))
                .collect()
        };
        if names(file) != names(first) {
            return Err(Failure::new(format!(
                "'{here}' has other channels than '{}': {:?} against {:?}",
                first.path.display(),
                names(file),
                names(first)
            )));
        }
    }
    Ok(())
}

fn sample_type(samples: &FlatSamples) -> &'static str {
    match samples {
        FlatSamples::F16(_) => "half",
        FlatSamples::F32(_) => "float",
        FlatSamples::U32(_) => "uint",
    }
}

/// Appends `more`'s samples to `all` (both of one type, checked in `check_bands`).
fn append(all: &mut FlatSamples, more: &FlatSamples) {
    match (all, more) {
        (FlatSamples::F16(a), FlatSamples::F16(b)) => a.extend_from_slice(b),
        (FlatSamples::F32(a), FlatSamples::F32(b)) => a.extend_from_slice(b),
        (FlatSamples::U32(a), FlatSamples::U32(b)) => a.extend_from_slice(b),
        _ => {}
    }
}

fn write_merged(target: &Path, bands: Vec<BandFile>) -> Outcome<()> {
    let mut bands = bands.into_iter();
    let Some(first) = bands.next() else {
        return Err(Failure::new("there are no bands to merge"));
    };
    let ExrImage {
        attributes,
        layer_data: mut layer,
    } = first.image;
    for band in bands {
        for (all, more) in layer
            .channel_data
            .list
            .iter_mut()
            .zip(band.image.layer_data.channel_data.list.iter())
        {
            append(&mut all.sample_data, &more.sample_data);
        }
    }
    layer.size = attributes.display_window.size;
    layer.attributes.layer_position = attributes.display_window.position;
    for name in [BAND_ATTRIBUTE, BANDS_ATTRIBUTE] {
        layer.attributes.other.remove(&Text::from(name));
    }
    let png = target
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if png {
        return crate::render::write_image(target, &to_image(&layer)?);
    }
    let merged = ExrImage::new(attributes, layer);
    crate::io::output::write_atomically(target, |file| {
        crate::render::exr_order::write_sorted(file, |buffer| {
            merged
                .write()
                .to_buffered(buffer)
                .map_err(|e| e.to_string())
        })
    })
    .map_err(|e| Failure::new(format!("cannot write image '{}': {e}", target.display())))
}

/// The merged channels as an image, for a PNG preview.
fn to_image(layer: &Layer<Channels>) -> Outcome<crate::render::Image> {
    let (width, height) = (layer.size.0, layer.size.1);
    let mut image = crate::render::Image::new(width, height);
    let values =
        |c: &AnyChannel<FlatSamples>| -> Vec<f32> { c.sample_data.values_as_f32().collect() };
    for channel in &layer.channel_data.list {
        let name = channel.name.to_string();
        match ["R", "G", "B", "A"].iter().position(|n| *n == name) {
            Some(c) => {
                for (pixel, v) in image.rgba.iter_mut().zip(values(channel)) {
                    pixel[c] = v;
                }
            }
            None => image.aovs.push((name, values(channel))),
        }
    }
    Ok(image)
}
