//! Reading a VDB file: the header, metadata, grid descriptors, transforms and instancing.
//!
//! The whole file is read into memory and parsed through a `Cursor` that knows the byte
//! range it may read and the grid it is in, so every failure names the byte offset and the
//! grid. The key decision: files with grid offsets (all files OpenVDB writes to disk) are
//! walked descriptor by descriptor, each grid parsed within its own `[start, end)` range; a
//! request for one grid parses only that grid (and the grid it is an instance of), so a file
//! may hold types felt cannot read next to the grid a script asks for.

use super::cursor::Cursor;
use super::read_tree::{self, Scalar, TreeFormat, ValueFormat};
use super::{FRUSTUM_MAP, FrustumMap, VdbGrid, VdbMeta, VdbValues};
use crate::base::failure::{Failure, Outcome};
use glam::DMat4;
use std::path::Path;

const MAGIC: i64 = 0x5644_4220;
/// The oldest format felt reads: per-grid selective compression arrived in 220.
const OLDEST_VERSION: u32 = 220;
/// From this version on, compression flags are stored per grid and value buffers carry a
/// mask-compression code (OpenVDB's `NODE_MASK_COMPRESSION`).
pub(super) const VERSION_NODE_MASK_COMPRESSION: u32 = 222;
const HALF_FLOAT_SUFFIX: &str = "_HalfFloat";
/// OpenVDB separates a grid's name from the number that makes it unique with this byte.
pub(super) const UNIQUE_NAME_SEPARATOR: char = '\u{1e}';

/// Every grid in a VDB file, in file order.
pub fn read_file(path: &Path) -> Outcome<Vec<VdbGrid>> {
    let bytes = load(path)?;
    read_bytes(&bytes).map_err(|e| in_file(path, e))
}

/// Every grid in the bytes of a VDB file, in file order.
pub fn read_bytes(bytes: &[u8]) -> Outcome<Vec<VdbGrid>> {
    read_archive(bytes, None)
}

/// The file-level metadata of the bytes of a VDB file (its grids are not read).
pub fn read_file_metadata(bytes: &[u8]) -> Outcome<Vec<(String, VdbMeta)>> {
    let mut cur = Cursor::new(bytes);
    read_header(&mut cur)?;
    read_metadata(&mut cur)
}

/// The first grid called `name` in a VDB file; other grids are skipped unread.
pub fn read_grid(path: &Path, name: &str) -> Outcome<VdbGrid> {
    let bytes = load(path)?;
    read_grid_bytes(&bytes, name).map_err(|e| in_file(path, e))
}

/// The first grid called `name` in the bytes of a VDB file.
pub fn read_grid_bytes(bytes: &[u8], name: &str) -> Outcome<VdbGrid> {
    let mut grids = read_archive(bytes, Some(name))?;
    grids
        .pop()
        .ok_or_else(|| Failure::new(format!("no grid named '{name}'")))
}

fn load(path: &Path) -> Outcome<Vec<u8>> {
    let cannot = |reason: &dyn std::fmt::Display| {
        Failure::new(format!(
            "cannot read VDB file '{}': {reason}",
            path.display()
        ))
    };
    // A VDB file is read whole, so it may be no larger than the memory budget.
    let limit = crate::space::domain::memory_limit();
    crate::io::input::read_whole(path, limit, "a VDB file").map_err(|e| {
        cannot(&e).with_help("check the path; a relative one starts at the script's folder")
    })
}

fn in_file(path: &Path, failure: Failure) -> Failure {
    Failure {
        message: format!("{}: {}", path.display(), failure.message),
        ..failure
    }
}

struct Header {
    version: u32,
    has_offsets: bool,
    /// The compression of every grid, for files older than per-grid flags.
    compression: u32,
}

