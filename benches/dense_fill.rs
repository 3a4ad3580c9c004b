//! How close felt's dense procedural fill comes to a hand-written SIMD kernel of the same
//! field: the five-octave Perlin pyroclastic level set `0.6 + 0.3·|fbm(p̂)| − |p|` (no
//! density mask, so no brick can be skipped) on a 256³ grid over [-1, 1]³.
//!
//! felt's side is what `cachewrite` + `cachefill` do: the field comes from the standard
//! library's `pyroclastic` and `fbm` (evaluated in a session, so it is exactly the script's
//! field), is compiled, and fills a fresh `Cache` with `fill_all`. The hand side is the same
//! noise written directly with AVX2+FMA intrinsics, chosen at run time: eight `f32` points of
//! a grid row per register, the arithmetic corner hash, quintic fade and twelve edge gradients
//! of felt's Perlin kernel, and per-row constants (y, z) hoisted out. The one key decision:
//! the hand kernel is checked against felt's cells (largest absolute difference, which must be
//! under `TOLERANCE`) before any time is printed, so a kernel that computes something cheaper
//! cannot pass for a fast one. It works in plain `f32` lattice coordinates, which is accurate
//! enough here because the octave coordinates stay below a few hundred.
//!
//! Prints wall (best of `RUNS`) and CPU seconds (mean of the runs) of each side on 1 and 2
//! threads and the ratio felt/hand. Each felt fill makes a fresh cache, and the one before is
//! dropped outside the timing. Run with `cargo bench --bench dense_fill`;
//! `FELT_BENCH_THREADS=N` times felt's side alone on N threads, for profiling.

use felt::field::CompiledField;
use felt::grid::cache::Cache;
use felt::interp::value::Value;
use felt::session::Session;
use felt::space::domain::Domain;
use glam::DVec3;
use std::time::Instant;

#[path = "peer/felt_run.rs"]
#[allow(dead_code)]
mod felt_run;
use felt_run::cpu_seconds;

const N: usize = 256;
const RUNS: usize = 3;
const OCTAVES: usize = 5;
/// Largest allowed |felt − hand| over all cells. felt locates each block's lattice cell in
/// `f64` and only the offsets in `f32`; the hand kernel works in `f32` throughout, where the
/// fifth octave's coordinates (up to about 220) carry rounding of about 1.5e-5 times slopes up
/// to 4 and a weight of 1/16, so the two differ by a few 1e-6 at most.
const TOLERANCE: f32 = 1e-4;
/// The offset between octaves, as the standard library's `fbm` uses it.
const OCTAVE_SHIFT: [f32; 3] = [17.31, -41.47, 29.83];

const FELT_SCRIPT: &str = "pyroclastic((0, 0, 0), 0.6, fbm(perlin(), 5, scalarfield(2.0), \
                           scalarfield(2.0), scalarfield(0.5)), 0.3)";

fn domain() -> Domain {
    Domain::with_cells(
        DVec3::splat(-1.0),
        DVec3::splat(2.0),
        DVec3::ZERO,
        2.0 / N as f64,
        2.0 / N as f64,
    )
    .expect("the benchmark domain fits in memory")
}

/// The pyroclastic field as the script language builds it.
fn felt_field() -> felt::field::Field {
    let mut session = Session::new(Box::new(std::io::sink()))
        .unwrap_or_else(|_| panic!("the standard library failed to load"));
    let mut field = None;
    let result = session.eval_input(FELT_SCRIPT, &mut |_, value| {
        if let Value::Field(f) = value {
            field = Some(f);
        }
    });
    if result.is_err() {
        panic!("the pyroclastic expression failed to evaluate");
    }
    field.expect("the expression is a field")
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool")
}

/// Best wall seconds and mean CPU seconds over `RUNS` runs of `work` (after one warm-up).
fn measure(mut work: impl FnMut()) -> (f64, f64) {
    work();
    let mut best = f64::INFINITY;
    let cpu_start = cpu_seconds().0;
    for _ in 0..RUNS {
        let start = Instant::now();
        work();
        best = best.min(start.elapsed().as_secs_f64());
    }
    (best, (cpu_seconds().0 - cpu_start) / RUNS as f64)
}

