//! A simulation step in farm jobs (`felt farm ... --sim`): the simulation runs once, over every
//! frame in order, and the render bands read the caches it wrote.

use super::*;

/// The simulation and render halves of a farm job, copied into one folder.
fn simulated_scene() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("smoke_sim.felt");
    let shot = dir.path().join("smoke_shot.felt");
    std::fs::copy("tests/scripts/farm/smoke_sim.felt", &sim).unwrap();
    std::fs::copy("tests/scripts/farm/smoke_shot.felt", &shot).unwrap();
    (dir, sim, shot)
}

/// The simulated frames 1-3 made on one machine: the simulation run, then the shot.
fn simulated_reference() -> tempfile::TempDir {
    let reference = tempfile::tempdir().unwrap();
    for script in ["smoke_sim", "smoke_shot"] {
        assert_ok(&run(&[
            "run",
            &format!("tests/scripts/farm/{script}.felt"),
            "--frames",
            "1-3",
            "--output-dir",
            &dir_arg(reference.path()),
        ]));
    }
    reference
}

fn simulated_job(engine: &str, shot: &Path, sim: &Path, out: &Path) -> Output {
    run(&[
        "farm",
        engine,
        &shot.display().to_string(),
        "--sim",
        &sim.display().to_string(),
        "--frames",
        "1-3",
        "--tiles",
        "2",
        "--out",
        &out.display().to_string(),
    ])
}

/// How many times each frame was simulated, from the simulation's printed lines in `log`.
fn simulated_frames(log: &str) -> Vec<usize> {
    (1..=3)
        .map(|f| log.matches(&format!("simulated frame {f}\n")).count())
        .collect()
}

/// Each cache file's identity (device, inode, modification time): an atomic rewrite changes it.
fn cache_identities(dir: &Path) -> Vec<(u64, u64, std::time::SystemTime)> {
    use std::os::unix::fs::MetadataExt;
    (1..=3)
        .map(|f| {
            let m = std::fs::metadata(dir.join(format!("smoke_cache.{f:04}.vdb"))).unwrap();
            (m.dev(), m.ino(), m.modified().unwrap())
        })
        .collect()
}

#[track_caller]
fn assert_simulated_frames_match(reference: &Path, farm: &Path) {
    for frame in 1..=3 {
        let name = format!("smoke.{frame:04}.exr");
        assert_same_image(&reference.join(&name), &farm.join(&name));
    }
}

#[test]
fn a_simulation_runs_once_and_the_bands_render_from_its_caches() {
    let (dir, sim, shot) = simulated_scene();
    let render = dir.path().join("job.sh");
    assert_ok(&simulated_job("slurm", &shot, &sim, &render));
    let sim_job = std::fs::read_to_string(dir.path().join("job.sim.sh")).unwrap();
    assert!(!sim_job.contains("--array"), "one task: {sim_job}");
    let submit = std::fs::read_to_string(dir.path().join("job.submit.sh")).unwrap();
    let (before, after) = submit.split_once("render=$(").unwrap();
    assert!(before.contains("job.sim.sh"), "{submit}");
    assert!(
        after.starts_with("sbatch --parsable --dependency=afterok:\"${sim%%;*}\""),
        "{submit}"
    );
    let render_job = std::fs::read_to_string(&render).unwrap();
    assert!(!render_job.contains("smoke_sim"), "{render_job}");
    // The simulation job, then each array task as Slurm starts it, from another folder.
    let out = Command::new("bash")
        .arg(dir.path().join("job.sim.sh"))
        .current_dir("/")
        .output()
        .unwrap();
    assert_ok(&out);
    let mut log = text(&out.stdout);
    let caches = cache_identities(dir.path());
    for (script, tasks) in [(&render, 6), (&dir.path().join("job.merge.sh"), 3)] {
        for id in 0..tasks {
            let out = Command::new("bash")
                .arg(script)
                .env("SLURM_ARRAY_TASK_ID", id.to_string())
                .current_dir("/")
                .output()
                .unwrap();
            assert_ok(&out);
            log.push_str(&text(&out.stdout));
        }
    }
    assert_eq!(simulated_frames(&log), [1, 1, 1], "{log}");
    assert_eq!(
        cache_identities(dir.path()),
        caches,
        "no render task rewrote a cache"
    );
    assert_simulated_frames_match(simulated_reference().path(), dir.path());
}

#[test]
fn a_simulation_step_needs_a_script_with_a_frame() {
    let (dir, _, shot) = simulated_scene();
    let still = dir.path().join("still.felt");
    std::fs::write(&still, "print(1);\n").unwrap();
    let out = dir.path().join("job.yaml");
    let refused = simulated_job("openjd", &shot, &still, &out);
    assert_eq!(refused.status.code(), Some(2));
    assert!(
        text(&refused.stderr).contains("declares no `param int frame`"),
        "{}",
        text(&refused.stderr)
    );
    let refused = run(&[
        "farm",
        "openjd",
        &shot.display().to_string(),
        "--sim",
        &dir.path().join("smoke_sim.felt").display().to_string(),
        "--sim-set",
        "resolution=8",
        "--frames",
        "1-3",
        "--out",
        &out.display().to_string(),
    ]);
    assert_eq!(refused.status.code(), Some(2));
    assert!(
        text(&refused.stderr).contains("--set resolution"),
        "{}",
        text(&refused.stderr)
    );
    assert!(!out.exists());
}

/// Opt-in: `openjd run` runs the simulation step once, then the bands and the merge, making
/// the frames a single machine makes.
#[test]
fn openjd_cli_runs_the_simulation_once_before_the_bands() {
    if !peer("openjd") {
        return;
    }
    let (dir, sim, shot) = simulated_scene();
    let job = dir.path().join("job.yaml");
    assert_ok(&simulated_job("openjd", &shot, &sim, &job));
    assert_ok(
        &Command::new("openjd")
            .arg("check")
            .arg(&job)
            .output()
            .unwrap(),
    );
    let ran = Command::new("openjd")
        .arg("run")
        .arg(&job)
        .args(["--step", "merge", "--run-dependencies"])
        .output()
        .unwrap();
    assert_ok(&ran);
    let log = text(&ran.stdout) + &text(&ran.stderr);
    assert_eq!(simulated_frames(&log), [1, 1, 1], "{log}");
    assert_simulated_frames_match(simulated_reference().path(), dir.path());
}

/// Opt-in: on a real single-node Slurm the submit script runs the simulation job, the render
/// array after it and the merge after that, making the frames a single machine makes.
#[test]
fn slurm_runs_the_simulation_then_the_array_and_the_merge() {
    if !slurm_node_up() {
        return;
    }
    let (dir, sim, shot) = simulated_scene();
    let render = dir.path().join("job.sh");
    assert_ok(&simulated_job("slurm", &shot, &sim, &render));
    let submitted = Command::new("sh")
        .arg(dir.path().join("job.submit.sh"))
        .arg("--wait")
        .arg(format!("--output={}/slurm-%A_%a.out", dir.path().display()))
        .current_dir("/")
        .output()
        .unwrap();
    assert_ok(&submitted);
    let mut log = String::new();
    for entry in std::fs::read_dir(dir.path()).unwrap() {
        let path = entry.unwrap().path();
        if path
            .file_name()
            .unwrap()
            .to_string_lossy()
            .starts_with("slurm-")
        {
            log.push_str(&std::fs::read_to_string(&path).unwrap());
        }
    }
    assert_eq!(simulated_frames(&log), [1, 1, 1], "{log}");
    assert_simulated_frames_match(simulated_reference().path(), dir.path());
}
