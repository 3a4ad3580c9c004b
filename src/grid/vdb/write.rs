//! Writing VDB files in the layout OpenVDB 10 and 11 write (file format 224).
//!
//! The key decision: the whole file is assembled in memory, so each grid descriptor's
//! offsets are patched in place once the grid is written, and the file reaches disk through
//! a temporary file renamed over the target — a reader never sees half a file. Everything
//! written is determined by the grids: even the file's UUID is a hash of its contents, so the
//! same grids give the same bytes.

use super::read::UNIQUE_NAME_SEPARATOR;
use super::read_tree::{COMPRESS_ACTIVE_MASK, COMPRESS_ZIP};
use super::write_tree::write_tree;
use super::{Compression, VdbGrid, VdbMeta, VdbValues};
use crate::base::failure::{Failure, Outcome};
use glam::{DMat3, DVec3};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::io::Write;
use std::path::Path;

const MAGIC: i64 = 0x5644_4220;
const FILE_VERSION: u32 = 224;
const LIBRARY_VERSION: (u32, u32) = (10, 0);

/// Writes `grids` to `path`, replacing any file there only once the new one is complete.
pub fn write_file(path: &Path, grids: &[VdbGrid], compression: Compression) -> Outcome<()> {
    write_file_with_metadata(path, grids, compression, &[])
}

/// `write_file` with file-level metadata (what `vdb_print` shows above the grids and
/// pyopenvdb's `readAll` returns beside them).
pub fn write_file_with_metadata(
    path: &Path,
    grids: &[VdbGrid],
    compression: Compression,
    metadata: &[(String, VdbMeta)],
) -> Outcome<()> {
    let bytes = write_bytes_with_metadata(grids, compression, metadata)?;
    crate::io::output::write_atomically(path, |file| {
        file.write_all(&bytes).map_err(|e| e.to_string())
    })
    .map_err(|e| Failure::new(format!("cannot write VDB file '{}': {e}", path.display())))
}

/// The bytes of a VDB file holding `grids`.
pub fn write_bytes(grids: &[VdbGrid], compression: Compression) -> Outcome<Vec<u8>> {
    write_bytes_with_metadata(grids, compression, &[])
}

/// The bytes of a VDB file holding `grids` and the file-level `metadata`.
pub fn write_bytes_with_metadata(
    grids: &[VdbGrid],
    compression: Compression,
    metadata: &[(String, VdbMeta)],
) -> Outcome<Vec<u8>> {
    let flags = COMPRESS_ACTIVE_MASK
        | match compression {
            Compression::None => 0,
            Compression::Zip => COMPRESS_ZIP,
        };
    let mut out = Vec::new();
    out.extend_from_slice(&MAGIC.to_le_bytes());
    put_u32(&mut out, FILE_VERSION);
    put_u32(&mut out, LIBRARY_VERSION.0);
    put_u32(&mut out, LIBRARY_VERSION.1);
    out.push(1); // the file records where each grid starts and ends
    let uuid_at = out.len();
    out.extend_from_slice(&[b'0'; 36]);
    let file_entries: BTreeMap<String, VdbMeta> = metadata.iter().cloned().collect();
    put_entries(&mut out, &file_entries);
    let count =
        i32::try_from(grids.len()).map_err(|_| Failure::new("too many grids for one VDB file"))?;
    out.extend_from_slice(&count.to_le_bytes());
    for (grid, unique_name) in grids.iter().zip(unique_names(grids)) {
        write_grid(&mut out, grid, &unique_name, flags)?;
    }
    let uuid = uuid_of(&out[uuid_at + 36..]);
    out[uuid_at..uuid_at + 36].copy_from_slice(uuid.as_bytes());
    Ok(out)
}

/// Names that tell grids apart, made the way OpenVDB makes them: a name shared by several
/// grids (or empty) gets a separator and a number.
fn unique_names(grids: &[VdbGrid]) -> Vec<String> {
    let mut counts: HashMap<&str, usize> = HashMap::new();
    for grid in grids {
        *counts.entry(grid.name.as_str()).or_default() += 1;
    }
    let mut taken = HashSet::new();
    let mut names = Vec::new();
    for grid in grids {
        let with_suffix = |n: usize| format!("{}{UNIQUE_NAME_SEPARATOR}{n}", grid.name);
        let mut name = grid.name.clone();
        if name.is_empty() || counts[grid.name.as_str()] > 1 {
            name = with_suffix(0);
        }
        let mut n = 1;
        while taken.contains(&name) {
            name = with_suffix(n);
            n += 1;
        }
        taken.insert(name.clone());
        names.push(name);
    }
    names
}

