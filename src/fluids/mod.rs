//! Fluids: the FFT solves on whole grids — Gaussian random fields, the divergence-free
//! projection (`fftdivfree`) and its operators. They produce grids the caches then hold;
//! the storage itself is `grid`'s.

pub mod divfree;
pub mod fft;
