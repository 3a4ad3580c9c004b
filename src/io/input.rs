//! Input files: reading a script, a VDB file or a shape file whole, safely.
//!
//! Only regular files are read, and the kind is looked at before the file is opened: opening a
//! FIFO blocks until something writes to it, and a device such as `/dev/zero` never ends. The
//! size is checked against a cap before reading, and the read itself is capped too, since a
//! file may grow after its size was looked at. Readers check what they were given against its
//! name with `sniff`, so a VDB file renamed `.obj` is reported as one, not read as nothing.

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

/// What a file's first bytes say it holds, for the formats felt reads or writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Content {
    Vdb,
    Ply,
    Png,
    Exr,
    /// Anything that reads as text (a script, an OBJ mesh).
    Text,
    /// Bytes that are not text: a NUL byte, or invalid UTF-8, near the start.
    Binary,
}

impl Content {
    /// "a VDB file", "a PLY mesh", … for messages.
    pub fn describe(self) -> &'static str {
        match self {
            Content::Vdb => "a VDB file",
            Content::Ply => "a PLY mesh",
            Content::Png => "a PNG image",
            Content::Exr => "an OpenEXR image",
            Content::Text => "a text file",
            Content::Binary => "a binary file",
        }
    }
}

/// The VDB magic number, an `i64` written little endian.
pub const VDB_MAGIC: [u8; 8] = [0x20, 0x42, 0x44, 0x56, 0, 0, 0, 0];

/// Bytes looked at to tell text from binary.
const SNIFF_BYTES: usize = 8192;

/// What `bytes` (the start of a file, or all of it) hold, by their magic numbers, else by
/// whether they read as text.
pub fn sniff(bytes: &[u8]) -> Content {
    let first_line = bytes.split(|&b| b == b'\n').next().unwrap_or(bytes);
    if bytes.starts_with(&VDB_MAGIC) {
        Content::Vdb
    } else if first_line.trim_ascii() == b"ply" {
        Content::Ply
    } else if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Content::Png
    } else if bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        Content::Exr
    } else {
        let head = &bytes[..bytes.len().min(SNIFF_BYTES)];
        let text = match std::str::from_utf8(head) {
            Ok(_) => true,
            // A character cut off by the end of the sample is still text.
            Err(e) => e.error_len().is_none() && head.len() == SNIFF_BYTES,
        };
        if text && !head.contains(&0) {
            Content::Text
        } else {
            Content::Binary
        }
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

    #[test]
    fn sniffing_tells_formats_by_their_first_bytes() {
        let mut vdb = VDB_MAGIC.to_vec();
        vdb.extend_from_slice(&[224, 0, 0, 0, b'\n', 0xff]);
        assert_eq!(sniff(&vdb), Content::Vdb);
        assert_eq!(sniff(b"ply\r\nformat ascii 1.0\n"), Content::Ply);
        assert_eq!(sniff(b"\x89PNG\r\n\x1a\n\0\0"), Content::Png);
        assert_eq!(sniff(&[0x76, 0x2f, 0x31, 0x01, 2, 0]), Content::Exr);
        assert_eq!(sniff(b"# a mesh\nv 0 0 0\n"), Content::Text);
        assert_eq!(sniff(b""), Content::Text);
        assert_eq!(sniff(b"v 0 0 0\n\0\x01"), Content::Binary);
        assert_eq!(sniff(&[b'v', b' ', 0xc3, 0x28]), Content::Binary);
        // UTF-8 cut off at the end of the sample is text.
        let mut long = vec![b'x'; SNIFF_BYTES - 1];
        long.extend_from_slice("é".as_bytes());
        assert_eq!(sniff(&long), Content::Text);
    }
}