fn write_grid(out: &mut Vec<u8>, grid: &VdbGrid, unique_name: &str, flags: u32) -> Outcome<()> {
    let type_name = match grid.value_type {
        VdbValues::Float => "Tree_float_5_4_3",
        VdbValues::Vec3 => "Tree_vec3s_5_4_3",
    };
    put_string(out, unique_name);
    if grid.saved_as_half {
        put_string(out, &format!("{type_name}_HalfFloat"));
    } else {
        put_string(out, type_name);
    }
    put_string(out, ""); // not an instance
    let offsets_at = out.len();
    out.extend_from_slice(&[0u8; 24]);
    let grid_pos = out.len();
    put_u32(out, flags);
    write_metadata(out, grid, flags);
    write_transform(out, grid)?;
    let block_pos = write_tree(out, grid, flags)?;
    let end_pos = out.len();
    for (n, pos) in [grid_pos, block_pos, end_pos].into_iter().enumerate() {
        let at = offsets_at + 8 * n;
        out[at..at + 8].copy_from_slice(&(pos as i64).to_le_bytes());
    }
    Ok(())
}

/// Metadata the writer produces itself; stale copies from a file read earlier are dropped.
const GENERATED_KEYS: [&str; 9] = [
    "name",
    "class",
    "is_saved_as_half_float",
    "file_bbox_min",
    "file_bbox_max",
    "file_compression",
    "file_mem_bytes",
    "file_voxel_count",
    "file_delayed_load",
];

fn write_metadata(out: &mut Vec<u8>, grid: &VdbGrid, flags: u32) {
    let mut entries: BTreeMap<String, VdbMeta> = grid
        .metadata
        .iter()
        .filter(|(key, _)| !GENERATED_KEYS.contains(&key.as_str()))
        .cloned()
        .collect();
    entries.insert("name".into(), VdbMeta::String(grid.name.clone()));
    entries.insert("class".into(), VdbMeta::String(grid.class.clone()));
    if grid.saved_as_half {
        entries.insert("is_saved_as_half_float".into(), VdbMeta::Bool(true));
    }
    // OpenVDB's statistics, which vdb_print shows without loading the tree. An empty grid
    // has OpenVDB's empty box, minimum above maximum.
    let (min, max) = grid
        .active_bounds()
        .unwrap_or(([i32::MAX; 3], [i32::MIN; 3]));
    entries.insert("file_bbox_min".into(), VdbMeta::Vec3i(min));
    entries.insert("file_bbox_max".into(), VdbMeta::Vec3i(max));
    let voxels = i64::try_from(grid.active_voxel_count()).unwrap_or(i64::MAX);
    entries.insert("file_voxel_count".into(), VdbMeta::Int64(voxels));
    let compression = if flags & COMPRESS_ZIP != 0 {
        "zip + active values"
    } else {
        "active values"
    };
    entries.insert(
        "file_compression".into(),
        VdbMeta::String(compression.into()),
    );

    put_entries(out, &entries);
}

/// Metadata entries as OpenVDB's `MetaMap` stores them: a count, then name, type and value.
fn put_entries(out: &mut Vec<u8>, entries: &BTreeMap<String, VdbMeta>) {
    put_u32(out, entries.len() as u32);
    for (key, value) in entries {
        put_string(out, key);
        let (type_name, bytes): (&str, Vec<u8>) = match value {
            VdbMeta::String(s) => ("string", s.as_bytes().to_vec()),
            VdbMeta::Bool(b) => ("bool", vec![u8::from(*b)]),
            VdbMeta::Int32(v) => ("int32", v.to_le_bytes().to_vec()),
            VdbMeta::Int64(v) => ("int64", v.to_le_bytes().to_vec()),
            VdbMeta::Float(v) => ("float", v.to_le_bytes().to_vec()),
            VdbMeta::Double(v) => ("double", v.to_le_bytes().to_vec()),
            VdbMeta::Vec3i(v) => ("vec3i", v.iter().flat_map(|c| c.to_le_bytes()).collect()),
            VdbMeta::Vec3s(v) => ("vec3s", v.iter().flat_map(|c| c.to_le_bytes()).collect()),
            VdbMeta::Vec3d(v) => ("vec3d", v.iter().flat_map(|c| c.to_le_bytes()).collect()),
            VdbMeta::Other { type_name, bytes } => (type_name.as_str(), bytes.clone()),
        };
        put_string(out, type_name);
        put_u32(out, bytes.len() as u32);
        out.extend_from_slice(&bytes);
    }
}

