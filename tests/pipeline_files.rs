//! Files in a pipeline, through the `felt` binary as a farm node runs it: permissions under
//! the umask, folders made on demand, relative paths from the script's folder, `--output-dir`,
//! environment variables, several grids in one VDB file and the EXR header.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn felt() -> Command {
    Command::new(env!("CARGO_BIN_EXE_felt"))
}

/// Writes `source` as `name` under `folder` (creating it) and returns the script's path.
fn script(folder: &Path, name: &str, source: &str) -> PathBuf {
    std::fs::create_dir_all(folder).unwrap();
    let path = folder.join(name);
    std::fs::write(&path, source).unwrap();
    path
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn ran(out: Output) -> Output {
    assert!(out.status.success(), "felt failed:\n{}", stderr(&out));
    out
}

/// A scene writing every kind of output into `folder` (relative to the script).
fn every_output(folder: &str) -> String {
    format!(
        "domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.25);\n\
         scalarcache c(d);\n\
         cachewrite(c, scalarfield(0.5));\n\
         cachesave(c, \"{folder}/a.vdb\");\n\
         camera cam = camera((0.5, 0.5, 3), (0.5, 0.5, 0.5), (0, 1, 0), 40);\n\
         render(\"{folder}/a.exr\", density = cacheread(c), camera = cam, width = 4, height = 3, step = 0.1);\n\
         render(\"{folder}/a.png\", density = cacheread(c), camera = cam, width = 4, height = 3, step = 0.1);\n\
         saveshape(ls2shape(sphere((0.5, 0.5, 0.5), 0.3), d), \"{folder}/a.obj\");\n"
    )
}

#[cfg(unix)]
#[test]
fn outputs_and_their_folders_get_the_permissions_the_umask_gives() {
    use std::os::unix::fs::PermissionsExt;
    for umask in [0o022u32, 0o077] {
        let dir = tempfile::tempdir().unwrap();
        let scene = script(dir.path(), "scene.felt", &every_output("renders/new"));
        let shell = format!(
            "umask {umask:03o} && exec '{}' run '{}'",
            env!("CARGO_BIN_EXE_felt"),
            scene.display()
        );
        ran(Command::new("sh").arg("-c").arg(&shell).output().unwrap());
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        for name in ["a.vdb", "a.exr", "a.png", "a.obj"] {
            let path = dir.path().join("renders/new").join(name);
            assert_eq!(
                mode(&path),
                0o666 & !umask,
                "{name} under umask {umask:03o}"
            );
        }
        for folder in ["renders", "renders/new"] {
            assert_eq!(mode(&dir.path().join(folder)), 0o777 & !umask, "{folder}");
        }
        // No temporary is left beside them.
        let left: Vec<_> = std::fs::read_dir(dir.path().join("renders/new"))
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .filter(|n| n.starts_with(".felt-"))
            .collect();
        assert!(left.is_empty(), "{left:?}");
    }
}

#[test]
fn a_path_through_a_file_is_an_error_before_the_render() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("renders"), "a file, not a folder").unwrap();
    let scene = script(dir.path(), "scene.felt", &every_output("renders"));
    let out = felt().arg("run").arg(&scene).output().unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let text = stderr(&out);
    assert!(
        text.contains("cannot write VDB file") && text.contains("/renders' is not a"),
        "{text}"
    );
}

