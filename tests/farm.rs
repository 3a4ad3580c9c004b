//! Frames, bands and farms from the command line: `felt run --frames`, `--tile` with `felt
//! merge`, and the jobs `felt farm` writes, run by hand here (each Slurm array task as Slurm
//! would start it) and, opt-in with `FELT_PEER_TESTS=1`, by the real `openjd-cli` and a real
//! single-node Slurm.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const TURNTABLE: &str = "tests/scripts/frames/turntable.felt";

fn felt() -> Command {
    Command::new(env!("CARGO_BIN_EXE_felt"))
}

fn run(args: &[&str]) -> Output {
    felt().args(args).output().unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[track_caller]
fn assert_ok(out: &Output) {
    assert!(
        out.status.success(),
        "exit {:?}\nstdout: {}\nstderr: {}",
        out.status.code(),
        text(&out.stdout),
        text(&out.stderr)
    );
}

/// Every layer attribute, channel name and sample bit of an EXR file, for comparing files
/// whose headers may list attributes in another order.
fn exr_contents(path: &Path) -> (String, Vec<(String, Vec<u32>)>) {
    use exr::prelude::FlatSamples;
    use exr::prelude::traits::*;
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(image.layer_data.len(), 1);
    let layer = &image.layer_data[0];
    let mut attributes: Vec<String> = layer
        .attributes
        .other
        .iter()
        .map(|(k, v)| format!("{k}={v:?}"))
        // The script's own path is recorded, and a copy of the script is elsewhere.
        .filter(|a| !a.starts_with("felt/script="))
        .collect();
    attributes.sort();
    let header = format!(
        "display {:?} data {:?} at {:?} {:?} {:?}",
        image.attributes.display_window,
        layer.size,
        layer.attributes.layer_position,
        layer.encoding,
        attributes
    );
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let bits = match &c.sample_data {
                FlatSamples::F32(v) => v.iter().map(|x| x.to_bits()).collect(),
                FlatSamples::F16(v) => v.iter().map(|x| u32::from(x.to_bits())).collect(),
                FlatSamples::U32(v) => v.clone(),
            };
            (c.name.to_string(), bits)
        })
        .collect();
    (header, channels)
}

#[track_caller]
fn assert_same_image(a: &Path, b: &Path) {
    let (ha, ca) = exr_contents(a);
    let (hb, cb) = exr_contents(b);
    assert_eq!(ha, hb, "headers of {} and {}", a.display(), b.display());
    let names: Vec<&String> = ca.iter().map(|(n, _)| n).collect();
    assert_eq!(
        names,
        cb.iter().map(|(n, _)| n).collect::<Vec<_>>(),
        "channels"
    );
    for ((name, x), (_, y)) in ca.iter().zip(&cb) {
        let differ = x.iter().zip(y).filter(|(p, q)| p != q).count();
        assert_eq!(differ, 0, "{name}: {differ} samples differ in their bits");
    }
}

fn dir_arg(dir: &Path) -> String {
    dir.display().to_string()
}

#[test]
fn a_frame_range_runs_each_frame_with_its_own_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir_arg(dir.path());
    let ran = run(&[
        "run",
        TURNTABLE,
        "--frames",
        "1-5:2",
        "--output-dir",
        &out,
        "--set",
        "width=16",
        "--set",
        "height=12",
    ]);
    assert_ok(&ran);
    let stderr = text(&ran.stderr);
    assert!(stderr.contains("felt: frame 3 (2 of 3)"), "{stderr}");
    assert!(stderr.contains("felt: all 3 frames done"), "{stderr}");
    for frame in [1, 3, 5] {
        assert!(dir.path().join(format!("turn.{frame:04}.exr")).exists());
        assert!(dir.path().join(format!("turn.{frame:04}.png")).exists());
    }
    assert!(!dir.path().join("turn.0002.exr").exists());
    // A frame of the range is the frame run alone, the param set by hand.
    let alone = tempfile::tempdir().unwrap();
    assert_ok(&run(&[
        "run",
        TURNTABLE,
        "--set",
        "frame=3",
        "--output-dir",
        &dir_arg(alone.path()),
        "--set",
        "width=16",
        "--set",
        "height=12",
    ]));
    for name in ["turn.0003.exr", "turn.0003.png"] {
        assert_eq!(
            std::fs::read(dir.path().join(name)).unwrap(),
            std::fs::read(alone.path().join(name)).unwrap(),
            "{name}"
        );
    }
}