fn read_header(cur: &mut Cursor) -> Outcome<Header> {
    let magic = cur.i64("the file header").map_err(|_| not_vdb())?;
    if magic != MAGIC {
        return Err(not_vdb());
    }
    let version = cur.u32("the file format version")?;
    if version < OLDEST_VERSION {
        return Err(Failure::new(format!(
            "this VDB file uses format version {version}, older than the oldest felt reads \
             ({OLDEST_VERSION})"
        ))
        .with_help("re-save the file with a current OpenVDB (for example with vdb_tool)"));
    }
    let _library_major = cur.u32("the library version")?;
    let _library_minor = cur.u32("the library version")?;
    let has_offsets = cur.u8("the grid offsets flag")? != 0;
    let mut compression = read_tree::COMPRESS_ACTIVE_MASK | read_tree::COMPRESS_BLOSC;
    if version < VERSION_NODE_MASK_COMPRESSION {
        let zipped = cur.u8("the compression flag")? != 0;
        compression = if zipped { read_tree::COMPRESS_ZIP } else { 0 };
    }
    cur.take(36, "the file's UUID")?;
    Ok(Header {
        version,
        has_offsets,
        compression,
    })
}

fn not_vdb() -> Failure {
    Failure::new("not an OpenVDB file (it does not start with the VDB magic number)")
}

/// Metadata names and types that the grid fields carry instead.
const NAME_KEY: &str = "name";
const CLASS_KEY: &str = "class";
const HALF_KEY: &str = "is_saved_as_half_float";

fn read_metadata(cur: &mut Cursor) -> Outcome<Vec<(String, VdbMeta)>> {
    let at = cur.pos();
    let count = cur.u32("the metadata count")? as usize;
    // Each entry holds at least three u32 lengths.
    if count > cur.remaining() / 12 {
        return Err(cur.fail(
            at,
            format!("{count} metadata entries cannot fit in the file"),
        ));
    }
    let mut entries = Vec::new();
    for _ in 0..count {
        let name = cur.string("a metadata name")?;
        let type_name = cur.string("a metadata type")?;
        let size = cur.u32("a metadata size")? as usize;
        let bytes = cur.take(size, "a metadata value")?;
        // Types starting with "__" are OpenVDB's transient bookkeeping (delayed loading).
        if type_name.starts_with("__") {
            continue;
        }
        entries.push((name, meta_value(type_name, bytes)));
    }
    Ok(entries)
}

fn meta_value(type_name: String, bytes: &[u8]) -> VdbMeta {
    let le4 = |i: usize| [bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]];
    let le8 = |i: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&bytes[i..i + 8]);
        b
    };
    match (type_name.as_str(), bytes.len()) {
        ("string", _) => VdbMeta::String(String::from_utf8_lossy(bytes).into_owned()),
        ("bool", 1) => VdbMeta::Bool(bytes[0] != 0),
        ("int32", 4) => VdbMeta::Int32(i32::from_le_bytes(le4(0))),
        ("int64", 8) => VdbMeta::Int64(i64::from_le_bytes(le8(0))),
        ("float", 4) => VdbMeta::Float(f32::from_le_bytes(le4(0))),
        ("double", 8) => VdbMeta::Double(f64::from_le_bytes(le8(0))),
        ("vec3i", 12) => VdbMeta::Vec3i([0, 4, 8].map(|i| i32::from_le_bytes(le4(i)))),
        ("vec3s", 12) => VdbMeta::Vec3s([0, 4, 8].map(|i| f32::from_le_bytes(le4(i)))),
        ("vec3d", 24) => VdbMeta::Vec3d([0, 8, 16].map(|i| f64::from_le_bytes(le8(i)))),
        _ => VdbMeta::Other {
            type_name,
            bytes: bytes.to_vec(),
        },
    }
}

