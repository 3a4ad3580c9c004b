//! Comparing what a run produced with what its reference produced.
//!
//! Three kinds of output are compared, each by the measures its users read:
//! - **Images** (`.exr`, `.png`): RMSE over the RGBA channels, PSNR against a peak of 1 (or the
//!   reference's brightest channel where that is brighter), relative MSE (each channel's squared
//!   error over the reference's square plus 0.01, the form renderers report), and SSIM of the
//!   displayed colour. EXR is compared in its stored linear, premultiplied values; PNG in its
//!   stored 8-bit values scaled to [0, 1]. SSIM needs images of at least 11 × 11 pixels.
//! - **VDB files**: for each grid of the reference, RMSE and largest error (`grids`); a grid on
//!   other voxels than the reference's is resampled onto the reference's.
//! - **Printed numbers**: every number on each line of standard output. A line's label is its
//!   text without the numbers; the k-th line with a label is matched with the reference's k-th
//!   line with that label, number by number. A line whose label says it is an error
//!   ("area error") or a time ("fill seconds") the script measured itself is shown as it is,
//!   not compared; errors among them are plotted.
//!
//! The key decision: a setting is compared in whatever can be compared. A file it did not
//! write, or an image of another size, is a problem of that one output, reported beside the
//! measures of every other output, so one unmatched file never hides the rest of the row.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// One measured quantity of one setting, named for the table, the CSV and the plots.
#[derive(Clone, Debug, PartialEq)]
pub struct Measure {
    /// `image.exr rmse`, `density.vdb:density max`, `area error`.
    pub name: String,
    pub value: f64,
    pub kind: Kind,
    /// Measured on the run's grid resampled onto the reference's voxels (the two differ).
    pub resampled: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// An error against the reference: plotted, smaller is better.
    Error,
    /// A similarity (PSNR, SSIM): larger is better.
    Similarity,
    /// A number the script printed, shown as it is; plotted as an error when its label says
    /// it is one.
    Printed,
}

impl Measure {
    fn new(name: String, value: f64, kind: Kind) -> Measure {
        Measure {
            name,
            value,
            kind,
            resampled: false,
        }
    }

    /// Whether the plots show this measure as an error to minimise.
    pub fn plotted(&self) -> bool {
        match self.kind {
            Kind::Error => {
                self.name.ends_with(" rmse")
                    || self.name.ends_with(" max")
                    || self.name.ends_with(" rel")
            }
            Kind::Printed => is_error_label(&self.name),
            Kind::Similarity => false,
        }
    }
}

/// Whether a printed line's label says it is an error the script measured itself.
fn is_error_label(label: &str) -> bool {
    label.to_lowercase().contains("error")
}

/// Whether a printed line's label says it is a time the script measured itself.
fn is_time_label(label: &str) -> bool {
    let lower = label.to_lowercase();
    lower.contains("seconds") || lower.contains("time")
}

/// Every file under `directory`, as sorted paths relative to it.
pub fn files_under(directory: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut found = Vec::new();
    let mut pending = vec![directory.to_path_buf()];
    while let Some(dir) = pending.pop() {
        let entries = match std::fs::read_dir(&dir) {
            Ok(entries) => entries,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(e),
        };
        for entry in entries {
            let entry = entry?;
            let path = entry.path();
            let kind = entry.file_type()?;
            if kind.is_dir() {
                pending.push(path);
            } else if kind.is_file()
                && !crate::io::output::is_temporary(&entry.file_name().to_string_lossy())
                && let Ok(relative) = path.strip_prefix(directory)
            {
                found.push(relative.to_path_buf());
            }
        }
    }
    found.sort();
    Ok(found)
}

/// What one run's outputs came to against its reference's.
#[derive(Debug, Default)]
pub struct Comparison {
    pub measures: Vec<Measure>,
    /// What could not be compared, and why, one output each.
    pub problems: Vec<String>,
}