#[test]
fn a_path_built_from_the_frame_names_each_frame_of_a_range() {
    let dir = tempfile::tempdir().unwrap();
    let script = |name: &str, path: &str| {
        let at = dir.path().join(name);
        std::fs::write(
            &at,
            format!(
                "param int frame = 1;\nparam int take = 7;\n\
                 scalarcache c(domain((0,0,0), (1,1,1), (0,0,0), 0.5));\n\
                 cachewrite(c, scalarfield(frame));\ncachesave(c, {path});\n"
            ),
        )
        .unwrap();
        at.display().to_string()
    };
    let out = tempfile::tempdir().unwrap();
    let built = script("built.felt", "format(\"built.%04d.vdb\", frame)");
    let ran = run(&[
        "run",
        &built,
        "--frames",
        "1-2",
        "--output-dir",
        &dir_arg(out.path()),
    ]);
    assert_ok(&ran);
    for frame in [1, 2] {
        assert!(out.path().join(format!("built.{frame:04}.vdb")).exists());
    }
    // A path built from something else is still one file for every frame.
    let fixed = script("fixed.felt", "format(\"take.%04d.vdb\", take)");
    let ran = run(&[
        "run",
        &fixed,
        "--frames",
        "1-2",
        "--output-dir",
        &dir_arg(out.path()),
    ]);
    assert_eq!(ran.status.code(), Some(1));
    let flat = text(&ran.stderr)
        .replace('│', " ")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    assert!(flat.contains("put the frame in its name"), "{flat}");
    assert!(!out.path().join("take.0007.vdb").exists());
}

#[test]
fn a_failed_frame_is_reported_and_the_others_still_run() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("fails.felt");
    std::fs::write(
        &script,
        "param int frame = 1;\nint[] ok = {1, 1, 0, 1};\nfloat x = 1 / ok[frame];\n\
         scalarcache c(domain((0,0,0), (1,1,1), (0,0,0), 0.5));\n\
         cachewrite(c, scalarfield(x));\ncachesave(c, \"out.$F4.vdb\");\n",
    )
    .unwrap();
    let ran = run(&[
        "run",
        &script.display().to_string(),
        "--frames",
        "1-3",
        "--output-dir",
        &dir_arg(dir.path()),
    ]);
    assert_eq!(ran.status.code(), Some(1), "{}", text(&ran.stderr));
    let stderr = text(&ran.stderr);
    assert!(
        stderr.contains("felt: frame 2 failed (exit status 1)"),
        "{stderr}"
    );
    assert!(stderr.contains("felt: 1 of 3 frames failed: 2"), "{stderr}");
    assert!(dir.path().join("out.0001.vdb").exists() && dir.path().join("out.0003.vdb").exists());
    assert!(!dir.path().join("out.0002.vdb").exists());
}