#[test]
fn relative_paths_start_at_the_script_and_output_dir_redirects_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("shot");
    // An input beside the script, written by a first run.
    let make = script(
        &shot,
        "make.felt",
        "domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.25);\nscalarcache c(d);\n\
         cachewrite(c, scalarfield(2.0));\ncachesave(c, \"cache/input.vdb\");\n",
    );
    let elsewhere = tempfile::tempdir().unwrap();
    ran(felt()
        .arg("run")
        .arg(&make)
        .current_dir(elsewhere.path())
        .output()
        .unwrap());
    assert!(shot.join("cache/input.vdb").exists());
    assert_eq!(std::fs::read_dir(elsewhere.path()).unwrap().count(), 0);
    // A second script reads it, writes its own cache and reads that back too.
    let use_it = script(
        &shot,
        "use.felt",
        "scalarfield input = cacheload(\"cache/input.vdb\", \"density\");\n\
         domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.25);\nscalarcache c(d);\n\
         cachewrite(c, input * 3.0);\ncachesave(c, \"out/tripled.vdb\");\n\
         print(probe(cacheload(\"out/tripled.vdb\", \"density\"), (0.5, 0.5, 0.5)));\n",
    );
    let out = ran(felt()
        .arg("run")
        .arg(&use_it)
        .current_dir(elsewhere.path())
        .output()
        .unwrap());
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), "6.0");
    assert!(shot.join("out/tripled.vdb").exists());
    // With --output-dir the output lands there (and is read back from there), the input is
    // still found beside the script.
    let redirected = elsewhere.path().join("farm/frame1");
    let out = ran(felt()
        .arg("run")
        .arg(&use_it)
        .arg("--output-dir")
        .arg(&redirected)
        .current_dir(elsewhere.path())
        .output()
        .unwrap());
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), "6.0");
    assert!(redirected.join("out/tripled.vdb").exists());
}

#[test]
fn environment_variables_in_paths_expand_and_an_unset_one_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let scene = script(
        dir.path(),
        "scene.felt",
        "domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.5);\nscalarcache c(d);\n\
         cachewrite(c, scalarfield(1.0));\ncachesave(c, \"$SHOT/cache/density.vdb\");\n\
         cachesave(c, \"${SHOT}/v${TAKE}.vdb#temperature\");\n",
    );
    let shot = dir.path().join("sq010_sh020");
    ran(felt()
        .arg("run")
        .arg(&scene)
        .env("SHOT", &shot)
        .env("TAKE", "3")
        .output()
        .unwrap());
    assert!(shot.join("cache/density.vdb").exists());
    let grids = felt::grid::vdb::read_file(&shot.join("v3.vdb")).unwrap();
    assert_eq!(grids[0].name, "temperature");
    let out = felt()
        .arg("run")
        .arg(&scene)
        .env("SHOT", &shot)
        .env_remove("TAKE")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let text = stderr(&out);
    assert!(
        text.contains(
            "the environment variable TAKE in the path \"${SHOT}/v${TAKE}.vdb\" is not set"
        ) && text.contains("scene.felt:5"),
        "{text}"
    );
}

#[test]
fn the_repl_reads_and_writes_relative_to_the_current_directory() {
    let dir = tempfile::tempdir().unwrap();
    let mut child = felt()
        .arg("repl")
        .current_dir(dir.path())
        .env("FELT_HISTORY", dir.path().join("history"))
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    {
        use std::io::Write;
        let input = child.stdin.as_mut().unwrap();
        input
            .write_all(
                b"domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.5);\nscalarcache c(d);\n\
                  cachewrite(c, scalarfield(1.0));\ncachesave(c, \"here.vdb\");\n",
            )
            .unwrap();
    }
    let out = child.wait_with_output().unwrap();
    assert!(dir.path().join("here.vdb").exists(), "{}", stderr(&out));
}

