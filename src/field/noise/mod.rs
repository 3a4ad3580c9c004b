//! Procedural noise kernels: Perlin, simplex and Worley noise with exact derivatives,
//! evaluated a block of points at a time.
//!
//! The field evaluator calls [`eval_f32`] (rendering and cache fills) or [`eval_f64`] (`probe`
//! and accuracy checks) on up to `BLOCK` points laid out as separate x/y/z slices. The one key
//! decision: every kernel is one generic function of the lane type, inlined into a loop over
//! the block; that loop is compiled twice, once plain and once with AVX2+FMA enabled, and the
//! second is chosen at run time when the CPU has them. The compiler then keeps eight `f32`
//! points per register through hashing, gradient choice and blending, with no table lookups
//! and no call per point. Perlin values alone, what fills and renders mostly ask for, also have
//! loops written with AVX2 and AVX-512 intrinsics (`perlin_lanes.rs`) that give the generic
//! loop's bits with fewer instructions. Lattice spacing is 1: frequency and offsets are applied
//! by the caller.
//!
//! Amplitudes, for displacement and interval bounds (lattice spacing 1; a noise read at
//! frequency `f` has slopes `f` times larger). "Bound" is what [`value_range`] and
//! [`lipschitz`] return, certified for every seed in `bounds.rs`; "largest" is the supremum
//! over all gradient assignments (so some seed and point come arbitrarily close); "std" is
//! the standard deviation over space, from the closed forms in `statistics.rs`.
//!
//! | kind    | value bound   | largest value | std   | slope bound | largest slope |
//! |---------|---------------|---------------|-------|-------------|---------------|
//! | Perlin  | [-1.04, 1.04] | 1.0364        | 0.270 | 4           | 3.75          |
//! | simplex | [-1, 1]       | 0.9885        | 0.388 | 8           | 6.89          |
//! | Worley  | [0, 1]        | 1 (the cap)   |       | 1           | 1             |
//!
//! Typical values are far inside the bounds: 80 000 random points reach about ±0.8 for
//! Perlin and ±0.85 for simplex. An `fbm` of octaves with gains `aᵢ` is bounded by
//! `Σ|aᵢ|` times the value bound, and its slope by `Σ|aᵢ|·fᵢ` times the slope bound.
//!
//! Bit-for-bit results: the output for a point depends only on its block's `base` and its
//! own offset, not on the block's length or the point's place in it. The same absolute point
//! reached from two different bases can differ by `f32` rounding, so callers that need
//! identical values whatever the blocking should derive the base from something fixed (a
//! brick's corner, say), not from the thread or the first point of a work item.

mod hash;
mod lattice;
mod perlin;
#[cfg(target_arch = "x86_64")]
mod perlin_lanes;
mod simplex;
mod worley;

#[cfg(test)]
mod bounds;
#[cfg(test)]
mod statistics;
#[cfg(test)]
mod tests;

use lattice::{BlockBase, Located, Real, Sample, locate_f64};

/// The noise families.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NoiseKind {
    /// Improved Perlin gradient noise (quintic fade, twelve edge gradients), in [-1.04, 1.04].
    Perlin,
    /// 3D simplex noise, scaled so its range is inside [-1, 1].
    Simplex,
    /// Worley F1 cellular noise (distance to the nearest feature point, capped at 1), [0, 1].
    Worley,
}