#[test]
fn frames_need_a_frame_param_and_a_frame_in_every_output_name() {
    let dir = tempfile::tempdir().unwrap();
    let none = dir.path().join("none.felt");
    std::fs::write(&none, "print(1);\n").unwrap();
    let ran = run(&["run", &none.display().to_string(), "--frames", "1-2"]);
    assert_eq!(ran.status.code(), Some(2));
    assert!(
        text(&ran.stderr).contains("declares no `param int frame`"),
        "{}",
        text(&ran.stderr)
    );
    let float = dir.path().join("float.felt");
    std::fs::write(&float, "param float frame = 1;\n").unwrap();
    let ran = run(&["run", &float.display().to_string(), "--frames", "1"]);
    assert_eq!(ran.status.code(), Some(2));
    assert!(text(&ran.stderr).contains("is a float, not an int"));
    let ran = run(&["run", TURNTABLE, "--frames", "1", "--set", "frame=2"]);
    assert_eq!(ran.status.code(), Some(2));
    let ran = run(&["run", TURNTABLE, "--frames", "3-1"]);
    assert_eq!(ran.status.code(), Some(2));
    assert!(text(&ran.stderr).contains("ends before it starts"));
    // One file written by every frame would be overwritten by each: an error naming the fix.
    let fixed = dir.path().join("fixed.felt");
    std::fs::write(
        &fixed,
        "param int frame = 1;\nscalarcache c(domain((0,0,0), (1,1,1), (0,0,0), 0.5));\n\
         cachewrite(c, scalarfield(1.0));\ncachesave(c, \"same.vdb\");\n",
    )
    .unwrap();
    let ran = run(&[
        "run",
        &fixed.display().to_string(),
        "--frames",
        "1-2",
        "--output-dir",
        &dir_arg(dir.path()),
    ]);
    assert_eq!(ran.status.code(), Some(1));
    let stderr = text(&ran.stderr);
    // The diagnostic wraps its message: compare it as one line.
    let flat = stderr
        .replace('│', " ")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    assert!(flat.contains("put the frame in its name"), "{stderr}");
    assert!(stderr.contains("2 of 2 frames failed: 1, 2"), "{stderr}");
    // A frame pattern with no frame param to fill it.
    let unframed = dir.path().join("unframed.felt");
    std::fs::write(
        &unframed,
        "scalarcache c(domain((0,0,0), (1,1,1), (0,0,0), 0.5));\n\
         cachewrite(c, scalarfield(1.0));\ncachesave(c, \"a.####.vdb\");\n",
    )
    .unwrap();
    let ran = run(&[
        "run",
        &unframed.display().to_string(),
        "--output-dir",
        &dir_arg(dir.path()),
    ]);
    assert_eq!(ran.status.code(), Some(1));
    let stderr = text(&ran.stderr);
    let flat = stderr
        .replace('│', " ")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    assert!(flat.contains("declares no `param int frame`"), "{stderr}");
}

#[test]
fn a_log_gets_plain_progress_lines_with_frame_share_and_time() {
    let dir = tempfile::tempdir().unwrap();
    let ran = felt()
        .args([
            "run",
            TURNTABLE,
            "--frames",
            "4",
            "--output-dir",
            &dir_arg(dir.path()),
            "--set",
            "width=24",
            "--set",
            "height=20",
        ])
        .env("FELT_PROGRESS_SECONDS", "0")
        .output()
        .unwrap();
    assert_ok(&ran);
    let stderr = text(&ran.stderr);
    // 24 x 20 pixels at 2 samples is 2 x 2 tiles of 16 (4 tiles) per render.
    let lines: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("felt: frame 4: rendering "))
        .collect();
    assert!(lines.len() >= 4, "{stderr}");
    for line in &lines {
        let (share, time) = line
            .strip_prefix("felt: frame 4: rendering ")
            .and_then(|l| l.strip_suffix(" elapsed"))
            .and_then(|l| l.split_once(" of 4 tiles), "))
            .unwrap_or_else(|| panic!("{line}"));
        let (percent, done) = share.split_once("% (").unwrap();
        let done: u64 = done.parse().unwrap();
        assert_eq!(percent.parse::<u64>().unwrap(), done * 100 / 4, "{line}");
        assert_eq!(time.split(':').count(), 3, "{line}");
    }
    assert!(lines.iter().any(|l| l.contains("100% (4 of 4 tiles)")));
    assert!(
        !stderr.contains('\r') && !stderr.contains('\x1b'),
        "no bar in a log"
    );
}

/// Renders frame 2 whole into one folder and in `bands` bands, merged, into another.
fn whole_and_merged(bands: usize, extra: &[&str]) -> (tempfile::TempDir, tempfile::TempDir) {
    let whole = tempfile::tempdir().unwrap();
    let split = tempfile::tempdir().unwrap();
    let mut args = vec!["run", TURNTABLE, "--frames", "2"];
    args.extend_from_slice(extra);
    let whole_dir = dir_arg(whole.path());
    let mut w = args.clone();
    w.extend(["--output-dir", &whole_dir]);
    assert_ok(&run(&w));
    let split_dir = dir_arg(split.path());
    for i in 0..bands {
        let tile = format!("{i}/{bands}");
        let mut b = args.clone();
        b.extend([
            "--output-dir",
            &split_dir,
            "--tile",
            &tile,
            "--threads",
            "1",
        ]);
        assert_ok(&run(&b));
    }
    (whole, split)
}

