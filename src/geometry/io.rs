//! Shape files: `loadshape` and `saveshape`, choosing OBJ or PLY by the file's extension.
//!
//! Loading first checks the file's content against its extension (`input::sniff`): a VDB
//! file or an image renamed `.obj` would otherwise read as an OBJ with no records, an empty
//! shape. The one key decision: saving writes the whole file under a temporary name in the target's
//! directory and renames it into place, so a reader (or a crash) never sees half a mesh and an
//! existing file is replaced only by a complete one.

use super::Mesh;
use super::obj::{parse_obj, write_obj};
use super::ply::{parse_ply, write_ply};
use crate::base::failure::{Failure, Outcome};
use crate::io::input::{Content, sniff};
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
    // A shape file is read whole, so it may be no larger than the memory budget.
    let limit = crate::space::domain::memory_limit();
    let bytes =
        crate::io::input::read_whole(path, limit, "a shape file").map_err(|e| cannot(&e))?;
    let mesh = check_content(kind, &bytes).and_then(|()| match kind {
        Kind::Obj => parse_obj(&bytes).and_then(|mesh| {
            // Any bytes parse as an OBJ file with no records; binary ones were not meant as one.
            if mesh.positions.is_empty() && sniff(&bytes) == Content::Binary {
                return Err(Failure::new(
                    "this is not an OBJ mesh: it holds binary data and no vertices or faces",
                ));
            }
            Ok(mesh)
        }),
        Kind::Ply => parse_ply(&bytes),
    });
    mesh.map_err(|f| Failure {
        message: format!("{}: {}", path.display(), f.message),
        ..f
    })
}

/// Refuses a file whose first bytes say it is something other than its extension says.
fn check_content(kind: Kind, bytes: &[u8]) -> Outcome<()> {
    let content = sniff(bytes);
    let (expected, fits) = match kind {
        Kind::Obj => (
            "an OBJ mesh",
            matches!(content, Content::Text | Content::Binary),
        ),
        Kind::Ply => ("a PLY mesh", content == Content::Ply),
    };
    if fits {
        return Ok(());
    }
    let failure = match content {
        Content::Text | Content::Binary => Failure::new(format!(
            "this is not a PLY file: it does not start with 'ply' (it is {})",
            content.describe()
        )),
        other => Failure::new(format!("this is {}, not {expected}", other.describe())),
    };
    Err(match content {
        Content::Vdb => failure.with_help("read VDB grids with cacheload or cacheloadvector"),
        Content::Ply => failure.with_help("rename the file to end in .ply"),
        Content::Text => failure.with_help("if it is an OBJ mesh, rename the file to end in .obj"),
        _ => failure,
    })
}

/// Writes a mesh as OBJ text or binary PLY, by the path's extension, atomically.
pub fn save_mesh(mesh: &Mesh, path: &Path) -> Outcome<()> {
    let bytes = match kind(path)? {
        Kind::Obj => write_obj(mesh)?,
        Kind::Ply => write_ply(mesh)?,
    };
    crate::io::output::write_atomically(path, |file| {
        file.write_all(&bytes).map_err(|e| e.to_string())
    })
    .map_err(|e| Failure::new(format!("cannot write shape file '{}': {e}", path.display())))
}
