//! The `felt` command as a user runs it: exit codes, `check`, `doc`, `--set`, and the REPL
//! driven through a real terminal (tmux), when tmux is installed.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::Duration;

fn felt() -> Command {
    Command::new(env!("CARGO_BIN_EXE_felt"))
}

/// Runs `felt` with `args`, failing the test (not hanging it) if it never ends: the cases
/// that use this would block forever on the bug they guard against (a device or FIFO read to
/// its end), so the guard is far beyond any run's time on a loaded machine, not a speed check.
fn felt_within(args: &[&str]) -> Output {
    // Polled every 20 ms, up to 30,000 times.
    let polls = 30_000;
    let mut child = felt()
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    for _ in 0..polls {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap();
    let _ = child.wait();
    panic!("`felt {}` never ended", args.join(" "));
}

#[test]
fn exit_codes_follow_the_outcome() {
    let ok = felt()
        .args(["run", "tests/scripts/lang/values.felt"])
        .output()
        .unwrap();
    assert_eq!(
        ok.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let script_error = felt()
        .args(["run", "tests/scripts/errors/unknown_variable.felt"])
        .output()
        .unwrap();
    assert_eq!(script_error.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&script_error.stderr);
    assert!(stderr.contains("unknown_variable.felt:2:7"), "{stderr}");
    let usage = felt().args(["run"]).output().unwrap();
    assert_eq!(usage.status.code(), Some(2));
    let bad_set = felt()
        .args(["run", "tests/scripts/lang/params.felt", "--set", "nosuch=1"])
        .output()
        .unwrap();
    assert_eq!(bad_set.status.code(), Some(2));
    let missing = felt()
        .args(["run", "tests/scripts/does_not_exist.felt"])
        .output()
        .unwrap();
    assert_eq!(missing.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&missing.stderr).contains("cannot read"));
}

#[test]
fn set_overrides_params_from_the_command_line() {
    let out = felt()
        .args([
            "run",
            "tests/scripts/lang/params.felt",
            "--set",
            "step=0.5",
            "--set",
            "name=take2",
        ])
        .output()
        .unwrap();
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        "0.5 3 take2 (0.0, 1.0, 0.0)\n"
    );
}

#[test]
fn check_reports_without_running() {
    let out = felt()
        .args(["check", "tests/scripts/lang/strings.felt"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stdout).contains("no errors"));
    let bad = felt()
        .args(["check", "tests/scripts/errors/several_errors.felt"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(1));
    assert_eq!(
        String::from_utf8_lossy(&bad.stderr)
            .matches("felt::type")
            .count(),
        3
    );
}

/// `felt check --set` reads each value as `felt run --set` would, without running anything:
/// a value of the wrong type, or a param the script does not declare, is a usage error (exit
/// 2) at the declaration, and a good value passes.
#[test]
fn check_reads_set_values_as_run_does() {
    let check = |set: &str| {
        let out = felt()
            .args(["check", "tests/scripts/lang/params.felt", "--set", set])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        let stderr = stderr.split_whitespace().collect::<Vec<_>>().join(" ");
        (
            out.status.code(),
            stderr,
            String::from_utf8_lossy(&out.stdout).to_string(),
        )
    };
    let (code, stderr, stdout) = check("frames=2");
    assert_eq!(code, Some(0), "{stderr}");
    // Checked, not run: the script's print did not happen.
    assert_eq!(stdout.trim(), "tests/scripts/lang/params.felt: no errors");
    let (code, stderr, _) = check("frames=2.5");
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains("--set frames=2.5: expected an int, found `2.5`"),
        "{stderr}"
    );
    assert!(stderr.contains("params.felt:3:11"), "{stderr}");
    let (code, stderr, _) = check("offset=(1, 2)");
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains("expected a vector like (1, 2, 3)"),
        "{stderr}"
    );
    let (code, stderr, _) = check("frame=2");
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains("the script has no param named `frame`"),
        "{stderr}"
    );
    assert!(stderr.contains("did you mean `frames`?"), "{stderr}");
}

/// A wrong type given to `felt run --set` is found before the first statement runs, so a
/// long script does not fail at its end.
#[test]
fn run_rejects_a_set_value_of_the_wrong_type_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("late_param.felt");
    std::fs::write(
        &script,
        "print(\"started\");\nparam float step = 0.01;\nprint(step);\n",
    )
    .unwrap();
    let out = felt()
        .args(["run", script.to_str().unwrap(), "--set", "step=fast"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(
        out.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("expected a float, found `fast`"));
}

#[test]
fn doc_lists_and_describes_builtins() {
    let index = felt().args(["doc"]).output().unwrap();
    let text = String::from_utf8_lossy(&index.stdout);
    assert!(text.contains("print") && text.contains("format"), "{text}");
    let one = felt().args(["doc", "size"]).output().unwrap();
    let text = String::from_utf8_lossy(&one.stdout);
    assert!(text.contains("size(any[] a) -> int"), "{text}");
    let unknown = felt().args(["doc", "sise"]).output().unwrap();
    assert_eq!(unknown.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&unknown.stderr).contains("did you mean `size`?"));
}

