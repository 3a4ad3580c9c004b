//! Input files: reading a script, a VDB file or a shape file whole, safely.
//!
//! Only regular files are read, and the kind is looked at before the file is opened: opening a
//! FIFO blocks until something writes to it, and a device such as `/dev/zero` never ends. The
//! size is checked against a cap before reading, and the read itself is capped too, since a
//! file may grow after its size was looked at.

use std::io::Read;
use std::path::Path;

/// The bytes of the regular file at `path`, at most `limit` of them. The error is a reason
/// for the caller's "cannot read ... 'path': " message.
pub fn read_whole(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>, String> {
    let too_large = || format!("it is larger than {}, the most {what} may be", size(limit));
    let metadata = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if !metadata.is_file() {
        return Err(format!(
            "it is {}, not a regular file",
            describe_file_type(metadata.file_type())
        ));
    }
    if metadata.len() > limit {
        return Err(too_large());
    }
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut bytes = Vec::new();
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > limit {
        return Err(too_large());
    }
    Ok(bytes)
}

/// `limit` in the largest binary unit that keeps it whole-ish: "64 MiB", "1.5 GiB".
fn size(limit: u64) -> String {
    const UNITS: [&str; 5] = ["bytes", "KiB", "MiB", "GiB", "TiB"];
    let mut value = limit as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    if value.fract() == 0.0 {
        format!("{value} {}", UNITS[unit])
    } else {
        format!("{value:.1} {}", UNITS[unit])
    }
}

/// "a directory", "a FIFO (named pipe)", … for a file that is not a regular one.
fn describe_file_type(kind: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_char_device() {
            return "a character device";
        }
        if kind.is_block_device() {
            return "a block device";
        }
        if kind.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if kind.is_socket() {
            return "a socket";
        }
    }
    if kind.is_dir() {
        "a directory"
    } else {
        "a special file"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_devices_folders_and_large_files() {
        let dir = tempfile::tempdir().unwrap();
        let err = read_whole(dir.path(), 1 << 20, "a script").unwrap_err();
        assert_eq!(err, "it is a directory, not a regular file");
        #[cfg(unix)]
        assert_eq!(
            read_whole(Path::new("/dev/zero"), 1 << 20, "a script").unwrap_err(),
            "it is a character device, not a regular file"
        );
        let big = dir.path().join("big");
        std::fs::write(&big, vec![b'x'; 3000]).unwrap();
        assert_eq!(
            read_whole(&big, 2048, "a script").unwrap_err(),
            "it is larger than 2 KiB, the most a script may be"
        );
        assert_eq!(read_whole(&big, 3000, "a script").unwrap().len(), 3000);
    }
}
