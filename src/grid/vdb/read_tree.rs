//! Reading one grid's tree: the root table, the 32³ and 16³ internal nodes, the leaves, and
//! the compressed value buffers they hold.
//!
//! A file stores a tree twice over: first the topology (every node's masks and every tile
//! value, depth first), then the leaf value buffers, in the order of OpenVDB's root table —
//! root children sorted by origin, whatever order the topology listed them in. The key
//! decision is how inactive values come back: OpenVDB stores only active values plus a
//! one-byte code saying how to restore the rest (background, −background, one or two stored
//! values, chosen per voxel by a selection mask), and felt restores them exactly as OpenVDB
//! does, so a level set's inactive interior reads −background. Leaf buffers are found in file
//! order, then inflated and decoded on all threads, each thread reusing one inflater.

use super::compress::{self, Inflater};
use super::cursor::Cursor;
use super::half::f16_to_f32;
use super::read::VERSION_NODE_MASK_COMPRESSION;
use super::{LEAF_VOXELS, VdbLeaf, VdbTile};
use crate::base::failure::Outcome;
use rayon::prelude::*;
use std::collections::HashSet;

pub(super) const COMPRESS_ZIP: u32 = 0x1;
pub(super) const COMPRESS_ACTIVE_MASK: u32 = 0x2;
pub(super) const COMPRESS_BLOSC: u32 = 0x4;

/// How the inactive values of a node were stored (OpenVDB's mask-compression codes).
pub(super) const NO_MASK_OR_INACTIVE_VALS: i8 = 0;
pub(super) const NO_MASK_AND_MINUS_BG: i8 = 1;
pub(super) const NO_MASK_AND_ONE_INACTIVE_VAL: i8 = 2;
pub(super) const MASK_AND_NO_INACTIVE_VALS: i8 = 3;
pub(super) const MASK_AND_ONE_INACTIVE_VAL: i8 = 4;
pub(super) const MASK_AND_TWO_INACTIVE_VALS: i8 = 5;
pub(super) const NO_MASK_AND_ALL_VALS: i8 = 6;

/// The scalar type of stored values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Scalar {
    Half,
    Single,
    Double,
}

/// How one value is laid out in the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct ValueFormat {
    pub scalar: Scalar,
    pub components: usize,
}

impl ValueFormat {
    pub(super) fn bytes(self) -> usize {
        let scalar = match self.scalar {
            Scalar::Half => 2,
            Scalar::Single => 4,
            Scalar::Double => 8,
        };
        scalar * self.components
    }

    /// Widens `bytes` (whole values) into `out`, one `f32` per component.
    fn decode(self, bytes: &[u8], out: &mut [f32]) {
        match self.scalar {
            Scalar::Half => {
                for (o, b) in out.iter_mut().zip(bytes.chunks_exact(2)) {
                    *o = f16_to_f32(u16::from_le_bytes([b[0], b[1]]));
                }
            }
            Scalar::Single => {
                for (o, b) in out.iter_mut().zip(bytes.chunks_exact(4)) {
                    *o = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                }
            }
            Scalar::Double => {
                for (o, b) in out.iter_mut().zip(bytes.chunks_exact(8)) {
                    let mut w = [0u8; 8];
                    w.copy_from_slice(b);
                    *o = f64::from_le_bytes(w) as f32;
                }
            }
        }
    }
}

/// What the reader must know about a grid's storage.
pub(super) struct TreeFormat {
    pub value: ValueFormat,
    /// Value buffers (not the background or root tiles) hold halves.
    pub half: bool,
    pub compression: u32,
    pub version: u32,
}

pub(super) struct Tree {
    pub background: [f32; 3],
    pub leaves: Vec<VdbLeaf>,
    pub tiles: Vec<VdbTile>,
}

/// A leaf whose topology is known and whose values come later in the file.
struct PendingLeaf {
    origin: [i32; 3],
    active: [u64; 8],
}