/// miette panics on a label past column ~65,530; long lines are cut around the label, and the
/// header still gives the line and column in the file as written.
#[test]
fn diagnostics_on_very_long_lines_keep_their_place() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("long.felt");
    let script = format!("float a = 1.0;\n{}undefined_name;\n", " ".repeat(70_000));
    std::fs::write(&path, script).unwrap();
    let path = path.to_str().unwrap();
    for command in ["check", "run"] {
        let out = felt().args([command, path]).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "felt {command}: {stderr}");
        assert!(
            stderr.contains("unknown variable `undefined_name`"),
            "felt {command}: {stderr}"
        );
        assert!(
            stderr.contains("long.felt:2:70001]"),
            "felt {command}: {stderr}"
        );
        assert!(
            stderr.lines().all(|line| line.chars().count() < 400),
            "felt {command}: the long line was not cut"
        );
    }
}

/// Scripts that used to hang or panic the command: 20,000 unknown names (rendering every
/// diagnostic scanned the file from its start: quadratic) and runs of 100,000 signs (miette
/// panicked on the label far along the line). Each is a prompt, clean diagnostic.
#[test]
fn pathological_scripts_give_prompt_diagnostics() {
    let dir = tempfile::tempdir().unwrap();
    let unknown: String = (0..20_000)
        .map(|i| format!("print(unknown{i});\n"))
        .collect();
    let cases = [
        ("unknown.felt", unknown, "… and 19900 more errors"),
        (
            "signs.felt",
            format!("print({}1);\n", "-".repeat(100_000)),
            "unexpected `--`, expected an expression",
        ),
        (
            "nested.felt",
            format!("print({}1{});\n", "-(".repeat(100_000), ")".repeat(100_000)),
            "expression nested too deeply (more than 256 levels)",
        ),
    ];
    for (name, script, message) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, script).unwrap();
        let path = path.to_str().unwrap();
        for command in ["check", "run"] {
            let out = felt_within(&[command, path]);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(
                out.status.code(),
                Some(1),
                "felt {command} {name}: {stderr}"
            );
            assert!(stderr.contains(message), "felt {command} {name}: {stderr}");
            assert!(
                stderr.lines().all(|line| line.chars().count() < 400),
                "felt {command} {name}: a long line was not cut"
            );
        }
    }
}

#[test]
fn thread_counts_are_checked_before_the_pool_starts() {
    let absurd = felt()
        .args(["run", "--threads", "4000", "tests/scripts/lang/values.felt"])
        .output()
        .unwrap();
    assert_eq!(absurd.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&absurd.stderr);
    assert!(stderr.contains("1..=1024"), "{stderr}");
    let two = felt()
        .args(["run", "--threads", "2", "tests/scripts/lang/values.felt"])
        .output()
        .unwrap();
    assert_eq!(
        two.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&two.stderr)
    );
}