fn felt_cache(field: &felt::field::Field) -> Cache {
    Cache::from_field(
        domain(),
        1,
        CompiledField::shared(field),
        vec![0.0],
        "dense fill bench".into(),
    )
    .expect("the benchmark cache fits in memory")
}

fn felt_fill(field: &felt::field::Field, threads: usize) -> (f64, f64) {
    let pool = pool(threads);
    let (mut best, mut cpu) = (f64::INFINITY, 0.0);
    // One warm-up, then `RUNS` timed fills. Each fill makes a fresh cache; the last one is
    // dropped before the next is made, outside the timing, so felt writes into memory the
    // process already has, as the hand kernel writes into its one grid.
    for run in 0..=RUNS {
        let cache = felt_cache(field);
        let (start, cpu_start) = (Instant::now(), cpu_seconds().0);
        pool.install(|| cache.fill_all());
        let (wall, used) = (start.elapsed().as_secs_f64(), cpu_seconds().0 - cpu_start);
        if run > 0 {
            best = best.min(wall);
            cpu += used;
        }
        drop(cache);
    }
    (best, cpu / RUNS as f64)
}

fn hand_fill(threads: usize, grid: &mut [f32]) -> (f64, f64) {
    let pool = pool(threads);
    measure(|| pool.install(|| hand::fill(grid)))
}

fn main() {
    let field = felt_field();
    if let Ok(threads) = std::env::var("FELT_BENCH_THREADS") {
        let threads = threads
            .parse()
            .expect("FELT_BENCH_THREADS is a thread count");
        let (wall, cpu) = felt_fill(&field, threads);
        println!("felt alone, {threads} threads: {wall:.3} s, {cpu:.3} CPU-s");
        return;
    }
    let cache = felt_cache(&field);
    cache.fill_all();
    let mut grid = vec![0f32; N * N * N];
    hand::fill(&mut grid);
    let mut worst = 0f32;
    let mut worst_at = [0usize; 3];
    for k in 0..N {
        for j in 0..N {
            for i in 0..N {
                let felt = cache.value_at_cell(i, j, k).expect("a filled cell")[0];
                let diff = (felt - grid[i + N * (j + N * k)]).abs();
                // A NaN counts as the worst difference.
                if diff > worst || diff.is_nan() {
                    worst = diff;
                    worst_at = [i, j, k];
                }
            }
        }
    }
    drop(cache);
    println!(
        "dense 256^3 five-octave Perlin pyroclastic, no mask; hand kernel: {}",
        if hand::has_avx2() {
            "AVX2+FMA"
        } else {
            "portable (no AVX2 on this CPU)"
        }
    );
    println!(
        "largest |felt - hand| = {worst:.2e} at cell {worst_at:?} (tolerance {TOLERANCE:.0e})"
    );
    assert!(
        worst <= TOLERANCE,
        "the hand kernel does not compute felt's field"
    );
    println!(
        "{:>8} {:>10} {:>10} {:>10} {:>10} {:>12} {:>12}",
        "threads", "felt s", "felt CPU", "hand s", "hand CPU", "ratio wall", "ratio CPU"
    );
    for threads in [1, 2] {
        let (fw, fc) = felt_fill(&field, threads);
        let (hw, hc) = hand_fill(threads, &mut grid);
        println!(
            "{threads:>8} {fw:>10.3} {fc:>10.3} {hw:>10.3} {hc:>10.3} {:>12.2} {:>12.2}",
            fw / hw,
            fc / hc
        );
    }
}

/// The hand-written kernel.
mod hand {
    use super::{N, OCTAVE_SHIFT, OCTAVES};
    use rayon::prelude::*;

    const PRIME_X: u32 = 0x8da6_b343;
    const PRIME_Y: u32 = 0xd816_3841;
    const PRIME_Z: u32 = 0xcb1a_b31f;

    fn mix(mut h: u32) -> u32 {
        h ^= h >> 16;
        h = h.wrapping_mul(0x7feb_352d);
        h ^= h >> 15;
        h = h.wrapping_mul(0x846c_a68b);
        h ^= h >> 16;
        h
    }

    /// felt's key for seed 0.
    fn key() -> u32 {
        mix(mix(0x9e37_79b9).wrapping_add(0x632b_e5ab))
    }

