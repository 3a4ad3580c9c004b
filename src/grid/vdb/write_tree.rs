//! Writing one grid's tree: rebuilding OpenVDB's root table and internal nodes from felt's
//! flat leaves and tiles, then the topology and the compressed value buffers.
//!
//! The key decision: each node stores its active values only, with the one-byte code and (at
//! most) two values and a selection mask that restore its inactive values — chosen by the
//! same rules as OpenVDB's writer, so OpenVDB reads every inactive voxel back exactly
//! (a level set's interior stays −background). Internal nodes are kept sparse (maps from slot
//! to tile or child) and expanded to their dense value arrays one at a time while writing.

use super::compress;
use super::half::{f32_to_f16, round_to_half};
use super::read_tree::{
    COMPRESS_ACTIVE_MASK, COMPRESS_ZIP, MASK_AND_NO_INACTIVE_VALS, MASK_AND_ONE_INACTIVE_VAL,
    MASK_AND_TWO_INACTIVE_VALS, NO_MASK_AND_ALL_VALS, NO_MASK_AND_MINUS_BG,
    NO_MASK_AND_ONE_INACTIVE_VAL, NO_MASK_OR_INACTIVE_VALS, bit,
};
use super::write::put_u32;
use super::{LEAF_VOXELS, TILE_SIZES, VdbGrid, VdbLeaf, align};
use crate::base::failure::{Failure, Outcome};
use std::collections::BTreeMap;

type TileValue = ([f32; 3], bool);

#[derive(Default)]
struct Lower {
    tiles: BTreeMap<usize, TileValue>,
    leaves: BTreeMap<usize, usize>,
}

#[derive(Default)]
struct Upper {
    tiles: BTreeMap<usize, TileValue>,
    children: BTreeMap<usize, Lower>,
}

#[derive(Default)]
struct Root {
    tiles: BTreeMap<[i32; 3], TileValue>,
    children: BTreeMap<[i32; 3], Upper>,
}

/// The slot that holds `ijk` in a node with `1 << log2_dim` children of `1 << child_log2`
/// voxels per axis.
fn slot(ijk: [i32; 3], log2_dim: u32, child_log2: u32) -> usize {
    let mask = (1 << log2_dim) - 1;
    let local = ijk.map(|c| ((c >> child_log2) & mask) as usize);
    (local[0] << (2 * log2_dim)) | (local[1] << log2_dim) | local[2]
}

fn overlap(grid: &VdbGrid, origin: [i32; 3]) -> Failure {
    Failure::new(format!(
        "grid '{}' has overlapping leaves or tiles at index {origin:?}",
        grid.name
    ))
}

fn build(grid: &VdbGrid) -> Outcome<Root> {
    let components = grid.components();
    let mut root = Root::default();
    for tile in &grid.tiles {
        let level = TILE_SIZES
            .iter()
            .position(|&s| s == tile.size)
            .ok_or_else(|| {
                Failure::new(format!(
                    "grid '{}' has a tile of size {}; tiles are 8, 128 or 4096 voxels wide",
                    grid.name, tile.size
                ))
            })?;
        if align(tile.origin, tile.size) != tile.origin {
            return Err(Failure::new(format!(
                "grid '{}' has a tile at {:?} that is not aligned to its size {}",
                grid.name, tile.origin, tile.size
            )));
        }
        let value = (tile.value, tile.active);
        let fresh = match level {
            2 => root.tiles.insert(tile.origin, value).is_none(),
            1 => {
                let upper = root.children.entry(align(tile.origin, 4096)).or_default();
                upper.tiles.insert(slot(tile.origin, 5, 7), value).is_none()
            }
            _ => {
                let upper = root.children.entry(align(tile.origin, 4096)).or_default();
                let lower = upper.children.entry(slot(tile.origin, 5, 7)).or_default();
                lower.tiles.insert(slot(tile.origin, 4, 3), value).is_none()
            }
        };
        if !fresh {
            return Err(overlap(grid, tile.origin));
        }
    }
    for (index, leaf) in grid.leaves.iter().enumerate() {
        if align(leaf.origin, 8) != leaf.origin {
            return Err(Failure::new(format!(
                "grid '{}' has a leaf at {:?} that is not aligned to 8 voxels",
                grid.name, leaf.origin
            )));
        }
        if leaf.values.len() != LEAF_VOXELS * components {
            return Err(Failure::new(format!(
                "grid '{}' has a leaf at {:?} with {} values, expected {}",
                grid.name,
                leaf.origin,
                leaf.values.len(),
                LEAF_VOXELS * components
            )));
        }
        let upper = root.children.entry(align(leaf.origin, 4096)).or_default();
        let lower = upper.children.entry(slot(leaf.origin, 5, 7)).or_default();
        if lower
            .leaves
            .insert(slot(leaf.origin, 4, 3), index)
            .is_some()
        {
            return Err(overlap(grid, leaf.origin));
        }
    }
    // A tile and a node below it cannot share a slot.
    for (origin, upper) in &root.children {
        if root.tiles.contains_key(origin) {
            return Err(overlap(grid, *origin));
        }
        for (&n, lower) in &upper.children {
            if upper.tiles.contains_key(&n) {
                return Err(overlap(grid, *origin));
            }
            if let Some(&n) = lower.tiles.keys().find(|n| lower.leaves.contains_key(n)) {
                let leaf = &grid.leaves[lower.leaves[&n]];
                return Err(overlap(grid, leaf.origin));
            }
        }
    }
    Ok(root)
}