/// Scripts, imports and VDB files are read only from regular files, and scripts only up to
/// 64 MiB: a device never ends, a FIFO blocks until someone writes to it.
#[cfg(unix)]
#[test]
fn only_regular_files_are_read() {
    let zero = felt_within(&["run", "/dev/zero"]);
    assert_eq!(zero.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&zero.stderr);
    assert!(
        stderr.contains("/dev/zero") && stderr.contains("not a regular file"),
        "{stderr}"
    );

    let dir = tempfile::tempdir().unwrap();
    let importer = dir.path().join("importer.felt");
    std::fs::write(&importer, "print(1);\nimport \"/dev/zero\";\n").unwrap();
    let import = felt_within(&["run", importer.to_str().unwrap()]);
    assert_eq!(import.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&import.stderr);
    assert!(
        stderr.contains("importer.felt:2:1]") && stderr.contains("not a regular file"),
        "{stderr}"
    );

    let huge = dir.path().join("huge.felt");
    std::fs::File::create(&huge)
        .unwrap()
        .set_len((64 << 20) + 1)
        .unwrap();
    let too_big = felt_within(&["check", huge.to_str().unwrap()]);
    assert_eq!(too_big.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&too_big.stderr);
    assert!(
        stderr.contains("huge.felt") && stderr.contains("larger than 64 MiB"),
        "{stderr}"
    );

    let fifo = dir.path().join("grid.vdb");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    for (load, kind) in [
        ("cacheload", "scalarfield"),
        ("cacheloadvector", "vectorfield"),
    ] {
        let script = dir.path().join(format!("{load}.felt"));
        std::fs::write(
            &script,
            format!(
                "{kind} f = {load}({:?}, \"density\");\n",
                fifo.to_str().unwrap()
            ),
        )
        .unwrap();
        let out = felt_within(&["run", script.to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(1));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.contains(&format!("{load}.felt:1:")) && stderr.contains("not a regular file"),
            "{stderr}"
        );
    }

    // A shape file that is a FIFO is refused the same way.
    let pipe = dir.path().join("mesh.obj");
    assert!(
        Command::new("mkfifo")
            .arg(&pipe)
            .status()
            .unwrap()
            .success()
    );
    let script = dir.path().join("shape.felt");
    std::fs::write(
        &script,
        format!("shape s = loadshape({:?});\n", pipe.to_str().unwrap()),
    )
    .unwrap();
    let out = felt_within(&["run", script.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("shape.felt:1:") && stderr.contains("it is a FIFO (named pipe)"),
        "{stderr}"
    );
}

/// Drives `felt repl` in a tmux pane: a function over several lines, a call, an error, and a
/// session that keeps going with its state.
#[test]
fn repl_in_a_real_terminal() {
    if Command::new("tmux").arg("-V").output().is_err() {
        eprintln!("tmux not installed; skipping the terminal test");
        return;
    }
    let session = format!("felt-test-{}", std::process::id());
    let history = tempfile::NamedTempFile::new().unwrap();
    let exe = Path::new(env!("CARGO_BIN_EXE_felt"));
    let tmux = |args: &[&str]| Command::new("tmux").args(args).output().unwrap();
    let started = tmux(&[
        "new-session",
        "-d",
        "-s",
        &session,
        "-x",
        "120",
        "-y",
        "50",
        &format!(
            "FELT_HISTORY={} {} repl",
            history.path().display(),
            exe.display()
        ),
    ]);
    assert!(
        started.status.success(),
        "{}",
        String::from_utf8_lossy(&started.stderr)
    );
    let wait_for = |needle: &str| -> String {
        for _ in 0..400 {
            std::thread::sleep(std::time::Duration::from_millis(50));
            let pane =
                String::from_utf8_lossy(&tmux(&["capture-pane", "-p", "-t", &session]).stdout)
                    .into_owned();
            if pane.contains(needle) {
                return pane;
            }
        }
        let pane = String::from_utf8_lossy(&tmux(&["capture-pane", "-p", "-t", &session]).stdout)
            .into_owned();
        tmux(&["kill-session", "-t", &session]);
        panic!("`{needle}` never appeared:\n{pane}");
    };
    let pane_now = || {
        String::from_utf8_lossy(&tmux(&["capture-pane", "-p", "-t", &session]).stdout).into_owned()
    };
    // The last line with text on it, as the terminal shows it now.
    let last_line = || {
        pane_now()
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("")
            .trim_end()
            .to_string()
    };
    let settle = |ready: &dyn Fn(&str) -> bool, what: &str| {
        for _ in 0..400 {
            if ready(&last_line()) {
                return;
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
        let pane = pane_now();
        tmux(&["kill-session", "-t", &session]);
        panic!("{what} never appeared:\n{pane}");
    };
    // A line editor may drop keys typed while it evaluates the previous line, so each line
    // is typed only at an empty prompt, and Enter is pressed only once the text shows.
    let send = |line: &str| {
        settle(&|l| l == "felt>" || l == "...>", "an empty prompt");
        // tmux reads a trailing `;` as its own command separator unless escaped.
        let keys = match line.strip_suffix(';') {
            Some(head) => format!("{head}\\;"),
            None => line.to_string(),
        };
        tmux(&["send-keys", "-t", &session, "-l", &keys]);
        settle(&|l| l.ends_with(line.trim_end()), "the typed line");
        tmux(&["send-keys", "-t", &session, "Enter"]);
    };
    wait_for("felt>");
    send("func float cube(float x) {");
    send("    return x * x * x;");
    send("}");
    // Each line after the first of an open input has the continuation prompt.
    let pane = wait_for("...> }");
    assert!(pane.contains("...>     return x * x * x;"), "{pane}");
    send("cube(3)");
    wait_for("27.0");
    send("cube(undefined_name)");
    wait_for("unknown variable `undefined_name`");
    send("float y = cube(2) + 1");
    send("y * 2");
    wait_for("18.0");
    send(":type y");
    let pane = wait_for("float");
    tmux(&["send-keys", "-t", &session, ":quit", "Enter"]);
    tmux(&["kill-session", "-t", &session]);
    assert!(pane.contains("felt>"));
}

/// Runs `source` as a script under `--memory-limit MB`, within a minute.
fn run_under_budget(source: &str, megabytes: u32) -> (Option<i32>, String) {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("budget.felt");
    std::fs::write(&script, source).unwrap();
    let out = felt_within(&[
        "run",
        script.to_str().unwrap(),
        "--memory-limit",
        &megabytes.to_string(),
    ]);
    // The renderer wraps long messages: hand back the words, one space apart.
    let stderr = String::from_utf8_lossy(&out.stderr);
    let words: Vec<&str> = stderr.split_whitespace().filter(|w| *w != "│").collect();
    (out.status.code(), words.join(" "))
}

#[test]
fn the_memory_budget_covers_the_whole_run() {
    // Each cache of 100³ cells takes 3.8 MiB once written: two fit a 10 MiB budget, the
    // third does not, and the message is at the third's line.
    let (code, stderr) = run_under_budget(
        "domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.01);\n\
         scalarcache a(d);\nscalarcache b(d);\nscalarcache c(d);\n\
         cachewrite(a, scalarfield(1));\ncachewrite(b, scalarfield(2));\n\
         cachewrite(c, scalarfield(3));\n",
        10,
    );
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains("budget.felt:7:") && stderr.contains("over the memory budget of 10.0 MiB"),
        "{stderr}"
    );
    assert!(stderr.contains("7.6 MiB of it already held"), "{stderr}");
    // A cache no value refers to any more gives its memory back.
    let (code, stderr) = run_under_budget(
        "domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.01);\n\
         for (int i = 0; i < 6; i++) { scalarcache c(d); cachewrite(c, scalarfield(i)); }\n",
        10,
    );
    assert_eq!(code, Some(0), "{stderr}");
    // A string doubled 40 times, an image too large for memory: refused before allocating.
    let (code, stderr) = run_under_budget(
        "string s = \"ab\";\nfor (int i = 0; i < 40; i++) { s = s + s; }\n",
        64,
    );
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains("budget.felt:2:") && stderr.contains("a string of"),
        "{stderr}"
    );
    let (code, stderr) = run_under_budget(
        "camera cam = camera((0, 0, 3), (0, 0, 0), (0, 1, 0), 40);\n\
         render(\"big.exr\", density = scalarfield(1), camera = cam, width = 20000,\n\
                height = 20000, bounds = domain((-1, -1, -1), (2, 2, 2), (0, 0, 0)));\n",
        1024,
    );
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("a 20000 x 20000 image"), "{stderr}");
    // gaussiannoise's FFT buffers are counted before the transform.
    let (code, stderr) = run_under_budget(
        "domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 1.0 / 200);\n\
         scalarfield n = gaussiannoise(d, 0.05);\nprint(probe(n, (0.5, 0.5, 0.5)));\n",
        100,
    );
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("over the memory budget"), "{stderr}");
}