/// The measures of one run's outputs against its reference's, and the outputs that cannot be
/// compared (files only one of them wrote, images of other sizes, grids of other kinds).
pub fn compare(
    run: &Path,
    run_stdout: &str,
    reference: &Path,
    reference_stdout: &str,
) -> Comparison {
    let mut found = Comparison::default();
    let ours = match files_under(run) {
        Ok(files) => files,
        Err(e) => {
            found.problems.push(format!("cannot list its outputs: {e}"));
            return found;
        }
    };
    let theirs = match files_under(reference) {
        Ok(files) => files,
        Err(e) => {
            found
                .problems
                .push(format!("cannot list the reference's outputs: {e}"));
            return found;
        }
    };
    let missing: Vec<String> = theirs
        .iter()
        .filter(|f| !ours.contains(f))
        .map(|f| f.display().to_string())
        .collect();
    let extra: Vec<String> = ours
        .iter()
        .filter(|f| !theirs.contains(f))
        .map(|f| f.display().to_string())
        .collect();
    if !missing.is_empty() {
        found.problems.push(format!(
            "did not write {} (the reference did)",
            missing.join(", ")
        ));
    }
    if !extra.is_empty() {
        found.problems.push(format!(
            "wrote {}, which the reference did not; a study compares files of the same \
             name, so output names must not depend on the swept params",
            extra.join(", ")
        ));
    }
    for file in theirs.iter().filter(|f| ours.contains(f)) {
        let name = file.display().to_string();
        let (a, b) = (run.join(file), reference.join(file));
        let extension = file
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let measured = match extension.as_deref() {
            Some("exr") | Some("png") => compare_images(&name, &a, &b),
            Some("vdb") => super::grids::compare_vdb(&name, &a, &b),
            _ => Ok(Vec::new()),
        };
        match measured {
            Ok(measures) => found.measures.extend(measures),
            Err(e) => found.problems.push(format!("{name}: {e}")),
        }
    }
    match compare_printed(run_stdout, reference_stdout) {
        Ok(measures) => found.measures.extend(measures),
        Err(e) => found.problems.push(e),
    }
    found
}

/// An image as RGBA samples in [0, 1]-ish units, row-major.
struct Pixels {
    width: usize,
    height: usize,
    rgba: Vec<[f32; 4]>,
}

fn read_image(path: &Path) -> Result<Pixels, String> {
    let is_png = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if is_png {
        let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
        let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
        decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
        let mut reader = decoder.read_info().map_err(|e| e.to_string())?;
        let size = reader
            .output_buffer_size()
            .ok_or_else(|| String::from("the image is too large"))?;
        let mut buffer = vec![0; size];
        let info = reader.next_frame(&mut buffer).map_err(|e| e.to_string())?;
        let channels = info.color_type.samples();
        let (width, height) = (info.width as usize, info.height as usize);
        let rgba = buffer[..info.buffer_size()]
            .chunks_exact(channels)
            .map(|p| {
                let v = |i: usize| p[i] as f32 / 255.0;
                match channels {
                    1 => [v(0), v(0), v(0), 1.0],
                    2 => [v(0), v(0), v(0), v(1)],
                    3 => [v(0), v(1), v(2), 1.0],
                    _ => [v(0), v(1), v(2), v(3)],
                }
            })
            .collect();
        return Ok(Pixels {
            width,
            height,
            rgba,
        });
    }
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |size, _| (size.width(), vec![[0f32; 4]; size.width() * size.height()]),
        |(width, pixels), position, (r, g, b, a): (f32, f32, f32, f32)| {
            pixels[position.y() * *width + position.x()] = [r, g, b, a]
        },
    )
    .map_err(|e| e.to_string())?;
    let size = image.layer_data.size;
    Ok(Pixels {
        width: size.width(),
        height: size.height(),
        rgba: image.layer_data.channel_data.pixels.1,
    })
}

fn compare_images(name: &str, run: &Path, reference: &Path) -> Result<Vec<Measure>, String> {
    let a = read_image(run)?;
    let b = read_image(reference).map_err(|e| format!("the reference's copy: {e}"))?;
    if (a.width, a.height) != (b.width, b.height) {
        return Err(format!(
            "it is {}×{} but the reference's is {}×{}",
            a.width, a.height, b.width, b.height
        ));
    }
    let (mut squared, mut relative, mut peak) = (0.0f64, 0.0f64, 1.0f64);
    for (p, q) in a.rgba.iter().zip(&b.rgba) {
        for c in 0..4 {
            let (x, y) = (p[c] as f64, q[c] as f64);
            let d = x - y;
            squared += d * d;
            relative += d * d / (y * y + 0.01);
            peak = peak.max(y);
        }
    }
    let samples = (4 * a.rgba.len()).max(1) as f64;
    let mse = squared / samples;
    let psnr = if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (peak * peak / mse).log10()
    };
    let mut measures = vec![
        Measure::new(format!("{name} rmse"), mse.sqrt(), Kind::Error),
        Measure::new(format!("{name} psnr"), psnr, Kind::Similarity),
        Measure::new(format!("{name} relmse"), relative / samples, Kind::Error),
    ];
    if a.width >= 11 && a.height >= 11 {
        let ssim = iqa::ssim(
            &displayed(&a)?,
            &displayed(&b)?,
            iqa::SsimOptions::default(),
        )
        .map_err(|e| e.to_string())?;
        measures.push(Measure::new(format!("{name} ssim"), ssim, Kind::Similarity));
    }
    Ok(measures)
}