/// An internal node level: `log2_dim` children per axis, each `1 << child_log2` voxels wide.
#[derive(Clone, Copy)]
struct Level {
    log2_dim: u32,
    child_log2: u32,
}

const UPPER: Level = Level {
    log2_dim: 5,
    child_log2: 7,
};
const LOWER: Level = Level {
    log2_dim: 4,
    child_log2: 3,
};
const ROOT_CHILD_SIZE: i32 = 4096;

/// Local coordinates of slot `n` of a node with `1 << log2_dim` slots per axis.
pub(super) fn slot_coords(n: usize, log2_dim: u32) -> [i32; 3] {
    let mask = (1 << log2_dim) - 1;
    [
        (n >> (2 * log2_dim)) as i32,
        ((n >> log2_dim) & mask) as i32,
        (n & mask) as i32,
    ]
}

pub(super) fn bit(mask: &[u64], n: usize) -> bool {
    mask[n >> 6] >> (n & 63) & 1 == 1
}

fn ones(mask: &[u64]) -> impl Iterator<Item = usize> + '_ {
    mask.iter().enumerate().flat_map(|(w, &word)| {
        let mut bits = word;
        std::iter::from_fn(move || {
            if bits == 0 {
                return None;
            }
            let n = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            Some(w * 64 + n)
        })
    })
}

fn read_value(cur: &mut Cursor, format: ValueFormat, what: &str) -> Outcome<[f32; 3]> {
    let bytes = cur.take(format.bytes(), what)?;
    let mut value = [0.0; 3];
    format.decode(bytes, &mut value[..format.components]);
    Ok(value)
}

struct TreeReader<'r, 'a> {
    cur: &'r mut Cursor<'a>,
    format: &'r TreeFormat,
    background: [f32; 3],
    tiles: Vec<VdbTile>,
    /// One internal node's values, reused from node to node.
    node_values: Vec<f32>,
    scratch: DecodeScratch,
}

pub(super) fn read_tree(cur: &mut Cursor, format: &TreeFormat) -> Outcome<Tree> {
    // Trees used to be able to hold several buffers per leaf; the count is no longer used.
    cur.i32("the tree's buffer count")?;
    let background = read_value(cur, format.value, "the background value")?;
    let at = cur.pos();
    let tile_count = cur.u32("the root's tile count")? as usize;
    let child_count = cur.u32("the root's child count")? as usize;
    let tile_bytes = 12 + format.value.bytes() + 1;
    if tile_count > cur.remaining() / tile_bytes {
        return Err(cur.fail(
            at,
            format!("the root claims {tile_count} tiles, more than fit in the file"),
        ));
    }
    // A root child holds at least its origin and two 4096-byte masks.
    if child_count > cur.remaining() / (12 + 8192) {
        return Err(cur.fail(
            at,
            format!("the root claims {child_count} children, more than fit in the file"),
        ));
    }
    let mut reader = TreeReader {
        cur,
        format,
        background,
        tiles: Vec::new(),
        node_values: Vec::new(),
        scratch: DecodeScratch::default(),
    };
    let mut origins = HashSet::new();
    for _ in 0..tile_count {
        let at = reader.cur.pos();
        let origin = reader.cur.coord("a root tile's origin")?;
        let value = read_value(reader.cur, format.value, "a root tile's value")?;
        let active = reader.cur.u8("a root tile's state")? != 0;
        reader.check_root_origin(at, origin, &mut origins)?;
        if active || value != background {
            reader.tiles.push(VdbTile {
                origin,
                size: ROOT_CHILD_SIZE,
                value,
                active,
            });
        }
    }
    let mut children = Vec::new();
    for _ in 0..child_count {
        let at = reader.cur.pos();
        let origin = reader.cur.coord("a root child's origin")?;
        reader.check_root_origin(at, origin, &mut origins)?;
        let mut pending = Vec::new();
        reader.read_internal(origin, UPPER, &mut pending)?;
        children.push((origin, pending));
    }
    children.sort_by_key(|(origin, _)| *origin);
    // Each buffer's length is only known once the one before it is read, so the buffers are
    // located in file order first; then they are inflated and decoded in parallel, each into
    // its own leaf, and collected in order: the same leaves, and for a damaged file the same
    // first failure, for any thread count.
    let mut located = Vec::new();
    for pending in children.into_iter().flat_map(|(_, pending)| pending) {
        located.push(reader.locate_leaf_buffer(pending)?);
    }
    let cur: &Cursor = reader.cur;
    let decoded: Vec<Outcome<VdbLeaf>> = located
        .into_par_iter()
        .with_min_len(64)
        .map_init(
            DecodeScratch::default,
            |scratch, (pending, buffer)| -> Outcome<VdbLeaf> {
                let mut values = vec![0.0; LEAF_VOXELS * format.value.components];
                buffer.decode(cur, format, &pending.active, &mut values, scratch)?;
                Ok(VdbLeaf {
                    origin: pending.origin,
                    values,
                    active: pending.active,
                })
            },
        )
        .collect();
    let leaves = decoded.into_iter().collect::<Outcome<Vec<VdbLeaf>>>()?;
    Ok(Tree {
        background,
        leaves,
        tiles: reader.tiles,
    })
}