    pub fn has_avx2() -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
        }
    }

    /// Fills `grid[i + N (j + N k)]`, one row of `N` cells per work item.
    pub fn fill(grid: &mut [f32]) {
        let avx2 = has_avx2();
        let key = key();
        grid.par_chunks_mut(N).enumerate().for_each(|(row, out)| {
            let (j, k) = (row % N, row / N);
            #[cfg(target_arch = "x86_64")]
            if avx2 {
                // SAFETY: the CPU has AVX2 and FMA (checked above).
                unsafe { avx2::row(j, k, key, out) };
                return;
            }
            let _ = avx2;
            portable_row(j, k, key, out);
        });
    }

    fn coordinate(i: usize) -> f32 {
        -1.0 + (i as f32 + 0.5) * (2.0 / N as f32)
    }

    /// The same field one point at a time (used where AVX2 is missing).
    fn portable_row(j: usize, k: usize, key: u32, out: &mut [f32]) {
        let (y, z) = (coordinate(j), coordinate(k));
        for (i, o) in out.iter_mut().enumerate() {
            let x = coordinate(i);
            let r = (x * x + y * y + z * z).sqrt();
            let s = 0.6 / r;
            let mut n = 0.0;
            let (mut freq, mut amp) = (2.0f32, 1.0f32);
            for oct in 0..OCTAVES {
                let shift = oct as f32;
                let q = [
                    x * s * freq + OCTAVE_SHIFT[0] * shift,
                    y * s * freq + OCTAVE_SHIFT[1] * shift,
                    z * s * freq + OCTAVE_SHIFT[2] * shift,
                ];
                n += amp * perlin(q, key);
                freq *= 2.0;
                amp *= 0.5;
            }
            *o = 0.6 + 0.3 * n.abs() - r;
        }
    }

    fn fade(t: f32) -> f32 {
        t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
    }

    fn perlin(q: [f32; 3], key: u32) -> f32 {
        let cell = q.map(|c| c.floor());
        let f = [q[0] - cell[0], q[1] - cell[1], q[2] - cell[2]];
        let terms = [
            (cell[0] as i32 as u32).wrapping_mul(PRIME_X),
            (cell[1] as i32 as u32).wrapping_mul(PRIME_Y),
            (cell[2] as i32 as u32).wrapping_mul(PRIME_Z),
        ];
        let primes = [PRIME_X, PRIME_Y, PRIME_Z];
        let mut ramp = [0f32; 8];
        for (c, r) in ramp.iter_mut().enumerate() {
            let mut h = key;
            let mut d = [0f32; 3];
            for axis in 0..3 {
                let bit = (c >> axis) & 1;
                h ^= terms[axis].wrapping_add(primes[axis] * bit as u32);
                d[axis] = f[axis] - bit as f32;
            }
            let h = mix(h);
            let zero_axis = ((h >> 22) * 3) >> 10;
            *r = (0..3)
                .map(|axis| {
                    if zero_axis == axis as u32 {
                        0.0
                    } else if (h >> axis) & 1 == 1 {
                        -d[axis]
                    } else {
                        d[axis]
                    }
                })
                .sum();
        }
        let (u, v, w) = (fade(f[0]), fade(f[1]), fade(f[2]));
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let x00 = lerp(ramp[0], ramp[1], u);
        let x10 = lerp(ramp[2], ramp[3], u);
        let x01 = lerp(ramp[4], ramp[5], u);
        let x11 = lerp(ramp[6], ramp[7], u);
        lerp(lerp(x00, x10, v), lerp(x01, x11, v), w)
    }

    #[cfg(target_arch = "x86_64")]
    mod avx2 {
        use super::super::{N, OCTAVE_SHIFT, OCTAVES};
        use super::{PRIME_X, PRIME_Y, PRIME_Z, coordinate};
        use std::arch::x86_64::*;

        #[target_feature(enable = "avx2,fma")]
        #[inline]
        fn splat_u(v: u32) -> __m256i {
            _mm256_set1_epi32(v as i32)
        }

        /// felt's `mix` on eight lanes.
        #[target_feature(enable = "avx2,fma")]
        #[inline]
        fn mix(mut h: __m256i) -> __m256i {
            h = _mm256_xor_si256(h, _mm256_srli_epi32(h, 16));
            h = _mm256_mullo_epi32(h, splat_u(0x7feb_352d));
            h = _mm256_xor_si256(h, _mm256_srli_epi32(h, 15));
            h = _mm256_mullo_epi32(h, splat_u(0x846c_a68b));
            _mm256_xor_si256(h, _mm256_srli_epi32(h, 16))
        }

        /// `g·d` for the edge gradient hashed to `h`: each offset gets its sign bit from bits
        /// 0–2 of the hash, and the axis `⌊3·(h >> 22) / 1024⌋` is dropped.
        #[target_feature(enable = "avx2,fma")]
        #[inline]
        fn ramp(h: __m256i, dx: __m256, dy: __m256, dz: __m256) -> __m256 {
            let sign = splat_u(0x8000_0000);
            let sx = _mm256_and_si256(_mm256_slli_epi32(h, 31), sign);
            let sy = _mm256_and_si256(_mm256_slli_epi32(h, 30), sign);
            let sz = _mm256_and_si256(_mm256_slli_epi32(h, 29), sign);
            let tx = _mm256_xor_ps(dx, _mm256_castsi256_ps(sx));
            let ty = _mm256_xor_ps(dy, _mm256_castsi256_ps(sy));
            let tz = _mm256_xor_ps(dz, _mm256_castsi256_ps(sz));
            let zero_axis =
                _mm256_srli_epi32(_mm256_mullo_epi32(_mm256_srli_epi32(h, 22), splat_u(3)), 10);
            let zx = _mm256_castsi256_ps(_mm256_cmpeq_epi32(zero_axis, _mm256_setzero_si256()));
            let zy = _mm256_castsi256_ps(_mm256_cmpeq_epi32(zero_axis, splat_u(1)));
            let zz = _mm256_castsi256_ps(_mm256_cmpeq_epi32(zero_axis, splat_u(2)));
            let tx = _mm256_andnot_ps(zx, tx);
            let ty = _mm256_andnot_ps(zy, ty);
            let tz = _mm256_andnot_ps(zz, tz);
            _mm256_add_ps(_mm256_add_ps(tx, ty), tz)
        }

        #[target_feature(enable = "avx2,fma")]
        #[inline]
        fn fade(t: __m256) -> __m256 {
            let inner = _mm256_fmadd_ps(
                t,
                _mm256_fmsub_ps(t, _mm256_set1_ps(6.0), _mm256_set1_ps(15.0)),
                _mm256_set1_ps(10.0),
            );
            _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(t, t), t), inner)
        }

        #[target_feature(enable = "avx2,fma")]
        #[inline]
        fn lerp(a: __m256, b: __m256, t: __m256) -> __m256 {
            _mm256_fmadd_ps(_mm256_sub_ps(b, a), t, a)
        }

        #[target_feature(enable = "avx2,fma")]
        #[inline]
        fn perlin(x: __m256, y: __m256, z: __m256, key: __m256i) -> __m256 {
            let (fx0, fy0, fz0) = (_mm256_floor_ps(x), _mm256_floor_ps(y), _mm256_floor_ps(z));
            let (dx0, dy0, dz0) = (
                _mm256_sub_ps(x, fx0),
                _mm256_sub_ps(y, fy0),
                _mm256_sub_ps(z, fz0),
            );
            let one = _mm256_set1_ps(1.0);
            let (dx1, dy1, dz1) = (
                _mm256_sub_ps(dx0, one),
                _mm256_sub_ps(dy0, one),
                _mm256_sub_ps(dz0, one),
            );
            let x0 = _mm256_mullo_epi32(_mm256_cvttps_epi32(fx0), splat_u(PRIME_X));
            let y0 = _mm256_mullo_epi32(_mm256_cvttps_epi32(fy0), splat_u(PRIME_Y));
            let z0 = _mm256_mullo_epi32(_mm256_cvttps_epi32(fz0), splat_u(PRIME_Z));
            let x1 = _mm256_add_epi32(x0, splat_u(PRIME_X));
            let y1 = _mm256_add_epi32(y0, splat_u(PRIME_Y));
            let z1 = _mm256_add_epi32(z0, splat_u(PRIME_Z));
            let z0k = _mm256_xor_si256(z0, key);
            let z1k = _mm256_xor_si256(z1, key);
            let y0z0 = _mm256_xor_si256(y0, z0k);
            let y1z0 = _mm256_xor_si256(y1, z0k);
            let y0z1 = _mm256_xor_si256(y0, z1k);
            let y1z1 = _mm256_xor_si256(y1, z1k);
            let r000 = ramp(mix(_mm256_xor_si256(x0, y0z0)), dx0, dy0, dz0);
            let r100 = ramp(mix(_mm256_xor_si256(x1, y0z0)), dx1, dy0, dz0);
            let r010 = ramp(mix(_mm256_xor_si256(x0, y1z0)), dx0, dy1, dz0);
            let r110 = ramp(mix(_mm256_xor_si256(x1, y1z0)), dx1, dy1, dz0);
            let r001 = ramp(mix(_mm256_xor_si256(x0, y0z1)), dx0, dy0, dz1);
            let r101 = ramp(mix(_mm256_xor_si256(x1, y0z1)), dx1, dy0, dz1);
            let r011 = ramp(mix(_mm256_xor_si256(x0, y1z1)), dx0, dy1, dz1);
            let r111 = ramp(mix(_mm256_xor_si256(x1, y1z1)), dx1, dy1, dz1);
            let (u, v, w) = (fade(dx0), fade(dy0), fade(dz0));
            let a = lerp(lerp(r000, r100, u), lerp(r010, r110, u), v);
            let b = lerp(lerp(r001, r101, u), lerp(r011, r111, u), v);
            lerp(a, b, w)
        }

        /// One grid row: eight cells of it per register; y and z are constant along it.
        #[target_feature(enable = "avx2,fma")]
        pub fn row(j: usize, k: usize, key: u32, out: &mut [f32]) {
            let (y, z) = (coordinate(j), coordinate(k));
            let yz2 = y * y + z * z;
            let key = splat_u(key);
            let lane = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0);
            let step = 2.0 / N as f32;
            for (chunk, o) in out.chunks_exact_mut(8).enumerate() {
                let i = _mm256_add_ps(_mm256_set1_ps((chunk * 8) as f32 + 0.5), lane);
                let x = _mm256_fmadd_ps(i, _mm256_set1_ps(step), _mm256_set1_ps(-1.0));
                let r = _mm256_sqrt_ps(_mm256_fmadd_ps(x, x, _mm256_set1_ps(yz2)));
                let s = _mm256_div_ps(_mm256_set1_ps(0.6), r);
                let (sx, sy, sz) = (
                    _mm256_mul_ps(x, s),
                    _mm256_mul_ps(_mm256_set1_ps(y), s),
                    _mm256_mul_ps(_mm256_set1_ps(z), s),
                );
                let mut n = _mm256_setzero_ps();
                let (mut freq, mut amp) = (2.0f32, 1.0f32);
                for oct in 0..OCTAVES {
                    let shift = oct as f32;
                    let f = _mm256_set1_ps(freq);
                    let qx = _mm256_fmadd_ps(sx, f, _mm256_set1_ps(OCTAVE_SHIFT[0] * shift));
                    let qy = _mm256_fmadd_ps(sy, f, _mm256_set1_ps(OCTAVE_SHIFT[1] * shift));
                    let qz = _mm256_fmadd_ps(sz, f, _mm256_set1_ps(OCTAVE_SHIFT[2] * shift));
                    n = _mm256_fmadd_ps(_mm256_set1_ps(amp), perlin(qx, qy, qz, key), n);
                    freq *= 2.0;
                    amp *= 0.5;
                }
                let abs = _mm256_andnot_ps(_mm256_set1_ps(-0.0), n);
                let v = _mm256_sub_ps(
                    _mm256_fmadd_ps(_mm256_set1_ps(0.3), abs, _mm256_set1_ps(0.6)),
                    r,
                );
                // SAFETY: `o` is exactly eight f32s.
                unsafe { _mm256_storeu_ps(o.as_mut_ptr(), v) };
            }
        }
    }
}