/// Which outputs a call fills. Hessian order: xx, yy, zz, xy, xz, yz.
pub struct NoiseOutput<'a, T> {
    pub value: &'a mut [T],
    pub gradient: Option<[&'a mut [T]; 3]>,
    pub hessian: Option<[&'a mut [T]; 6]>,
}

impl<'a, T> NoiseOutput<'a, T> {
    /// Values only.
    pub fn value(value: &'a mut [T]) -> NoiseOutput<'a, T> {
        NoiseOutput {
            value,
            gradient: None,
            hessian: None,
        }
    }
}

/// Noise at the points `base + (x[i], y[i], z[i])`: one `f64` base point per block and `f32`
/// offsets from it, so precision does not depend on the distance from the origin. Lattice
/// spacing is 1. All slices should have the same length (at most `BLOCK`); if they differ,
/// only the common prefix is computed.
pub fn eval_f32(
    kind: NoiseKind,
    seed: u32,
    base: [f64; 3],
    x: &[f32],
    y: &[f32],
    z: &[f32],
    out: NoiseOutput<'_, f32>,
) {
    eval_f32_built(Build::detect(), kind, seed, base, x, y, z, out)
}

/// [`eval_f32`] with the build of the block loops chosen by the caller, so tests can compare
/// the builds on one machine.
#[allow(clippy::too_many_arguments)]
fn eval_f32_built(
    build: Build,
    kind: NoiseKind,
    seed: u32,
    base: [f64; 3],
    x: &[f32],
    y: &[f32],
    z: &[f32],
    out: NoiseOutput<'_, f32>,
) {
    let key = hash::seed_key(seed);
    match kind {
        NoiseKind::Perlin => run_f32::<Perlin>(build, key, base, x, y, z, out),
        NoiseKind::Simplex => run_f32::<Simplex>(build, key, base, x, y, z, out),
        NoiseKind::Worley => run_f32::<Worley>(build, key, base, x, y, z, out),
    }
}

/// Which build of the `f32` block loops runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Build {
    /// Compiled for the baseline instruction set.
    Plain,
    /// The generic loops compiled with AVX2+FMA enabled (only tests ask for it alone).
    #[cfg_attr(any(not(test), not(target_arch = "x86_64")), allow(dead_code))]
    Avx2,
    /// As `Avx2`, with the eight-lane intrinsics loops where a kernel has them (Perlin values).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    Avx2Intrinsics,
    /// As `Avx2Intrinsics`, with sixteen-lane AVX-512 loops first.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    Avx512Intrinsics,
}

impl Build {
    /// The fastest build this CPU runs.
    fn detect() -> Build {
        #[cfg(target_arch = "x86_64")]
        if has_avx2_fma() {
            return if perlin_lanes::has_avx512() {
                Build::Avx512Intrinsics
            } else {
                Build::Avx2Intrinsics
            };
        }
        Build::Plain
    }
}

/// The same noise at absolute `f64` points: the accuracy reference for [`eval_f32`], which it
/// matches to `f32` rounding.
pub fn eval_f64(
    kind: NoiseKind,
    seed: u32,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    out: NoiseOutput<'_, f64>,
) {
    let key = hash::seed_key(seed);
    match kind {
        NoiseKind::Perlin => run_f64::<Perlin>(key, x, y, z, out),
        NoiseKind::Simplex => run_f64::<Simplex>(key, x, y, z, out),
        NoiseKind::Worley => run_f64::<Worley>(key, x, y, z, out),
    }
}

/// A bound `(lo, hi)` on the value for every seed and point (certified in `bounds.rs`).
pub fn value_range(kind: NoiseKind) -> (f64, f64) {
    match kind {
        NoiseKind::Perlin => (-PERLIN_BOUND, PERLIN_BOUND),
        NoiseKind::Simplex => (-SIMPLEX_BOUND, SIMPLEX_BOUND),
        NoiseKind::Worley => (0.0, 1.0),
    }
}

/// A proven bound on the length of the gradient, i.e. a Lipschitz constant of the noise.
pub fn lipschitz(kind: NoiseKind) -> f64 {
    match kind {
        NoiseKind::Perlin => PERLIN_LIPSCHITZ,
        NoiseKind::Simplex => SIMPLEX_LIPSCHITZ,
        NoiseKind::Worley => 1.0,
    }
}

/// Perlin's largest value over all gradient assignments is 1.03635; certified in `bounds.rs`.
const PERLIN_BOUND: f64 = 1.04;
/// Perlin's largest slope is 3.75 (along an axis at a cell centre); certified in `bounds.rs`.
const PERLIN_LIPSCHITZ: f64 = 4.0;
/// Simplex's largest value is 0.98854 after scaling; certified in `bounds.rs`.
const SIMPLEX_BOUND: f64 = 1.0;
/// Simplex's largest slope is 6.89 after scaling; `bounds.rs` certifies a per-corner bound.
const SIMPLEX_LIPSCHITZ: f64 = 8.0;

/// A noise family as the block loops see it: where a point sits on its lattice, and the kernel.
trait Kernel {
    /// Whether the lattice is the skewed simplex lattice rather than the cube lattice.
    const SKEWED: bool;
    /// A values-only block loop written with intrinsics, where the family has one; it must give
    /// the generic loop's bits. Called only where the CPU has AVX2 and FMA, and with its first
    /// argument `true` only where it also has the AVX-512 features of `has_avx512`.
    #[cfg(target_arch = "x86_64")]
    const AVX2_VALUES: Option<Avx2Values> = None;
    fn sample<R: Real, const G: bool, const H: bool>(p: Located<R>, key: u32) -> Sample<R>;
}

/// The signature of an intrinsics values loop: whether to use AVX-512, key, block base,
/// offsets, values.
#[cfg(target_arch = "x86_64")]
type Avx2Values = unsafe fn(bool, u32, &BlockBase, &[f32], &[f32], &[f32], &mut [f32]);

struct Perlin;
struct Simplex;
struct Worley;

impl Kernel for Perlin {
    const SKEWED: bool = false;
    #[cfg(target_arch = "x86_64")]
    const AVX2_VALUES: Option<Avx2Values> = Some(perlin_lanes::values);
    #[inline(always)]
    fn sample<R: Real, const G: bool, const H: bool>(p: Located<R>, key: u32) -> Sample<R> {
        perlin::sample::<R, G, H>(p, key)
    }
}

impl Kernel for Simplex {
    const SKEWED: bool = true;
    #[inline(always)]
    fn sample<R: Real, const G: bool, const H: bool>(p: Located<R>, key: u32) -> Sample<R> {
        simplex::sample::<R, G, H>(p, key)
    }
}

impl Kernel for Worley {
    const SKEWED: bool = false;
    #[inline(always)]
    fn sample<R: Real, const G: bool, const H: bool>(p: Located<R>, key: u32) -> Sample<R> {
        worley::sample::<R, G, H>(p, key)
    }
}

/// Output slices cut to the block length; unused ones are empty.
struct Sink<'a, T> {
    value: &'a mut [T],
    gradient: [&'a mut [T]; 3],
    hessian: [&'a mut [T]; 6],
}

impl<T: Copy> Sink<'_, T> {
    #[inline(always)]
    fn store<const G: bool, const H: bool>(&mut self, i: usize, s: &Sample<T>) {
        self.value[i] = s.value;
        if G {
            for (slot, v) in self.gradient.iter_mut().zip(s.gradient) {
                slot[i] = v;
            }
        }
        if H {
            for (slot, v) in self.hessian.iter_mut().zip(s.hessian) {
                slot[i] = v;
            }
        }
    }
}

/// A block loop that can be instantiated for each combination of requested outputs.
trait BlockRun<T> {
    fn run<const G: bool, const H: bool>(self, sink: &mut Sink<'_, T>);
}

/// Cuts the requested outputs to `n` points and calls `run` with the matching `G`/`H`
/// instantiation. A Hessian without a gradient still computes the gradient, into scratch.
fn with_sink<T: Copy + Default, B: BlockRun<T>>(out: NoiseOutput<'_, T>, n: usize, run: B) {
    let NoiseOutput {
        value,
        gradient,
        hessian,
    } = out;
    let value = &mut value[..n];
    let mut scratch = Vec::new();
    let gradient = match (gradient, hessian.is_some()) {
        (Some(g), _) => Some(g.map(|s| &mut s[..n])),
        (None, true) => {
            scratch.resize(3 * n, T::default());
            let (a, rest) = scratch.split_at_mut(n);
            let (b, c) = rest.split_at_mut(n);
            Some([a, b, c])
        }
        (None, false) => None,
    };
    match (gradient, hessian) {
        (None, _) => run.run::<false, false>(&mut Sink {
            value,
            gradient: [&mut [], &mut [], &mut []],
            hessian: [&mut [], &mut [], &mut [], &mut [], &mut [], &mut []],
        }),
        (Some(gradient), None) => run.run::<true, false>(&mut Sink {
            value,
            gradient,
            hessian: [&mut [], &mut [], &mut [], &mut [], &mut [], &mut []],
        }),
        (Some(gradient), Some(hessian)) => run.run::<true, true>(&mut Sink {
            value,
            gradient,
            hessian: hessian.map(|s| &mut s[..n]),
        }),
    }
}

/// The common length of the inputs and outputs (the prefix every slice has).
fn common_len<T, U>(x: &[T], y: &[T], z: &[T], out: &NoiseOutput<'_, U>) -> usize {
    let mut n = x.len().min(y.len()).min(z.len()).min(out.value.len());
    if let Some(g) = &out.gradient {
        n = g.iter().fold(n, |n, s| n.min(s.len()));
    }
    if let Some(h) = &out.hessian {
        n = h.iter().fold(n, |n, s| n.min(s.len()));
    }
    n
}

fn run_f32<K: Kernel>(
    build: Build,
    key: u32,
    base: [f64; 3],
    x: &[f32],
    y: &[f32],
    z: &[f32],
    out: NoiseOutput<'_, f32>,
) {
    let n = common_len(x, y, z, &out);
    let base = if K::SKEWED { simplex::skew(base) } else { base };
    let base = BlockBase::new(base);
    let (x, y, z) = (&x[..n], &y[..n], &z[..n]);
    struct Run<'a, K> {
        build: Build,
        key: u32,
        base: BlockBase,
        x: &'a [f32],
        y: &'a [f32],
        z: &'a [f32],
        kernel: std::marker::PhantomData<K>,
    }
    impl<K: Kernel> BlockRun<f32> for Run<'_, K> {
        fn run<const G: bool, const H: bool>(self, sink: &mut Sink<'_, f32>) {
            dispatch_f32::<K, G, H>(
                self.build, self.key, &self.base, self.x, self.y, self.z, sink,
            )
        }
    }
    let kernel = std::marker::PhantomData::<K>;
    with_sink(
        out,
        n,
        Run {
            build,
            key,
            base,
            x,
            y,
            z,
            kernel,
        },
    )
}

