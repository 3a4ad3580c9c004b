//! The look of a render: `blackbody` from scripts, on numbers and on fields, checked against
//! colour-science (values recorded here, and opt-in with `FELT_PEER_TESTS=1` against the
//! package itself); the PNG views against an independent evaluation.

mod common;

use common::{lines_of, numbers, run_source};
use felt::render::view;
use glam::DVec3;

/// colour-science 0.4.7: `colour.sd_blackbody(T)` on 360–830 nm at 1 nm, summed against its
/// 1 nm CIE 1931 table, taken to BT.709 and divided by Y.
const REC709_AT: [(f64, [f64; 3]); 3] = [
    (1500.0, [3.264599, 0.434099, -0.064201]),
    (2856.0, [1.845154, 0.826099, 0.233378]),
    (6504.0, [1.043062, 0.983605, 1.035580]),
];

#[test]
fn blackbody_of_numbers_and_fields_agree_with_colour_science() {
    for (t, expected) in REC709_AT {
        let lines = lines_of(run_source(
            "blackbody.felt",
            &format!(
                "print(blackbody({t:.1}));\n\
                 print(probe(blackbody(scalarfield({t:.1})), (0, 0, 0)));\n\
                 print(blackbody({t:.1}, normalize = false));\n\
                 print(probe(blackbody(scalarfield({t:.1}), normalize = false), (0, 0, 0)));\n"
            ),
        ));
        let [plain, field, absolute, absolute_field] = [0, 1, 2, 3].map(|i| numbers(&lines[i]));
        for c in 0..3 {
            assert!(
                (plain[c] - expected[c]).abs() < 1e-3 * expected[0],
                "{t} K: {plain:?}"
            );
            assert!(
                (field[c] - plain[c]).abs() < 1e-5,
                "{t} K: {field:?} vs {plain:?}"
            );
            let scale = absolute[0].abs();
            assert!(
                (absolute_field[c] - absolute[c]).abs() < 1e-5 * scale,
                "{t} K"
            );
        }
        // The absolute colour is the normalised one times Y, which the matrix's middle row
        // gives back: 0.2126 R + 0.7152 G + 0.0722 B of the normalised colour is 1.
        let y = 0.2126 * plain[0] + 0.7152 * plain[1] + 0.0722 * plain[2];
        assert!((y - 1.0).abs() < 1e-3, "{t} K: luminance {y}");
    }
}

#[test]
fn blackbody_is_black_where_it_does_not_glow() {
    let lines = lines_of(run_source(
        "cold.felt",
        "print(blackbody(500.0));\n\
         print(blackbody(-1.0));\n\
         print(probe(blackbody(scalarfield(0.0) / scalarfield(0.0)), (0, 0, 0)));\n\
         print(probe(blackbody(scalarfield(700.0), normalize = false), (0, 0, 0)));\n",
    ));
    for line in &lines {
        assert_eq!(numbers(line), vec![0.0, 0.0, 0.0], "{line}");
    }
}

