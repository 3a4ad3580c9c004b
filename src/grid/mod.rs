//! Grids: domains, the caches that sample fields over them, and grid file formats.

pub mod cache;
pub mod domain;
pub mod fft;
pub mod interp;
pub mod profile;
pub mod vdb;
pub mod vdb_cache;