#[test]
fn merged_bands_equal_a_whole_render_bit_for_bit() {
    let (whole, split) = whole_and_merged(3, &[]);
    for i in 0..3 {
        assert!(
            split
                .path()
                .join(format!("turn.0002.tile-{i}-of-3.exr"))
                .exists()
        );
        assert!(
            split
                .path()
                .join(format!("turn.0002.png.tile-{i}-of-3.exr"))
                .exists()
        );
    }
    assert!(!split.path().join("turn.0002.exr").exists());
    let merged = run(&[
        "merge",
        "turn.####.exr",
        "turn.####.png",
        "--frames",
        "2",
        "--output-dir",
        &dir_arg(split.path()),
    ]);
    assert_ok(&merged);
    let (a, b) = (
        whole.path().join("turn.0002.exr"),
        split.path().join("turn.0002.exr"),
    );
    assert_same_image(&a, &b);
    // All 4 + 3 + 1 + 1 + 6 channels (RGBA, emission, depth, transmittance, two lights).
    assert_eq!(exr_contents(&a).1.len(), 15);
    assert_eq!(
        std::fs::read(whole.path().join("turn.0002.png")).unwrap(),
        std::fs::read(split.path().join("turn.0002.png")).unwrap(),
        "the PNG previews"
    );
}

