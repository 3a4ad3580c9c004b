//! Counter-based random draws for the automaton: a hash of (seed, step, cell), never a
//! sequential generator, so that a draw does not depend on which thread asks or in what order.
//!
//! One 64-bit hash per cell and step gives three independent 16-bit draws (humidity,
//! activation, extinction). A probability is quantised to a 16-bit threshold `t` with
//! `p = t / 65535`; the event happens when `r · 65535 < t · 65536` for a draw `r` in
//! `[0, 65535]`, so `t = 0` never fires and `t = 65535` always does.

/// The channels of one cell's draw.
pub const HUM: u32 = 0;
pub const ACT: u32 = 16;
pub const EXT: u32 = 32;

/// Step number used for the draws that set up the initial state.
pub const INITIAL: u64 = u64::MAX;

/// The 64-bit hash of a cell's draw at a step.
#[inline]
pub fn draw(seed: u64, step: u64, cell: u64) -> u64 {
    // Three rounds of a strong 64-bit finaliser over the counters (SplitMix64's), so nearby
    // cells and consecutive steps give unrelated bits.
    let mut h = mix(seed ^ 0x9e37_79b9_7f4a_7c15);
    h = mix(h ^ step);
    mix(h ^ cell)
}

#[inline]
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Whether the 16-bit channel `channel` of `hash` fires for threshold `t`.
#[inline]
pub fn fires(hash: u64, channel: u32, t: u16) -> bool {
    let r = ((hash >> channel) & 0xffff) as u32;
    r * 65535 < t as u32 * 65536
}

/// A probability as a threshold: clamped to [0, 1]; NaN counts as 0.
pub fn threshold(p: f64) -> u16 {
    // Without branches, rounding half up by hand: this runs for every cell of a region update,
    // where values below 0, inside and above 1 are mixed unpredictably, and `f64::round` is a
    // library call on the baseline x86-64 target. `max` turns NaN into 0.
    #[allow(clippy::manual_clamp)] // clamp keeps NaN; this maps it to 0
    let x = (p * 65535.0).max(0.0).min(65535.0);
    let t = x as i32;
    (t + (x - t as f64 >= 0.5) as i32) as u16
}

/// `threshold` of each value, in a loop that vectorises: for an `f32` value, `p·65535` is exact
/// in `f64` and so is adding one half, so truncating the sum rounds half up exactly as
/// `threshold` does.
pub fn thresholds(values: &[f32], out: &mut Vec<u16>) {
    out.clear();
    #[allow(clippy::manual_clamp)] // clamp keeps NaN; this maps it to 0
    out.extend(
        values
            .iter()
            // Through i32: the conversion LLVM vectorises (to u16 directly it does not).
            .map(|&p| ((p as f64 * 65535.0).max(0.0).min(65535.0) + 0.5) as i32 as u16),
    );
}
