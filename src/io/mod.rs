//! Files in and out: reading a script's input files, writing outputs atomically with the
//! permissions a shared farm needs, frame patterns in paths, and USD layers. These know
//! nothing of fields or rendering; the engine's output settings are read by `output`.

pub mod frames;
pub mod input;
pub mod output;
pub mod usd;
