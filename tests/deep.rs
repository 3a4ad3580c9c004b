//! Deep OpenEXR output (`render(..., deep = true)`, docs/language.md "Deep images").
//!
//! The files are read back by a reader written here from OpenEXR's file layout (not felt's
//! writer), and composited front to back with `over`: that must give the flat render of the
//! same scene, pixel for pixel. A homogeneous slab checks depths and alpha against the closed
//! form. The peer test (opt in with `FELT_PEER_TESTS=1`; `apt-get install openexr` and
//! `pip install OpenEXR`) has OpenEXR's own `exrheader` and Python bindings read the file.

mod common;

use std::io::Read;
use std::path::Path;
use std::process::Command;

/// A deep scanline file as read back: size, and per pixel its samples
/// `[A, B, G, R, Z, ZBack]` front to back.
struct Deep {
    width: usize,
    height: usize,
    pixels: Vec<Vec<[f32; 6]>>,
}

fn le_i32(b: &[u8], at: usize) -> i32 {
    i32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

fn le_u64(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}

/// Undoes OpenEXR's ZIP compressor on one block of `raw` bytes (stored as is when packing did
/// not shrink it): zlib, then the delta predictor, then the even/odd byte split.
fn unzips(packed: &[u8], raw: usize) -> Vec<u8> {
    if packed.len() == raw {
        return packed.to_vec();
    }
    let mut split = Vec::new();
    flate2::read::ZlibDecoder::new(packed)
        .read_to_end(&mut split)
        .unwrap();
    assert_eq!(split.len(), raw);
    for i in 1..split.len() {
        split[i] = split[i].wrapping_add(split[i - 1]).wrapping_sub(128);
    }
    let half = raw.div_ceil(2);
    (0..raw)
        .map(|i| {
            if i % 2 == 0 {
                split[i / 2]
            } else {
                split[half + i / 2]
            }
        })
        .collect()
}

fn read_deep(path: &Path) -> Deep {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..4], &[0x76, 0x2f, 0x31, 0x01], "not OpenEXR");
    let version = u32::from_le_bytes(b[4..8].try_into().unwrap());
    assert_eq!(version & 0xff, 2);
    assert_ne!(version & 0x800, 0, "the deep (non-image) flag is not set");
    assert_eq!(version & 0x200, 0, "a deep scanline file is not tiled");
    let mut at = 8;
    let name = |at: &mut usize| {
        let end = *at + b[*at..].iter().position(|&c| c == 0).unwrap();
        let text = String::from_utf8_lossy(&b[*at..end]).into_owned();
        *at = end + 1;
        text
    };
    let (mut window, mut channels, mut kind) = (None, Vec::new(), String::new());
    loop {
        let attribute = name(&mut at);
        if attribute.is_empty() {
            break;
        }
        let _type = name(&mut at);
        let size = le_i32(&b, at) as usize;
        at += 4;
        let value = &b[at..at + size];
        match attribute.as_str() {
            "dataWindow" => window = Some([0, 4, 8, 12].map(|i| le_i32(value, i))),
            "type" => kind = String::from_utf8_lossy(value).into_owned(),
            "compression" => assert!(value[0] == 0 || value[0] == 2, "{value:?}"),
            "channels" => {
                let mut c = 0;
                while value[c] != 0 {
                    let end = c + value[c..].iter().position(|&x| x == 0).unwrap();
                    let pixel_type = le_i32(value, end + 1);
                    channels.push((
                        String::from_utf8_lossy(&value[c..end]).into_owned(),
                        pixel_type,
                    ));
                    c = end + 1 + 16;
                }
            }
            _ => {}
        }
        at += size;
    }
    assert_eq!(kind, "deepscanline");
    let names: Vec<&str> = channels.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["A", "B", "G", "R", "Z", "ZBack"]);
    assert!(channels.iter().all(|(_, t)| *t == 2), "every channel FLOAT");
    let [x0, y0, x1, y1] = window.unwrap();
    let (width, height) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
    let offsets: Vec<usize> = (0..height)
        .map(|i| le_u64(&b, at + 8 * i) as usize)
        .collect();
    let mut pixels = Vec::with_capacity(width * height);
    for (line, &chunk) in offsets.iter().enumerate() {
        assert_eq!(le_i32(&b, chunk), y0 + line as i32);
        let (table_size, data_size) = (
            le_u64(&b, chunk + 4) as usize,
            le_u64(&b, chunk + 12) as usize,
        );
        let unpacked = le_u64(&b, chunk + 20) as usize;
        let table = unzips(&b[chunk + 28..chunk + 28 + table_size], 4 * width);
        let start = chunk + 28 + table_size;
        let data = unzips(&b[start..start + data_size], unpacked);
        let cumulative: Vec<usize> = (0..width).map(|x| le_i32(&table, 4 * x) as usize).collect();
        let total = cumulative[width - 1];
        assert_eq!(unpacked, 4 * 6 * total);
        let value = |channel: usize, sample: usize| {
            f32::from_le_bytes(
                data[4 * (channel * total + sample)..][..4]
                    .try_into()
                    .unwrap(),
            )
        };
        for x in 0..width {
            let first = if x == 0 { 0 } else { cumulative[x - 1] };
            pixels.push(
                (first..cumulative[x])
                    .map(|s| std::array::from_fn(|c| value(c, s)))
                    .collect(),
            );
        }
    }
    Deep {
        width,
        height,
        pixels,
    }
}