impl<'a> TreeReader<'_, 'a> {
    fn check_root_origin(
        &self,
        at: usize,
        origin: [i32; 3],
        seen: &mut HashSet<[i32; 3]>,
    ) -> Outcome<()> {
        if origin.iter().any(|c| c & (ROOT_CHILD_SIZE - 1) != 0) {
            return Err(self.cur.fail(
                at,
                format!("root entry origin {origin:?} is not a multiple of 4096"),
            ));
        }
        if !seen.insert(origin) {
            return Err(self
                .cur
                .fail(at, format!("two root entries share the origin {origin:?}")));
        }
        Ok(())
    }

    fn read_internal(
        &mut self,
        origin: [i32; 3],
        level: Level,
        leaves: &mut Vec<PendingLeaf>,
    ) -> Outcome<()> {
        let slots = 1usize << (3 * level.log2_dim);
        let words = slots / 64;
        let child_mask = self.cur.words(words, "an internal node's child mask")?;
        let value_mask = self.cur.words(words, "an internal node's value mask")?;
        let children = child_mask
            .iter()
            .map(|w| w.count_ones() as usize)
            .sum::<usize>();
        let components = self.format.value.components;
        let old_layout = self.format.version < VERSION_NODE_MASK_COMPRESSION;
        // Old files store values only for the slots that hold no child.
        let count = if old_layout { slots - children } else { slots };
        self.node_values.resize(slots * components, 0.0);
        let out = &mut self.node_values[..count * components];
        locate_values(self.cur, self.format, self.background, &value_mask, count)?.decode(
            self.cur,
            self.format,
            &value_mask,
            out,
            &mut self.scratch,
        )?;
        let tile_size = 1i32 << level.child_log2;
        let mut next = 0;
        for slot in 0..slots {
            if bit(&child_mask, slot) {
                continue;
            }
            let index = if old_layout { next } else { slot };
            next += 1;
            let mut value = [0.0; 3];
            value[..components]
                .copy_from_slice(&self.node_values[index * components..(index + 1) * components]);
            let active = bit(&value_mask, slot);
            if active || value != self.background {
                self.tiles.push(VdbTile {
                    origin: child_origin(origin, slot, level),
                    size: tile_size,
                    value,
                    active,
                });
            }
        }
        for slot in ones(&child_mask) {
            let child = child_origin(origin, slot, level);
            if level.child_log2 == UPPER.child_log2 {
                self.read_internal(child, LOWER, leaves)?;
            } else {
                let mask = self.cur.words(8, "a leaf's value mask")?;
                let mut active = [0u64; 8];
                active.copy_from_slice(&mask);
                leaves.push(PendingLeaf {
                    origin: child,
                    active,
                });
            }
        }
        Ok(())
    }

    /// Finds a leaf's value buffer, reading past it (and past the auxiliary buffers of very old
    /// files, which are dropped).
    fn locate_leaf_buffer(
        &mut self,
        pending: PendingLeaf,
    ) -> Outcome<(PendingLeaf, ValueBuffer<'a>)> {
        // The buffer repeats the topology's value mask; OpenVDB reads files by the topology's.
        self.cur.take(64, "a leaf buffer's value mask")?;
        let mut extra_buffers = 0;
        if self.format.version < VERSION_NODE_MASK_COMPRESSION {
            self.cur.take(12, "a leaf buffer's origin")?;
            extra_buffers = (self.cur.i8("a leaf's buffer count")? as i32 - 1).max(0);
        }
        let buffer = locate_values(
            self.cur,
            self.format,
            self.background,
            &pending.active,
            LEAF_VOXELS,
        )?;
        let element = self.element_format();
        for _ in 0..extra_buffers {
            let zipped = self.format.compression & COMPRESS_ZIP;
            locate_data(
                self.cur,
                LEAF_VOXELS * element.bytes(),
                zipped,
                "an auxiliary leaf buffer",
            )?;
        }
        Ok((pending, buffer))
    }

    fn element_format(&self) -> ValueFormat {
        element_format(self.format)
    }
}