/// How values are written for this grid.
struct Encoding {
    components: usize,
    half: bool,
    compression: u32,
    /// At full precision: OpenVDB compares against it before rounding anything.
    background: [f32; 3],
}

/// Writes the topology and the leaf buffers; returns where the buffers start.
pub(super) fn write_tree(out: &mut Vec<u8>, grid: &VdbGrid, compression: u32) -> Outcome<usize> {
    let root = build(grid)?;
    let encoding = Encoding {
        components: grid.components(),
        half: grid.saved_as_half,
        compression,
        background: grid.background,
    };
    put_u32(out, 1); // one buffer per leaf
    let mut background = grid.background;
    if encoding.half {
        background = background.map(round_to_half);
    }
    put_value(out, &background[..encoding.components]);
    put_u32(out, root.tiles.len() as u32);
    put_u32(out, root.children.len() as u32);
    for (origin, (value, active)) in &root.tiles {
        put_coord(out, *origin);
        put_value(out, &value[..encoding.components]);
        out.push(u8::from(*active));
    }
    let mut values = Vec::new();
    for (origin, upper) in &root.children {
        put_coord(out, *origin);
        let children: Vec<usize> = upper.children.keys().copied().collect();
        write_internal(out, &upper.tiles, &children, 5, &encoding, &mut values);
        for lower in upper.children.values() {
            let leaves: Vec<usize> = lower.leaves.keys().copied().collect();
            write_internal(out, &lower.tiles, &leaves, 4, &encoding, &mut values);
            for &index in lower.leaves.values() {
                put_mask(out, &grid.leaves[index].active);
            }
        }
    }
    let block_pos = out.len();
    for upper in root.children.values() {
        for lower in upper.children.values() {
            for &index in lower.leaves.values() {
                let leaf: &VdbLeaf = &grid.leaves[index];
                put_mask(out, &leaf.active);
                write_values(out, &leaf.values, &leaf.active, None, &encoding);
            }
        }
    }
    Ok(block_pos)
}

fn write_internal(
    out: &mut Vec<u8>,
    tiles: &BTreeMap<usize, TileValue>,
    children: &[usize],
    log2_dim: u32,
    encoding: &Encoding,
    values: &mut Vec<f32>,
) {
    let slots = 1usize << (3 * log2_dim);
    let components = encoding.components;
    let mut child_mask = vec![0u64; slots / 64];
    let mut value_mask = vec![0u64; slots / 64];
    values.clear();
    for _ in 0..slots {
        values.extend_from_slice(&encoding.background[..components]);
    }
    for &n in children {
        child_mask[n >> 6] |= 1 << (n & 63);
        // OpenVDB stores zero in the slots of children.
        values[n * components..(n + 1) * components].fill(0.0);
    }
    for (&n, (value, active)) in tiles {
        if *active {
            value_mask[n >> 6] |= 1 << (n & 63);
        }
        values[n * components..(n + 1) * components].copy_from_slice(&value[..components]);
    }
    put_mask(out, &child_mask);
    put_mask(out, &value_mask);
    write_values(out, values, &value_mask, Some(&child_mask), encoding);
}

