//! Interrupts as a farm or a user sends them: `felt run`, `felt run --frames` over a range and
//! `felt study`, each stopped with SIGINT and with SIGTERM while a script runs, exit 130 and
//! leave no process behind: not themselves, not the `felt run` children a range or a study
//! starts, nor anything those started (checked by process group and by the recorded pids).

#![cfg(unix)]

use std::collections::BTreeSet;
use std::io::{BufRead, BufReader};
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

/// How often anything waited for here is polled, and how many polls it gets before the test
/// fails instead of hanging (6,000 polls 10 ms apart: about a minute, counted, not timed).
const POLL: Duration = Duration::from_millis(10);
const PATIENCE: u32 = 6_000;

/// A script that says it has started, then loops for minutes (the interpreter checks for an
/// interrupt at every iteration).
const LOOP: &str = "param int frame = 1;\n\
                    param int n = 1;\n\
                    print(\"started\");\n\
                    float s = 0;\n\
                    for (int i = 0; i < 2000000000; i = i + 1) { s = s + n; }\n\
                    print(s);\n";

/// One process as /proc shows it.
#[derive(Clone, Copy, Debug)]
struct Process {
    pid: i32,
    parent: i32,
    group: i32,
}

/// Every process on the machine.
fn processes() -> Vec<Process> {
    let mut all = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<i32>() else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(entry.path().join("stat")) else {
            continue; // gone since the listing
        };
        // "pid (command) state parent group ...": the command may hold spaces and parentheses.
        let Some(after) = stat.rfind(')').map(|at| &stat[at + 1..]) else {
            continue;
        };
        let fields: Vec<&str> = after.split_whitespace().collect();
        if let [_state, parent, group, ..] = fields[..] {
            all.push(Process {
                pid,
                parent: parent.parse().unwrap(),
                group: group.parse().unwrap(),
            });
        }
    }
    all
}

/// The processes descended from `root`, not counting it.
fn descendants(root: i32) -> Vec<Process> {
    let all = processes();
    let mut tree: BTreeSet<i32> = BTreeSet::from([root]);
    loop {
        let before = tree.len();
        for p in &all {
            if tree.contains(&p.parent) {
                tree.insert(p.pid);
            }
        }
        if tree.len() == before {
            break;
        }
    }
    all.into_iter()
        .filter(|p| p.pid != root && tree.contains(&p.pid))
        .collect()
}

/// Starts `felt` with `args` in `dir`, in a process group of its own (as a shell's job or a
/// farm's task is), its output piped; returns it and the lines it prints, as they come.
fn start(dir: &Path, args: &[&str]) -> (Child, mpsc::Receiver<String>) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_felt"))
        .current_dir(dir)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .process_group(0)
        .spawn()
        .unwrap();
    let (send, lines) = mpsc::channel();
    let stdout = child.stdout.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            if send.send(line).is_err() {
                break;
            }
        }
    });
    (child, lines)
}

/// Waits for the line "started" from the script.
fn wait_for_start(lines: &mpsc::Receiver<String>) {
    for _ in 0..PATIENCE {
        match lines.recv_timeout(POLL) {
            Ok(line) if line == "started" => return,
            Ok(_) | Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(e) => panic!("the script never said it started: {e}"),
        }
    }
    panic!("the script never said it started");
}

/// Polls until `felt` has a `felt run` child, and returns the pids of its descendants.
fn wait_for_children(felt: &Child) -> Vec<i32> {
    for _ in 0..PATIENCE {
        let below = descendants(felt.id() as i32);
        if !below.is_empty() {
            return below.iter().map(|p| p.pid).collect();
        }
        std::thread::sleep(POLL);
    }
    panic!("no child was started");
}

/// Sends `signal` to `felt` alone (not its group, as `kill PID` does), waits for it, and
/// returns its exit code. A `felt` still running after `PATIENCE` polls is killed with its
/// group and the test fails.
fn interrupt(felt: &mut Child, signal: libc::c_int) -> Option<i32> {
    // SAFETY: kill has no memory effects; the pid is our own unreaped child.
    assert_eq!(unsafe { libc::kill(felt.id() as i32, signal) }, 0);
    for _ in 0..PATIENCE {
        if let Some(status) = felt.try_wait().unwrap() {
            return status.code();
        }
        std::thread::sleep(POLL);
    }
    // SAFETY: as above; the group is the one `start` made for this felt.
    unsafe { libc::kill(-(felt.id() as i32), libc::SIGKILL) };
    panic!("felt did not exit within {PATIENCE} polls of the signal");
}

/// Asserts that no process of `groups` and none of `pids` is left.
fn nothing_left(groups: &[i32], pids: &[i32]) {
    let left: Vec<Process> = processes()
        .into_iter()
        .filter(|p| groups.contains(&p.group) || pids.contains(&p.pid))
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// The names of felt's temporary files anywhere under `dir`.
fn temporaries(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        if path.is_dir() {
            found.extend(temporaries(&path));
        } else if name.starts_with(".felt-") && name.ends_with(".tmp") {
            found.push(path.display().to_string());
        }
    }
    found
}

const SIGNALS: [(libc::c_int, &str); 2] = [(libc::SIGINT, "SIGINT"), (libc::SIGTERM, "SIGTERM")];

#[test]
fn an_interrupted_run_exits_130_and_leaves_no_process() {
    for (signal, name) in SIGNALS {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("loop.felt"), LOOP).unwrap();
        let (mut felt, lines) = start(dir.path(), &["run", "loop.felt", "--threads", "1"]);
        wait_for_start(&lines);
        let group = felt.id() as i32;
        assert_eq!(interrupt(&mut felt, signal), Some(130), "{name}");
        nothing_left(&[group], &[group]);
        assert_eq!(temporaries(dir.path()), Vec::<String>::new(), "{name}");
    }
}

#[test]
fn an_interrupted_frame_range_stops_its_frame_and_exits_130() {
    for (signal, name) in SIGNALS {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("loop.felt"), LOOP).unwrap();
        let (mut felt, lines) = start(
            dir.path(),
            &["run", "loop.felt", "--frames", "1-3", "--threads", "1"],
        );
        // The frame's own output comes through: its process is running the script.
        wait_for_start(&lines);
        let children = wait_for_children(&felt);
        let group = felt.id() as i32;
        assert_eq!(interrupt(&mut felt, signal), Some(130), "{name}");
        // A frame runs in a group of its own, led by the frame's process.
        let groups: Vec<i32> = [group].into_iter().chain(children.clone()).collect();
        nothing_left(&groups, &children);
        assert_eq!(temporaries(dir.path()), Vec::<String>::new(), "{name}");
    }
}

#[test]
fn an_interrupted_study_stops_its_run_and_exits_130() {
    for (signal, name) in SIGNALS {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("loop.felt"), LOOP).unwrap();
        let (mut felt, _lines) = start(
            dir.path(),
            &[
                "study",
                "loop.felt",
                "--sweep",
                "n=1,2",
                "--reference",
                "n=3",
                "--threads",
                "1",
                "--out",
                "s",
            ],
        );
        let children = wait_for_children(&felt);
        let group = felt.id() as i32;
        assert_eq!(interrupt(&mut felt, signal), Some(130), "{name}");
        let groups: Vec<i32> = [group].into_iter().chain(children.clone()).collect();
        nothing_left(&groups, &children);
        assert_eq!(temporaries(dir.path()), Vec::<String>::new(), "{name}");
    }
}