/// Reads a map: its index-to-world matrix, and for a frustum map the frustum's numbers (the
/// matrix is then its second map).
fn read_transform(cur: &mut Cursor) -> Outcome<(DMat4, Option<FrustumMap>)> {
    let at = cur.pos();
    let map = cur.string("the transform's map type")?;
    if map == FRUSTUM_MAP {
        let frustum = FrustumMap::read(cur)?;
        let second_at = cur.pos();
        let second = cur.string("a frustum map's second map type")?;
        return Ok((read_linear(cur, &second, second_at)?, Some(frustum)));
    }
    Ok((read_linear(cur, &map, at)?, None))
}

/// Reads the numbers of a linear map of type `map` (whose name began at `at`).
fn read_linear(cur: &mut Cursor, map: &str, at: usize) -> Outcome<DMat4> {
    let matrix = match map {
        "UniformScaleMap" | "ScaleMap" => {
            let scale = cur.vec3d("a scale map")?;
            // Then voxel size, 1/scale, 1/scale² and 1/(2·scale): caches of the scale.
            cur.take(4 * 24, "a scale map")?;
            DMat4::from_scale(scale)
        }
        "UniformScaleTranslateMap" | "ScaleTranslateMap" => {
            let translation = cur.vec3d("a scale-translate map")?;
            let scale = cur.vec3d("a scale-translate map")?;
            cur.take(4 * 24, "a scale-translate map")?;
            DMat4::from_translation(translation) * DMat4::from_scale(scale)
        }
        "TranslationMap" => DMat4::from_translation(cur.vec3d("a translation map")?),
        "AffineMap" | "UnitaryMap" => {
            // A row-major 4×4 matrix applied to row vectors, so its rows are glam's columns.
            let mut cells = [0.0; 16];
            for cell in &mut cells {
                *cell = cur.f64("an affine map")?;
            }
            DMat4::from_cols_array(&cells)
        }
        other => {
            return Err(Failure::new(format!(
                "grid '{}' has an unsupported transform '{other}'; felt reads linear \
                 transforms (scale, translation, affine) and frustum maps with a linear one",
                cur.grid
            ))
            .with_help(
                "resample the grid to a linear transform, for example with vdb_tool -resample",
            ));
        }
    };
    let linear = glam::DMat3::from_mat4(matrix);
    let determinant = linear.determinant();
    if !matrix.is_finite() || determinant == 0.0 || !determinant.is_finite() {
        return Err(cur.fail(at, format!("the {map} transform is degenerate")));
    }
    if matrix.row(3) != glam::DVec4::W {
        return Err(cur.fail(at, format!("the {map} transform is projective, not affine")));
    }
    Ok(matrix)
}

struct Descriptor {
    unique_name: String,
    /// The unique name without OpenVDB's numeric suffix.
    name: String,
    type_name: String,
    half_suffix: bool,
    parent: String,
    /// Where the grid's data starts and ends, when the file records it.
    range: Option<(usize, usize)>,
}

fn read_descriptor(cur: &mut Cursor, has_offsets: bool) -> Outcome<Descriptor> {
    let unique_name = cur.string("a grid name")?;
    let name = match unique_name.split_once(UNIQUE_NAME_SEPARATOR) {
        Some((base, _)) => base.to_string(),
        None => unique_name.clone(),
    };
    let mut type_name = cur.string("a grid type")?;
    let half_suffix = type_name.ends_with(HALF_FLOAT_SUFFIX);
    if half_suffix {
        type_name.truncate(type_name.len() - HALF_FLOAT_SUFFIX.len());
    }
    let parent = cur.string("an instance parent name")?;
    let at = cur.pos();
    let grid_pos = cur.i64("a grid's start offset")?;
    let _block_pos = cur.i64("a grid's buffer offset")?;
    let end_pos = cur.i64("a grid's end offset")?;
    let after = cur.pos();
    let range = if has_offsets {
        let start = usize::try_from(grid_pos).ok();
        let end = usize::try_from(end_pos).ok();
        match (start, end) {
            // Grids lie after their descriptors and in file order, so parsing moves forward.
            (Some(start), Some(end)) if after <= start && start <= end && end <= cur.end => {
                Some((start, end))
            }
            _ => {
                return Err(cur.fail(
                    at,
                    format!(
                        "grid '{name}' claims to span bytes {grid_pos}..{end_pos}, outside \
                         {after}..{}",
                        cur.end
                    ),
                ));
            }
        }
    } else {
        None
    };
    Ok(Descriptor {
        unique_name,
        name,
        type_name,
        half_suffix,
        parent,
        range,
    })
}