/// Writes the simplest OpenVDB map that equals the grid's index-to-world matrix, or the
/// grid's frustum map with that matrix as its second map.
fn write_transform(out: &mut Vec<u8>, grid: &VdbGrid) -> Outcome<()> {
    let m = grid.index_to_world;
    let linear = DMat3::from_mat4(m);
    let translation = m.w_axis.truncate();
    let determinant = linear.determinant();
    if !m.is_finite() || determinant == 0.0 || !determinant.is_finite() {
        return Err(Failure::new(format!(
            "grid '{}' has a degenerate index-to-world transform",
            grid.name
        )));
    }
    if m.row(3) != glam::DVec4::W {
        return Err(Failure::new(format!(
            "grid '{}' has a projective transform; VDB files hold affine ones",
            grid.name
        )));
    }
    if let Some(frustum) = &grid.frustum {
        // OpenVDB writes a frustum's second map as the affine map it keeps, whatever it was.
        put_string(out, super::FRUSTUM_MAP);
        frustum.write(out);
        put_affine(out, &m);
        return Ok(());
    }
    let diagonal = DVec3::new(linear.x_axis.x, linear.y_axis.y, linear.z_axis.z);
    let off_diagonal = [
        linear.x_axis.y,
        linear.x_axis.z,
        linear.y_axis.x,
        linear.y_axis.z,
        linear.z_axis.x,
        linear.z_axis.y,
    ];
    if off_diagonal.iter().all(|&v| v == 0.0) {
        let uniform = diagonal.x == diagonal.y && diagonal.y == diagonal.z;
        let map = match (uniform, translation == DVec3::ZERO) {
            (true, true) => "UniformScaleMap",
            (true, false) => "UniformScaleTranslateMap",
            (false, true) => "ScaleMap",
            (false, false) => "ScaleTranslateMap",
        };
        put_string(out, map);
        if translation != DVec3::ZERO {
            put_vec3d(out, translation);
        }
        // The scale, then the caches OpenVDB keeps beside it and reads back as they are.
        let inverse = diagonal.recip();
        put_vec3d(out, diagonal);
        put_vec3d(out, diagonal.abs());
        put_vec3d(out, inverse);
        put_vec3d(out, inverse * inverse);
        put_vec3d(out, inverse * 0.5);
    } else {
        put_affine(out, &m);
    }
    Ok(())
}

fn put_affine(out: &mut Vec<u8>, m: &glam::DMat4) {
    put_string(out, "AffineMap");
    // Row-major for row vectors: glam's columns are OpenVDB's rows.
    for cell in m.to_cols_array() {
        out.extend_from_slice(&cell.to_le_bytes());
    }
}

pub(super) fn put_u32(out: &mut Vec<u8>, value: u32) {
    out.extend_from_slice(&value.to_le_bytes());
}

fn put_string(out: &mut Vec<u8>, text: &str) {
    put_u32(out, text.len() as u32);
    out.extend_from_slice(text.as_bytes());
}

fn put_vec3d(out: &mut Vec<u8>, v: DVec3) {
    for c in v.to_array() {
        out.extend_from_slice(&c.to_le_bytes());
    }
}

/// A UUID-shaped hash of the file's contents (two FNV-1a passes with different seeds).
fn uuid_of(bytes: &[u8]) -> String {
    let fnv = |seed: u64| {
        bytes.iter().fold(seed, |h, &b| {
            (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
        })
    };
    let hex = format!(
        "{:016x}{:016x}",
        fnv(0xcbf2_9ce4_8422_2325),
        fnv(0x6c62_272e_07bb_0142)
    );
    format!(
        "{}-{}-{}-{}-{}",
        &hex[..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..]
    )
}