fn element_format(format: &TreeFormat) -> ValueFormat {
    if format.half {
        ValueFormat {
            scalar: Scalar::Half,
            components: format.value.components,
        }
    } else {
        format.value
    }
}

fn child_origin(origin: [i32; 3], slot: usize, level: Level) -> [i32; 3] {
    let local = slot_coords(slot, level.log2_dim);
    [0, 1, 2].map(|a| origin[a] + (local[a] << level.child_log2))
}

/// What one node's value buffer needs for decoding, its bytes located but not yet read.
struct ValueBuffer<'a> {
    /// Where the stored data starts, for messages.
    at: usize,
    /// The values of inactive voxels: `[0]` where the selection mask is clear, `[1]` where set.
    inactive: [[f32; 3]; 2],
    selection: Option<Vec<u64>>,
    /// Values stored: all of the node's, or only its active ones.
    stored: usize,
    count: usize,
    data: Data<'a>,
}

/// The stored values' bytes.
enum Data<'a> {
    /// Nothing stored (an empty half-float buffer).
    Empty,
    Raw(&'a [u8]),
    Zip(&'a [u8]),
    Blosc(&'a [u8]),
}

/// One thread's buffers for decoding.
#[derive(Default)]
struct DecodeScratch {
    inflater: Inflater,
    values: Vec<f32>,
}

/// Reads the header of one node's value buffer (`count` values, `value_mask.len() × 64` or
/// fewer for old internal nodes) and reads past its data.
fn locate_values<'a>(
    cur: &mut Cursor<'a>,
    format: &TreeFormat,
    background: [f32; 3],
    value_mask: &[u64],
    count: usize,
) -> Outcome<ValueBuffer<'a>> {
    let at = cur.pos();
    let code = if format.version >= VERSION_NODE_MASK_COMPRESSION {
        cur.i8("a value buffer's compression code")?
    } else {
        NO_MASK_AND_ALL_VALS
    };
    if !(NO_MASK_OR_INACTIVE_VALS..=NO_MASK_AND_ALL_VALS).contains(&code) {
        return Err(cur.fail(at, format!("unknown value-compression code {code}")));
    }
    let minus_background = background.map(|v| -v);
    let mut inactive = [
        if code == NO_MASK_OR_INACTIVE_VALS {
            background
        } else {
            minus_background
        },
        background,
    ];
    if matches!(
        code,
        NO_MASK_AND_ONE_INACTIVE_VAL | MASK_AND_ONE_INACTIVE_VAL | MASK_AND_TWO_INACTIVE_VALS
    ) {
        inactive[0] = read_value(cur, format.value, "an inactive value")?;
        if code == MASK_AND_TWO_INACTIVE_VALS {
            inactive[1] = read_value(cur, format.value, "an inactive value")?;
        }
    }
    let selection = if matches!(
        code,
        MASK_AND_NO_INACTIVE_VALS | MASK_AND_ONE_INACTIVE_VAL | MASK_AND_TWO_INACTIVE_VALS
    ) {
        Some(cur.words(value_mask.len(), "a selection mask")?)
    } else {
        None
    };
    let masked = format.compression & COMPRESS_ACTIVE_MASK != 0 && code != NO_MASK_AND_ALL_VALS;
    let stored = if masked {
        value_mask.iter().map(|w| w.count_ones() as usize).sum()
    } else {
        count
    };
    if stored > count {
        return Err(cur.fail(
            at,
            "a value mask has more active values than the node has values",
        ));
    }
    let element = element_format(format);
    let data_at = cur.pos();
    // OpenVDB writes nothing at all for an empty half-float buffer.
    let data = if format.half && stored == 0 {
        Data::Empty
    } else {
        locate_data(
            cur,
            stored * element.bytes(),
            format.compression,
            "a value buffer",
        )?
    };
    Ok(ValueBuffer {
        at: data_at,
        inactive,
        selection,
        stored,
        count,
        data,
    })
}

