//! Damaged files: the reader must answer every one with a grid or a `Failure`, never a panic.

use super::super::*;
use super::fixture;
use std::panic::{AssertUnwindSafe, catch_unwind};

const FILES: [&str; 16] = [
    "fog.vdb",
    "sphere.vdb",
    "vec3.vdb",
    "vec3_zip.vdb",
    "masks.vdb",
    "masks_zip.vdb",
    "masks_raw.vdb",
    "half.vdb",
    "half_zip.vdb",
    "transforms.vdb",
    "translation_map.vdb",
    "unitary_map.vdb",
    "frustum.vdb",
    "instance.vdb",
    "types.vdb",
    "stream.vdb",
];

/// A small deterministic generator (xorshift64*), so failures reproduce.
struct Dice(u64);

impl Dice {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

fn mutate(original: &[u8], donor: &[u8], dice: &mut Dice) -> Vec<u8> {
    let mut bytes = original.to_vec();
    match dice.below(6) {
        0 => {
            for _ in 0..1 + dice.below(8) {
                let at = dice.below(bytes.len());
                bytes[at] ^= 1 + dice.below(255) as u8;
            }
        }
        1 => bytes.truncate(dice.below(bytes.len())),
        2 => {
            // Splice a run of another file over this one.
            let len = 1 + dice.below(256);
            let from = dice.below(donor.len().saturating_sub(len));
            let to = dice.below(bytes.len().saturating_sub(len));
            let run = &donor[from..(from + len).min(donor.len())];
            let end = (to + run.len()).min(bytes.len());
            bytes[to..end].copy_from_slice(&run[..end - to]);
        }
        3 => {
            // Lengths and counts are 4- or 8-byte fields: give one an extreme value.
            let extremes: [u64; 6] = [0, u64::MAX, 0x7fff_ffff, 0x8000_0000, 0xffff_ffff, 1 << 40];
            let value = extremes[dice.below(extremes.len())].to_le_bytes();
            let width = if dice.below(2) == 0 { 4 } else { 8 };
            let at = dice.below(bytes.len().saturating_sub(width));
            let end = (at + width).min(bytes.len());
            bytes[at..end].copy_from_slice(&value[..end - at]);
        }
        4 => {
            let at = dice.below(bytes.len());
            let len = 1 + dice.below(16);
            bytes.drain(at..(at + len).min(bytes.len()));
        }
        _ => {
            let at = dice.below(bytes.len());
            let extra: Vec<u8> = (0..1 + dice.below(16)).map(|_| dice.next() as u8).collect();
            bytes.splice(at..at, extra);
        }
    }
    bytes
}

/// Equal as OpenVDB compares values: −0 equals +0, and any NaN equals any NaN.
fn same_values(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()))
}

/// Whatever felt reads, it can write, and reading that gives the same voxels back (exactly,
/// unless half-float rounding applies to values the file stored at full precision).
fn check_rewrite(grids: &[VdbGrid]) {
    let bytes = write_bytes(grids, Compression::Zip).expect("a grid felt read can be written");
    let again = read_bytes(&bytes).expect("a file felt wrote can be read");
    for (a, b) in grids.iter().zip(&again) {
        assert_eq!(a.leaves.len(), b.leaves.len());
        assert_eq!(a.tiles.len(), b.tiles.len());
        if a.saved_as_half {
            continue;
        }
        assert!(same_values(&a.background, &b.background));
        for (x, y) in a.leaves.iter().zip(&b.leaves) {
            assert!(
                x.origin == y.origin && x.active == y.active && same_values(&x.values, &y.values)
            );
        }
        for (x, y) in a.tiles.iter().zip(&b.tiles) {
            assert!(x.origin == y.origin && x.size == y.size && x.active == y.active);
            assert!(same_values(&x.value, &y.value));
        }
    }
}

