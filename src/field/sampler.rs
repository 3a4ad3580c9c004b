//! Fields as samplers: the compiled form that cache fills, the raymarcher and mesh extraction
//! consume, and the two inspection outputs, `probe` and `stats`.
//!
//! `stats` splits the domain into fixed runs of cells, evaluates the runs on all threads and
//! combines the per-run results in run order, so its result does not depend on the number of
//! threads. The one key decision: inspection evaluates in double precision throughout (noise
//! included), because it is how scripts and tests check values against closed forms.

use crate::base::failure::{Failure, Outcome};
use crate::field::eval::{Evaluator, Precision, ProgramRef};
use crate::field::interval;
use crate::field::node::NodeRef;
use crate::field::program::Program;
use crate::field::prune;
use crate::field::ssa::{Index, Inst, Ssa};
use crate::field::{Field, FieldKind, FieldValue};
use crate::space::domain::Domain;
use crate::space::{Aabb, BLOCK, BlockEval, FieldSampler, GridSource};
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use std::sync::{Arc, OnceLock};

/// A field compiled for evaluation: its graph flattened once into a linear form, from which
/// the register program, the interval tape and the support search are all derived.
pub struct CompiledField {
    program: Program,
    /// The linear form, for the interval ranges asked of every brick and the support search.
    intervals: interval::IntervalTape,
    support: OnceLock<Option<Aabb>>,
    /// Every grid the roots read, for solving them ahead of an output.
    grids: Vec<Arc<dyn GridSource>>,
    /// The max, min and select instructions, which a region may decide (`prune`).
    choices: Vec<Index>,
    /// The budget its worker threads' evaluators take, when it was `prepared` for an output.
    _evaluators: Option<crate::engine::budget::Reservation>,
}

impl CompiledField {
    pub fn new(field: &Field) -> CompiledField {
        CompiledField::from_ssa(Arc::new(Ssa::new(field.components())))
    }

    fn from_ssa(ssa: Arc<Ssa>) -> CompiledField {
        CompiledField {
            program: Program::from_ssa(&ssa),
            grids: grids_of(&ssa),
            choices: prune::choices(&ssa),
            intervals: interval::IntervalTape::from_ssa(ssa),
            support: OnceLock::new(),
            _evaluators: None,
        }
    }

    /// The field with the choices that `region` decides dropped (`field::prune`), for
    /// evaluating many points inside it; `None` when the region decides none. Its values at
    /// points inside the region are this field's, bit for bit. A region split into bricks is
    /// pruned once for the whole and then per brick from the shorter tape, which is what makes
    /// pruning cheap on a long tape.
    pub fn pruned(&self, region: &Aabb) -> Option<CompiledField> {
        if self.choices.is_empty() {
            return None;
        }
        let ssa = self.intervals.ssa();
        let iv = self.intervals.intervals(region);
        let decisions = prune::decisions(ssa, &self.choices, &iv);
        prune::pruned(ssa, &self.choices, &decisions).map(|p| CompiledField::from_ssa(Arc::new(p)))
    }

    /// Instructions in the linear form.
    pub fn len(&self) -> usize {
        self.intervals.ssa().len()
    }

    pub fn is_empty(&self) -> bool {
        self.intervals.ssa().is_empty()
    }

    /// Compiled and with its whole-grid solves run: what outputs evaluate.
    pub fn prepared(field: &Field) -> Outcome<CompiledField> {
        let mut compiled = CompiledField::new(field);
        compiled.prepare()?;
        // Every worker thread evaluates it with its own registers: a figure known now, so it
        // is charged before any thread starts (a long tape on many threads is megabytes).
        let threads = rayon::current_num_threads();
        let registers = compiled.program.registers;
        compiled._evaluators = Some(crate::engine::budget::reserve(
            (threads * crate::field::eval::evaluator_bytes(&compiled.program)) as f64,
            &format!(
                "evaluating a field of {registers} registers of {BLOCK} points on each of \
                 {threads} threads"
            ),
        )?);
        Ok(compiled)
    }

