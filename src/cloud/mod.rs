//! Cloud animation by cellular automaton (seed 003, after Nagel and Dobashi): a grid of three
//! bits per cell — humidity `hum`, activation `act` and cloud `cld` — stepped by boolean rules
//! for growth, random rules for extinction and regeneration, and a per-layer shift for wind;
//! then smoothed into a continuous density that the rest of felt reads as a field.
//!
//! The one key decision: the three bits live in separate bit planes packed 64 cells to a `u64`
//! word along x, so a growth step is a few dozen word operations per 64 cells, and every random
//! draw is a counter-based hash of (seed, step, cell). A state therefore depends only on its
//! predecessor, its step number and the seed: the same sequence comes out bit for bit on any
//! number of threads, and any frame can be recomputed from the one before it.
//!
//! - `bits.rs`: the bit-plane layout and the shifts along x.
//! - `automaton.rs`: the state and one step of the rules.
//! - `random.rs`: the counter-based draws.
//! - `region.rs`: region volumes, the per-cell probabilities `p_hum`, `p_act`, `p_ext`.
//! - `smooth.rs`: the space–time smoothing of `cld` into a density (eq. 2.11).

mod automaton;
mod bits;
mod random;
mod region;
#[cfg(test)]
mod region_tests;
mod smooth;
#[cfg(test)]
mod tests;

pub use automaton::{CloudState, Wind};
pub use bits::Planes;
pub use region::{Probabilities, Probability, ellipsoid_profile};
pub use smooth::{SmoothedCloud, Smoothing};

/// The largest smoothing radius and time window `clouddensity` accepts.
pub fn smooth_limits() -> (usize, usize) {
    (smooth::MAX_RADIUS, automaton::HISTORY)
}
