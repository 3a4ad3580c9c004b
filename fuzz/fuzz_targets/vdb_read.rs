//! Feeds arbitrary bytes to the VDB reader: it must return grids or a failure, never panic,
//! hang or allocate without bound. Whatever it reads must write, and read back the same.
//! Seed the corpus with the fixture files: `cp tests/fixtures/vdb/*.vdb fuzz/corpus/vdb_read/`.

#![no_main]

use felt::grid::vdb::{Compression, VdbGrid, read_bytes, read_grid_bytes, write_bytes};
use libfuzzer_sys::fuzz_target;

/// Equal as OpenVDB compares values: −0 equals +0, and any NaN equals any NaN.
fn same_values(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()))
}

fn check_rewrite(grids: &[VdbGrid]) {
    let bytes = write_bytes(grids, Compression::Zip).expect("a grid felt read can be written");
    let again = read_bytes(&bytes).expect("a file felt wrote can be read");
    assert_eq!(grids.len(), again.len());
    for (a, b) in grids.iter().zip(&again) {
        assert_eq!(a.leaves.len(), b.leaves.len());
        assert_eq!(a.tiles.len(), b.tiles.len());
        // Half grids may round values the file held at full precision.
        if a.saved_as_half {
            continue;
        }
        assert!(same_values(&a.background, &b.background));
        for (x, y) in a.leaves.iter().zip(&b.leaves) {
            assert!(x.origin == y.origin && x.active == y.active);
            assert!(same_values(&x.values, &y.values));
        }
        for (x, y) in a.tiles.iter().zip(&b.tiles) {
            assert!(x.origin == y.origin && x.size == y.size && x.active == y.active);
            assert!(same_values(&x.value, &y.value));
        }
    }
}

fuzz_target!(|data: &[u8]| {
    if let Ok(grids) = read_bytes(data) {
        for grid in &grids {
            let _ = grid.active_bounds();
            let _ = grid.value_at([0, 0, 0]);
        }
        check_rewrite(&grids);
    }
    let _ = read_grid_bytes(data, "density");
});