    /// Runs the whole-grid solves this field depends on, in dependency order (see
    /// `grid::demand`). Every output calls this before it evaluates in parallel.
    pub fn prepare(&self) -> Outcome<()> {
        crate::space::demand::solve_ahead(self.grids.clone())
    }

    pub fn program(&self) -> &Program {
        &self.program
    }

    /// As a shareable sampler.
    pub fn shared(field: &Field) -> Arc<dyn FieldSampler> {
        Arc::new(CompiledField::new(field))
    }
}

struct CompiledEval<'a> {
    field: &'a CompiledField,
    evaluator: Evaluator<'a>,
    /// The decisions of the pruned program being run; empty while the field's own runs.
    decided: Vec<Index>,
}

impl CompiledEval<'_> {
    fn each_block(
        &mut self,
        xs: &[f64],
        ys: &[f64],
        zs: &[f64],
        precision: Precision,
        mut store: impl FnMut(usize, usize, &[f64]),
    ) {
        let total = xs.len();
        let mut start = 0;
        while start < total {
            let end = (start + BLOCK).min(total);
            self.evaluator.run_emitting(
                &xs[start..end],
                &ys[start..end],
                &zs[start..end],
                precision,
                |c, values| store(c, start, values),
            );
            start = end;
        }
    }
}

impl BlockEval for CompiledEval<'_> {
    fn eval_f32(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f32]) {
        let n = xs.len();
        self.each_block(xs, ys, zs, Precision::Single, |c, start, values| {
            let row = &mut out[c * n + start..c * n + start + values.len()];
            for (o, v) in row.iter_mut().zip(values) {
                *o = *v as f32;
            }
        });
    }

    fn eval_f64(&mut self, xs: &[f64], ys: &[f64], zs: &[f64], out: &mut [f64]) {
        let n = xs.len();
        self.each_block(xs, ys, zs, Precision::Double, |c, start, values| {
            out[c * n + start..c * n + start + values.len()].copy_from_slice(values);
        });
    }

    /// Runs the program pruned to `region` (or the field's own where the region decides no
    /// choice). Neighbouring regions usually decide alike, so the program is rebuilt only when
    /// the decisions change.
    fn focus(&mut self, region: &Aabb) -> Option<Vec<(f64, f64)>> {
        let field = self.field;
        let iv = field.intervals.intervals(region);
        let ssa = field.intervals.ssa();
        let range = ssa
            .roots
            .iter()
            .map(|&r| (iv[r as usize].lo, iv[r as usize].hi))
            .collect();
        if field.choices.is_empty() {
            return Some(range);
        }
        let decisions = prune::decisions(ssa, &field.choices, &iv);
        let undecided = decisions.iter().all(|&d| d == Index::MAX);
        if undecided {
            if !self.decided.is_empty() {
                self.evaluator
                    .set_program(ProgramRef::Borrowed(&field.program));
                self.decided.clear();
            }
        } else if decisions != self.decided {
            if let Some(pruned) = prune::pruned(ssa, &field.choices, &decisions) {
                self.evaluator
                    .set_program(ProgramRef::Shared(Arc::new(Program::from_ssa(&pruned))));
            }
            self.decided = decisions;
        }
        Some(range)
    }
}

impl FieldSampler for CompiledField {
    fn width(&self) -> usize {
        self.program.outputs.len()
    }

