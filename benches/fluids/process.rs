//! Running a program as a child process and measuring it as a whole: wall seconds, CPU seconds
//! (user + system) and peak resident memory, all of that child alone. The fluid benchmarks use
//! it for felt and for the numpy baseline alike, so both are measured the same way.
//!
//! The one key decision: the child is reaped with `wait4`, which returns that child's own
//! resource usage. `getrusage(RUSAGE_CHILDREN)` would give the largest peak of *all* children
//! so far, and reading `/proc/PID/status` races the child's exit. On targets other than 64-bit
//! Linux the child is waited for normally and CPU time and memory are NaN.

use std::io::Read;
use std::process::{Command, Stdio};
use std::time::Instant;

/// What a finished child did.
pub struct Finished {
    pub success: bool,
    pub stdout: String,
    pub stderr: String,
    pub wall: f64,
    /// User + system CPU seconds.
    pub cpu: f64,
    /// Peak resident set size in bytes.
    pub max_rss: f64,
}

#[cfg(all(target_os = "linux", target_pointer_width = "64"))]
mod sys {
    // `struct rusage` on 64-bit Linux: two `struct timeval`s (seconds, microseconds) then
    // fourteen `long`s, of which the first is ru_maxrss in KiB.
    pub type Rusage = [i64; 18];
    unsafe extern "C" {
        pub fn wait4(pid: i32, status: *mut i32, options: i32, rusage: *mut Rusage) -> i32;
    }
}

/// Runs `command` to its end with its output captured.
pub fn run(command: &mut Command) -> Finished {
    let start = Instant::now();
    let mut child = command
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {command:?}: {e}"));
    let mut err_pipe = child.stderr.take().expect("piped stderr");
    let err_reader = std::thread::spawn(move || {
        let mut text = Vec::new();
        let _ = err_pipe.read_to_end(&mut text);
        text
    });
    let mut stdout = Vec::new();
    let _ = child
        .stdout
        .take()
        .expect("piped stdout")
        .read_to_end(&mut stdout);
    let (success, cpu, max_rss) = reap(child);
    let wall = start.elapsed().as_secs_f64();
    let stderr = err_reader.join().unwrap_or_default();
    Finished {
        success,
        stdout: String::from_utf8_lossy(&stdout).into_owned(),
        stderr: String::from_utf8_lossy(&stderr).into_owned(),
        wall,
        cpu,
        max_rss,
    }
}

#[cfg(all(target_os = "linux", target_pointer_width = "64"))]
fn reap(child: std::process::Child) -> (bool, f64, f64) {
    let pid = child.id() as i32;
    let mut status = 0i32;
    let mut usage: sys::Rusage = [0; 18];
    // SAFETY: `status` and `usage` are valid for writes of the sizes wait4 writes on this
    // target; the child has not been waited for yet, and `child` is not waited for afterwards
    // (dropping a `Child` does not wait).
    let reaped = loop {
        let r = unsafe { sys::wait4(pid, &mut status, 0, &mut usage) };
        if r == pid {
            break true;
        }
        if r == -1 && std::io::Error::last_os_error().kind() == std::io::ErrorKind::Interrupted {
            continue;
        }
        break false;
    };
    drop(child);
    assert!(reaped, "wait4 failed on child {pid}");
    let exited_zero = status & 0x7f == 0 && (status >> 8) & 0xff == 0;
    let seconds = |sec: i64, usec: i64| sec as f64 + usec as f64 * 1e-6;
    let cpu = seconds(usage[0], usage[1]) + seconds(usage[2], usage[3]);
    (exited_zero, cpu, usage[4] as f64 * 1024.0)
}

#[cfg(not(all(target_os = "linux", target_pointer_width = "64")))]
fn reap(mut child: std::process::Child) -> (bool, f64, f64) {
    let success = child.wait().is_ok_and(|s| s.success());
    (success, f64::NAN, f64::NAN)
}

/// Every number on every line that starts with `key` followed by a space, line by line.
pub fn numbers(text: &str, key: &str) -> Vec<Vec<f64>> {
    text.lines()
        .filter_map(|l| l.strip_prefix(key)?.strip_prefix(' '))
        .map(|rest| {
            rest.split(|c: char| c.is_whitespace() || c == ',' || c == '(' || c == ')')
                .filter(|t| !t.is_empty())
                .filter_map(|t| t.parse().ok())
                .collect()
        })
        .collect()
}

/// The first number of each line that starts with `key`.
pub fn series(text: &str, key: &str) -> Vec<f64> {
    numbers(text, key)
        .into_iter()
        .filter_map(|v| v.first().copied())
        .collect()
}

/// A size in bytes as `--profile` prints it: `771.0 KiB`, `48.2 MiB`, `12 B`.
pub fn parse_bytes(number: &str, unit: &str) -> Option<f64> {
    let scale = match unit {
        "B" => 1.0,
        "KiB" => 1024.0,
        "MiB" => 1024.0 * 1024.0,
        "GiB" => 1024.0 * 1024.0 * 1024.0,
        _ => return None,
    };
    Some(number.parse::<f64>().ok()? * scale)
}

pub fn mib(bytes: f64) -> f64 {
    bytes / (1024.0 * 1024.0)
}

/// The 1, 5 and 15 minute load averages, from `/proc/loadavg` (other work shares the machine:
/// a load above its core count means the figures were measured under contention).
pub fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}