#[test]
fn several_grids_share_a_file_and_append_keeps_an_earlier_runs() {
    let dir = tempfile::tempdir().unwrap();
    let scene = script(
        dir.path(),
        "sim.felt",
        "param float heat = 2.5;\n\
         domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.25);\n\
         scalarcache rho(d); cachewrite(rho, scalarfield(0.5));\n\
         scalarcache t(d); cachewrite(t, identity().x * heat);\n\
         vectorcache v(d); cachewrite(v, vectorfield((1, 2, 3)));\n\
         cachesave(rho, \"sim.vdb\");\n\
         cachesave(t, \"sim.vdb#temperature\");\n\
         cachesave(v, \"sim.vdb\", vector_type = \"covariant\");\n\
         print(probe(cacheload(\"sim.vdb\", \"temperature\", interp = \"cubic\"), (0.5, 0.5, 0.5)));\n\
         print(probe(cacheloadvector(\"sim.vdb\", \"vel\", outside = \"hold\"), (0.99, 0.5, 0.5)));\n",
    );
    let out = ran(felt().arg("run").arg(&scene).output().unwrap());
    let printed = String::from_utf8_lossy(&out.stdout).into_owned();
    let lines: Vec<&str> = printed.lines().collect();
    // A linear field is reproduced by Catmull-Rom; outside = "hold" keeps the edge value.
    assert!(
        (lines[0].parse::<f64>().unwrap() - 1.25).abs() < 1e-6,
        "{printed}"
    );
    let vel: Vec<f64> = lines[1]
        .trim_matches(|c| c == '(' || c == ')')
        .split(", ")
        .map(|c| c.parse().unwrap())
        .collect();
    assert!(
        vel.iter()
            .zip([1.0, 2.0, 3.0])
            .all(|(v, e)| (v - e).abs() < 1e-9),
        "{printed}"
    );
    let path = dir.path().join("sim.vdb");
    let grids = felt::grid::vdb::read_file(&path).unwrap();
    let names: Vec<(&str, &str)> = grids
        .iter()
        .map(|g| (g.name.as_str(), g.class.as_str()))
        .collect();
    assert_eq!(
        names,
        [
            ("density", "fog volume"),
            ("temperature", "fog volume"),
            ("vel", "unknown")
        ]
    );
    use felt::grid::vdb::VdbMeta;
    assert_eq!(
        grids[2].meta("vector_type"),
        Some(&VdbMeta::String("covariant".into()))
    );
    let file_meta = felt::grid::vdb::read_file_metadata(&std::fs::read(&path).unwrap()).unwrap();
    let text = |key: &str| {
        file_meta
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.clone())
    };
    assert_eq!(text("felt/param/heat"), Some(VdbMeta::String("2.5".into())));
    assert_eq!(
        text("felt/script"),
        Some(VdbMeta::String(
            scene.canonicalize().unwrap().display().to_string()
        ))
    );
    assert_eq!(
        text("creator"),
        Some(VdbMeta::String(format!(
            "felt {}",
            env!("CARGO_PKG_VERSION")
        )))
    );
    // A second run with append = true keeps the first run's grids; without it the file is
    // this run's alone.
    let more = |append: &str| {
        format!(
            "domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.25);\nscalarcache f(d);\n\
             cachewrite(f, scalarfield(9.0));\ncachesave(f, \"sim.vdb#fuel\"{append});\n"
        )
    };
    let add = script(dir.path(), "add.felt", &more(", append = true"));
    ran(felt().arg("run").arg(&add).output().unwrap());
    assert_eq!(felt::grid::vdb::read_file(&path).unwrap().len(), 4);
    let replace = script(dir.path(), "replace.felt", &more(""));
    ran(felt().arg("run").arg(&replace).output().unwrap());
    let grids = felt::grid::vdb::read_file(&path).unwrap();
    assert_eq!(grids.len(), 1);
    assert_eq!(grids[0].name, "fuel");
}

#[test]
fn a_domain_that_is_not_whole_cells_is_rounded_with_a_warning_and_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let scene = script(
        dir.path(),
        "odd.felt",
        "domain d((0.1, -0.2, 0.3), (1.0, 0.7, 0.45), (0.2, 0.5, -0.3), 0.3);\n\
         scalarcache c(d);\ncachewrite(c, identity().x + 2 * identity().y);\n\
         cachesave(c, \"odd.vdb\");\n\
         scalarfield back = cacheload(\"odd.vdb\", \"density\");\n\
         vector a = stats(back, d);\nvector b = stats(cacheread(c), d);\n         print(a.x - b.x, a.y - b.y, a.z - b.z, b.y - b.x);\n",
    );
    let out = ran(felt().arg("run").arg(&scene).output().unwrap());
    let printed = String::from_utf8_lossy(&out.stdout).into_owned();
    let numbers: Vec<f64> = printed
        .split_whitespace()
        .map(|n| n.parse().unwrap())
        .collect();
    assert!(numbers[..3].iter().all(|d| d.abs() < 1e-9), "{printed}");
    assert!(numbers[3] > 0.5, "{printed}");
    let text = stderr(&out);
    assert!(
        text.contains("the domain's z length 0.45 is not a whole number of cells of 0.3"),
        "{text}"
    );
}

