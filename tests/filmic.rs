//! `view = "filmic"` against Blender's own Filmic view (opt in with `FELT_PEER_TESTS=1`;
//! `apt-get install blender`): Blender saves a ramp of scene-linear colours through Filmic as
//! an 8-bit PNG (`tests/fixtures/blender_filmic.py`), and felt shows the same colours through
//! its Filmic view and its PNG writer's pixel path, reading the tables from the configuration
//! Blender used. Every byte must be within 2/255; the grey, orange, blue and yellow ramps run
//! from 2^-12 to 2^6, through the cube's desaturation and the curve's clip.
//!
//! One test in its own binary: it sets `OCIO` for this process, which nothing else here reads.

use felt::render::image::preview_pixel;
use felt::render::view::View;
use std::path::Path;
use std::process::Command;

const WIDTH: usize = 256;
const TINTS: [[f64; 3]; 4] = [
    [1.0, 1.0, 1.0],
    [1.0, 0.3, 0.05],
    [0.1, 0.5, 1.0],
    [1.0, 1.0, 0.0],
];

#[test]
fn filmic_matches_blenders_filmic_within_two_levels() {
    if std::env::var("FELT_PEER_TESTS").as_deref() != Ok("1") {
        eprintln!("skipped: set FELT_PEER_TESTS=1 to compare with Blender's Filmic");
        return;
    }
    if !Command::new("blender")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        eprintln!("skipped: Blender is not installed (apt-get install blender)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (png, config) = (dir.path().join("filmic.png"), dir.path().join("config.txt"));
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/blender_filmic.py");
    let run = Command::new("blender")
        .args(["-b", "--factory-startup", "--python-exit-code", "1", "-P"])
        .arg(&script)
        .arg("--")
        .args([&png, &config])
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let config = std::fs::read_to_string(&config).unwrap();
    // SAFETY: this binary runs this one test, and nothing else in the process reads or writes
    // the environment while it is set.
    unsafe { std::env::set_var("OCIO", config.trim()) };
    let view = View::parse("filmic").expect("Blender's configuration has Filmic's tables");

    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut bytes = vec![0; reader.output_buffer_size().unwrap()];
    let frame = reader.next_frame(&mut bytes).unwrap();
    assert_eq!((frame.width, frame.height), (WIDTH as u32, 4));
    let channels = frame.line_size / WIDTH;
    let mut worst = 0;
    for (row, tint) in TINTS.iter().enumerate() {
        // Blender's first row is the image's bottom one.
        let line = &bytes[(3 - row) * frame.line_size..][..frame.line_size];
        for column in 0..WIDTH {
            let v = (-12.0 + 18.0 * column as f64 / (WIDTH - 1) as f64).exp2();
            let rgba = [tint[0] * v, tint[1] * v, tint[2] * v, 1.0].map(|c| c as f32);
            let felt = preview_pixel(view.apply(rgba));
            for c in 0..3 {
                let blender = line[column * channels + c];
                let off = (felt[c] as i32 - blender as i32).abs();
                worst = worst.max(off);
                assert!(
                    off <= 2,
                    "row {row}, column {column} ({rgba:?}), channel {c}: felt {} Blender {blender}",
                    felt[c]
                );
            }
        }
    }
    eprintln!("largest difference from Blender: {worst}/255");
}
