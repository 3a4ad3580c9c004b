//! Seeded random numbers for generators: a SplitMix64 stream per (seed, stream) pair.
//!
//! The key decision: every independent walk or chain gets its own stream, keyed by the
//! script's seed and the walk's index, never a shared or thread-local generator, so the
//! dots a generator makes do not depend on how its work is split across threads.

/// One stream of uniform numbers.
#[derive(Clone, Debug)]
pub struct Stream {
    state: u64,
}

fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl Stream {
    /// The stream numbered `stream` of the generator seeded `seed`.
    pub fn new(seed: u64, stream: u64) -> Stream {
        Stream {
            state: mix(seed ^ mix(stream.wrapping_add(0x9e37_79b9_7f4a_7c15))),
        }
    }

    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        mix(self.state)
    }

    /// Uniform in [0, 1), with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        // Through i64: the 53 bits fit, and a signed conversion is one instruction.
        ((self.next_u64() >> 11) as i64) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [-1, 1): the thesis's `2 prn - 1`.
    pub fn signed(&mut self) -> f64 {
        2.0 * self.uniform() - 1.0
    }

    /// A point uniform in the bi-unit cube [-1, 1)³.
    pub fn cube(&mut self) -> [f64; 3] {
        [self.signed(), self.signed(), self.signed()]
    }

    /// An index drawn with probability proportional to `cumulative[i] - cumulative[i-1]`
    /// (`cumulative` ascending, last entry the total).
    pub fn pick(&mut self, cumulative: &[f64]) -> usize {
        let total = cumulative.last().copied().unwrap_or(0.0);
        let u = self.uniform() * total;
        // The first entry above u, counted without branches (the chaos game's map choice is
        // unpredictable): the entries at most u, as `cumulative` ascends.
        let below = cumulative.iter().map(|&c| (c <= u) as usize).sum::<usize>();
        below.min(cumulative.len().saturating_sub(1))
    }
}
