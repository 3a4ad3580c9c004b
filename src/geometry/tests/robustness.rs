//! Damaged files: each named defect is a failure that says what and where, and thousands of
//! random mutations of valid files never panic.

use super::files_for_mutation;
use super::*;

fn obj_error(text: &str) -> String {
    parse_obj(text.as_bytes()).unwrap_err().message
}

fn ply_error(bytes: &[u8]) -> String {
    parse_ply(bytes).unwrap_err().message
}

#[test]
fn obj_defects_name_their_line() {
    let e = obj_error("v 0 0 0\nv 1 x 0\n");
    assert!(
        e.contains("line 2") && e.contains("'x' is not a number"),
        "{e}"
    );
    let e = obj_error("v 0 0 0\nv 1 0\n");
    assert!(
        e.contains("line 2") && e.contains("three coordinates"),
        "{e}"
    );
    let e = obj_error("v inf 0 0\n");
    assert!(e.contains("not finite"), "{e}");
    let e = obj_error("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 7\n");
    assert!(e.contains("line 5") && e.contains("vertex 7"), "{e}");
    let e = obj_error("v 0 0 0\nf 1 2\n");
    assert!(e.contains("three corners"), "{e}");
    let e = obj_error("v 0 0 0\nf 0 1 1\n");
    assert!(e.contains("start at 1"), "{e}");
    let e = obj_error("v 0 0 0\nf -1 -2 -1\n");
    assert!(
        e.contains("line 2") && e.contains("before the first"),
        "{e}"
    );
    let e = obj_error("v 0 0 0\nf 1/2/3 a/1 1\n");
    assert!(e.contains("'a/1' is not a vertex index"), "{e}");
    let e = obj_error("f 99999999999999999999 1 1\n");
    assert!(e.contains("not a vertex index"), "{e}");
    let e = obj_error("f 5000000000 1 1\n");
    assert!(e.contains("larger than a shape can hold"), "{e}");
}

#[test]
fn ply_defects_say_what_is_wrong() {
    assert!(ply_error(b"solid ascii\n").contains("not a PLY file"));
    assert!(ply_error(b"ply\nformat ascii 1.0\nelement vertex 1\n").contains("no end_header"));
    assert!(ply_error(b"ply\nelement vertex 0\nend_header\n").contains("format"));
    let e = ply_error(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float3 x\nend_header\n");
    assert!(e.contains("line 4") && e.contains("float3"), "{e}");
    let e = ply_error(b"ply\nformat ascii 1.0\nproperty float x\nend_header\n");
    assert!(e.contains("before any element"), "{e}");
    let e = ply_error(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\nproperty float z\nend_header\n1 2\n");
    assert!(e.contains("x, y and z"), "{e}");
    let e = ply_error(b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 zz 0\n");
    assert!(e.contains("line 9") && e.contains("'zz'"), "{e}");
    let e = ply_error(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n3 0 1 2\n");
    assert!(e.contains("vertex 2") && e.contains("only 1"), "{e}");
    let e = ply_error(b"ply\nformat ascii 1.0\nelement face 1\nproperty list uchar float vertex_indices\nend_header\n3 0 1 2\n");
    assert!(e.contains("integers"), "{e}");
    // A property named twice would leave the second one's values silently unread.
    let e = ply_error(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float x\nend_header\n0 0 0 1\n");
    assert!(
        e.contains("line 7")
            && e.contains("element 'vertex' has two properties named 'x' (properties 1 and 4)"),
        "{e}"
    );
}

#[test]
fn lying_counts_fail_before_allocating() {
    // 2⁴⁰ vertices declared in a file of a few hundred bytes, in every format.
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        let header = format!(
            "ply\nformat {format} 1.0\nelement vertex 1099511627776\nproperty float x\n\
             property float y\nproperty float z\nend_header\n0 0 0\n"
        );
        let e = ply_error(header.as_bytes());
        assert!(
            e.contains("line 3") && e.contains("room for at most"),
            "{e}"
        );
    }
    // A list length far beyond the file.
    let mut bytes = b"ply\nformat binary_little_endian 1.0\nelement face 1\n\
        property list uint int vertex_indices\nend_header\n"
        .to_vec();
    bytes.extend_from_slice(&u32::MAX.to_le_bytes());
    bytes.extend_from_slice(&[0; 12]);
    assert!(ply_error(&bytes).contains("does not fit"));
}

#[test]
fn truncated_binary_files_name_the_byte() {
    let whole = write_ply(&box_mesh(DVec3::ZERO, DVec3::ONE)).unwrap();
    let header = whole
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    for cut in [header + 1, header + 8 * 24 - 3, whole.len() - 1] {
        let e = ply_error(&whole[..cut]);
        assert!(
            e.contains("PLY") && (e.contains("byte") || e.contains("room")),
            "{e}"
        );
    }
}

/// A small reproducible generator for the mutations.
struct Mutator(u64);

impl Mutator {
    fn next(&mut self, below: usize) -> usize {
        self.0 += 1;
        (unit(self.0) * below as f64) as usize
    }

    fn mutate(&mut self, original: &[u8]) -> Vec<u8> {
        let mut bytes = original.to_vec();
        for _ in 0..1 + self.next(4) {
            if bytes.is_empty() {
                break;
            }
            let at = self.next(bytes.len());
            match self.next(7) {
                0 => bytes[at] = self.next(256) as u8,
                1 => bytes[at] ^= 1 << self.next(8),
                2 => bytes.truncate(at),
                3 => {
                    bytes.remove(at);
                }
                4 => bytes.insert(at, b"0123456789-. \n/"[self.next(15)]),
                5 => {
                    let digits = b"4294967296";
                    for (k, d) in digits.iter().enumerate() {
                        bytes.insert(at + k.min(bytes.len() - at), *d);
                    }
                }
                _ => {
                    let from = self.next(bytes.len());
                    let length = self.next(16).min(bytes.len() - from);
                    let piece = bytes[from..from + length].to_vec();
                    for (k, b) in piece.into_iter().enumerate() {
                        bytes.insert((at + k).min(bytes.len()), b);
                    }
                }
            }
        }
        bytes
    }
}

#[test]
fn mutated_files_never_panic() {
    let mut mutator = Mutator(12345);
    let mut accepted = 0;
    for (name, original) in files_for_mutation() {
        let parse = if name.ends_with("obj") {
            parse_obj
        } else {
            parse_ply
        };
        assert!(
            parse(&original).is_ok(),
            "{name} must parse before mutation"
        );
        for _ in 0..2500 {
            let bytes = mutator.mutate(&original);
            if let Ok(mesh) = parse(&bytes) {
                // Whatever is accepted is a valid mesh.
                mesh.validate().unwrap();
                accepted += 1;
            }
        }
    }
    // Mutations that hit comments or skipped values still parse.
    assert!(accepted > 100, "only {accepted} mutations parsed");
}
