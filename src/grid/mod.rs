//! Grids: domains, the caches that sample fields over them, and grid file formats.

pub mod domain;
pub mod vdb;
