//! Rendering (in progress).
pub mod camera;
pub mod light;
pub mod phase;
pub mod settings;
pub mod space;
#[cfg(test)]
mod testing;
pub mod transmittance;