/// The value layout a grid type name stands for.
fn value_format(
    grid_name: &str,
    type_name: &str,
) -> Outcome<(ValueFormat, VdbValues, &'static str)> {
    let Some(value) = type_name
        .strip_prefix("Tree_")
        .and_then(|t| t.strip_suffix("_5_4_3"))
    else {
        return Err(Failure::new(format!(
            "grid '{grid_name}' has the unsupported grid type '{type_name}'; felt reads trees \
             with the standard 5-4-3 node layout"
        )));
    };
    let (scalar, values, stored) = match value {
        "float" => (Scalar::Single, VdbValues::Float, "float"),
        "double" => (Scalar::Double, VdbValues::Float, "double"),
        "half" => (Scalar::Half, VdbValues::Float, "half"),
        "vec3s" => (Scalar::Single, VdbValues::Vec3, "vec3s"),
        "vec3d" => (Scalar::Double, VdbValues::Vec3, "vec3d"),
        other => {
            return Err(Failure::new(format!(
                "grid '{grid_name}' holds {other} values: unsupported grid type; felt reads \
                 float, double, half, vec3s and vec3d grids"
            )));
        }
    };
    Ok((
        ValueFormat {
            scalar,
            components: values.components(),
        },
        values,
        stored,
    ))
}

fn read_archive(bytes: &[u8], wanted: Option<&str>) -> Outcome<Vec<VdbGrid>> {
    let content = crate::io::input::sniff(bytes);
    if content != crate::io::input::Content::Vdb {
        let failure = Failure::new(format!(
            "not an OpenVDB file: it does not start with the VDB magic number (it is {})",
            content.describe()
        ));
        return Err(match content {
            crate::io::input::Content::Ply => failure.with_help("read meshes with loadshape"),
            crate::io::input::Content::Text => {
                failure.with_help("if it is an OBJ mesh, read it with loadshape")
            }
            _ => failure,
        });
    }
    let mut cur = Cursor::new(bytes);
    let header = read_header(&mut cur)?;
    read_metadata(&mut cur)?;
    let at = cur.pos();
    let count = cur.i32("the grid count")?;
    // A descriptor takes at least three u32 lengths and three i64 offsets.
    if count < 0 || count as usize > cur.remaining() / 36 {
        return Err(cur.fail(
            at,
            format!("a grid count of {count} cannot fit in the file"),
        ));
    }
    let mut descriptors = Vec::new();
    let mut parsed: Vec<Option<VdbGrid>> = Vec::new();
    for _ in 0..count {
        let descriptor = read_descriptor(&mut cur, header.has_offsets)?;
        match descriptor.range {
            Some((_, end)) => {
                parsed.push(None);
                cur.pos = end;
            }
            // Without offsets the only way to the next descriptor is through this grid.
            None => {
                let grid = parse_grid(&mut cur, &descriptor, &header)?;
                cur.grid.clear();
                parsed.push(Some(grid));
            }
        }
        descriptors.push(descriptor);
    }

    let chosen: Vec<usize> = match wanted {
        None => (0..descriptors.len()).collect(),
        Some(name) => match descriptors
            .iter()
            .position(|d| d.name == name || d.unique_name == name)
        {
            Some(index) => vec![index],
            None => {
                let names: Vec<String> = descriptors
                    .iter()
                    .map(|d| format!("'{}'", d.name))
                    .collect();
                let held = if names.is_empty() {
                    "no grids".into()
                } else {
                    names.join(", ")
                };
                return Err(Failure::new(format!(
                    "no grid named '{name}' in the file; it holds {held}"
                )));
            }
        },
    };
    let mut needed = chosen.clone();
    for &index in &chosen {
        let parent = &descriptors[index].parent;
        if parent.is_empty() {
            continue;
        }
        match descriptors.iter().position(|d| &d.unique_name == parent) {
            Some(p) if descriptors[p].parent.is_empty() => needed.push(p),
            Some(_) => {
                return Err(Failure::new(format!(
                    "grid '{}' is an instance of an instance, which felt does not read",
                    descriptors[index].name
                )));
            }
            None => {
                return Err(Failure::new(format!(
                    "grid '{}' shares the tree of a grid '{}' that is not in the file",
                    descriptors[index].name,
                    parent.replace(UNIQUE_NAME_SEPARATOR, "#")
                )));
            }
        }
    }
    for &index in &needed {
        if parsed[index].is_none() {
            let descriptor = &descriptors[index];
            let Some((start, end)) = descriptor.range else {
                continue;
            };
            let mut grid_cursor = cur.range(start, end, &descriptor.name);
            parsed[index] = Some(parse_grid(&mut grid_cursor, descriptor, &header)?);
        }
    }

    let mut grids = Vec::with_capacity(chosen.len());
    for &index in &chosen {
        let Some(mut grid) = parsed[index].clone() else {
            continue;
        };
        let parent = &descriptors[index].parent;
        if !parent.is_empty() {
            let source = descriptors
                .iter()
                .position(|d| &d.unique_name == parent)
                .and_then(|p| parsed[p].as_ref());
            if let Some(source) = source {
                if source.value_type != grid.value_type {
                    return Err(Failure::new(format!(
                        "grid '{}' shares the tree of grid '{}', which holds another value type",
                        grid.name, source.name
                    )));
                }
                grid.background = source.background;
                grid.leaves = source.leaves.clone();
                grid.tiles = source.tiles.clone();
                grid.saved_as_half = source.saved_as_half;
            }
        }
        grids.push(grid);
    }
    Ok(grids)
}