/// Opt-in: colour-science integrates Planck's law itself, and the chromaticities felt's
/// colours imply agree with it within 1e-3 from 800 K to 12000 K.
#[test]
fn blackbody_chromaticity_matches_colour_science() {
    if std::env::var("FELT_PEER_TESTS").as_deref() != Ok("1") {
        eprintln!("skipped: set FELT_PEER_TESTS=1 to compare with colour-science");
        return;
    }
    let installed = std::process::Command::new("python3")
        .args(["-c", "import colour"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !installed {
        eprintln!("skipped: colour-science is not installed (pip install colour-science)");
        return;
    }
    let temperatures: Vec<f64> = (0..=56).map(|i| 800.0 + 200.0 * i as f64).collect();
    let script: String = temperatures
        .iter()
        .map(|t| format!("print(blackbody({t:.1}));\n"))
        .collect();
    let ours: Vec<Vec<f64>> = lines_of(run_source("sweep.felt", &script))
        .iter()
        .map(|l| numbers(l))
        .collect();
    let list: Vec<String> = temperatures.iter().map(|t| t.to_string()).collect();
    let program = format!(
        "import warnings; warnings.filterwarnings('ignore')\n\
         import colour\n\
         cs = colour.RGB_COLOURSPACES['ITU-R BT.709']\n\
         for t in [{}]:\n\
         \x20   sd = colour.sd_blackbody(t, colour.SpectralShape(360, 830, 1))\n\
         \x20   XYZ = colour.sd_to_XYZ(sd, method='Integration', k=1)\n\
         \x20   print(*(XYZ[:2] / XYZ.sum()))\n",
        list.join(", ")
    );
    let output = std::process::Command::new("python3")
        .args(["-c", &program])
        .output()
        .expect("python3 with colour-science");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let theirs: Vec<Vec<f64>> = String::from_utf8_lossy(&output.stdout)
        .lines()
        .map(numbers)
        .collect();
    // felt's Rec.709 colour back to XYZ with the inverse of the standard matrix.
    let to_xyz = [
        [0.4123908, 0.3575843, 0.1804808],
        [0.2126390, 0.7151687, 0.0721923],
        [0.0193308, 0.1191948, 0.9505322],
    ];
    assert_eq!(ours.len(), theirs.len());
    for ((t, rgb), xy) in temperatures.iter().zip(&ours).zip(&theirs) {
        let xyz: Vec<f64> = to_xyz
            .iter()
            .map(|row| (0..3).map(|c| row[c] * rgb[c]).sum())
            .collect();
        let sum: f64 = xyz.iter().sum();
        let (x, y) = (xyz[0] / sum, xyz[1] / sum);
        assert!(
            (x - xy[0]).abs() < 1e-3 && (y - xy[1]).abs() < 1e-3,
            "{t} K: felt ({x}, {y}), colour-science ({}, {})",
            xy[0],
            xy[1]
        );
    }
}

fn grey(v: f64) -> f64 {
    view::agx(DVec3::splat(v)).x
}

/// Values of an independent numpy evaluation of three.js's `AgXToneMapping` (its own
/// 4-digit Rec.709↔Rec.2020 matrices), display-linear, for greys.
const AGX_GREYS: [(f64, f64); 10] = [
    (0.001, 0.000106),
    (0.01, 0.005996),
    (0.05, 0.061383),
    (0.18, 0.214549),
    (0.5, 0.425197),
    (1.0, 0.590229),
    (2.0, 0.743395),
    (4.0, 0.861016),
    (16.0, 0.995212),
    (100.0, 0.996978),
];

#[test]
fn agx_view_matches_an_independent_evaluation() {
    for (scene, shown) in AGX_GREYS {
        let ours = grey(scene);
        assert!(
            (ours - shown).abs() < 0.5 / 255.0,
            "{scene}: {ours} vs {shown}"
        );
    }
    for (scene, shown) in [
        ([1.0, 0.2, 0.05], [0.655102, 0.265218, 0.137397]),
        ([4.6, 0.04, -0.09], [1.0, 0.415314, 0.256163]),
    ] {
        let ours = view::agx(DVec3::from_array(scene));
        let error = (ours - DVec3::from_array(shown)).abs().max_element();
        assert!(error < 1.0 / 255.0, "{scene:?}: {ours} vs {shown:?}");
    }
}

#[test]
fn views_are_monotone_and_keep_black() {
    assert_eq!(view::View::Agx.apply([0.0; 4]), [0.0; 4]);
    assert_eq!(
        view::View::Standard.apply([0.3, 2.0, -1.0, 0.5]),
        [0.3, 2.0, -1.0, 0.5]
    );
    let mut last = -1.0;
    for k in 0..=4000 {
        let v = (k as f64 / 4000.0 * 20.0 - 14.0).exp2();
        let shown = grey(v);
        assert!(shown >= last, "not monotone at {v}");
        last = shown;
    }
    assert!(grey(1e6) > 0.99);
}

#[test]
fn unknown_views_are_errors() {
    assert!(view::View::parse("AgX").is_err() && view::View::parse("film").is_err());
    assert_eq!(view::View::parse("agx").ok(), Some(view::View::Agx));
}

/// `view = "filmic"` reads Filmic's tables from the configuration `$OCIO` names; where that
/// has none, the render call is a diagnostic that says what to set, before any work.
#[test]
fn filmic_without_its_tables_is_a_diagnostic_at_the_render() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("config.ocio"), "search_path: \"luts\"\n").unwrap();
    std::fs::write(
        dir.path().join("film.felt"),
        "camera cam = camera((0, 0, 3), (0, 0, 0), (0, 1, 0), 40);\n\
         render(\"film.png\", density = mask(sphere((0, 0, 0), 0.5)), camera = cam,\n\
                width = 8, height = 8, view = \"filmic\");\n",
    )
    .unwrap();
    for ocio in [None, Some(dir.path().join("config.ocio"))] {
        let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_felt"));
        command.current_dir(dir.path()).args(["run", "film.felt"]);
        match &ocio {
            Some(path) => command.env("OCIO", path),
            None => command.env_remove("OCIO"),
        };
        let out = command.output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{stderr}");
        let wanted = if ocio.is_some() {
            "filmic_desat65cube.spi3d"
        } else {
            "OCIO is not set"
        };
        assert!(
            stderr.contains(wanted) && stderr.contains("film.felt:2"),
            "{stderr}"
        );
        assert!(!dir.path().join("film.png").exists());
    }
}

/// Every EXR says what its pixels are: OpenEXR's standard `chromaticities` attribute holds the
/// ITU-R BT.709 primaries and the D65 white (the values BT.709 publishes), read back by the
/// `exr` crate and, with `FELT_PEER_TESTS=1`, by OpenEXR's own `exrheader`.
#[test]
fn exr_images_declare_rec709_chromaticities() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("chroma.felt");
    std::fs::write(
        &script,
        "camera cam = camera((0, 0, 3), (0, 0, 0), (0, 1, 0), 40);\n\
         render(\"chroma.exr\", density = mask(sphere((0, 0, 0), 0.5)), camera = cam, width = 8, height = 8);\n",
    )
    .unwrap();
    let outcome = common::run_script(&script, &[]);
    assert!(outcome.ok, "{}", outcome.rendered);
    let path = dir.path().join("chroma.exr");
    let meta = exr::meta::MetaData::read_from_file(&path, false).unwrap();
    let c = meta.headers[0]
        .shared_attributes
        .chromaticities
        .expect("a chromaticities attribute");
    let published = [
        (c.red, (0.64, 0.33)),
        (c.green, (0.30, 0.60)),
        (c.blue, (0.15, 0.06)),
        (c.white, (0.3127, 0.3290)),
    ];
    for (found, (x, y)) in published {
        assert_eq!((found.0, found.1), (x as f32, y as f32));
    }
    if std::env::var_os("FELT_PEER_TESTS").is_some()
        && let Ok(out) = std::process::Command::new("exrheader").arg(&path).output()
    {
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            text.contains("chromaticities") && text.contains("0.3127"),
            "{text}"
        );
    }
}