/// OpenVDB's choice of how to store a node's inactive values: at most two distinct values,
/// preferably ±background so that none needs storing.
fn inactive_scheme(
    values: &[f32],
    value_mask: &[u64],
    child_mask: Option<&[u64]>,
    encoding: &Encoding,
) -> (i8, [[f32; 3]; 2]) {
    let components = encoding.components;
    let mut background = [0.0; 3];
    background[..components].copy_from_slice(&encoding.background[..components]);
    let minus_background = background.map(|v| -v);
    let mut inactive = [background; 2];
    let mut unique = 0;
    for (n, value) in values.chunks_exact(components).enumerate() {
        if unique >= 3 {
            break;
        }
        if bit(value_mask, n) || child_mask.is_some_and(|m| bit(m, n)) {
            continue;
        }
        let mut v = [0.0; 3];
        v[..components].copy_from_slice(value);
        let seen = (unique > 0 && v == inactive[0]) || (unique > 1 && v == inactive[1]);
        if !seen {
            if unique < 2 {
                inactive[unique] = v;
            }
            unique += 1;
        }
    }
    let code = match unique {
        0 => NO_MASK_OR_INACTIVE_VALS,
        1 if inactive[0] == background => NO_MASK_OR_INACTIVE_VALS,
        1 if inactive[0] == minus_background => NO_MASK_AND_MINUS_BG,
        1 => NO_MASK_AND_ONE_INACTIVE_VAL,
        2 if inactive[0] != background && inactive[1] != background => MASK_AND_TWO_INACTIVE_VALS,
        2 if inactive[1] == background => {
            if inactive[0] == minus_background {
                MASK_AND_NO_INACTIVE_VALS
            } else {
                MASK_AND_ONE_INACTIVE_VAL
            }
        }
        2 => {
            // The first value is the background: keep the other in slot 0.
            inactive.swap(0, 1);
            if inactive[0] == minus_background {
                MASK_AND_NO_INACTIVE_VALS
            } else {
                MASK_AND_ONE_INACTIVE_VAL
            }
        }
        _ => NO_MASK_AND_ALL_VALS,
    };
    (code, inactive)
}

fn write_values(
    out: &mut Vec<u8>,
    values: &[f32],
    value_mask: &[u64],
    child_mask: Option<&[u64]>,
    encoding: &Encoding,
) {
    let components = encoding.components;
    let masked = encoding.compression & COMPRESS_ACTIVE_MASK != 0;
    let (code, inactive) = if masked {
        inactive_scheme(values, value_mask, child_mask, encoding)
    } else {
        (NO_MASK_AND_ALL_VALS, [[0.0; 3]; 2])
    };
    out.push(code as u8);
    let stored_values = matches!(
        code,
        NO_MASK_AND_ONE_INACTIVE_VAL | MASK_AND_ONE_INACTIVE_VAL | MASK_AND_TWO_INACTIVE_VALS
    );
    if stored_values {
        let count = if code == MASK_AND_TWO_INACTIVE_VALS {
            2
        } else {
            1
        };
        for value in &inactive[..count] {
            let mut value = *value;
            if encoding.half {
                value = value.map(round_to_half);
            }
            put_value(out, &value[..components]);
        }
    }
    let mut kept: Vec<f32> = Vec::new();
    let data: &[f32] = if code == NO_MASK_AND_ALL_VALS {
        values
    } else {
        let with_selection = matches!(
            code,
            MASK_AND_NO_INACTIVE_VALS | MASK_AND_ONE_INACTIVE_VAL | MASK_AND_TWO_INACTIVE_VALS
        );
        let mut selection = vec![0u64; value_mask.len()];
        for (n, value) in values.chunks_exact(components).enumerate() {
            if bit(value_mask, n) {
                kept.extend_from_slice(value);
            } else if with_selection && value == &inactive[1][..components] {
                selection[n >> 6] |= 1 << (n & 63);
            }
        }
        if with_selection {
            put_mask(out, &selection);
        }
        &kept
    };
    let mut bytes = Vec::with_capacity(data.len() * 4);
    if encoding.half {
        // OpenVDB writes nothing at all for an empty half-float buffer.
        if data.is_empty() {
            return;
        }
        for &v in data {
            bytes.extend_from_slice(&f32_to_f16(v).to_le_bytes());
        }
    } else {
        for &v in data {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    put_data(out, &bytes, encoding.compression);
}

/// Writes a value buffer, zipped when that makes it smaller (a negative length marks raw
/// bytes, as in OpenVDB).
fn put_data(out: &mut Vec<u8>, bytes: &[u8], compression: u32) {
    if compression & COMPRESS_ZIP == 0 {
        out.extend_from_slice(bytes);
        return;
    }
    let packed = compress::zip(bytes);
    if packed.len() < bytes.len() {
        out.extend_from_slice(&(packed.len() as i64).to_le_bytes());
        out.extend_from_slice(&packed);
    } else {
        out.extend_from_slice(&(-(bytes.len() as i64)).to_le_bytes());
        out.extend_from_slice(bytes);
    }
}

fn put_value(out: &mut Vec<u8>, value: &[f32]) {
    for v in value {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

fn put_coord(out: &mut Vec<u8>, origin: [i32; 3]) {
    for c in origin {
        out.extend_from_slice(&c.to_le_bytes());
    }
}

fn put_mask(out: &mut Vec<u8>, words: &[u64]) {
    for w in words {
        out.extend_from_slice(&w.to_le_bytes());
    }
}