fn run_f64<K: Kernel>(key: u32, x: &[f64], y: &[f64], z: &[f64], out: NoiseOutput<'_, f64>) {
    let n = common_len(x, y, z, &out);
    let (x, y, z) = (&x[..n], &y[..n], &z[..n]);
    struct Run<'a, K> {
        key: u32,
        x: &'a [f64],
        y: &'a [f64],
        z: &'a [f64],
        kernel: std::marker::PhantomData<K>,
    }
    impl<K: Kernel> BlockRun<f64> for Run<'_, K> {
        fn run<const G: bool, const H: bool>(self, sink: &mut Sink<'_, f64>) {
            dispatch_f64::<K, G, H>(self.key, self.x, self.y, self.z, sink)
        }
    }
    let kernel = std::marker::PhantomData::<K>;
    with_sink(
        out,
        n,
        Run {
            key,
            x,
            y,
            z,
            kernel,
        },
    )
}

/// Whether the AVX2+FMA build of the block loops can run here (detected once, then cached).
#[cfg(target_arch = "x86_64")]
#[inline]
fn has_avx2_fma() -> bool {
    std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
}

fn dispatch_f32<K: Kernel, const G: bool, const H: bool>(
    build: Build,
    key: u32,
    base: &BlockBase,
    x: &[f32],
    y: &[f32],
    z: &[f32],
    sink: &mut Sink<'_, f32>,
) {
    #[cfg(target_arch = "x86_64")]
    if build != Build::Plain && has_avx2_fma() {
        let intrinsics = matches!(build, Build::Avx2Intrinsics | Build::Avx512Intrinsics);
        let wide = build == Build::Avx512Intrinsics && perlin_lanes::has_avx512();
        // SAFETY: the CPU has just been checked for the features this build enables.
        unsafe { block_f32_avx2::<K, G, H>(intrinsics, wide, key, base, x, y, z, sink) };
        return;
    }
    let _ = build;
    block_f32::<K, G, H>(key, base, x, y, z, sink)
}