/// The colour as it is shown over black: clipped to [0, 1] and sRGB-encoded, in 16 bits.
fn displayed(image: &Pixels) -> Result<iqa::Image<iqa::Srgb16>, String> {
    let encode = |linear: f32| {
        let x = (linear as f64).clamp(0.0, 1.0);
        let s = if x <= 0.003_130_8 {
            12.92 * x
        } else {
            1.055 * x.powf(1.0 / 2.4) - 0.055
        };
        (s * 65535.0).round() as u16
    };
    let data = image
        .rgba
        .iter()
        .flat_map(|p| [encode(p[0]), encode(p[1]), encode(p[2])])
        .collect();
    iqa::Image::srgb16(image.width as u32, image.height as u32, data).map_err(|e| e.to_string())
}

/// One line of standard output that holds numbers.
#[derive(Debug, PartialEq)]
struct PrintedLine {
    label: String,
    numbers: Vec<f64>,
}

/// The lines of `text` that hold numbers, each with its label.
fn printed_lines(text: &str) -> Vec<PrintedLine> {
    text.lines()
        .filter_map(|line| {
            let mut label = Vec::new();
            let mut numbers = Vec::new();
            for token in line
                .split(|c: char| c.is_whitespace() || "(),{}[]=:;".contains(c))
                .filter(|t| !t.is_empty())
            {
                match token.parse::<f64>() {
                    Ok(x) => numbers.push(x),
                    Err(_) => label.push(token),
                }
            }
            (!numbers.is_empty()).then(|| PrintedLine {
                label: label.join(" "),
                numbers,
            })
        })
        .collect()
}

