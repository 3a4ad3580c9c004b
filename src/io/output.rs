//! Output files: where a script's files land and how every one of them reaches disk.
//!
//! Every file felt writes (images, VDB caches, meshes) goes through `write_atomically`: the
//! bytes go to a temporary file in the target's own directory, are synced, and the temporary
//! is renamed over the target, so a reader, a crash or a full disk never sees half a file. The
//! temporary is created with mode 0666 less the umask, so outputs get the same permissions as
//! any other tool's files (not the 0600 of a private temporary). A target that is a symbolic
//! link is written through: the link's final target is replaced and the link stays.
//!
//! Folders a file's path names that do not exist yet are created (with the umask's
//! permissions, as `mkdir -p` makes them), so a script can write `renders/sq010/a.exr` on a
//! fresh disk; a path through something that is not a folder is an error before any work.
//!
//! Where a run's outputs go (`--output-dir`, the frame that fills patterns) is the engine's
//! (`engine::output`); `interp::paths` turns a script's names into paths; this module
//! only writes them.
//!
//! A file that is read, changed and written back (a VDB a run appends a grid to) is guarded
//! by `lock_for_update`: an advisory lock (`flock`) on a sibling `NAME.lock` file, held from
//! the read to the rename, so runs that append to one file at once take turns and none loses
//! another's grid. The lock file is left in place: removing it would let a run that opened it
//! just before the removal lock a file nobody else can see any more, and two runs would
//! update at once again. It is empty and harmless to delete when no run is writing.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Temporary files being written now, so an interrupted run can remove them. Process-wide on
/// purpose: the Ctrl-C handler that empties it runs just before the process exits, whatever
/// engine wrote them.
static IN_PROGRESS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Removes every temporary file being written now (from a Ctrl-C or SIGTERM handler, just
/// before the process exits). A temporary left by a run killed outright (SIGKILL) is never
/// read: its name is unique and ignored by everything felt lists.
pub fn remove_temporaries() {
    let paths = IN_PROGRESS.lock().unwrap_or_else(|e| e.into_inner());
    for path in paths.iter() {
        let _ = std::fs::remove_file(path);
    }
}

/// Whether `name` is one of felt's temporary files.
pub fn is_temporary(name: &str) -> bool {
    name.starts_with(".felt-") && name.ends_with(".tmp")
}

/// Symbolic links followed before giving up, as the kernel's own limit.
const MAX_LINKS: usize = 40;

/// Checks, before the work that produces it, that a file can be written at `path`: the
/// nearest of its folders that exists is a folder (the missing ones are created when the file
/// is written). A render can take minutes; a file in its way should not cost them.
pub fn check_writable(path: &Path) -> Result<(), String> {
    let mut folder = path.parent();
    while let Some(f) = folder {
        if f.as_os_str().is_empty() {
            return Ok(());
        }
        match std::fs::metadata(f) {
            Ok(meta) if meta.is_dir() => return Ok(()),
            Ok(_) => return Err(format!("'{}' is not a folder", f.display())),
            Err(_) => folder = f.parent(),
        }
    }
    Ok(())
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

/// An update of a file in progress: while this lives, no other felt process updates the same
/// file (see the module doc). Dropping it closes the lock file, which releases the lock.
#[derive(Debug)]
pub struct UpdateLock {
    _file: File,
}

/// Waits for, then takes, the right to read, change and replace the file at `path` (resolved
/// already, see `paths`): an exclusive `flock` on `NAME.lock` beside the file a write of
/// `path` lands on (through its symbolic links, so two links to one file share one lock).
/// The error is a sentence fragment, as for `write_atomically`.
pub fn lock_for_update(path: &Path) -> Result<UpdateLock, String> {
    check_writable(path)?;
    if let Some(parent) = path.parent()
        && !parent.as_os_str().is_empty()
    {
        std::fs::create_dir_all(parent)
            .map_err(|e| format!("cannot create the folder '{}': {e}", parent.display()))?;
    }
    let landing = through_links(path)?;
    let mut name = landing.into_os_string();
    name.push(".lock");
    let lock_path = PathBuf::from(name);
    let file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&lock_path)
        .map_err(|e| format!("cannot open the lock file '{}': {e}", lock_path.display()))?;
    file.lock()
        .map_err(|e| format!("cannot lock '{}': {e}", lock_path.display()))?;
    Ok(UpdateLock { _file: file })
}

/// Writes a file at `path` (resolved already, see `paths`) with `write`, atomically, creating
/// the folders it names that are missing. The error is a sentence fragment for the caller's
/// "cannot write ... 'path': " message.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut File) -> Result<(), String>,
) -> Result<(), String> {
    check_writable(path)?;
    if let Some(parent) = path.parent()
        && !parent.as_os_str().is_empty()
    {
        std::fs::create_dir_all(parent)
            .map_err(|e| format!("cannot create the folder '{}': {e}", parent.display()))?;
    }
    let landing = through_links(path)?;
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
    let name = temporary.path().to_path_buf();
    IN_PROGRESS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push(name.clone());
    let written = write(temporary.as_file_mut())
        .and_then(|()| temporary.as_file().sync_all().map_err(|e| e.to_string()))
        .and_then(|()| {
            temporary
                .persist(&landing)
                .map(|_| ())
                .map_err(|e| e.error.to_string())
        });
    IN_PROGRESS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .retain(|p| *p != name);
    written
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