fn dispatch_f64<K: Kernel, const G: bool, const H: bool>(
    key: u32,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    sink: &mut Sink<'_, f64>,
) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: the CPU has just been checked for the features this build enables.
        unsafe { block_f64_avx2::<K, G, H>(key, x, y, z, sink) };
        return;
    }
    block_f64::<K, G, H>(key, x, y, z, sink)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
fn block_f32_avx2<K: Kernel, const G: bool, const H: bool>(
    intrinsics: bool,
    wide: bool,
    key: u32,
    base: &BlockBase,
    x: &[f32],
    y: &[f32],
    z: &[f32],
    sink: &mut Sink<'_, f32>,
) {
    if let (false, false, true, Some(values)) = (G, H, intrinsics, K::AVX2_VALUES) {
        // SAFETY: this function runs only where the CPU has AVX2 and FMA, and `wide` only where
        // it has AVX-512 too.
        unsafe { values(wide, key, base, x, y, z, sink.value) };
        return;
    }
    block_f32::<K, G, H>(key, base, x, y, z, sink)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn block_f64_avx2<K: Kernel, const G: bool, const H: bool>(
    key: u32,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    sink: &mut Sink<'_, f64>,
) {
    block_f64::<K, G, H>(key, x, y, z, sink)
}

#[inline(always)]
fn block_f32<K: Kernel, const G: bool, const H: bool>(
    key: u32,
    base: &BlockBase,
    x: &[f32],
    y: &[f32],
    z: &[f32],
    sink: &mut Sink<'_, f32>,
) {
    for i in 0..sink.value.len().min(x.len()).min(y.len()).min(z.len()) {
        let offset = [x[i], y[i], z[i]];
        let offset = if K::SKEWED {
            simplex::skew(offset)
        } else {
            offset
        };
        let s = K::sample::<f32, G, H>(base.locate(offset), key);
        sink.store::<G, H>(i, &s);
    }
}

#[inline(always)]
fn block_f64<K: Kernel, const G: bool, const H: bool>(
    key: u32,
    x: &[f64],
    y: &[f64],
    z: &[f64],
    sink: &mut Sink<'_, f64>,
) {
    for i in 0..sink.value.len().min(x.len()).min(y.len()).min(z.len()) {
        let p = [x[i], y[i], z[i]];
        let p = if K::SKEWED { simplex::skew(p) } else { p };
        let s = K::sample::<f64, G, H>(locate_f64(p), key);
        sink.store::<G, H>(i, &s);
    }
}
