//! The byte-level codecs of VDB value buffers: zlib ("zip") both ways, and blosc decoding.
//!
//! OpenVDB hands each value array to zlib or to blosc (LZ4 with a byte shuffle). felt decodes
//! blosc's container itself — header, block table, optional per-byte-plane "splits", LZ4 or
//! zlib payloads, unshuffle — rather than binding the C library, so a corrupt file is a
//! `Err` and never undefined behaviour. The key decision: every decoder is told how many bytes
//! the caller expects and never produces more, so a hostile length field cannot inflate memory.

use flate2::FlushDecompress;
use flate2::write::ZlibEncoder;
use std::io::Write;

/// The blosc header is 16 bytes: version, codec version, flags, type size, then the raw
/// length, the block size and the stream length as little-endian u32.
const BLOSC_HEADER: usize = 16;
const BLOSC_SHUFFLE: u8 = 0x1;
const BLOSC_MEMCPYED: u8 = 0x2;
const BLOSC_BITSHUFFLE: u8 = 0x4;
const BLOSC_RESERVED: u8 = 0x8;
const BLOSC_DONT_SPLIT: u8 = 0x10;
/// Blocks of at most this type size and at least this many elements are stored as one
/// stream per byte plane unless the header says otherwise (blosc's compatibility rule).
const BLOSC_MAX_SPLITS: usize = 16;
const BLOSC_MIN_SPLIT_ELEMENTS: usize = 128;

/// A zlib inflater kept from one value buffer to the next.
///
/// A file holds one zlib stream per leaf, a few kilobytes each; setting up a fresh decoder per
/// stream (its state and window) cost more than inflating the stream, so one reader resets the
/// same decoder for every buffer and inflates into one reused byte buffer.
pub(crate) struct Inflater {
    state: flate2::Decompress,
    /// The last buffer inflated (or decoded from blosc).
    pub(crate) out: Vec<u8>,
}

impl Default for Inflater {
    fn default() -> Self {
        Inflater {
            state: flate2::Decompress::new(true),
            out: Vec::new(),
        }
    }
}

impl Inflater {
    /// Inflates a zlib stream that must hold exactly `expected` bytes; the bytes stay valid
    /// until the next call.
    pub(crate) fn unzip(&mut self, src: &[u8], expected: usize) -> Result<&[u8], String> {
        // One byte of room past `expected` tells a stream that is too long from one that fits.
        self.out.clear();
        self.out.resize(expected + 1, 0);
        let produced = inflate_with(&mut self.state, src, &mut self.out)
            .map_err(|e| format!("zip data is corrupt ({e})"))?;
        if produced != expected {
            return Err(format!(
                "zip data inflates to {produced}{} bytes, expected {expected}",
                if produced > expected { " or more" } else { "" }
            ));
        }
        Ok(&self.out[..expected])
    }
}

/// Inflates one whole zlib stream from `src` into `out` with a reset `state`; returns the bytes
/// produced, at most `out.len()`.
fn inflate_with(
    state: &mut flate2::Decompress,
    src: &[u8],
    out: &mut [u8],
) -> Result<usize, flate2::DecompressError> {
    state.reset(true);
    loop {
        let (read, written) = (state.total_in() as usize, state.total_out() as usize);
        let status =
            state.decompress(&src[read..], &mut out[written..], FlushDecompress::Finish)?;
        let (now_read, now_written) = (state.total_in() as usize, state.total_out() as usize);
        let stalled = now_read == read && now_written == written;
        if status == flate2::Status::StreamEnd || now_written == out.len() || stalled {
            return Ok(now_written);
        }
    }
}

/// Inflates a zlib stream that must hold exactly `expected` bytes.
#[cfg(test)]
fn unzip(src: &[u8], expected: usize) -> Result<Vec<u8>, String> {
    Inflater::default().unzip(src, expected).map(<[u8]>::to_vec)
}

/// Deflates `data` at zlib's default level, as OpenVDB does.
pub(crate) fn zip(data: &[u8]) -> Vec<u8> {
    let mut encoder = ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    // Writing into a Vec cannot fail.
    let _ = encoder.write_all(data);
    encoder.finish().unwrap_or_default()
}

fn read_u32(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
}

