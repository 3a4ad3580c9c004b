//! A render's progress on standard error: the indicatif bar on a terminal, and on anything
//! else (a farm's log file) a plain line every few seconds.
//!
//! The one key decision: a log gets whole lines that never redraw, each saying which frame,
//! how far and how long, so a farm's log viewer shows a render's state at its last line and
//! a grep for `felt: frame` tells the whole story. Renders shorter than the first interval say
//! nothing. The interval is `FELT_PROGRESS_SECONDS` (default 5; 0 reports every tile).

use std::io::IsTerminal;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Seconds between plain progress lines, unless `FELT_PROGRESS_SECONDS` says otherwise.
const DEFAULT_INTERVAL: f64 = 5.0;

/// Seconds before the terminal bar appears.
const BAR_DELAY: Duration = Duration::from_secs(1);

pub struct Progress {
    bar: indicatif::ProgressBar,
    terminal: bool,
    shown: AtomicBool,
    started: Instant,
    total: u64,
    /// Plain lines: tiles done, and when the last line was written.
    plain: Mutex<(u64, Option<Instant>)>,
    interval: Duration,
}

impl Progress {
    pub fn new(tiles: u64) -> Progress {
        let bar = indicatif::ProgressBar::hidden();
        bar.set_length(tiles);
        Progress {
            bar,
            terminal: std::io::stderr().is_terminal(),
            shown: AtomicBool::new(false),
            started: Instant::now(),
            total: tiles,
            plain: Mutex::new((0, None)),
            interval: interval(std::env::var("FELT_PROGRESS_SECONDS").ok().as_deref()),
        }
    }

    pub fn tick(&self) {
        if !self.terminal {
            self.tick_plain();
            return;
        }
        if !self.shown.load(Ordering::Relaxed)
            && self.started.elapsed() > BAR_DELAY
            && !self.shown.swap(true, Ordering::Relaxed)
        {
            self.bar
                .set_draw_target(indicatif::ProgressDrawTarget::stderr());
            if let Ok(style) = indicatif::ProgressStyle::with_template(
                "rendering {bar:40} {percent}% ({eta} left)",
            ) {
                self.bar.set_style(style);
            }
        }
        self.bar.inc(1);
    }

    fn tick_plain(&self) {
        let mut plain = self.plain.lock().unwrap_or_else(|e| e.into_inner());
        plain.0 += 1;
        let now = Instant::now();
        let since = plain.1.unwrap_or(self.started);
        if now.duration_since(since) >= self.interval {
            plain.1 = Some(now);
            eprintln!(
                "{}",
                line(
                    crate::engine::output::current_frame(),
                    plain.0,
                    self.total,
                    self.started.elapsed()
                )
            );
        }
    }

    pub fn finish(&self) {
        if self.shown.load(Ordering::Relaxed) {
            self.bar.finish_and_clear();
        }
    }
}

/// The interval `FELT_PROGRESS_SECONDS` asks for (a number of seconds, 0 or more).
fn interval(setting: Option<&str>) -> Duration {
    let seconds = setting
        .and_then(|s| s.trim().parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s >= 0.0)
        .unwrap_or(DEFAULT_INTERVAL);
    Duration::from_secs_f64(seconds.min(1e6))
}

/// One plain progress line: `felt: frame 12: rendering 45% (120 of 266 tiles), 0:01:05 elapsed`.
pub fn line(frame: Option<i64>, done: u64, total: u64, elapsed: Duration) -> String {
    let percent = (done * 100).checked_div(total).unwrap_or(100);
    let seconds = elapsed.as_secs();
    let frame = frame.map_or(String::new(), |f| format!(" frame {f}:"));
    format!(
        "felt:{frame} rendering {percent}% ({done} of {total} tiles), {}:{:02}:{:02} elapsed",
        seconds / 3600,
        seconds / 60 % 60,
        seconds % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plain_line_names_the_frame_the_share_done_and_the_time() {
        assert_eq!(
            line(Some(12), 120, 266, Duration::from_secs(3725)),
            "felt: frame 12: rendering 45% (120 of 266 tiles), 1:02:05 elapsed"
        );
        assert_eq!(
            line(None, 3, 3, Duration::from_millis(900)),
            "felt: rendering 100% (3 of 3 tiles), 0:00:00 elapsed"
        );
    }

    #[test]
    fn the_interval_falls_back_to_the_default_on_nonsense() {
        assert_eq!(interval(Some("0")), Duration::ZERO);
        assert_eq!(interval(Some("2.5")), Duration::from_millis(2500));
        for bad in [None, Some("-1"), Some("soon"), Some("NaN")] {
            assert_eq!(interval(bad), Duration::from_secs(5));
        }
    }
}
