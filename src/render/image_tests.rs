use super::*;

fn sample_image() -> Image {
    let (width, height) = (5, 3);
    let mut image = Image::new(width, height);
    for (i, p) in image.rgba.iter_mut().enumerate() {
        let v = i as f32;
        *p = [0.1 * v, 0.01 * v + 3.5, -0.25, 1.0 / (1.0 + v)];
    }
    let depth: Vec<f32> = (0..width * height)
        .map(|i| {
            if i == 4 {
                f32::INFINITY
            } else {
                2.0 + i as f32
            }
        })
        .collect();
    image.aovs.push(("depth.Z".into(), depth));
    image
        .aovs
        .push(("emission.R".into(), vec![0.75; width * height]));
    image
}

#[test]
fn exr_round_trips_through_the_exr_reader_as_scanline_zip() {
    use exr::prelude::traits::*;
    use exr::prelude::{Blocks, Compression, FlatSamples};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("beauty.exr");
    let image = sample_image();
    write_image(&path, &image).unwrap();
    let file = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(&path)
        .unwrap();
    assert_eq!(file.layer_data.len(), 1);
    let layer = &file.layer_data[0];
    assert_eq!((layer.size.0, layer.size.1), (5, 3));
    assert_eq!(layer.encoding.compression, Compression::ZIP16);
    assert_eq!(layer.encoding.blocks, Blocks::ScanLines);
    let names: Vec<String> = layer
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    assert_eq!(names, ["A", "B", "G", "R", "depth.Z", "emission.R"]);
    let channel = |name: &str| -> Vec<f32> {
        let c = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .unwrap();
        match &c.sample_data {
            FlatSamples::F32(v) => v.clone(),
            other => panic!("{name} stored as {other:?}"),
        }
    };
    for (name, component) in [("R", 0), ("G", 1), ("B", 2), ("A", 3)] {
        let values: Vec<f32> = image.rgba.iter().map(|p| p[component]).collect();
        assert_eq!(channel(name), values, "{name}");
    }
    assert_eq!(channel("depth.Z"), image.aovs[0].1);
    assert_eq!(channel("emission.R"), vec![0.75; 15]);
    // Nothing but the image is left in the directory.
    let entries: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(entries.len(), 1);
}

#[test]
fn png_preview_is_straight_alpha_srgb() {
    // Half-covered mid grey: premultiplied 0.25 at alpha 0.5 is straight 0.5, and
    // sRGB(0.5) = 1.055·0.5^(1/2.4) − 0.055 = 0.7354 → 188.
    assert_eq!(preview_pixel([0.25, 0.25, 0.25, 0.5]), [188, 188, 188, 128]);
    // Opaque: linear 0.0031308 is the curve's knee, 12.92 × it = 0.04045 → 10.
    assert_eq!(
        preview_pixel([0.003_130_8, 1.0, 2.0, 1.0]),
        [10, 255, 255, 255]
    );
    // Glow brighter than its opacity: alpha is raised to the brightest channel (0.8).
    assert_eq!(preview_pixel([0.8, 0.2, 0.0, 0.1]), [255, 137, 0, 204]);
    assert_eq!(preview_pixel([0.0, 0.0, 0.0, 0.0]), [0, 0, 0, 0]);
    assert_eq!(preview_pixel([f32::NAN, 0.0, 0.0, 0.0]), [0, 0, 0, 0]);

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("preview.PNG");
    let mut image = Image::new(2, 1);
    image.rgba = vec![[0.25, 0.25, 0.25, 0.5], [0.8, 0.2, 0.0, 0.1]];
    write_image(&path, &image).unwrap();
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut bytes = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut bytes).unwrap();
    assert_eq!((info.width, info.height), (2, 1));
    assert_eq!(info.color_type, png::ColorType::Rgba);
    assert_eq!(&bytes[..8], &[188, 188, 188, 128, 255, 137, 0, 204]);
}

#[test]
fn bad_paths_and_images_are_named_errors() {
    let dir = tempfile::tempdir().unwrap();
    let image = sample_image();
    let err = write_image(&dir.path().join("out.tiff"), &image).unwrap_err();
    assert!(err.message.contains("out.tiff") && err.help.is_some());
    // Missing folders are made; a file where a folder should be is an error naming the path.
    let missing = dir.path().join("no/such/dir/out.exr");
    write_image(&missing, &image).unwrap();
    assert!(missing.exists());
    std::fs::write(dir.path().join("flat"), "").unwrap();
    let blocked = dir.path().join("flat/dir/out.exr");
    let err = write_image(&blocked, &image).unwrap_err();
    assert!(
        err.message.contains("flat/dir/out.exr") && err.message.contains("is not a folder"),
        "{}",
        err.message
    );
    let mut short = image.clone();
    short.aovs[1].1.pop();
    assert!(
        write_image(&dir.path().join("a.exr"), &short)
            .unwrap_err()
            .message
            .contains("emission.R")
    );
    let mut twice = image.clone();
    twice.aovs.push(("depth.Z".into(), vec![0.0; 15]));
    assert!(write_image(&dir.path().join("a.exr"), &twice).is_err());
    let mut clash = image.clone();
    clash.aovs.push(("A".into(), vec![0.0; 15]));
    assert!(write_image(&dir.path().join("a.exr"), &clash).is_err());
    // Overwriting an existing file replaces it whole.
    let path = dir.path().join("again.exr");
    std::fs::write(&path, b"not an image").unwrap();
    write_image(&path, &image).unwrap();
    assert_eq!(
        &std::fs::read(&path).unwrap()[..4],
        &[0x76, 0x2f, 0x31, 0x01]
    );
}

/// Opt-in (`FELT_PEER_TESTS=1`): OpenEXR's own `exrheader` reads felt's file and reports the
/// channels and ZIP scanline compression.
#[test]
fn exrheader_reads_felt_exr() {
    if std::env::var("FELT_PEER_TESTS").as_deref() != Ok("1") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("peer.exr");
    write_image(&path, &sample_image()).unwrap();
    let output = std::process::Command::new("exrheader")
        .arg(&path)
        .output()
        .unwrap();
    assert!(output.status.success());
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(text.contains("zip, multi-scanline blocks"), "{text}");
    for channel in ["A", "B", "G", "R", "depth.Z", "emission.R"] {
        assert!(
            text.contains(&format!("    {channel}, 32-bit floating-point")),
            "{channel} missing from\n{text}"
        );
    }
    assert!(text.contains("(0 0) - (4 2)"), "{text}");
}