#[test]
fn merge_refuses_missing_duplicate_and_mismatched_bands() {
    let (_, split) = whole_and_merged(2, &["--set", "spp=1"]);
    let dir = split.path();
    let merge = |extra: &[&str]| {
        let mut args = vec!["merge", "turn.0002.exr", "--output-dir"];
        let d = dir_arg(dir);
        args.push(&d);
        args.extend_from_slice(extra);
        let out = run(&args);
        assert_eq!(out.status.code(), Some(1), "{}", text(&out.stderr));
        text(&out.stderr)
    };
    let band = |i: usize| dir.join(format!("turn.0002.tile-{i}-of-2.exr"));
    let keep = std::fs::read(band(1)).unwrap();
    // Missing.
    std::fs::remove_file(band(1)).unwrap();
    assert!(merge(&[]).contains("band 1 of 2 of 'turn.0002.exr' is missing"));
    // Duplicate: band 0 copied over band 1's name.
    std::fs::copy(band(0), band(1)).unwrap();
    assert!(merge(&[]).contains("band 0 appears twice"));
    // Of another split (asked for 3, or two splits present).
    std::fs::write(band(1), &keep).unwrap();
    assert!(merge(&["--tiles", "3"]).contains("band 0 of 3"));
    std::fs::copy(band(0), dir.join("turn.0002.tile-0-of-3.exr")).unwrap();
    assert!(merge(&[]).contains("different splits"));
    std::fs::remove_file(dir.join("turn.0002.tile-0-of-3.exr")).unwrap();
    // Of another image size.
    let other = tempfile::tempdir().unwrap();
    assert_ok(&run(&[
        "run",
        TURNTABLE,
        "--frames",
        "2",
        "--set",
        "spp=1",
        "--set",
        "width=48",
        "--tile",
        "1/2",
        "--output-dir",
        &dir_arg(other.path()),
    ]));
    std::fs::copy(other.path().join("turn.0002.tile-1-of-2.exr"), band(1)).unwrap();
    assert!(merge(&[]).contains("the bands are of different images"));
    // Too many bands for the image is an error at render time.
    let out = run(&[
        "run",
        TURNTABLE,
        "--frames",
        "2",
        "--set",
        "height=20",
        "--tile",
        "0/3",
        "--output-dir",
        &dir_arg(other.path()),
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        text(&out.stderr).contains("at most 2 bands"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn the_simulation_example_carries_its_state_from_frame_to_frame() {
    let dir = tempfile::tempdir().unwrap();
    let example = std::fs::canonicalize("examples/smoke_frames.felt").unwrap();
    let ran = run(&[
        "run",
        &example.display().to_string(),
        "--frames",
        "1-3",
        "--set",
        "res=16",
        "--set",
        "width=16",
        "--set",
        "height=12",
        "--output-dir",
        &dir_arg(dir.path()),
    ]);
    assert_ok(&ran);
    let frames = text(&ran.stdout);
    let looped = run(&[
        "run",
        "tests/scripts/frames/smoke_one_run.felt",
        "--set",
        "frames=3",
        "--set",
        "res=16",
        "--output-dir",
        &dir_arg(dir.path()),
    ]);
    assert_ok(&looped);
    let lines = |t: &str| -> Vec<String> {
        t.lines()
            .filter(|l| l.starts_with("frame "))
            .map(String::from)
            .collect()
    };
    assert_eq!(lines(&frames).len(), 3, "{frames}");
    assert_eq!(lines(&frames), lines(&text(&looped.stdout)));
    // The density grows frame by frame (each frame starts from the last one's cache).
    let means: Vec<f64> = lines(&frames)
        .iter()
        .map(|l| l.rsplit(' ').next().unwrap().parse().unwrap())
        .collect();
    assert!(means[0] < means[1] && means[1] < means[2], "{means:?}");
    for frame in 1..=3 {
        assert!(
            dir.path()
                .join(format!("smoke_cache.{frame:04}.vdb"))
                .exists()
        );
        assert!(dir.path().join(format!("smoke.{frame:04}.exr")).exists());
    }
}

/// A copy of the turntable in its own folder (farm tasks write beside the script).
fn scene_copy() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("turntable.felt");
    std::fs::copy(TURNTABLE, &script).unwrap();
    (dir, script)
}

/// The reference: frames 1-2 of the turntable at 32 x 24 (as `felt run` writes them).
fn reference_frames() -> tempfile::TempDir {
    let reference = tempfile::tempdir().unwrap();
    assert_ok(&run(&[
        "run",
        TURNTABLE,
        "--frames",
        "1-2",
        "--set",
        "width=32",
        "--set",
        "height=24",
        "--output-dir",
        &dir_arg(reference.path()),
    ]));
    reference
}

#[track_caller]
fn assert_frames_match(reference: &Path, farm: &Path) {
    for frame in [1, 2] {
        let name = format!("turn.{frame:04}.exr");
        assert_same_image(&reference.join(&name), &farm.join(&name));
        let png = format!("turn.{frame:04}.png");
        assert_eq!(
            std::fs::read(reference.join(&png)).unwrap(),
            std::fs::read(farm.join(&png)).unwrap(),
            "{png}"
        );
    }
}

fn farm_job(engine: &str, script: &Path, out: &Path) -> Output {
    run(&[
        "farm",
        engine,
        &script.display().to_string(),
        "--frames",
        "1-2",
        "--tiles",
        "2",
        "--set",
        "width=32",
        "--set",
        "height=24",
        "--out",
        &out.display().to_string(),
    ])
}

#[test]
fn slurm_array_tasks_run_by_hand_make_the_same_images() {
    let (dir, script) = scene_copy();
    let render = dir.path().join("job.sh");
    let wrote = farm_job("slurm", &script, &render);
    assert_ok(&wrote);
    let merge = dir.path().join("job.merge.sh");
    let submit = std::fs::read_to_string(dir.path().join("job.submit.sh")).unwrap();
    assert!(submit.contains("--dependency=afterok:"), "{submit}");
    let body = std::fs::read_to_string(&render).unwrap();
    assert!(body.contains("#SBATCH --array=0-3"), "{body}");
    assert!(
        body.contains(env!("CARGO_BIN_EXE_felt")),
        "the binary by its absolute path"
    );
    // Each array task as Slurm starts it: the script with its task id, from another folder.
    for (script, tasks) in [(&render, 4), (&merge, 2)] {
        for id in 0..tasks {
            let out = Command::new("bash")
                .arg(script)
                .env("SLURM_ARRAY_TASK_ID", id.to_string())
                .current_dir("/")
                .output()
                .unwrap();
            assert_ok(&out);
        }
    }
    assert_frames_match(reference_frames().path(), dir.path());
}

#[test]
fn the_openjd_template_names_every_task() {
    let (dir, script) = scene_copy();
    let out = dir.path().join("job.yaml");
    assert_ok(&farm_job("openjd", &script, &out));
    let yaml = std::fs::read_to_string(&out).unwrap();
    assert!(yaml.contains("specificationVersion: \"jobtemplate-2023-09\""));
    assert!(
        yaml.contains("range: \"1-2\"") && yaml.contains("range: \"0-1\""),
        "{yaml}"
    );
    assert!(
        yaml.contains(
            r#""merge", "--frames", "{{Task.Param.Frame}}", "--tiles", "2", "--", "turn.####.exr", "turn.####.png"]"#
        ),
        "{yaml}"
    );
    let script_path = std::fs::canonicalize(&script).unwrap();
    assert!(yaml.contains(&script_path.display().to_string()));
    // A computed image path cannot be merged without --image.
    let computed = dir.path().join("computed.felt");
    std::fs::write(
        &computed,
        "param int frame = 1;\nrender(format(\"a.%04d.exr\", frame), density = 1.0, \
         camera = camera((0, 0, 5), (0, 0, 0), (0, 1, 0), 40));\n",
    )
    .unwrap();
    let refused = run(&[
        "farm",
        "openjd",
        &computed.display().to_string(),
        "--frames",
        "1-2",
        "--tiles",
        "2",
        "--out",
        &out.display().to_string(),
    ]);
    assert_eq!(refused.status.code(), Some(2));
    assert!(
        text(&refused.stderr).contains("--image"),
        "{}",
        text(&refused.stderr)
    );
}

fn peer(tool: &str) -> bool {
    if std::env::var("FELT_PEER_TESTS").as_deref() != Ok("1") {
        eprintln!("skipped: set FELT_PEER_TESTS=1 to run the farm jobs with {tool}");
        return false;
    }
    let found = Command::new("sh")
        .args(["-c", &format!("command -v {tool}")])
        .output()
        .is_ok_and(|o| o.status.success());
    if !found {
        eprintln!("skipped: {tool} is not installed");
    }
    found
}

/// Opt-in: `openjd check` accepts both templates and `openjd run` runs every task of the
/// banded one, merge step included, making the images `felt run` makes.
#[test]
fn openjd_cli_checks_and_runs_the_template() {
    if !peer("openjd") {
        return;
    }
    let (dir, script) = scene_copy();
    let plain = dir.path().join("plain.yaml");
    assert_ok(&run(&[
        "farm",
        "openjd",
        &script.display().to_string(),
        "--frames",
        "1-240:2",
        "--out",
        &plain.display().to_string(),
    ]));
    let banded = dir.path().join("banded.yaml");
    assert_ok(&farm_job("openjd", &script, &banded));
    for template in [&plain, &banded] {
        let checked = Command::new("openjd")
            .arg("check")
            .arg(template)
            .output()
            .unwrap();
        assert_ok(&checked);
    }
    let ran = Command::new("openjd")
        .arg("run")
        .arg(&banded)
        .args(["--step", "merge", "--run-dependencies"])
        .output()
        .unwrap();
    assert_ok(&ran);
    assert_frames_match(reference_frames().path(), dir.path());
}

/// Whether `sbatch` is installed (opt-in) and a Slurm node is up to run jobs; says why not.
fn slurm_node_up() -> bool {
    if !peer("sbatch") {
        return false;
    }
    let ready = Command::new("sinfo").args(["-h", "-o", "%T"]).output();
    let states = ready.map(|o| text(&o.stdout)).unwrap_or_default();
    if !states.contains("idle") && !states.contains("mix") && !states.contains("alloc") {
        eprintln!(
            "skipped: no Slurm node is up (sinfo says: {})",
            states.trim()
        );
        return false;
    }
    true
}

/// Opt-in: the submit script on a real single-node Slurm (set up by `.ci/slurm-node`), waited
/// for with `sbatch --wait`, makes the images `felt run` makes.
#[test]
fn slurm_runs_the_array_and_the_dependent_merge() {
    if !slurm_node_up() {
        return;
    }
    let (dir, script) = scene_copy();
    let render = dir.path().join("job.sh");
    assert_ok(&farm_job("slurm", &script, &render));
    let submitted = Command::new("sh")
        .arg(dir.path().join("job.submit.sh"))
        .arg("--wait")
        .current_dir("/")
        .output()
        .unwrap();
    assert_ok(&submitted);
    assert_frames_match(reference_frames().path(), dir.path());
}

/// Farm jobs with a simulation step (`--sim`): the simulation runs once, the bands read its
/// caches.
#[path = "farm/simulation.rs"]
mod simulation;
