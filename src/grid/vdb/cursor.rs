//! A bounds-checked reader over the bytes of a VDB file.
//!
//! Every read states what it is reading, so a file that ends early or holds an impossible
//! length fails with a message naming the field, the byte offset and the grid. The key
//! decision: a cursor may be limited to a sub-range of the file (one grid's bytes), so a
//! corrupt grid cannot read — or make the reader re-read — the bytes of the grids after it.

use crate::base::failure::{Failure, Outcome};
use glam::DVec3;

/// A bounds-checked reader over `bytes[..end]` that reports offsets within the whole file.
pub(super) struct Cursor<'a> {
    bytes: &'a [u8],
    pub(super) pos: usize,
    pub(super) end: usize,
    /// The grid being read, for messages; empty at file level.
    pub(super) grid: String,
}

impl<'a> Cursor<'a> {
    pub(super) fn new(bytes: &'a [u8]) -> Cursor<'a> {
        Cursor {
            bytes,
            pos: 0,
            end: bytes.len(),
            grid: String::new(),
        }
    }

    /// A cursor over `[start, end)` of the same file, for one grid.
    pub(super) fn range(&self, start: usize, end: usize, grid: &str) -> Cursor<'a> {
        Cursor {
            bytes: self.bytes,
            pos: start,
            end,
            grid: grid.to_string(),
        }
    }

    pub(super) fn pos(&self) -> usize {
        self.pos
    }

    pub(super) fn remaining(&self) -> usize {
        self.end - self.pos
    }

    /// A failure at byte `at` of the file.
    pub(super) fn fail(&self, at: usize, message: impl std::fmt::Display) -> Failure {
        let place = if self.grid.is_empty() {
            String::new()
        } else {
            format!(" (grid '{}')", self.grid)
        };
        Failure::new(format!("corrupt VDB file at byte {at}{place}: {message}"))
    }

    pub(super) fn take(&mut self, n: usize, what: &str) -> Outcome<&'a [u8]> {
        if n > self.remaining() {
            let limit = if self.end == self.bytes.len() {
                "file"
            } else {
                "grid's data"
            };
            return Err(self.fail(
                self.pos,
                format!(
                    "{what} needs {n} bytes but only {} remain in the {limit}",
                    self.remaining()
                ),
            ));
        }
        let slice = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(slice)
    }

    fn array<const N: usize>(&mut self, what: &str) -> Outcome<[u8; N]> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N, what)?);
        Ok(out)
    }

    pub(super) fn u8(&mut self, what: &str) -> Outcome<u8> {
        Ok(self.array::<1>(what)?[0])
    }

    pub(super) fn i8(&mut self, what: &str) -> Outcome<i8> {
        Ok(self.u8(what)? as i8)
    }

    pub(super) fn u32(&mut self, what: &str) -> Outcome<u32> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    pub(super) fn i32(&mut self, what: &str) -> Outcome<i32> {
        Ok(i32::from_le_bytes(self.array(what)?))
    }

    pub(super) fn i64(&mut self, what: &str) -> Outcome<i64> {
        Ok(i64::from_le_bytes(self.array(what)?))
    }

    pub(super) fn f64(&mut self, what: &str) -> Outcome<f64> {
        Ok(f64::from_le_bytes(self.array(what)?))
    }

    pub(super) fn vec3d(&mut self, what: &str) -> Outcome<DVec3> {
        Ok(DVec3::new(
            self.f64(what)?,
            self.f64(what)?,
            self.f64(what)?,
        ))
    }

    pub(super) fn coord(&mut self, what: &str) -> Outcome<[i32; 3]> {
        Ok([self.i32(what)?, self.i32(what)?, self.i32(what)?])
    }

    /// A bit mask of `words` 64-bit words.
    pub(super) fn words(&mut self, words: usize, what: &str) -> Outcome<Vec<u64>> {
        let bytes = self.take(words * 8, what)?;
        Ok(bytes
            .chunks_exact(8)
            .map(|w| u64::from_le_bytes([w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7]]))
            .collect())
    }

    /// A string stored as a u32 length and that many bytes.
    pub(super) fn string(&mut self, what: &str) -> Outcome<String> {
        let len = self.u32(what)? as usize;
        Ok(String::from_utf8_lossy(self.take(len, what)?).into_owned())
    }
}