    fn evaluator(&self) -> Box<dyn BlockEval + '_> {
        Box::new(CompiledEval {
            field: self,
            evaluator: Evaluator::new(&self.program),
            decided: Vec::new(),
        })
    }

    fn bounds(&self) -> Option<Aabb> {
        *self
            .support
            .get_or_init(|| interval::support_of(&self.intervals))
    }

    fn grids(&self) -> Vec<Arc<dyn GridSource>> {
        self.grids.clone()
    }

    /// A field that is nothing but a read of one grid gives that grid's own cells.
    fn fill_cells(&self, domain: &Domain, lo: [usize; 3], hi: [usize; 3], out: &mut [f32]) -> bool {
        let ssa = self.intervals.ssa();
        let [Inst::X, Inst::Y, Inst::Z, Inst::Kernel(kernel, args), ..] = ssa.insts.as_slice()
        else {
            return false;
        };
        let Some(read) = kernel.grid_read().filter(|r| r.is_value()) else {
            return false;
        };
        let plain_read = args.as_slice() == [0, 1, 2]
            && ssa.insts.len() == 4 + ssa.roots.len()
            && ssa.roots.iter().enumerate().all(
                |(c, &r)| matches!(ssa.insts[r as usize], Inst::Output([3], i) if i as usize == c),
            );
        plain_read && read.grid().cells(domain, lo, hi, out)
    }

    fn range(&self, region: &Aabb) -> Vec<(f64, f64)> {
        self.intervals
            .ranges(region)
            .into_iter()
            .map(|r| (r.lo, r.hi))
            .collect()
    }

    fn range_held(&self, region: &Aabb) -> Vec<(f64, f64)> {
        self.intervals
            .ranges_held(region)
            .into_iter()
            .map(|r| (r.lo, r.hi))
            .collect()
    }
}

/// The grids that the graph under `roots` reads, each once, in the order first met.
pub fn grids_read(roots: &[NodeRef]) -> Vec<Arc<dyn GridSource>> {
    grids_of(&Ssa::new(roots))
}

/// The grids a linear form reads, each once, in the order first met.
fn grids_of(ssa: &Ssa) -> Vec<Arc<dyn GridSource>> {
    let mut seen = std::collections::HashSet::new();
    let mut grids = Vec::new();
    for inst in &ssa.insts {
        if let Inst::Kernel(kernel, _) = inst
            && let Some(read) = kernel.grid_read()
            && seen.insert(read.grid().identity())
        {
            grids.push(read.grid().clone());
        }
    }
    grids
}

/// Runs the whole-grid solves `field` depends on (see `CompiledField::prepare`).
pub fn prepare(field: &Field) -> Outcome<()> {
    crate::space::demand::solve_ahead(grids_read(field.components()))
}

/// The value of `field` at `point`, in double precision.
pub fn probe(field: &Field, point: DVec3) -> Outcome<FieldValue> {
    if !point.is_finite() {
        return Err(Failure::new(format!(
            "probe point must be finite, found {point}"
        )));
    }
    prepare(field)?;
    let program = Program::compile(field.components());
    let mut evaluator = Evaluator::new(&program);
    evaluator.run(&[point.x], &[point.y], &[point.z], Precision::Double);
    let v: Vec<f64> = (0..field.kind().width())
        .map(|c| evaluator.output(c, 1)[0])
        .collect();
    Ok(match field.kind() {
        FieldKind::Scalar => FieldValue::Scalar(v[0]),
        FieldKind::Vector => FieldValue::Vector(DVec3::new(v[0], v[1], v[2])),
        FieldKind::Matrix => FieldValue::Matrix(DMat3::from_cols_array(&[
            v[0], v[3], v[6], v[1], v[4], v[7], v[2], v[5], v[8],
        ])),
    })
}

/// The values of `field` at each of `points`, in double precision: `width` numbers per point,
/// point after point. Blocks of points run on all threads; each point's value depends on that
/// point alone, so the result does not depend on the number of threads.
pub fn sample_points(field: &Field, points: &[DVec3]) -> Outcome<Vec<f64>> {
    if let Some(bad) = points.iter().find(|p| !p.is_finite()) {
        return Err(Failure::new(format!(
            "a point to evaluate at is not finite: {bad}"
        )));
    }
    prepare(field)?;
    let program = Program::compile(field.components());
    let width = field.kind().width();
    let mut out = vec![0.0; points.len() * width];
    out.par_chunks_mut(BLOCK * width)
        .zip(points.par_chunks(BLOCK))
        .for_each_init(
            || Evaluator::new(&program),
            |evaluator, (values, block)| {
                let xs: Vec<f64> = block.iter().map(|p| p.x).collect();
                let ys: Vec<f64> = block.iter().map(|p| p.y).collect();
                let zs: Vec<f64> = block.iter().map(|p| p.z).collect();
                evaluator.run(&xs, &ys, &zs, Precision::Double);
                for c in 0..width {
                    for (i, v) in evaluator.output(c, block.len()).iter().enumerate() {
                        values[i * width + c] = *v;
                    }
                }
            },
        );
    Ok(out)
}

