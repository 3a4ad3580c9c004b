//! Every example scene runs at thumbnail size without a warning and prints what it printed
//! before (snapshots of its statistics, rounded to six significant digits so that the last
//! bits of `f32` noise arithmetic on another processor do not matter), and its images are
//! written and readable.

mod common;

use std::path::PathBuf;

/// Numbers in `text` rounded to six significant digits.
fn rounded(text: &str) -> String {
    let mut out = String::new();
    let mut token = String::new();
    let flush = |token: &mut String, out: &mut String| {
        if token.chars().any(|c| c.is_ascii_digit()) && token.contains('.') {
            match token.parse::<f64>() {
                Ok(v) => out.push_str(&format!("{:.6e}", v)),
                Err(_) => out.push_str(token),
            }
        } else {
            out.push_str(token);
        }
        token.clear();
    };
    for c in text.chars() {
        if c.is_ascii_digit()
            || c == '.'
            || c == 'e' && !token.is_empty()
            || (c == '-' && (token.is_empty() || token.ends_with('e')))
        {
            token.push(c);
        } else {
            flush(&mut token, &mut out);
            out.push(c);
        }
    }
    flush(&mut token, &mut out);
    out
}

/// Thumbnail sizes, and a few frames for the simulations, for the params an example declares.
const SMALL: &[(&str, &str)] = &[
    ("width", "16"),
    ("height", "9"),
    ("res", "24"),
    ("frames", "3"),
    ("dots", "3000"),
];

#[test]
fn examples_run_at_thumbnail_size() {
    let examples: Vec<PathBuf> = {
        let mut v: Vec<PathBuf> = std::fs::read_dir("examples")
            .unwrap()
            .map(|e| std::fs::canonicalize(e.unwrap().path()).unwrap())
            .filter(|p| p.extension().is_some_and(|e| e == "felt"))
            .collect();
        v.sort();
        v
    };
    assert!(examples.len() >= 4);
    // Renders and meshes are written beside the script: run copies in a scratch folder.
    let scratch = tempfile::tempdir().unwrap();
    for original in &examples {
        let path = &scratch.path().join(original.file_name().unwrap());
        std::fs::copy(original, path).unwrap();
        let text = std::fs::read_to_string(path).unwrap();
        let overrides: Vec<(&str, &str)> = SMALL
            .iter()
            .copied()
            .filter(|(name, _)| text.contains(&format!("param int {name} ")))
            .collect();
        let outcome = common::run_script(path, &overrides);
        assert!(outcome.ok, "{}: {}", path.display(), outcome.rendered);
        // An example teaches: one that warns teaches users to ignore warnings.
        assert!(
            outcome.diagnostics.is_empty(),
            "{}: {}",
            path.display(),
            outcome.rendered
        );
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        insta::assert_snapshot!(name, rounded(&outcome.output));
    }
    // Every image the examples wrote reads back with the size asked for.
    for entry in std::fs::read_dir(scratch.path()).unwrap() {
        let path = entry.unwrap().path();
        match path.extension().and_then(|e| e.to_str()) {
            Some("png") => {
                let decoder =
                    png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
                let reader = decoder.read_info().unwrap();
                assert_eq!(
                    (reader.info().width, reader.info().height),
                    (16, 9),
                    "{}",
                    path.display()
                );
            }
            Some("exr") => {
                let image = exr::prelude::read_first_rgba_layer_from_file(
                    &path,
                    |size, _| vec![[0f32; 4]; size.width() * size.height()],
                    |pixels, position, (r, g, b, a): (f32, f32, f32, f32)| {
                        pixels[position.y() * 16 + position.x()] = [r, g, b, a]
                    },
                )
                .unwrap();
                assert_eq!(image.layer_data.size.width(), 16);
                assert!(
                    image
                        .layer_data
                        .channel_data
                        .pixels
                        .iter()
                        .all(|p| p.iter().all(|v| v.is_finite()))
                );
            }
            _ => {}
        }
    }
}