/// Reads `bytes` every way the API offers and uses what comes back.
fn exercise(bytes: &[u8]) {
    if let Ok(grids) = read_bytes(bytes) {
        for grid in &grids {
            let _ = grid.active_bounds();
            let _ = grid.index_bounds();
            let _ = grid.value_at([1, 2, 3]);
            let _ = grid.active_voxel_count();
        }
        check_rewrite(&grids);
    }
    let _ = read_grid_bytes(bytes, "density");
    let _ = read_grid_bytes(bytes, "b");
}

#[test]
fn thousands_of_damaged_files_never_panic() {
    let originals: Vec<Vec<u8>> = FILES
        .iter()
        .map(|f| std::fs::read(fixture(f)).unwrap())
        .collect();
    let mut dice = Dice(0x9e37_79b9_7f4a_7c15);
    let mut attempts = 0;
    // FELT_VDB_MUTATION_ROUNDS raises the count for a longer search.
    let rounds = std::env::var("FELT_VDB_MUTATION_ROUNDS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(220);
    for round in 0..rounds {
        for (index, original) in originals.iter().enumerate() {
            let donor = &originals[(index + 1 + round) % originals.len()];
            let damaged = mutate(original, donor, &mut dice);
            let outcome = catch_unwind(AssertUnwindSafe(|| exercise(&damaged)));
            assert!(
                outcome.is_ok(),
                "{} panicked after damage in round {round}",
                FILES[index]
            );
            attempts += 1;
        }
    }
    assert!(attempts >= 3000);
}

#[test]
fn every_truncation_is_a_failure_with_an_offset() {
    for name in ["transforms.vdb", "masks.vdb"] {
        let bytes = std::fs::read(fixture(name)).unwrap();
        for len in (0..bytes.len()).step_by(if name == "masks.vdb" { 7 } else { 1 }) {
            let failure = read_bytes(&bytes[..len]).expect_err("a truncated file cannot read");
            assert!(
                failure.message.contains("byte") || failure.message.contains("not an OpenVDB file"),
                "{name} cut at {len}: {}",
                failure.message
            );
        }
    }
}

#[test]
fn corrupt_fields_are_named() {
    let bytes = std::fs::read(fixture("masks.vdb")).unwrap();
    assert!(
        read_bytes(b"")
            .unwrap_err()
            .message
            .contains("not an OpenVDB file")
    );
    assert!(
        read_bytes(&bytes[8..])
            .unwrap_err()
            .message
            .contains("not an OpenVDB file")
    );

    let mut old = bytes.clone();
    old[8..12].copy_from_slice(&219u32.to_le_bytes());
    assert!(read_bytes(&old).unwrap_err().message.contains("older"));

    // The header is 57 bytes; the file metadata count and then the grid count follow.
    let mut many = bytes.clone();
    many[61..65].copy_from_slice(&i32::MAX.to_le_bytes());
    let failure = read_bytes(&many).unwrap_err();
    assert!(
        failure.message.contains("grid count") && failure.message.contains("byte 61"),
        "{}",
        failure.message
    );

    // The root's tile count follows the tree's buffer count (1) and the background (2.0).
    let mut pattern = 1i32.to_le_bytes().to_vec();
    pattern.extend_from_slice(&2.0f32.to_le_bytes());
    let at = bytes
        .windows(8)
        .position(|w| w == pattern.as_slice())
        .unwrap()
        + 8;
    let mut tiles = bytes.clone();
    tiles[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    let failure = read_bytes(&tiles).unwrap_err();
    assert!(
        failure.message.contains("tiles") && failure.message.contains("grid 'masks'"),
        "{}",
        failure.message
    );

    // The descriptor of grid "masks" ends with its start, buffer and end offsets; the first
    // leaf buffer is a 64-byte mask and then its compression code.
    let offsets = 65 + (4 + 5) + (4 + 16) + 4;
    let block = i64::from_le_bytes(bytes[offsets + 8..offsets + 16].try_into().unwrap()) as usize;
    let mut code = bytes.clone();
    code[block + 64] = 9;
    let failure = read_bytes(&code).unwrap_err();
    assert!(
        failure.message.contains("code 9")
            && failure.message.contains(&format!("byte {}", block + 64)),
        "{}",
        failure.message
    );
}