/// Decodes one blosc container that must hold exactly `expected` bytes.
pub(crate) fn unblosc(src: &[u8], expected: usize) -> Result<Vec<u8>, String> {
    if src.len() < BLOSC_HEADER {
        return Err(format!(
            "blosc data of {} bytes is shorter than its header",
            src.len()
        ));
    }
    let version = src[0];
    let flags = src[2];
    let type_size = src[3] as usize;
    let raw_len = read_u32(src, 4) as usize;
    let block_size = read_u32(src, 8) as usize;
    let stream_len = read_u32(src, 12) as usize;
    if raw_len != expected {
        return Err(format!(
            "blosc data holds {raw_len} bytes, expected {expected}"
        ));
    }
    if raw_len == 0 {
        return Ok(Vec::new());
    }
    if version != 2 {
        return Err(format!(
            "blosc format version {version} is not supported (expected 2)"
        ));
    }
    if flags & BLOSC_RESERVED != 0 {
        return Err("blosc data uses flags from a newer blosc".into());
    }
    if type_size == 0 || block_size == 0 || block_size > raw_len {
        return Err(format!(
            "blosc header is inconsistent (type size {type_size}, block size {block_size}, \
             length {raw_len})"
        ));
    }
    if stream_len > src.len() || stream_len < BLOSC_HEADER {
        return Err(format!(
            "blosc header claims {stream_len} bytes but the chunk holds {}",
            src.len()
        ));
    }
    let stream = &src[..stream_len];
    if flags & BLOSC_MEMCPYED != 0 {
        if stream_len != raw_len + BLOSC_HEADER {
            return Err("blosc uncompressed data has the wrong length".into());
        }
        return Ok(stream[BLOSC_HEADER..].to_vec());
    }
    let codec = match flags >> 5 {
        1 => Codec::Lz4,
        3 => Codec::Zlib,
        0 => return Err("blosc data uses the BloscLZ codec, which felt does not read".into()),
        2 => return Err("blosc data uses the Snappy codec, which felt does not read".into()),
        4 => return Err("blosc data uses the Zstd codec, which felt does not read".into()),
        n => return Err(format!("blosc data uses unknown codec {n}")),
    };
    if flags & BLOSC_BITSHUFFLE != 0 && block_size >= type_size {
        return Err("blosc data uses bit shuffling, which felt does not read".into());
    }
    let blocks = raw_len.div_ceil(block_size);
    if blocks > (stream_len - BLOSC_HEADER) / 4 {
        return Err("blosc block table runs past the end of the data".into());
    }
    let layout = BlockLayout {
        codec,
        type_size,
        shuffle: flags & BLOSC_SHUFFLE != 0 && type_size > 1,
        may_split: flags & BLOSC_DONT_SPLIT == 0,
    };
    let mut out = vec![0u8; raw_len];
    let mut scratch = vec![0u8; block_size];
    for (index, dest) in out.chunks_mut(block_size).enumerate() {
        let start = read_u32(stream, BLOSC_HEADER + 4 * index) as i32;
        let leftover = dest.len() < block_size;
        decode_block(stream, start, dest, leftover, &layout, &mut scratch)
            .map_err(|e| format!("blosc block {index}: {e}"))?;
    }
    Ok(out)
}

#[derive(Clone, Copy)]
enum Codec {
    Lz4,
    Zlib,
}

struct BlockLayout {
    codec: Codec,
    type_size: usize,
    shuffle: bool,
    may_split: bool,
}

fn decode_block(
    stream: &[u8],
    start: i32,
    dest: &mut [u8],
    leftover: bool,
    layout: &BlockLayout,
    scratch: &mut [u8],
) -> Result<(), String> {
    let size = dest.len();
    let splits = if layout.may_split
        && layout.type_size <= BLOSC_MAX_SPLITS
        && size / layout.type_size >= BLOSC_MIN_SPLIT_ELEMENTS
        && !leftover
    {
        layout.type_size
    } else {
        1
    };
    let split_len = size / splits;
    if split_len * splits != size {
        return Err("block size is not a multiple of the type size".into());
    }
    let target: &mut [u8] = if layout.shuffle {
        &mut scratch[..size]
    } else {
        dest
    };
    let mut at = usize::try_from(start).map_err(|_| "negative block offset".to_string())?;
    for split in target.chunks_mut(split_len) {
        if at + 4 > stream.len() {
            return Err("block offset runs past the end of the data".into());
        }
        let compressed = read_u32(stream, at) as usize;
        at += 4;
        if compressed > stream.len() - at {
            return Err("compressed length runs past the end of the data".into());
        }
        let payload = &stream[at..at + compressed];
        at += compressed;
        if compressed == split_len {
            split.copy_from_slice(payload);
            continue;
        }
        let produced = match layout.codec {
            Codec::Lz4 => lz4_flex::block::decompress_into(payload, split)
                .map_err(|e| format!("LZ4 data is corrupt ({e})"))?,
            Codec::Zlib => inflate_into(payload, split)?,
        };
        if produced != split_len {
            return Err(format!("decodes to {produced} bytes, expected {split_len}"));
        }
    }
    if layout.shuffle {
        unshuffle(layout.type_size, &scratch[..size], dest);
    }
    Ok(())
}

