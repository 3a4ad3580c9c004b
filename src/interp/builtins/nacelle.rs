//! Nacelle builtins (FELT chapter 4): `nacelle` builds the warp that carries an object level
//! set onto a reference one, `nacelleclamped` counts where its root was clamped.
//!
//! The iteration is a builtin rather than a library function so that the discriminant of every
//! step is at hand to be counted, and so that the cached variant can sample `B·B` and `B·M·B`
//! straight into caches without a script-level cache variable per iteration. The one key
//! decision: a cached iteration reads its caches with the zero background outside the
//! domain, which the step treats as "no gradient" — points outside the domain stay where they
//! are instead of moving by an extrapolated guess.

use crate::base::failure::{Failure, Outcome};
use crate::field::nacelle::{self, Step};
use crate::field::{CompiledField, Field, sample_points};
use crate::grid::cache::Cache;
use crate::interp::Interpreter;
use crate::interp::registry::{Args, Registry};
use crate::interp::value::Value;
use crate::space::GridSource;
use crate::space::domain::Domain;
use std::sync::Arc;

pub fn register(r: &mut Registry) {
    r.add(
        "geometry",
        &[
            "nacelle(scalarfield Lo, scalarfield Lr, int iterations) -> vectorfield",
            "nacelle(scalarfield Lo, scalarfield Lr, int iterations, domain cache) -> vectorfield",
        ],
        "the warp X with Lo(x) = Lr(X(x)) after `iterations` nacelle steps from the identity \
         (stable root, vertex where the root is complex, no step where grad(Lr) vanishes); with \
         `cache`, B·B and B·M·B are sampled onto cache's cells every iteration (the chapter's cached variant)",
        |interp, a| {
            let steps = steps(interp, &a)?;
            Ok(Value::Field(steps.last().expect("one step at least").warp.clone()))
        },
    );
    r.add(
        "geometry",
        &[
            "nacelleclamped(scalarfield Lo, scalarfield Lr, int iterations, shape points, domain cache?) -> int[]",
            "nacelleclamped(scalarfield Lo, scalarfield Lr, int iterations, domain cells, domain cache?) -> int[]",
        ],
        "for each nacelle iteration, how many of the shape's vertices (or the domain's cell \
         centres) had no real root (1 + 2ΔΓ < 0) and were moved to the parabola's vertex",
        |interp, a| {
            let points = match a.one_of(&["points", "cells"])? {
                Value::Shape(mesh) => mesh.positions.clone(),
                Value::Domain(d) => cell_centres(d)?,
                other => {
                    return Err(Failure::new(format!(
                        "expected a shape or a domain, found {}",
                        other.type_of()
                    )));
                }
            };
            let steps = steps(interp, &a)?;
            let counts = steps
                .iter()
                .map(|s| clamped(s, &points).map(|n| Value::Int(n as i64)))
                .collect::<Outcome<Vec<_>>>()?;
            Ok(Value::array(counts, crate::check::types::Type::Int))
        },
    );
}

/// The iteration the arguments ask for.
fn steps(interp: &Interpreter, a: &Args) -> Outcome<Vec<Step>> {
    let lo = a.get("Lo")?.as_field()?;
    let lr = a.get("Lr")?.as_field()?;
    let iterations = a.int("iterations")?;
    if iterations < 1 {
        return Err(Failure::new(format!(
            "nacelle needs at least one iteration, found {iterations}"
        ))
        .with_help("iterations counts the steps from the identity warp; 1 to 4 usually suffice"));
    }
    if iterations > 64 {
        return Err(Failure::new(format!(
            "nacelle converges in a few iterations; {iterations} would build a graph of \
             {iterations} nested warps"
        ))
        .with_help("use at most 64 iterations (the chapter needs 1 to 5)"));
    }
    let cache = match a.opt("cache") {
        Some(Value::Domain(d)) => {
            if d.resolution.is_none() {
                return Err(Failure::new("nacelle's cache domain needs a cell size"));
            }
            Some((**d).clone())
        }
        _ => None,
    };
    let label = format!("nacelle at {}", interp.location(interp.call_span));
    match cache {
        None => nacelle::iterate(&lo, &lr, iterations as usize, None),
        Some(domain) => {
            let sample = |f: &Field| sampled(f, &domain, &label);
            nacelle::iterate(&lo, &lr, iterations as usize, Some(&sample))
        }
    }
}

/// `field` sampled lazily at `domain`'s cells and read back trilinearly, zero outside.
fn sampled(field: &Field, domain: &Domain, label: &str) -> Outcome<Field> {
    let cache = Cache::from_field(
        domain.clone(),
        1,
        CompiledField::shared(field),
        vec![0.0],
        label.to_string(),
    )?;
    let grid: Arc<dyn GridSource> = Arc::new(cache);
    Field::from_linear_grid(grid)
}

fn clamped(step: &Step, points: &[glam::DVec3]) -> Outcome<usize> {
    let values = sample_points(&step.discriminant, points)?;
    Ok(values.iter().filter(|&&d| d < 0.0).count())
}

fn cell_centres(d: &Domain) -> Outcome<Vec<glam::DVec3>> {
    let [nx, ny, nz] = d
        .resolution
        .ok_or_else(|| Failure::new("the domain to count over needs a cell size"))?;
    d.check_grid_memory(6)?;
    let mut points = Vec::with_capacity(nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                points.push(d.cell_center(i, j, k));
            }
        }
    }
    Ok(points)
}
