//! What interpreting a field costs: the compiled field program run over blocks of 256 points
//! against the same expression written as a Rust closure and called per point, on the same
//! points, for three shapes of expression:
//! (a) a distance with its gradient, `sqrt(x·x)` and `grad` of it (four outputs),
//! (b) a flat polynomial/trig expression of about twenty nodes,
//! (c) a chain of ten `compose` warps (`F₀ = sin x + y·z`, `F_{k+1} = compose(F_k, G)`).
//! Each is timed in the `f64` and `f32` output paths on one and two threads, and then written
//! into a 256³ cache (`cachewrite` + `cachefill`) on two threads, next to a closure cache fill.
//!
//! The one key decision: the comparison is checked before it is timed. Interpreted and
//! hand-written values must agree to 1e-9 in `f64` (and to `f32` rounding in `f32`), so both
//! sides compute the same thing. Times are medians of several runs after a warm-up.
//! The distance case has four outputs, a width no field kind has, so it runs the field's
//! compiled program through a four-wide sampler made here; (b) and (c) are `CompiledField`s.
//!
//! Run with `cargo bench --bench field_eval`.

use felt::base::failure::Outcome;
use felt::field::eval::{Evaluator, Precision};
use felt::field::program::Program;
use felt::field::{CompiledField, Field, MathFn, grad};
use felt::grid::cache::Cache;
use felt::space::domain::Domain;
use felt::space::{Aabb, BLOCK, BlockEval, FieldSampler, FnField};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

#[path = "common/cpu.rs"]
mod cpu;
use cpu::cpu_seconds;

/// Points per timed evaluation (a multiple of `BLOCK`).
const POINTS: usize = 1 << 20;
const RUNS: usize = 7;
const FILL_RUNS: usize = 3;
const FILL_CELLS: usize = 256;
/// Levels of the compose chain.
const CHAIN: usize = 10;
/// Strength of the warp `G` in the compose chain.
const WARP: f64 = 0.1;

// ---------------------------------------------------------------------------------------------
// The three expressions, as felt fields and as plain Rust.

fn xyz() -> (Field, Field, Field) {
    let p = Field::identity();
    let c = |i| p.component(i).expect("identity is a vector");
    (c(0), c(1), c(2))
}

fn k(c: f64) -> Field {
    Field::constant_scalar(c)
}

/// (a) `sqrt(x·x)` and its gradient, as the four roots `[r, ∂r/∂x, ∂r/∂y, ∂r/∂z]`.
fn distance_roots() -> Vec<felt::field::node::NodeRef> {
    let r = Field::identity().length().expect("length of a vector");
    let g = grad(&r).expect("grad of a scalarfield");
    let mut roots = r.components().to_vec();
    roots.extend_from_slice(g.components());
    roots
}

fn distance_hand(x: f64, y: f64, z: f64) -> [f64; 4] {
    let r = (x * x + y * y + z * z).sqrt();
    [r, x / r, y / r, z / r]
}

/// (b) `sin(3x + y)·cos(2y − z) + xyz + 0.5x² − 0.25z³ + exp(−(x² + y²))`.
fn polynomial_field() -> Outcome<Field> {
    let (x, y, z) = xyz();
    let xx = x.mul(&x)?;
    let yy = y.mul(&y)?;
    let wave = k(3.0)
        .mul(&x)?
        .add(&y)?
        .math(MathFn::Sin)?
        .mul(&k(2.0).mul(&y)?.sub(&z)?.math(MathFn::Cos)?)?;
    let cubic = x
        .mul(&y)?
        .mul(&z)?
        .add(&k(0.5).mul(&xx)?.sub(&k(0.25).mul(&z.mul(&z)?.mul(&z)?)?)?)?;
    let bump = xx.add(&yy)?.neg().math(MathFn::Exp)?;
    wave.add(&cubic)?.add(&bump)
}

fn polynomial_hand(x: f64, y: f64, z: f64) -> [f64; 1] {
    let xx = x * x;
    let yy = y * y;
    let wave = (3.0 * x + y).sin() * (2.0 * y - z).cos();
    let cubic = x * y * z + (0.5 * xx - 0.25 * (z * z * z));
    let bump = (-(xx + yy)).exp();
    [wave + cubic + bump]
}