/// Front-to-back `over` of a pixel's samples: premultiplied `[R, G, B, A]`.
fn flatten(samples: &[[f32; 6]]) -> [f64; 4] {
    let (mut color, mut clear) = ([0.0f64; 3], 1.0f64);
    for s in samples {
        for (c, v) in color.iter_mut().zip([s[3], s[2], s[1]]) {
            *c += clear * f64::from(v);
        }
        clear *= 1.0 - f64::from(s[0]);
    }
    [color[0], color[1], color[2], 1.0 - clear]
}

fn flat_rgba(path: &Path) -> Vec<[f32; 4]> {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |size, _| (size.width(), vec![[0f32; 4]; size.width() * size.height()]),
        |(width, pixels), position, (r, g, b, a): (f32, f32, f32, f32)| {
            pixels[position.y() * *width + position.x()] = [r, g, b, a]
        },
    )
    .unwrap();
    image.layer_data.channel_data.pixels.1
}

const SCENE: &str = "scalarfield ball = mask(0.6 - length(identity())) * (1.2 + 0.8 * perlin(3.0));\n\
    camera cam = camera((0, 0.4, 3), (0, 0, 0), (0, 1, 0), 40);\n\
    light sun = distantlight((-1, -1, -0.5), (1, 0.9, 0.8));\n";

fn run_in(dir: &Path, script: &str) {
    let path = dir.join("scene.felt");
    std::fs::write(&path, format!("{SCENE}{script}")).unwrap();
    let outcome = common::run_script(&path, &[]);
    assert!(outcome.ok, "{}", outcome.rendered);
}

/// Renders the scene flat and deep with the same `look` and checks that every pixel of the
/// deep file flattens to the flat one, and the samples' order and count.
fn deep_matches_flat(look: &str, most: usize) -> Deep {
    let dir = tempfile::tempdir().unwrap();
    let call =
        format!("density = ball, camera = cam, width = 40, height = 24, step = 0.02, {look}");
    run_in(
        dir.path(),
        &format!(
            "render(\"flat.exr\", {call});\n\
             render(\"deep.exr\", {call}, deep = true, deepsamples = {most});\n"
        ),
    );
    let flat = flat_rgba(&dir.path().join("flat.exr"));
    let deep = read_deep(&dir.path().join("deep.exr"));
    assert_eq!((deep.width, deep.height), (40, 24));
    let mut worst = 0.0f64;
    for (pixel, (samples, want)) in deep.pixels.iter().zip(&flat).enumerate() {
        assert!(
            samples.len() <= most,
            "pixel {pixel}: {} samples",
            samples.len()
        );
        for s in samples {
            assert!(
                s[4] < s[5],
                "pixel {pixel}: Z {} not before ZBack {}",
                s[4],
                s[5]
            );
            assert!((0.0..=1.0).contains(&s[0]), "pixel {pixel}: alpha {}", s[0]);
        }
        for pair in samples.windows(2) {
            assert!(pair[0][5] <= pair[1][4], "pixel {pixel}: samples overlap");
        }
        let got = flatten(samples);
        for c in 0..4 {
            worst = worst.max((got[c] - f64::from(want[c])).abs());
        }
    }
    assert!(
        worst < 1e-4,
        "{look}: flattened deep differs from flat by {worst}"
    );
    deep
}