impl ValueBuffer<'_> {
    /// Decodes the values into `out` (`count` values), restoring the inactive ones the way the
    /// node's code says. `cur` only names the place in messages.
    fn decode(
        &self,
        cur: &Cursor,
        format: &TreeFormat,
        value_mask: &[u64],
        out: &mut [f32],
        scratch: &mut DecodeScratch,
    ) -> Outcome<()> {
        let components = format.value.components;
        let element = element_format(format);
        let expected = self.stored * element.bytes();
        let fail = |e: String| cur.fail(self.at, format!("a value buffer: {e}"));
        let bytes: &[u8] = match self.data {
            Data::Empty => &[],
            Data::Raw(bytes) => bytes,
            Data::Zip(packed) => scratch.inflater.unzip(packed, expected).map_err(fail)?,
            Data::Blosc(packed) => {
                scratch.inflater.out = compress::unblosc(packed, expected).map_err(fail)?;
                &scratch.inflater.out
            }
        };
        if self.stored == self.count {
            element.decode(bytes, out);
            return Ok(());
        }
        let values = &mut scratch.values;
        values.resize(self.stored * components, 0.0);
        element.decode(bytes, values);
        let mut next = 0;
        for (n, value) in out.chunks_exact_mut(components).enumerate() {
            if bit(value_mask, n) {
                value.copy_from_slice(&values[next * components..(next + 1) * components]);
                next += 1;
            } else {
                let pick = self.selection.as_ref().is_some_and(|s| bit(s, n));
                value.copy_from_slice(&self.inactive[usize::from(pick)][..components]);
            }
        }
        Ok(())
    }
}

/// Reads past `expected` bytes of a value buffer, compressed if the grid is. A compressed
/// chunk starts with its length; a negative length marks bytes stored raw because compressing
/// them did not help.
fn locate_data<'a>(
    cur: &mut Cursor<'a>,
    expected: usize,
    compression: u32,
    what: &str,
) -> Outcome<Data<'a>> {
    if compression & (COMPRESS_BLOSC | COMPRESS_ZIP) == 0 {
        return Ok(Data::Raw(cur.take(expected, what)?));
    }
    let at = cur.pos();
    let length = cur.i64("a compressed chunk's length")?;
    if length <= 0 {
        let raw = length.unsigned_abs();
        if raw != expected as u64 {
            return Err(cur.fail(at, format!("{what} holds {raw} bytes, expected {expected}")));
        }
        return Ok(Data::Raw(cur.take(expected, what)?));
    }
    let length = usize::try_from(length).unwrap_or(usize::MAX);
    let packed = cur.take(length, what)?;
    Ok(if compression & COMPRESS_BLOSC != 0 {
        Data::Blosc(packed)
    } else {
        Data::Zip(packed)
    })
}