fn inflate_into(payload: &[u8], out: &mut [u8]) -> Result<usize, String> {
    let mut state = flate2::Decompress::new(true);
    inflate_with(&mut state, payload, out).map_err(|e| format!("zlib data is corrupt ({e})"))
}

/// Undoes blosc's byte shuffle: `shuffled` holds byte `b` of every element, then byte `b + 1`,
/// …; the bytes past the last whole element are stored as they were.
fn unshuffle(type_size: usize, shuffled: &[u8], out: &mut [u8]) {
    let elements = shuffled.len() / type_size;
    if elements > 0 {
        for (byte, plane) in shuffled.chunks_exact(elements).take(type_size).enumerate() {
            for (element, &value) in plane.iter().enumerate() {
                out[element * type_size + byte] = value;
            }
        }
    }
    let tail = elements * type_size;
    out[tail..].copy_from_slice(&shuffled[tail..]);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The streams in `blosc.bin` were made by the system's C blosc library (see
    /// `make_fixtures.py`), each next to the bytes it must decode to.
    fn fixture_streams() -> Vec<(String, Vec<u8>, Vec<u8>)> {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/vdb/blosc.bin");
        let bytes = std::fs::read(path).expect("blosc fixture");
        let mut at = 0;
        let next = |at: &mut usize| {
            let n = read_u32(&bytes, *at) as usize;
            let slice = bytes[*at + 4..*at + 4 + n].to_vec();
            *at += 4 + n;
            slice
        };
        let mut cases = Vec::new();
        while at < bytes.len() {
            let raw = next(&mut at);
            let stream = next(&mut at);
            let label = String::from_utf8(next(&mut at)).expect("label");
            cases.push((label, raw, stream));
        }
        cases
    }

    #[test]
    fn decodes_streams_written_by_c_blosc() {
        let cases = fixture_streams();
        assert_eq!(cases.len(), 8);
        for (label, raw, stream) in &cases {
            let decoded = unblosc(stream, raw.len()).unwrap_or_else(|e| panic!("{label}: {e}"));
            assert!(decoded == *raw, "{label}");
        }
        // The fixtures cover the layouts that matter: split and unsplit, several blocks
        // with a short last one, the uncompressed fallback, and the zlib codec.
        let flags: Vec<u8> = cases.iter().map(|(_, _, s)| s[2]).collect();
        assert!(
            flags
                .iter()
                .any(|f| f & BLOSC_DONT_SPLIT == 0 && f & BLOSC_MEMCPYED == 0)
        );
        assert!(flags.iter().any(|f| f & BLOSC_MEMCPYED != 0));
        assert!(flags.iter().any(|f| f >> 5 == 3));
    }

    #[test]
    fn wrong_expectations_and_damage_are_errors() {
        for (label, raw, stream) in fixture_streams() {
            assert!(unblosc(&stream, raw.len() + 1).is_err(), "{label}");
            for cut in [0, 5, 16, stream.len() / 2, stream.len() - 1] {
                let _ = unblosc(&stream[..cut], raw.len());
            }
            let mut damaged = stream.clone();
            for i in (16..damaged.len()).step_by(7) {
                damaged[i] ^= 0x5a;
            }
            if let Ok(out) = unblosc(&damaged, raw.len()) {
                assert_eq!(out.len(), raw.len());
            }
        }
    }

    #[test]
    fn zip_round_trips_and_checks_length() {
        let data: Vec<u8> = (0..5000u32).map(|n| (n * n % 251) as u8).collect();
        let packed = zip(&data);
        assert!(packed.len() < data.len());
        assert_eq!(unzip(&packed, data.len()).unwrap(), data);
        assert!(
            unzip(&packed, data.len() - 1)
                .unwrap_err()
                .contains("or more")
        );
        assert!(unzip(&packed, data.len() + 1).is_err());
        assert!(unzip(&packed[..packed.len() / 2], data.len()).is_err());
        assert!(unzip(b"not zlib at all", 10).is_err());
    }

    #[test]
    fn unshuffle_restores_interleaved_bytes() {
        // Four 3-byte elements and one stray byte: planes are [a0 b0 c0 d0][a1 ..][a2 ..].
        let shuffled = [1, 4, 7, 10, 2, 5, 8, 11, 3, 6, 9, 12, 13];
        let mut out = [0u8; 13];
        unshuffle(3, &shuffled, &mut out);
        assert_eq!(out, [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13]);
    }
}