/// The EXR of a render with named lights, half floats and a depth AOV.
fn named_light_render(dir: &Path) -> PathBuf {
    let scene = script(
        dir,
        "lit.felt",
        "param int width = 8;\nparam string look = \"warm\";\n\
         scalarfield rho = mask(sphere((0, 0, 0), 0.6));\n\
         camera cam = camera((0, 0, 4), (0, 0, 0), (0, 1, 0), 30);\n\
         light key = distantlight((0, -1, 0), (2, 2, 2), name = \"key\");\n\
         light fill = pointlight((2, 0, 2), (1, 1, 1));\n\
         render(\"lit.exr\", density = rho, camera = cam, lights = {key, fill}, width = width, \
         height = 6, step = 0.05, aovs = {\"lights\", \"depth\"}, exr_half = true);\n",
    );
    ran(felt()
        .arg("run")
        .arg(&scene)
        .arg("--set")
        .arg("width=10")
        .output()
        .unwrap());
    dir.join("lit.exr")
}

#[test]
fn an_exr_carries_half_channels_named_lights_the_camera_and_the_run() {
    use exr::prelude::{AttributeValue, FlatSamples, ReadChannels, ReadLayers};
    let dir = tempfile::tempdir().unwrap();
    let path = named_light_render(dir.path());
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(&path)
        .unwrap();
    let layer = &image.layer_data;
    let kinds: Vec<(String, &str)> = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let kind = match c.sample_data {
                FlatSamples::F16(_) => "half",
                FlatSamples::F32(_) => "float",
                FlatSamples::U32(_) => "uint",
            };
            (c.name.to_string(), kind)
        })
        .collect();
    let expected: Vec<(String, &str)> = [
        ("A", "half"),
        ("B", "half"),
        ("G", "half"),
        ("R", "half"),
        ("depth.Z", "float"),
        ("key.B", "half"),
        ("key.G", "half"),
        ("key.R", "half"),
        ("light1.B", "half"),
        ("light1.G", "half"),
        ("light1.R", "half"),
    ]
    .iter()
    .map(|(n, k)| (n.to_string(), *k))
    .collect();
    assert_eq!(kinds, expected);
    assert_eq!(layer.size.0, 10);
    let attribute = |name: &str| {
        layer
            .attributes
            .other
            .iter()
            .find(|(k, _)| k.as_slice() == name.as_bytes())
            .map(|(_, v)| v.clone())
    };
    let text = |name: &str| match attribute(name) {
        Some(AttributeValue::Text(t)) => t.to_string(),
        other => panic!("{name}: {other:?}"),
    };
    assert_eq!(text("felt/version"), env!("CARGO_PKG_VERSION"));
    assert_eq!(text("felt/param/width"), "10");
    assert_eq!(text("felt/param/look"), "warm");
    assert!(text("felt/script").ends_with("lit.felt"));
    // The eye at z = 4 looking down −z: camera space is x right, y up, z forward, so world z
    // maps to 4 − z; the translation is the last row.
    let Some(m) = layer.attributes.world_to_camera else {
        panic!("no worldToCamera");
    };
    let expected = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 4.0, 1.0,
    ];
    for (a, b) in m.iter().zip(expected) {
        assert!((a - b).abs() < 1e-6, "{m:?}");
    }
    assert!(layer.attributes.world_to_normalized_device.is_some());
}