/// (c) `F₀ = sin x + y·z`, `F_{k+1} = compose(F_k, G)` with the smooth warp
/// `G(p) = p + 0.1·(sin 1.7y, cos 1.3z, sin 1.1x)`: ten levels, so `F₁₀ = F₀ ∘ G¹⁰`.
fn chain_field() -> Outcome<Field> {
    let (x, y, z) = xyz();
    let wiggle = |v: &Field, freq: f64, m: MathFn| k(WARP).mul(&k(freq).mul(v)?.math(m)?);
    let warp = Field::vector_from(
        &x.add(&wiggle(&y, 1.7, MathFn::Sin)?)?,
        &y.add(&wiggle(&z, 1.3, MathFn::Cos)?)?,
        &z.add(&wiggle(&x, 1.1, MathFn::Sin)?)?,
    )?;
    let mut f = x.math(MathFn::Sin)?.add(&y.mul(&z)?)?;
    for _ in 0..CHAIN {
        f = felt::field::compose(&f, &warp)?;
    }
    Ok(f)
}

fn chain_hand(x: f64, y: f64, z: f64) -> [f64; 1] {
    let (mut x, mut y, mut z) = (x, y, z);
    for _ in 0..CHAIN {
        (x, y, z) = (
            x + WARP * (1.7 * y).sin(),
            y + WARP * (1.3 * z).cos(),
            z + WARP * (1.1 * x).sin(),
        );
    }
    [x.sin() + y * z]
}

// ---------------------------------------------------------------------------------------------
// A sampler over any compiled program, for the four-output case.

/// A field program with any number of outputs, evaluated exactly as `CompiledField` does.
struct ProgramSampler {
    program: Program,
}

struct ProgramEval<'a> {
    evaluator: Evaluator<'a>,
}

impl BlockEval for ProgramEval<'_> {
    fn eval_f32(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f32]) {
        let n = xs.len();
        self.evaluator
            .run_emitting(xs, ys, zs, Precision::Single, |c, values| {
                for (o, v) in out[c * n..(c + 1) * n].iter_mut().zip(values) {
                    *o = *v as f32;
                }
            });
    }

    fn eval_f64(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        let n = xs.len();
        self.evaluator
            .run_emitting(xs, ys, zs, Precision::Double, |c, values| {
                out[c * n..(c + 1) * n].copy_from_slice(values);
            });
    }
}

impl FieldSampler for ProgramSampler {
    fn width(&self) -> usize {
        self.program.outputs.len()
    }

    fn evaluator(&self) -> Box<dyn BlockEval + '_> {
        Box::new(ProgramEval {
            evaluator: Evaluator::new(&self.program),
        })
    }

    fn bounds(&self) -> Option<Aabb> {
        None
    }

    fn range(&self, _region: &Aabb) -> Vec<(f64, f64)> {
        vec![(f64::NEG_INFINITY, f64::INFINITY); self.width()]
    }
}

// ---------------------------------------------------------------------------------------------
// Measurement.

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool")
}

/// Wall and CPU seconds of one run: the median wall time of `runs` runs after one warm-up run,
/// and the CPU time of all `runs` runs divided by `runs`.
fn measure(runs: usize, mut work: impl FnMut()) -> (f64, f64) {
    work();
    let cpu_start = cpu_seconds();
    let mut times: Vec<f64> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            work();
            start.elapsed().as_secs_f64()
        })
        .collect();
    let cpu = (cpu_seconds() - cpu_start) / runs as f64;
    times.sort_by(f64::total_cmp);
    (times[runs / 2], cpu)
}

/// Scattered points in [-1, 1]³ from a counter hash (splitmix64), as separate coordinate arrays.
struct Points {
    xs: Vec<f64>,
    ys: Vec<f64>,
    zs: Vec<f64>,
}

