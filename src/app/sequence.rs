//! `felt run --frames A-B`: a script run once per frame, each frame in a process of its own.
//!
//! The one key decision: a range of more than one frame starts one `felt run --frames F`
//! child per frame, in order, rather than reusing this process. Nothing can leak from one
//! frame into the next (globals, caches, the memory budget, the profile, the hash-consed
//! graphs all start fresh), a frame that runs out of memory or hits a bug fails alone, and a
//! frame runs exactly as the farm task for it would. A failed frame is reported and the rest
//! still run; the exit status is 1 when any failed, with the failed frames listed, and 130 as
//! soon as a frame is interrupted (nothing after it runs).

use crate::io::frames::FrameRange;
use std::ffi::{OsStr, OsString};
use std::process::Command;
use std::time::Instant;

/// `args` (this process's arguments, without the program) with the `--frames` value replaced
/// by `frame`.
pub fn frame_args(args: &[OsString], frame: i64) -> Vec<OsString> {
    let mut out = Vec::with_capacity(args.len());
    let mut replace_next = false;
    for arg in args {
        if replace_next {
            out.push(OsString::from(frame.to_string()));
            replace_next = false;
        } else if arg == OsStr::new("--frames") {
            out.push(arg.clone());
            replace_next = true;
        } else if arg.to_string_lossy().starts_with("--frames=") {
            out.push(OsString::from(format!("--frames={frame}")));
        } else {
            out.push(arg.clone());
        }
    }
    out
}

/// Runs each frame of `range` as `felt run` with this process's other arguments; returns the
/// exit status.
pub fn run(range: &FrameRange, args: &[OsString]) -> u8 {
    let felt = match std::env::current_exe() {
        Ok(path) => path,
        Err(e) => {
            eprintln!("felt: cannot find the felt binary to run each frame: {e}");
            return 2;
        }
    };
    let started = Instant::now();
    let total = range.frames.len();
    let mut failed = Vec::new();
    for (k, &frame) in range.frames.iter().enumerate() {
        eprintln!("felt: frame {frame} ({} of {total})", k + 1);
        let began = Instant::now();
        // In a group of its own, so an interrupt stops the frame and all it started
        // (`crate::engine::interrupt::stop_children`) before this process exits.
        let status = crate::engine::interrupt::spawn_child(
            Command::new(&felt).args(frame_args(args, frame)),
        )
        .and_then(|mut child| {
            let status = child.wait();
            crate::engine::interrupt::child_done();
            status
        });
        match status {
            Ok(s) if s.success() => eprintln!(
                "felt: frame {frame} done in {:.1} s",
                began.elapsed().as_secs_f64()
            ),
            Ok(s) if s.code() == Some(130) || interrupted(&s) => {
                eprintln!("felt: interrupted at frame {frame}");
                return 130;
            }
            Ok(s) => {
                let why = s
                    .code()
                    .map_or_else(|| format!("{s}"), |c| format!("exit status {c}"));
                eprintln!("felt: frame {frame} failed ({why})");
                failed.push(frame);
            }
            Err(e) => {
                eprintln!("felt: frame {frame} could not start: {e}");
                failed.push(frame);
            }
        }
    }
    let seconds = started.elapsed().as_secs_f64();
    eprintln!("{}", summary(total, &failed, seconds));
    u8::from(!failed.is_empty())
}

#[cfg(unix)]
fn interrupted(status: &std::process::ExitStatus) -> bool {
    use std::os::unix::process::ExitStatusExt;
    matches!(status.signal(), Some(libc::SIGINT | libc::SIGTERM))
}

#[cfg(not(unix))]
fn interrupted(_: &std::process::ExitStatus) -> bool {
    false
}

/// The last line of a range: how many frames ran, and which failed.
pub fn summary(total: usize, failed: &[i64], seconds: f64) -> String {
    if failed.is_empty() {
        return format!("felt: all {total} frames done in {seconds:.1} s");
    }
    let list: Vec<String> = failed.iter().map(|f| f.to_string()).collect();
    format!(
        "felt: {} of {total} frames failed: {} ({seconds:.1} s)",
        failed.len(),
        list.join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_frames_argument_is_replaced_in_either_spelling() {
        let args: Vec<OsString> = ["run", "s.felt", "--frames", "1-3", "--set", "a=1"]
            .map(OsString::from)
            .to_vec();
        let expect: Vec<OsString> = ["run", "s.felt", "--frames", "2", "--set", "a=1"]
            .map(OsString::from)
            .to_vec();
        assert_eq!(frame_args(&args, 2), expect);
        let args: Vec<OsString> = ["run", "--frames=1-3", "s.felt"]
            .map(OsString::from)
            .to_vec();
        assert_eq!(
            frame_args(&args, 3),
            ["run", "--frames=3", "s.felt"].map(OsString::from).to_vec()
        );
    }

    #[test]
    fn the_summary_lists_the_failed_frames() {
        assert_eq!(
            summary(5, &[2, 4], 1.31),
            "felt: 2 of 5 frames failed: 2, 4 (1.3 s)"
        );
        assert_eq!(summary(3, &[], 0.5), "felt: all 3 frames done in 0.5 s");
    }
}