#[test]
fn light_names_that_clash_or_break_channels_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let scene = |lights: &str| {
        format!(
            "scalarfield rho = mask(sphere((0, 0, 0), 0.6));\n\
             camera cam = camera((0, 0, 4), (0, 0, 0), (0, 1, 0), 30);\n{lights}\n\
             render(\"x.exr\", density = rho, camera = cam, lights = {{a, b}}, width = 4, \
             height = 3, step = 0.1, aovs = {{\"lights\"}});\n"
        )
    };
    let clash = script(
        dir.path(),
        "clash.felt",
        &scene(
            "light a = distantlight((0, -1, 0), name = \"light1\");\nlight b = distantlight((0, -1, 0));",
        ),
    );
    let out = felt().arg("run").arg(&clash).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("two AOV layers are called 'light1'"),
        "{}",
        stderr(&out)
    );
    let dotted = script(
        dir.path(),
        "dotted.felt",
        &scene(
            "light a = distantlight((0, -1, 0), name = \"key.1\");\nlight b = distantlight((0, -1, 0));",
        ),
    );
    let out = felt().arg("run").arg(&dotted).output().unwrap();
    assert!(
        stderr(&out).contains("a light's name must be letters"),
        "{}",
        stderr(&out)
    );
}

/// Runs that append to one VDB file at once (a farm's tasks) take turns: every run's grid is
/// in the file at the end, in every round. Without the lock each run wrote back the file it
/// had read, and most grids were lost with every run exiting 0.
#[test]
fn concurrent_appends_to_one_vdb_keep_every_grid() {
    const RUNS: usize = 6;
    const ROUNDS: usize = 5;
    let dir = tempfile::tempdir().unwrap();
    let scenes: Vec<PathBuf> = (0..RUNS)
        .map(|i| {
            script(
                dir.path(),
                &format!("add{i}.felt"),
                &format!(
                    "domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.03125);\n\
                     scalarcache c(d);\n\
                     cachewrite(c, scalarfield({i}.5) + identity().x);\n\
                     cachesave(c, \"shared.vdb#g{i}\", append = true);\n"
                ),
            )
        })
        .collect();
    let path = dir.path().join("shared.vdb");
    for round in 0..ROUNDS {
        let _ = std::fs::remove_file(&path);
        let children: Vec<_> = scenes
            .iter()
            .map(|scene| {
                felt()
                    .arg("run")
                    .arg(scene)
                    .arg("--threads")
                    .arg("1")
                    .stdout(std::process::Stdio::null())
                    .stderr(std::process::Stdio::piped())
                    .spawn()
                    .unwrap()
            })
            .collect();
        for child in children {
            ran(child.wait_with_output().unwrap());
        }
        let mut names: Vec<String> = felt::grid::vdb::read_file(&path)
            .unwrap()
            .into_iter()
            .map(|g| g.name)
            .collect();
        names.sort();
        let every: Vec<String> = (0..RUNS).map(|i| format!("g{i}")).collect();
        assert_eq!(names, every, "round {round} lost grids");
    }
    // Each grid holds its own run's values: read back through felt's own loader.
    let check = script(
        dir.path(),
        "check.felt",
        &(0..RUNS)
            .map(|i| {
                format!("print(probe(cacheload(\"shared.vdb\", \"g{i}\"), (0.5, 0.5, 0.5)));\n")
            })
            .collect::<String>(),
    );
    let out = ran(felt().arg("run").arg(&check).output().unwrap());
    let printed: Vec<f64> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| l.parse().unwrap())
        .collect();
    assert_eq!(printed.len(), RUNS);
    for (i, value) in printed.iter().enumerate() {
        assert!((value - (i as f64 + 1.0)).abs() < 1e-5, "g{i}: {value}");
    }
    // Only the file and its lock file stay beside the scripts: no temporary is left.
    let mut left: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.ends_with(".felt"))
        .collect();
    left.sort();
    assert_eq!(left, ["shared.vdb", "shared.vdb.lock"]);
}