#[test]
fn flattening_gives_the_flat_render() {
    let lit = "lights = {sun}, color = vectorfield((0.9, 0.7, 0.5))";
    let deep = deep_matches_flat(&format!("{lit}, spp = 1"), 32);
    // The corner sees only empty space; the centre sees the ball in several samples.
    assert!(deep.pixels[0].is_empty());
    assert!(deep.pixels[12 * 40 + 20].len() > 4);
    deep_matches_flat(&format!("{lit}, spp = 4"), 32);
    deep_matches_flat(&format!("{lit}, spp = 4"), 1);
    // Emission, and extinction differing per channel.
    deep_matches_flat(
        "emission = vectorfield((2, 1, 0.5)), kappa = (1, 3, 0.5), spp = 4",
        32,
    );
    deep_matches_flat(&format!("{lit}, kappa = (0.5, 2, 4), spp = 1"), 1);
}

#[test]
fn adaptive_steps_and_a_holdout_still_flatten_to_the_flat_render() {
    deep_matches_flat(
        "lights = {sun}, adaptive = true, spp = 2, holdout = 0.6 + 0.4 * mask(0.3 - length(identity() - (0.2, 0, 0.3)))",
        16,
    );
}

#[test]
fn a_slab_has_its_faces_for_depths_and_the_closed_form_alpha() {
    // Density 1 in the box z in [−0.5, 0.5] seen straight on by an orthographic camera at
    // z = 3: every ray crosses length 1, front face at depth 2.5, back face at 3.5.
    let dir = tempfile::tempdir().unwrap();
    run_in(
        dir.path(),
        "domain slab((-2, -2, -0.5), (4, 4, 1), (0, 0, 0));\n\
         camera front = camera((0, 0, 3), (0, 0, 0), (0, 1, 0), 40, ortho = 2);\n\
         render(\"slab.exr\", density = scalarfield(1.0), bounds = slab, camera = front, \
         width = 8, height = 8, kappa = 2, step = 0.01, deep = true, deepsamples = 8);\n",
    );
    let deep = read_deep(&dir.path().join("slab.exr"));
    let alpha = 1.0 - (-2.0f64).exp();
    for samples in &deep.pixels {
        assert!(!samples.is_empty() && samples.len() <= 8);
        assert!(
            (samples[0][4] - 2.5).abs() < 1e-5,
            "front {}",
            samples[0][4]
        );
        assert!((samples[samples.len() - 1][5] - 3.5).abs() < 1e-5);
        let flat = flatten(samples);
        assert!(
            (flat[3] - alpha).abs() < 1e-5,
            "{} against {alpha}",
            flat[3]
        );
        // Boundaries fall on the curve's recorded points, so each slab of medium has the
        // closed-form alpha of its own thickness.
        assert!(samples.len() >= 4, "{samples:?}");
        for s in samples {
            let own = 1.0 - (-2.0 * f64::from(s[5] - s[4])).exp();
            assert!((f64::from(s[0]) - own).abs() < 1e-5, "{s:?} against {own}");
        }
    }
}

#[test]
fn deep_files_are_bit_identical_for_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("threads.felt"),
        format!(
            "{SCENE}render(\"deep.exr\", density = ball, camera = cam, lights = {{sun}}, \
             width = 48, height = 40, spp = 2, step = 0.02, deep = true);\n"
        ),
    )
    .unwrap();
    let run = |threads: &str| {
        common::felt_succeeds(dir.path(), &["run", "threads.felt", "--threads", threads]);
        std::fs::read(dir.path().join("deep.exr")).unwrap()
    };
    assert!(
        run("1") == run("2"),
        "deep files differ between 1 and 2 threads"
    );
}

