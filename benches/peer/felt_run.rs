//! What the peer benchmarks share: running a felt script in a fresh session with its output
//! captured, reading numbers it printed, and the process's CPU time (other work shares the
//! machine, so CPU time is reported next to wall time).

use felt::session::Session;
use std::io::Write;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// A `Write` the bench can read back after the session is done with it.
#[derive(Clone, Default)]
struct Captured(Arc<Mutex<Vec<u8>>>);

impl Write for Captured {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Runs a script in a fresh session; returns the wall and CPU seconds of `run_file` and what
/// it printed. A script that fails stops the benchmark with its messages.
pub fn run_felt(path: &Path) -> (f64, f64, String) {
    let out = Captured::default();
    let mut session = match Session::new(Box::new(out.clone())) {
        Ok(s) => s,
        Err(_) => panic!("the standard library failed to load"),
    };
    let (start, cpu_start) = (Instant::now(), cpu_seconds().0);
    let result = session.run_file(path);
    let seconds = start.elapsed().as_secs_f64();
    let cpu = cpu_seconds().0 - cpu_start;
    if let Err(diagnostics) = result {
        let messages: Vec<&str> = diagnostics.iter().map(|d| d.message.as_str()).collect();
        panic!("{} failed: {messages:?}", path.display());
    }
    let text =
        String::from_utf8_lossy(&out.0.lock().unwrap_or_else(|e| e.into_inner())).into_owned();
    (seconds, cpu, text)
}

/// The number after `key` on the line that starts with it.
pub fn printed(text: &str, key: &str) -> Option<f64> {
    text.lines()
        .find_map(|l| l.strip_prefix(key))
        .and_then(|rest| rest.trim().parse().ok())
}

/// CPU seconds (user + system) used so far by this process and by its waited-for children,
/// from `/proc/self/stat` (ticks of 1/100 s); zeros where that file does not exist.
pub fn cpu_seconds() -> (f64, f64) {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return (0.0, 0.0);
    };
    // Fields after the parenthesised command name: utime, stime, cutime, cstime are 14–17.
    let after_name = stat.rsplit(')').next().unwrap_or("");
    let fields: Vec<&str> = after_name.split_whitespace().collect();
    let ticks = |n: usize| {
        fields
            .get(n)
            .and_then(|f| f.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    (
        (ticks(11) + ticks(12)) / 100.0,
        (ticks(13) + ticks(14)) / 100.0,
    )
}

pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}