fn points() -> Points {
    let unit = |n: u64| {
        let mut h = n.wrapping_add(0x9e37_79b9_7f4a_7c15);
        h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^= h >> 31;
        (h >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let n = POINTS as u64;
    Points {
        xs: (0..n).map(|i| unit(3 * i)).collect(),
        ys: (0..n).map(|i| unit(3 * i + 1)).collect(),
        zs: (0..n).map(|i| unit(3 * i + 2)).collect(),
    }
}

/// Output values: `f64` or `f32`, written block by block, component-major within a block.
trait Value: Copy + Default + Send + Sync {
    fn from_f64(v: f64) -> Self;
    fn eval(e: &mut dyn BlockEval, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [Self]);
}

impl Value for f64 {
    fn from_f64(v: f64) -> f64 {
        v
    }
    fn eval(e: &mut dyn BlockEval, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        e.eval_f64(xs, ys, zs, out);
    }
}

impl Value for f32 {
    fn from_f64(v: f64) -> f32 {
        v as f32
    }
    fn eval(e: &mut dyn BlockEval, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f32]) {
        e.eval_f32(xs, ys, zs, out);
    }
}

/// Every point through the interpreted field, blocks spread over the current pool.
fn interpreted<T: Value>(sampler: &dyn FieldSampler, p: &Points, out: &mut [T]) {
    let w = sampler.width();
    out.par_chunks_mut(BLOCK * w)
        .zip(p.xs.par_chunks(BLOCK))
        .zip(p.ys.par_chunks(BLOCK))
        .zip(p.zs.par_chunks(BLOCK))
        .for_each_init(
            || sampler.evaluator(),
            |e, (((o, xs), ys), zs)| T::eval(e.as_mut(), xs, ys, zs, o),
        );
}

/// Every point through the hand-written function, one call per point, same blocks and layout.
fn hand_written<T: Value, const W: usize>(
    f: impl Fn(f64, f64, f64) -> [f64; W] + Sync,
    p: &Points,
    out: &mut [T],
) {
    out.par_chunks_mut(BLOCK * W)
        .zip(p.xs.par_chunks(BLOCK))
        .zip(p.ys.par_chunks(BLOCK))
        .zip(p.zs.par_chunks(BLOCK))
        .for_each(|(((o, xs), ys), zs)| {
            let n = xs.len();
            for i in 0..n {
                let v = f(xs[i], ys[i], zs[i]);
                for c in 0..W {
                    o[c * n + i] = T::from_f64(v[c]);
                }
            }
        });
}

struct Case<F> {
    name: &'static str,
    nodes: usize,
    instrs: usize,
    sampler: Box<dyn FieldSampler>,
    hand: F,
}

/// Checks agreement, then prints one row per precision and thread count.
fn eval_rows<const W: usize, F>(case: &Case<F>, p: &Points)
where
    F: Fn(f64, f64, f64) -> [f64; W] + Sync + Copy,
{
    let sampler = case.sampler.as_ref();
    assert_eq!(sampler.width(), W);
    let mut a = vec![0.0f64; POINTS * W];
    let mut b = vec![0.0f64; POINTS * W];
    interpreted(sampler, p, &mut a);
    hand_written(case.hand, p, &mut b);
    let worst = a
        .iter()
        .zip(&b)
        .map(|(u, v)| (u - v).abs())
        .fold(0.0, f64::max);
    assert!(
        worst < 1e-9,
        "{}: interpreted and hand-written differ by {worst:e}",
        case.name
    );
    let mut a32 = vec![0.0f32; POINTS * W];
    let mut b32 = vec![0.0f32; POINTS * W];
    interpreted(sampler, p, &mut a32);
    hand_written(case.hand, p, &mut b32);
    for (u, v) in a32.iter().zip(&b32) {
        // Both round the same f64 values; they may differ by one f32 step where those differ.
        assert!(
            (u - v).abs() <= 2.0 * f32::EPSILON * (1.0 + u.abs()),
            "{}: f32 outputs {u} and {v} differ",
            case.name
        );
    }
    for threads in [1, 2] {
        let pool = pool(threads);
        for precision in ["f64", "f32"] {
            let (ti, th) = if precision == "f64" {
                (
                    measure(RUNS, || pool.install(|| interpreted(sampler, p, &mut a))),
                    measure(RUNS, || pool.install(|| hand_written(case.hand, p, &mut b))),
                )
            } else {
                (
                    measure(RUNS, || pool.install(|| interpreted(sampler, p, &mut a32))),
                    measure(RUNS, || {
                        pool.install(|| hand_written(case.hand, p, &mut b32))
                    }),
                )
            };
            let rate = |t: f64| POINTS as f64 / t * 1e-6;
            println!(
                "| {} | {} | {} | {W} | {precision} | {threads} | {:.1} | {:.1} | {:.2} | {:.2} |",
                case.name,
                case.nodes,
                case.instrs,
                rate(ti.0),
                rate(th.0),
                ti.0 / th.0,
                ti.1 / th.1
            );
        }
    }
    std::hint::black_box((&a, &b, &a32, &b32));
}

fn fill_domain() -> Domain {
    let cell = 2.0 / FILL_CELLS as f64;
    Domain::with_cells(
        DVec3::splat(-1.0),
        DVec3::splat(2.0),
        DVec3::ZERO,
        cell,
        cell,
    )
    .expect("the benchmark domain fits in memory")
}

/// Cells per second filling fresh caches from `source` on two threads (median wall time, and
/// per CPU second over the timed runs); also the first component at one cell, so the two
/// sources can be checked against each other.
fn fill_rate(source: &Arc<dyn FieldSampler>) -> (f64, f64, f32) {
    let width = source.width();
    let pool = pool(2);
    let mut probe = 0.0;
    let mut times = Vec::new();
    let mut cpu = 0.0;
    for run in 0..=FILL_RUNS {
        let cache = Cache::from_field(
            fill_domain(),
            width,
            source.clone(),
            vec![0.0; width],
            "bench".into(),
        )
        .expect("the benchmark cache fits in memory");
        let (start, cpu_start) = (Instant::now(), cpu_seconds());
        pool.install(|| cache.fill_all());
        let seconds = start.elapsed().as_secs_f64();
        // The first run warms up.
        if run > 0 {
            times.push(seconds);
            cpu += cpu_seconds() - cpu_start;
        }
        probe = cache.value_at_cell(37, 200, 91).expect("a cell inside")[0];
        // Dropping a filled cache takes time too; it happens here, outside the timed part.
        drop(cache);
    }
    times.sort_by(f64::total_cmp);
    let cells = FILL_CELLS.pow(3) as f64;
    (
        cells / times[times.len() / 2],
        cells * FILL_RUNS as f64 / cpu,
        probe,
    )
}

fn fill_row(name: &str, felt_source: Arc<dyn FieldSampler>, hand: Arc<dyn FieldSampler>) {
    let (felt_rate, felt_cpu, felt_probe) = fill_rate(&felt_source);
    let (hand_rate, hand_cpu, hand_probe) = fill_rate(&hand);
    assert!(
        (felt_probe - hand_probe).abs() <= 1e-6 * (1.0 + hand_probe.abs()),
        "{name}: cache values {felt_probe} and {hand_probe} differ"
    );
    println!(
        "| {name} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.2} | {:.2} |",
        felt_source.width(),
        felt_rate * 1e-6,
        felt_cpu * 1e-6,
        hand_rate * 1e-6,
        hand_cpu * 1e-6,
        hand_rate / felt_rate,
        hand_cpu / felt_cpu
    );
}

fn main() {
    let p = points();
    let distance = Program::compile(&distance_roots());
    let polynomial = polynomial_field().expect("the polynomial field builds");
    let chain = chain_field().expect("the compose chain builds");
    let size = |f: &Field| {
        let c = CompiledField::new(f);
        (c.program().nodes, c.program().instrs.len())
    };
    let (poly_nodes, poly_instrs) = size(&polynomial);
    let (chain_nodes, chain_instrs) = size(&chain);

    println!("threads available: {}", rayon::current_num_threads());
    println!(
        "\n## field evaluation, {POINTS} scattered points in [-1,1]^3, blocks of {BLOCK}, median of {RUNS}"
    );
    println!(
        "| expression | nodes | tape instrs | outputs | precision | threads | interpreted Mpts/s | hand-written Mpts/s | interpreted/hand-written time (wall) | same (CPU) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let (nodes, instrs) = (distance.nodes, distance.instrs.len());
    eval_rows(
        &Case {
            name: "(a) sqrt(x.x) + grad",
            nodes,
            instrs,
            sampler: Box::new(ProgramSampler { program: distance }),
            hand: distance_hand,
        },
        &p,
    );
    eval_rows(
        &Case {
            name: "(b) polynomial/trig",
            nodes: poly_nodes,
            instrs: poly_instrs,
            sampler: Box::new(CompiledField::new(&polynomial)),
            hand: polynomial_hand,
        },
        &p,
    );
    eval_rows(
        &Case {
            name: "(c) compose chain x10",
            nodes: chain_nodes,
            instrs: chain_instrs,
            sampler: Box::new(CompiledField::new(&chain)),
            hand: chain_hand,
        },
        &p,
    );

    println!(
        "\n## cachewrite + cachefill, {FILL_CELLS}^3 cells, 2 threads, median of {FILL_RUNS} after a warm-up"
    );
    println!(
        "| expression | components | felt Mcells/s | felt Mcells/CPU-s | closure (FnField) Mcells/s | closure Mcells/CPU-s | felt/closure time (wall) | same (CPU) |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let gradient = grad(&Field::identity().length().expect("length")).expect("grad");
    fill_row(
        "(a) grad sqrt(x.x) (vectorcache)",
        CompiledField::shared(&gradient),
        Arc::new(FnField::new(3, |p: DVec3, out: &mut [f64]| {
            let v = distance_hand(p.x, p.y, p.z);
            out.copy_from_slice(&v[1..]);
        })),
    );
    fill_row(
        "(b) polynomial/trig",
        CompiledField::shared(&polynomial),
        Arc::new(FnField::new(1, |p: DVec3, out: &mut [f64]| {
            out[0] = polynomial_hand(p.x, p.y, p.z)[0];
        })),
    );
    fill_row(
        "(c) compose chain x10",
        CompiledField::shared(&chain),
        Arc::new(FnField::new(1, |p: DVec3, out: &mut [f64]| {
            out[0] = chain_hand(p.x, p.y, p.z)[0];
        })),
    );
}
