//! Fields: lazy functions of 3D space, and the procedural noise they are built from.
pub mod noise;