#[cfg(unix)]
#[test]
fn an_address_space_limit_lowers_the_default_budget() {
    // Under `ulimit -v` of 2 GB the default budget is half of it, so a 4 GB grid is a
    // diagnostic at its line, not an abort when the allocation fails.
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("big.felt");
    std::fs::write(
        &script,
        "domain d((0, 0, 0), (1, 1, 1), (0, 0, 0), 0.001);\nscalarcache c(d);\n",
    )
    .unwrap();
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v 2000000 && exec '{}' run '{}'",
            env!("CARGO_BIN_EXE_felt"),
            script.display()
        ))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("big.felt:1:")
            && stderr.contains("over the memory budget")
            && stderr.contains("976.6 MiB"),
        "{stderr}"
    );
}

#[cfg(unix)]
#[test]
fn sigterm_during_a_write_leaves_no_temporary() {
    // A large image takes seconds to encode: wait until its temporary file exists, then stop
    // felt. The temporary must go with it, and the exit status says it was interrupted.
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("big.felt");
    std::fs::write(
        &script,
        "camera cam = camera((0, 0, 3), (0, 0, 0), (0, 1, 0), 40);\n\
         render(\"big.exr\", density = scalarfield(0), camera = cam, width = 3000, height = 3000,\n\
                bounds = domain((-1, -1, -1), (2, 2, 2), (0, 0, 0)));\n",
    )
    .unwrap();
    let mut child = felt()
        .current_dir(dir.path())
        .args(["run", "big.felt"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let temporaries = || -> Vec<String> {
        std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(".felt-") && n.ends_with(".tmp"))
            .collect()
    };
    while temporaries().is_empty() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "felt finished before its temporary was seen"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    assert_eq!(temporaries(), Vec::<String>::new());
    assert!(!dir.path().join("big.exr").exists());
}
