//! Tests of the VDB reader and writer: against files OpenVDB wrote (`fixtures`), against
//! damaged files (`robustness`), through round trips and builders (`round_trip`), and — when
//! `FELT_PEER_TESTS=1` — against OpenVDB's own tools reading files felt wrote (`peer`).

mod fixtures;
mod peer;
mod robustness;
mod round_trip;

use std::path::PathBuf;

pub(super) fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/vdb")
        .join(name)
}