fn compare_printed(run: &str, reference: &str) -> Result<Vec<Measure>, String> {
    let ours = printed_lines(run);
    let theirs = printed_lines(reference);
    let mut seen: HashMap<&str, usize> = HashMap::new();
    let mut measures = Vec::new();
    for (index, line) in theirs.iter().enumerate() {
        let k = seen.entry(line.label.as_str()).or_insert(0);
        *k += 1;
        let occurrence = *k;
        let base = match (line.label.is_empty(), occurrence) {
            (true, _) => format!("line {}", index + 1),
            (false, 1) => line.label.clone(),
            (false, k) => format!("{} ({k})", line.label),
        };
        let Some(mine) = ours
            .iter()
            .filter(|l| l.label == line.label)
            .nth(occurrence - 1)
        else {
            return Err(format!(
                "it did not print `{base}` (the reference printed {})",
                line.numbers
                    .iter()
                    .map(|x| x.to_string())
                    .collect::<Vec<_>>()
                    .join(" ")
            ));
        };
        if mine.numbers.len() != line.numbers.len() {
            return Err(format!(
                "`{base}` holds {} numbers, the reference's {}",
                mine.numbers.len(),
                line.numbers.len()
            ));
        }
        for (i, (&x, &y)) in mine.numbers.iter().zip(&line.numbers).enumerate() {
            let name = if line.numbers.len() == 1 {
                base.clone()
            } else {
                format!("{base} [{}]", i + 1)
            };
            measures.push(Measure::new(name.clone(), x, Kind::Printed));
            // An error or a time the script measured itself is shown as it is: its difference
            // from the reference's own means nothing.
            if is_error_label(&name) || is_time_label(&name) {
                continue;
            }
            let abs = (x - y).abs();
            let rel = if abs == 0.0 { 0.0 } else { abs / y.abs() };
            measures.push(Measure::new(format!("{name} abs"), abs, Kind::Error));
            measures.push(Measure::new(format!("{name} rel"), rel, Kind::Error));
        }
    }
    Ok(measures)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn value(measures: &[Measure], name: &str) -> f64 {
        measures
            .iter()
            .find(|m| m.name == name)
            .unwrap_or_else(|| panic!("no {name} in {measures:?}"))
            .value
    }

    #[test]
    fn printed_lines_are_matched_by_label_and_occurrence() {
        let reference = "integral 2.0\nsteps 64\nintegral 4.0\n(1, 2, 3)\n";
        let run = "steps 8\nintegral 2.5\nintegral 3.0\n(1, 2, 4)\n";
        let m = compare_printed(run, reference).unwrap();
        assert_eq!(value(&m, "integral"), 2.5);
        assert_eq!(value(&m, "integral abs"), 0.5);
        assert_eq!(value(&m, "integral rel"), 0.25);
        assert_eq!(value(&m, "integral (2) abs"), 1.0);
        assert_eq!(value(&m, "steps abs"), 56.0);
        assert_eq!(value(&m, "line 4 [3] rel"), 1.0 / 3.0);
        assert_eq!(value(&m, "line 4 [1] abs"), 0.0);
        assert!(
            m.iter()
                .find(|x| x.name == "integral")
                .is_some_and(|x| x.kind == Kind::Printed && !x.plotted())
        );
        let err = compare_printed("steps 8\n", reference).unwrap_err();
        assert!(err.contains("did not print `integral`"), "{err}");
    }

    #[test]
    fn a_printed_error_is_plotted_as_it_is() {
        let m = compare_printed("area error 0.01\n", "area error 0.001\n").unwrap();
        assert_eq!(m.len(), 1);
        let times = compare_printed("fill seconds 2.5\n", "fill seconds 1.0\n").unwrap();
        assert_eq!(times.len(), 1);
        assert!(!times[0].plotted() && times[0].value == 2.5);
        assert!(m[0].plotted() && m[0].kind == Kind::Printed && m[0].value == 0.01);
    }

    #[test]
    fn image_errors_follow_their_definitions() {
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str, level: f32| {
            let image = crate::render::Image {
                width: 16,
                height: 12,
                rgba: vec![[level, level, level, 1.0]; 16 * 12],
                aovs: Vec::new(),
            };
            crate::render::write_image(&dir.path().join(name), &image).unwrap();
        };
        write("a.exr", 0.5);
        write("b.exr", 0.25);
        let m = compare_images("i", &dir.path().join("a.exr"), &dir.path().join("b.exr")).unwrap();
        // Three of four channels differ by 0.25.
        let mse = 3.0 * 0.0625 / 4.0;
        assert!((value(&m, "i rmse") - f64::sqrt(mse)).abs() < 1e-7);
        assert!((value(&m, "i psnr") - 10.0 * (1.0 / mse).log10()).abs() < 1e-5);
        assert!((value(&m, "i relmse") - 3.0 * 0.0625 / (0.0625 + 0.01) / 4.0).abs() < 1e-6);
        // Flat images: SSIM is its luminance term alone, (2 μx μy + C1) / (μx² + μy² + C1).
        let (x, y) = (displayed_level(0.5), displayed_level(0.25));
        let c1 = (0.01f64 * 65535.0).powi(2);
        let expected = (2.0 * x * y + c1) / (x * x + y * y + c1);
        assert!((value(&m, "i ssim") - expected).abs() < 1e-9, "{m:?}");
        let same =
            compare_images("i", &dir.path().join("a.exr"), &dir.path().join("a.exr")).unwrap();
        assert_eq!(value(&same, "i rmse"), 0.0);
        assert_eq!(value(&same, "i ssim"), 1.0);
        assert!(value(&same, "i psnr").is_infinite());
    }

    fn displayed_level(linear: f64) -> f64 {
        (((1.055 * linear.powf(1.0 / 2.4) - 0.055) * 65535.0).round()).max(0.0)
    }

    #[test]
    fn different_files_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        std::fs::create_dir_all(&a).unwrap();
        std::fs::create_dir_all(&b).unwrap();
        std::fs::write(a.join("out_1.txt"), "").unwrap();
        std::fs::write(b.join("out_2.txt"), "").unwrap();
        let found = compare(&a, "", &b, "");
        let err = found.problems.join("; ");
        assert!(
            err.contains("did not write out_2.txt") && err.contains("wrote out_1.txt"),
            "{err}"
        );
        assert!(found.measures.is_empty());
    }
}