/// Cells per unit of parallel work in `stats`: fixed, so results do not depend on threads.
const STATS_RUN: usize = 16 * BLOCK;

/// `(min, max, mean)` of a scalarfield over the cell centres of `domain`, of its finite values
/// only: NaN and infinite values are left out (all three are NaN when no value is finite).
pub fn stats(field: &Field, domain: &Domain) -> Outcome<(f64, f64, f64)> {
    stats_with_count(field, domain).map(|(min, max, mean, _)| (min, max, mean))
}

/// `stats` plus the number of NaN or infinite values left out, for a warning.
pub fn stats_with_count(field: &Field, domain: &Domain) -> Outcome<(f64, f64, f64, u64)> {
    if field.kind() != FieldKind::Scalar {
        return Err(Failure::new(format!(
            "stats takes a scalarfield, found a {}",
            field.kind().name()
        )));
    }
    let [nx, ny, nz] = domain.resolution.ok_or_else(|| {
        Failure::new("stats needs a domain with a cell size")
            .with_help("give the domain a cell size: domain(origin, lengths, orientation, cell)")
    })?;
    let cells = nx * ny * nz;
    prepare(field)?;
    let program = Program::compile(field.components());
    let runs = cells.div_ceil(STATS_RUN);
    let partials: Vec<Option<(f64, f64, f64, u64)>> = (0..runs)
        .into_par_iter()
        .map_init(
            || Evaluator::new(&program),
            |evaluator, run| {
                if crate::engine::interrupt::requested() {
                    return None;
                }
                let first = run * STATS_RUN;
                let last = (first + STATS_RUN).min(cells);
                let (mut xs, mut ys, mut zs) = (
                    Vec::with_capacity(BLOCK),
                    Vec::with_capacity(BLOCK),
                    Vec::with_capacity(BLOCK),
                );
                let (mut min, mut max, mut sum, mut bad) =
                    (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0u64);
                let mut start = first;
                while start < last {
                    let end = (start + BLOCK).min(last);
                    xs.clear();
                    ys.clear();
                    zs.clear();
                    for cell in start..end {
                        let (i, j, k) = (cell % nx, (cell / nx) % ny, cell / (nx * ny));
                        let p = domain.cell_center(i, j, k);
                        xs.push(p.x);
                        ys.push(p.y);
                        zs.push(p.z);
                    }
                    evaluator.run(&xs, &ys, &zs, Precision::Double);
                    // Pairwise within a block keeps the sum's rounding small.
                    let values = evaluator.output(0, end - start);
                    let mut block_bad = 0;
                    for &v in values {
                        if v.is_finite() {
                            min = min.min(v);
                            max = max.max(v);
                        } else {
                            block_bad += 1;
                        }
                    }
                    sum += if block_bad == 0 {
                        pairwise_sum(values)
                    } else {
                        let finite: Vec<f64> =
                            values.iter().copied().filter(|v| v.is_finite()).collect();
                        pairwise_sum(&finite)
                    };
                    bad += block_bad;
                    start = end;
                }
                Some((min, max, sum, bad))
            },
        )
        .collect();
    let mut total = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0u64);
    let mut sums = Vec::with_capacity(partials.len());
    for p in partials {
        let (min, max, sum, bad) = p.ok_or_else(|| Failure::new("interrupted"))?;
        total.0 = total.0.min(min);
        total.1 = total.1.max(max);
        sums.push(sum);
        total.3 += bad;
    }
    let finite = cells as u64 - total.3;
    if finite == 0 {
        return Ok((f64::NAN, f64::NAN, f64::NAN, total.3));
    }
    total.2 = pairwise_sum(&sums) / finite as f64;
    Ok(total)
}

fn pairwise_sum(values: &[f64]) -> f64 {
    if values.len() <= 8 {
        return values.iter().sum();
    }
    let (a, b) = values.split_at(values.len() / 2);
    pairwise_sum(a) + pairwise_sum(b)
}
