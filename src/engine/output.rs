//! A run's output settings: where relative output paths land (`--output-dir DIR`, so one
//! script can run many times side by side — a study's settings, a farm's frames — without
//! overwriting itself) and the frame that fills frame patterns (`####`, `%04d`, `$F4`; see
//! `io::frames`) in any path felt opens. They belong to the engine of the run, so two sessions
//! in one process write to different folders; these are the accessors every layer uses. One
//! frame of `felt run --frames` must name its frame in every output path, or each frame would
//! overwrite the last one's file.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, OnceLock};

/// One engine's output settings: `--output-dir`, the `frame` param's
/// value and whether the run is one frame of `--frames`.
#[derive(Debug, Default)]
pub struct OutputSettings {
    /// The folder relative outputs go to, when `--output-dir` set one.
    directory: OnceLock<PathBuf>,
    /// The `frame` param's value, once the script has declared it.
    frame: Mutex<Option<i64>>,
    /// Whether this run is one frame of `felt run --frames`.
    in_range: AtomicBool,
}

impl OutputSettings {
    /// Sends relative outputs under `directory`, creating it if needed.
    pub fn set_directory(&self, directory: &Path) -> Result<(), String> {
        std::fs::create_dir_all(directory)
            .map_err(|e| format!("cannot create output folder '{}': {e}", directory.display()))?;
        if !directory.is_dir() {
            return Err(format!("'{}' is not a folder", directory.display()));
        }
        self.directory
            .set(directory.to_path_buf())
            .map_err(|_| String::from("the output folder is already set"))
    }

    /// The folder `--output-dir` named, if it named one.
    pub fn directory(&self) -> Option<&Path> {
        self.directory.get().map(PathBuf::as_path)
    }

    /// Records the `frame` param's value, which fills frame patterns in paths from now on.
    pub fn set_frame(&self, frame: i64) {
        *self.frame.lock().unwrap_or_else(|e| e.into_inner()) = Some(frame);
    }

    /// Marks the run as one frame of `--frames`: every output path must then name its frame.
    pub fn set_frame_range(&self) {
        self.in_range.store(true, Ordering::Relaxed);
    }

    /// The frame the run is on, if the script has one.
    pub fn current_frame(&self) -> Option<i64> {
        *self.frame.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn in_range(&self) -> bool {
        self.in_range.load(Ordering::Relaxed)
    }
}

/// Sends relative outputs of the current engine under `directory`, creating it if needed.
pub fn set_directory(directory: &Path) -> Result<(), String> {
    super::with(|e| e.output.set_directory(directory))
}

/// The folder `--output-dir` named for the current engine, if it named one.
pub fn directory() -> Option<PathBuf> {
    super::with(|e| e.output.directory().map(Path::to_path_buf))
}

/// Records the `frame` param's value, which fills frame patterns in paths from now on.
pub fn set_frame(frame: i64) {
    super::with(|e| e.output.set_frame(frame));
}

/// Marks this run as one frame of `--frames`: every output path must then name its frame.
pub fn set_frame_range() {
    super::with(|e| e.output.set_frame_range());
}

/// The frame this run is on, if the script has one.
pub fn current_frame() -> Option<i64> {
    super::with(|e| e.output.current_frame())
}

/// `text` with its frame patterns filled, when the script has a frame.
pub fn framed(text: &str) -> String {
    match current_frame() {
        Some(frame) => crate::io::frames::fill(text, frame).unwrap_or_else(|| text.to_string()),
        None => text.to_string(),
    }
}

/// Whether an output may be written at `text` as far as frames go: a pattern needs a frame to
/// fill it, and one frame of a range needs a name of its own: a pattern, or the frame's number
/// already in the name, as a path built with `format("name.%04d.exr", frame)` has it.
pub fn check_frame(text: &str) -> Result<(), String> {
    let pattern = crate::io::frames::has_pattern(text);
    let frame = current_frame();
    if pattern && frame.is_none() {
        return Err(String::from(
            "its name has a frame pattern but the script declares no `param int frame`",
        ));
    }
    let numbered = frame.is_some_and(|f| crate::io::frames::names_frame(text, f));
    if !pattern && !numbered && super::with(|e| e.output.in_range()) {
        return Err(String::from(
            "every frame of --frames would write this same file; put the frame in its name \
             (`name.####.exr`, `name.%04d.exr` or `name.$F4.exr`)",
        ));
    }
    Ok(())
}

/// Where a write of `path` lands when nothing resolved it against a script (bands, merges):
/// frame patterns filled, and under the output folder when there is one.
pub fn target(path: &Path) -> PathBuf {
    let path = PathBuf::from(framed(&path.to_string_lossy()));
    match directory() {
        Some(directory) if path.is_relative() => directory.join(path),
        _ => path,
    }
}
