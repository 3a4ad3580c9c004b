//! Output files: where a script's files land and how every one of them reaches disk.
//!
//! Every file felt writes (images, VDB caches, meshes) goes through `write_atomically`: the
//! bytes go to a temporary file in the target's own directory, are synced, and the temporary
//! is renamed over the target, so a reader, a crash or a full disk never sees half a file. The
//! temporary is created with mode 0666 less the umask, so outputs get the same permissions as
//! any other tool's files (not the 0600 of a private temporary). A target that is a symbolic
//! link is written through: the link's final target is replaced and the link stays.
//!
//! `--output-dir DIR` (`set_directory`) sends relative output paths under DIR, creating the
//! folders they name there, so one script can run many times side by side (a study's settings,
//! a farm's frames) without overwriting itself. Absolute paths are written as given. A relative
//! path the run wrote under DIR is also read back from there, so a script that saves a cache
//! and loads it again sees its own file.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The folder relative outputs go to, when `--output-dir` set one.
static DIRECTORY: OnceLock<PathBuf> = OnceLock::new();

/// Symbolic links followed before giving up, as the kernel's own limit.
const MAX_LINKS: usize = 40;

/// Sends relative outputs of this process under `directory`, creating it if needed.
pub fn set_directory(directory: &Path) -> Result<(), String> {
    std::fs::create_dir_all(directory)
        .map_err(|e| format!("cannot create output folder '{}': {e}", directory.display()))?;
    if !directory.is_dir() {
        return Err(format!("'{}' is not a folder", directory.display()));
    }
    DIRECTORY
        .set(directory.to_path_buf())
        .map_err(|_| String::from("the output folder is already set"))
}

/// Where a write of `path`, as the script named it, lands.
pub fn target(path: &Path) -> PathBuf {
    match DIRECTORY.get() {
        Some(directory) if path.is_relative() => directory.join(path),
        _ => path.to_path_buf(),
    }
}

/// Where a read of `path` comes from: the run's own copy under the output folder when there
/// is one, else `path` as given.
pub fn source(path: &Path) -> PathBuf {
    let written = target(path);
    if written != path && written.exists() {
        written
    } else {
        path.to_path_buf()
    }
}

/// The file a write to `path` should replace: `path` itself, or the final target of the
/// symbolic links it names.
fn through_links(path: &Path) -> Result<PathBuf, String> {
    let mut current = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match std::fs::symlink_metadata(&current) {
            Ok(meta) if meta.file_type().is_symlink() => {
                let next = std::fs::read_link(&current).map_err(|e| e.to_string())?;
                current = match current.parent() {
                    Some(parent) if next.is_relative() => parent.join(next),
                    _ => next,
                };
            }
            _ => return Ok(current),
        }
    }
    Err(String::from("too many levels of symbolic links"))
}

/// Writes a file at `path` (as the script named it) with `write`, atomically. The error is a
/// sentence fragment for the caller's "cannot write ... 'path': " message.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut File) -> Result<(), String>,
) -> Result<(), String> {
    let landing = target(path);
    if DIRECTORY.get().is_some()
        && path.is_relative()
        && let Some(parent) = landing.parent()
    {
        std::fs::create_dir_all(parent).map_err(|e| e.to_string())?;
    }
    let landing = through_links(&landing)?;
    let directory = match landing.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(".felt-").suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut temporary = builder.tempfile_in(directory).map_err(|e| e.to_string())?;
    write(temporary.as_file_mut())?;
    temporary.as_file().sync_all().map_err(|e| e.to_string())?;
    temporary
        .persist(&landing)
        .map_err(|e| e.error.to_string())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn writes_through_a_symbolic_link_and_keeps_it() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.txt");
        let link = dir.path().join("link.txt");
        std::fs::write(&real, "old").unwrap();
        #[cfg(unix)]
        std::os::unix::fs::symlink("real.txt", &link).unwrap();
        #[cfg(not(unix))]
        return;
        write_atomically(&link, |f| f.write_all(b"new").map_err(|e| e.to_string())).unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "new");
    }

    #[cfg(unix)]
    #[test]
    fn outputs_are_readable_by_others_as_the_umask_allows() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        write_atomically(&path, |f| f.write_all(b"x").map_err(|e| e.to_string())).unwrap();
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
        let Some(umask) = status
            .lines()
            .find_map(|l| l.strip_prefix("Umask:"))
            .and_then(|m| u32::from_str_radix(m.trim(), 8).ok())
        else {
            return; // no umask to compare with on this system
        };
        assert_eq!(mode, 0o666 & !umask, "mode {mode:o}, umask {umask:o}");
    }

    #[test]
    fn a_failed_write_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        let result = write_atomically(&path, |_| Err(String::from("disk full")));
        assert_eq!(result, Err(String::from("disk full")));
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
