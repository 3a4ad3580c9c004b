//! Running one setting of a study as its own `felt run` process, and measuring it.
//!
//! The one key decision: every run is a separate process, so its peak memory is its own (a
//! run inside the study's process would inherit the largest allocation of every run before
//! it). The process is reaped with `wait4`, which reports the child's CPU time (user plus
//! system, all threads) and its peak resident set together with its exit status. Wall time is
//! measured around the whole process, start-up included, as a user running the script sees it.

use super::plan::Assignments;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

/// What one run did.
#[derive(Clone, Debug, PartialEq)]
pub struct Measured {
    pub seconds: f64,
    pub cpu_seconds: f64,
    pub peak_bytes: u64,
    /// How many runs the times are the medians of.
    pub runs: u32,
    /// The process's exit code, or `None` when a signal ended it.
    pub exit: Option<i32>,
    pub stdout: String,
    pub stderr: String,
}

impl Measured {
    pub fn succeeded(&self) -> bool {
        self.exit == Some(0)
    }

    /// Why a failed run failed, in one line for the progress output: the first error line of
    /// its diagnostics, or how it ended.
    pub fn failure(&self) -> String {
        let how = match self.exit {
            Some(code) => format!("exit {code}"),
            None => String::from("killed by a signal"),
        };
        let first = self
            .stderr
            .lines()
            .map(str::trim)
            .find(|l| !l.is_empty() && !l.starts_with("Warning") && !l.starts_with('⚠'))
            .unwrap_or("");
        if first.is_empty() {
            how
        } else {
            format!("{how}: {first}")
        }
    }
}

/// How to start `felt run`.
pub struct Runner {
    pub felt: PathBuf,
    pub script: PathBuf,
    pub threads: Option<u16>,
    pub memory_limit: Option<u64>,
}

impl Runner {
    /// Runs the script once with `assignments`, its relative outputs written under `outputs`.
    pub fn run(&self, assignments: &Assignments, outputs: &Path) -> std::io::Result<Measured> {
        let mut command = Command::new(&self.felt);
        command.arg("run").arg(&self.script);
        for (name, value) in assignments {
            command.arg("--set").arg(format!("{name}={value}"));
        }
        if let Some(threads) = self.threads {
            command.arg("--threads").arg(threads.to_string());
        }
        if let Some(limit) = self.memory_limit {
            command.arg("--memory-limit").arg(limit.to_string());
        }
        command
            .arg("--output-dir")
            .arg(outputs)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        let start = Instant::now();
        // In a group of its own, so an interrupted study stops the run and all it started
        // (`crate::engine::interrupt::stop_children`) before it exits.
        let mut child = crate::engine::interrupt::spawn_child(&mut command)?;
        // Drained on their own threads so a chatty run never blocks on a full pipe.
        let drain = |pipe: Option<Box<dyn Read + Send>>| {
            std::thread::spawn(move || {
                let mut text = Vec::new();
                if let Some(mut pipe) = pipe {
                    let _ = pipe.read_to_end(&mut text);
                }
                String::from_utf8_lossy(&text).into_owned()
            })
        };
        let stdout = drain(
            child
                .stdout
                .take()
                .map(|p| Box::new(p) as Box<dyn Read + Send>),
        );
        let stderr = drain(
            child
                .stderr
                .take()
                .map(|p| Box::new(p) as Box<dyn Read + Send>),
        );
        let usage = reap(&mut child);
        crate::engine::interrupt::child_done();
        let usage = usage?;
        let seconds = start.elapsed().as_secs_f64();
        Ok(Measured {
            seconds,
            cpu_seconds: usage.cpu_seconds,
            peak_bytes: usage.peak_bytes,
            runs: 1,
            exit: usage.exit,
            stdout: stdout.join().unwrap_or_default(),
            stderr: stderr.join().unwrap_or_default(),
        })
    }
}

struct Usage {
    cpu_seconds: f64,
    peak_bytes: u64,
    exit: Option<i32>,
}

/// Waits for `child` and returns its resource use.
#[cfg(unix)]
fn reap(child: &mut std::process::Child) -> std::io::Result<Usage> {
    let pid = child.id() as libc::pid_t;
    let mut status: libc::c_int = 0;
    // SAFETY: `rusage` is plain old data that wait4 fills in; zeroed is a valid value of it.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    loop {
        // SAFETY: `pid` is our own unreaped child (std has not waited on it), and both
        // pointers are to live, writable locals.
        let reaped = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
        if reaped == pid {
            break;
        }
        let error = std::io::Error::last_os_error();
        if error.kind() != std::io::ErrorKind::Interrupted {
            return Err(error);
        }
    }
    let time = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    // Linux reports the peak resident set in KiB, macOS in bytes.
    let unit = if cfg!(target_os = "macos") { 1 } else { 1024 };
    let exit = if libc::WIFEXITED(status) {
        Some(libc::WEXITSTATUS(status))
    } else {
        None
    };
    Ok(Usage {
        cpu_seconds: time(usage.ru_utime) + time(usage.ru_stime),
        peak_bytes: (usage.ru_maxrss.max(0) as u64) * unit,
        exit,
    })
}

/// Without `wait4`: the exit status only; CPU time and memory are unknown.
#[cfg(not(unix))]
fn reap(child: &mut std::process::Child) -> std::io::Result<Usage> {
    let status = child.wait()?;
    Ok(Usage {
        cpu_seconds: f64::NAN,
        peak_bytes: 0,
        exit: status.code(),
    })
}

/// The median of `values` (the mean of the middle two for an even count).
pub fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(|a, b| a.total_cmp(b));
    let n = sorted.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => sorted[n / 2],
        _ => 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(&[]).is_nan());
    }

    #[cfg(unix)]
    #[test]
    fn a_process_that_allocates_shows_its_peak_and_cpu_time() {
        // A shell loop uses measurable CPU time; any process's peak is over a hundred KiB.
        let mut child = Command::new("sh")
            .arg("-c")
            .arg("i=0; while [ $i -lt 20000 ]; do i=$((i+1)); done; exit 3")
            .spawn()
            .unwrap();
        let usage = reap(&mut child).unwrap();
        assert_eq!(usage.exit, Some(3));
        assert!(usage.cpu_seconds > 0.0);
        assert!(usage.peak_bytes > 100 << 10);
    }
}
