//! Shape files: `loadshape` and `saveshape`, choosing OBJ or PLY by the file's extension.
//!
//! The one key decision: saving writes the whole file under a temporary name in the target's
//! directory and renames it into place, so a reader (or a crash) never sees half a mesh and an
//! existing file is replaced only by a complete one.

use super::Mesh;
use super::obj::{parse_obj, write_obj};
use super::ply::{parse_ply, write_ply};
use crate::failure::{Failure, Outcome};
use std::io::Write;
use std::path::Path;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Obj,
    Ply,
}

fn kind(path: &Path) -> Outcome<Kind> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match extension.as_deref() {
        Some("obj") => Ok(Kind::Obj),
        Some("ply") => Ok(Kind::Ply),
        _ => Err(Failure::new(format!(
            "cannot tell the format of shape file '{}' from its name",
            path.display()
        ))
        .with_help("shape files end in .obj or .ply")),
    }
}

/// Reads a mesh from an `.obj` or `.ply` file.
pub fn load_mesh(path: &Path) -> Outcome<Mesh> {
    let kind = kind(path)?;
    let cannot = |reason: &dyn std::fmt::Display| {
        Failure::new(format!(
            "cannot read shape file '{}': {reason}",
            path.display()
        ))
    };
    // Only regular files: a device such as /dev/zero streams forever and a FIFO blocks.
    let metadata = std::fs::metadata(path).map_err(|e| cannot(&e))?;
    if !metadata.is_file() {
        return Err(cannot(&"not a regular file (a directory, device or pipe)"));
    }
    let bytes = std::fs::read(path).map_err(|e| cannot(&e))?;
    let mesh = match kind {
        Kind::Obj => parse_obj(&bytes),
        Kind::Ply => parse_ply(&bytes),
    };
    mesh.map_err(|f| Failure {
        message: format!("{}: {}", path.display(), f.message),
        help: f.help,
    })
}

/// Writes a mesh as OBJ text or binary PLY, by the path's extension, atomically.
pub fn save_mesh(mesh: &Mesh, path: &Path) -> Outcome<()> {
    let bytes = match kind(path)? {
        Kind::Obj => write_obj(mesh)?,
        Kind::Ply => write_ply(mesh)?,
    };
    let cannot = |e: std::io::Error| {
        Failure::new(format!("cannot write shape file '{}': {e}", path.display()))
    };
    let directory = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut file = tempfile::NamedTempFile::new_in(directory).map_err(cannot)?;
    file.write_all(&bytes).map_err(cannot)?;
    file.as_file().sync_all().map_err(cannot)?;
    file.persist(path).map_err(|e| cannot(e.error))?;
    Ok(())
}
