//! A fixed order for the attributes of an OpenEXR header.
//!
//! The `exr` crate keeps custom attributes in a `HashMap` with a per-process random hasher, so
//! the same image written twice lists `felt/version`, `felt/script` and the params in a
//! different order each time: the pixels are identical but the files are not. felt promises
//! bit-identical files, so every EXR it writes is encoded to memory first and its header's
//! attributes are then sorted by name. The one key decision: sorting only permutes the header's
//! bytes, so its length, and with it every chunk offset after it, is unchanged.

use std::io::{Cursor, Write};

/// Encodes with `encode` into memory, puts the header's attributes in name order, and writes
/// the bytes to `file`.
pub fn write_sorted(
    file: &mut std::fs::File,
    encode: impl FnOnce(&mut Cursor<Vec<u8>>) -> Result<(), String>,
) -> Result<(), String> {
    let mut buffer = Cursor::new(Vec::new());
    encode(&mut buffer)?;
    let mut bytes = buffer.into_inner();
    sort_attributes(&mut bytes)?;
    file.write_all(&bytes).map_err(|e| e.to_string())
}

/// Sorts the attributes of a single-part file's header in place (the magic number and version
/// word come first; the attribute list ends with an empty name).
fn sort_attributes(bytes: &mut [u8]) -> Result<(), String> {
    const START: usize = 8;
    let corrupt = || String::from("the encoder wrote a header felt cannot read back");
    if bytes.len() < START || bytes[5] & 0x10 != 0 {
        // Multi-part files are never written by felt; leave anything else alone.
        return Ok(());
    }
    let mut attributes: Vec<(Vec<u8>, std::ops::Range<usize>)> = Vec::new();
    let mut at = START;
    loop {
        let name_end = bytes[at..]
            .iter()
            .position(|&b| b == 0)
            .ok_or_else(corrupt)?
            + at;
        if name_end == at {
            break;
        }
        let type_end = bytes[name_end + 1..]
            .iter()
            .position(|&b| b == 0)
            .ok_or_else(corrupt)?
            + name_end
            + 1;
        let size_at = type_end + 1;
        let size = bytes
            .get(size_at..size_at + 4)
            .map(|s| i32::from_le_bytes([s[0], s[1], s[2], s[3]]))
            .ok_or_else(corrupt)?;
        let end = size_at + 4 + usize::try_from(size).map_err(|_| corrupt())?;
        if end > bytes.len() {
            return Err(corrupt());
        }
        attributes.push((bytes[at..name_end].to_vec(), at..end));
        at = end;
    }
    let original = bytes[START..at].to_vec();
    attributes.sort_by(|a, b| a.0.cmp(&b.0));
    let mut sorted = Vec::with_capacity(original.len());
    for (_, range) in &attributes {
        sorted.extend_from_slice(&original[range.start - START..range.end - START]);
    }
    bytes[START..at].copy_from_slice(&sorted);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn attribute(name: &str, value: &[u8]) -> Vec<u8> {
        let mut out = name.as_bytes().to_vec();
        out.extend_from_slice(b"\0string\0");
        out.extend_from_slice(&(value.len() as i32).to_le_bytes());
        out.extend_from_slice(value);
        out
    }

    #[test]
    fn attributes_come_out_in_name_order_and_the_rest_is_untouched() {
        let mut file = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
        file.extend(attribute("felt/version", b"0.1.0"));
        file.extend(attribute("channels", b"xyz"));
        file.extend(attribute("felt/param/frame", b"3"));
        file.push(0);
        file.extend_from_slice(b"offsets and pixels");
        let length = file.len();
        sort_attributes(&mut file).unwrap();
        assert_eq!(file.len(), length);
        let mut expected = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
        expected.extend(attribute("channels", b"xyz"));
        expected.extend(attribute("felt/param/frame", b"3"));
        expected.extend(attribute("felt/version", b"0.1.0"));
        expected.push(0);
        expected.extend_from_slice(b"offsets and pixels");
        assert_eq!(file, expected);
    }

    #[test]
    fn a_truncated_header_is_an_error_not_a_panic() {
        let mut file = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
        file.extend(b"name\0string\0");
        assert!(sort_attributes(&mut file).is_err());
    }
}