fn parse_grid(cur: &mut Cursor, descriptor: &Descriptor, header: &Header) -> Outcome<VdbGrid> {
    cur.grid = descriptor.name.clone();
    let (value, value_type, stored_type) = value_format(&descriptor.name, &descriptor.type_name)?;
    let compression = if header.version >= VERSION_NODE_MASK_COMPRESSION {
        cur.u32("the grid's compression flags")?
    } else {
        header.compression
    };
    let mut metadata = read_metadata(cur)?;
    let (index_to_world, frustum) = read_transform(cur)?;

    let mut name = descriptor.name.clone();
    let mut class = super::UNKNOWN_CLASS.to_string();
    let mut half = descriptor.half_suffix;
    metadata.retain(|(key, value)| match (key.as_str(), value) {
        (NAME_KEY, VdbMeta::String(s)) => {
            name = s.clone();
            false
        }
        (CLASS_KEY, VdbMeta::String(s)) => {
            class = s.clone();
            false
        }
        (HALF_KEY, VdbMeta::Bool(b)) => {
            half = *b;
            false
        }
        _ => true,
    });
    // A half-precision file of a type that is already half stores plain halves.
    let half = half && value.scalar != Scalar::Half;
    let mut grid = VdbGrid::new(&name, &class, value_type, [0.0; 3], index_to_world);
    grid.saved_as_half = half;
    grid.frustum = frustum;
    grid.stored_type = stored_type.to_string();
    grid.metadata = metadata;
    if descriptor.parent.is_empty() {
        let format = TreeFormat {
            value,
            half,
            compression,
            version: header.version,
        };
        let tree = read_tree::read_tree(cur, &format)?;
        grid.background = tree.background;
        grid.leaves = tree.leaves;
        grid.tiles = tree.tiles;
        grid.sort_nodes();
    }
    Ok(grid)
}