#[test]
fn what_a_deep_file_cannot_hold_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (call, message) in [
        ("\"x.png\", deep = true", "not one"),
        (
            "\"x.exr\", deep = true, integrator = \"path\"",
            "path tracer",
        ),
        (
            "\"x.exr\", deep = true, aovs = {\"depth\"}",
            "aovs is not carried",
        ),
        (
            "\"x.exr\", deep = true, exr_half = true",
            "exr_half is not carried",
        ),
        (
            "\"x.exr\", deep = true, tonemap = \"max1\"",
            "tonemap is not carried",
        ),
        ("\"x.exr\", deepsamples = 8", "this render is flat"),
        (
            "\"x.exr\", deep = true, deepsamples = 0",
            "between 1 and 1024",
        ),
    ] {
        let script = dir.path().join("bad.felt");
        std::fs::write(
            &script,
            format!(
                "{SCENE}render({call}, density = ball, camera = cam, width = 8, height = 8);\n"
            ),
        )
        .unwrap();
        let outcome = common::run_script(&script, &[]);
        assert!(!outcome.ok, "{call} was accepted");
        assert!(
            outcome.rendered.contains(message),
            "{call}: {}",
            outcome.rendered
        );
        assert!(
            outcome.rendered.contains("help:"),
            "{call}: {}",
            outcome.rendered
        );
    }
}

#[test]
fn a_band_render_refuses_deep_output() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("band.felt"),
        format!("{SCENE}render(\"deep.exr\", density = ball, camera = cam, width = 8, height = 64, deep = true);\n"),
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_felt"))
        .current_dir(dir.path())
        .args(["run", "band.felt", "--tile", "0/2"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("cannot be rendered in bands") && stderr.contains("--tile"),
        "{stderr}"
    );
}

/// Whether the peer tests are asked for and OpenEXR's tools are there; says why not when not.
fn openexr_ready() -> bool {
    if std::env::var("FELT_PEER_TESTS").as_deref() != Ok("1") {
        eprintln!("skipped: set FELT_PEER_TESTS=1 to read deep files with OpenEXR");
        return false;
    }
    let there = Command::new("exrheader").arg("-h").output().is_ok();
    if !there {
        eprintln!("skipped: exrheader is not installed (apt-get install openexr)");
    }
    there
}

#[test]
fn openexr_reads_the_deep_file_and_flattens_it_to_the_flat_render() {
    if !openexr_ready() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let call = "density = ball, camera = cam, lights = {sun}, width = 32, height = 20, spp = 2, \
                emission = vectorfield((0.3, 0.1, 0))";
    run_in(
        dir.path(),
        &format!("render(\"flat.exr\", {call});\nrender(\"deep.exr\", {call}, deep = true);\n"),
    );
    let deep = dir.path().join("deep.exr");
    if Command::new("exrcheck").arg("-h").output().is_ok() {
        let check = Command::new("exrcheck").arg(&deep).output().unwrap();
        assert!(
            check.status.success(),
            "{}",
            String::from_utf8_lossy(&check.stdout)
        );
    }
    let header = Command::new("exrheader").arg(&deep).output().unwrap();
    let text = String::from_utf8_lossy(&header.stdout);
    assert!(header.status.success(), "{text}");
    assert!(text.contains("deepscanline"), "{text}");
    for channel in ["A, 32-bit floating-point", "ZBack, 32-bit floating-point"] {
        assert!(text.contains(channel), "{text}");
    }
    // OpenEXR's Python bindings (3.3 and later read deep parts) flatten it independently.
    let flat = flat_rgba(&dir.path().join("flat.exr"));
    let script = "import OpenEXR, sys\n\
        with OpenEXR.File(sys.argv[1], separate_channels=True) as f:\n\
        \x20   ch = f.channels()\n\
        \x20   a, r, g, b = (ch[n].pixels for n in 'ARGB')\n\
        \x20   h, w = a.shape\n\
        \x20   for y in range(h):\n\
        \x20       for x in range(w):\n\
        \x20           t, c = 1.0, [0.0, 0.0, 0.0]\n\
        \x20           for k in range(0 if a[y, x] is None else len(a[y, x])):\n\
        \x20               for i, v in enumerate((r, g, b)): c[i] += t * float(v[y, x][k])\n\
        \x20               t *= 1.0 - float(a[y, x][k])\n\
        \x20           print(c[0], c[1], c[2], 1.0 - t)\n";
    let out = Command::new("python3")
        .args(["-c", script])
        .arg(&deep)
        .output()
        .unwrap();
    if !out.status.success() {
        eprintln!(
            "skipped the Python read: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        return;
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let rows: Vec<Vec<f64>> = text.lines().map(common::numbers).collect();
    assert_eq!(rows.len(), flat.len());
    for (row, want) in rows.iter().zip(&flat) {
        for c in 0..4 {
            assert!(
                (row[c] - f64::from(want[c])).abs() < 1e-4,
                "{row:?} against {want:?}"
            );
        }
    }
}
