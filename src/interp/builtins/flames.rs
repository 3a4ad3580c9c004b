//! The 3D fractal-flame builtins' work (seed 004): reading a flame's arguments, and
//! `flamewisp` and `flamesplat`, which share them; `particles.rs` registers them beside the
//! other particle builtins. The one key decision: `flamesplat` runs the same chaos game as
//! `flamewisp` and splats each dot as it is made, so no dot is stored.

use super::particles::{compiled, count_of, floats_of, particles_of, seed_of, warn_outside};
use crate::base::failure::{Failure, Outcome};
use crate::field::CompiledField;
use crate::interp::Interpreter;
use crate::interp::registry::Args;
use crate::interp::value::Value;
use crate::particles::flame_splat::{SplatInto, splat_flame};
use crate::particles::splat::Kernel;
use crate::particles::{chaos, guide};
use crate::space::FieldSampler;
use crate::syntax::diagnostic::{Diagnostic, Stage};
use glam::DVec3;
use std::sync::Arc;

/// A flame's arguments, shared by `flamewisp` and `flamesplat`.
struct FlameArgs {
    guides: Vec<guide::Guide>,
    maps: Vec<CompiledField>,
    weights: Vec<f64>,
    colors: Vec<DVec3>,
    displace: Option<CompiledField>,
    color: Option<CompiledField>,
    amount: f64,
    iterations: usize,
    skip: usize,
    count: usize,
    seed: u64,
}

impl FlameArgs {
    fn read(a: &Args, call: &str) -> Outcome<FlameArgs> {
        let guides = guide::guides(particles_of(a.get("guides")?)?)?;
        let maps: Vec<CompiledField> = a
            .get("maps")?
            .as_array()?
            .iter()
            .map(|m| CompiledField::prepared(&m.as_field()?))
            .collect::<Outcome<_>>()?;
        let weights = floats_of(a.get("weights")?)?;
        let colors: Vec<DVec3> = a
            .get("colors")?
            .as_array()?
            .iter()
            .map(|c| c.as_vector())
            .collect::<Outcome<_>>()?;
        if weights.len() != maps.len() || colors.len() != maps.len() {
            return Err(Failure::new(format!(
                "{call} has {} maps, {} weights and {} colors; give one weight and one color per map",
                maps.len(),
                weights.len(),
                colors.len()
            )));
        }
        let amount = a.opt_float("amount")?.unwrap_or(1.0);
        if !amount.is_finite() {
            return Err(Failure::new("amount must be finite"));
        }
        let skip = match a.opt_int("skip")? {
            None => 20,
            Some(n) if n >= 0 => n as usize,
            Some(n) => {
                return Err(Failure::new(format!(
                    "skip must not be negative, found {n}"
                )));
            }
        };
        Ok(FlameArgs {
            guides,
            maps,
            weights,
            colors,
            displace: compiled(a, "displace")?,
            color: compiled(a, "color")?,
            amount,
            iterations: a.opt_positive_int("iterations")?.unwrap_or(1000),
            skip,
            count: count_of(a, "count")?,
            seed: seed_of(a)?,
        })
    }

    fn settings(&self) -> chaos::Settings<'_> {
        chaos::Settings {
            maps: self
                .maps
                .iter()
                .zip(&self.weights)
                .zip(&self.colors)
                .map(|((f, &weight), &color)| chaos::Map {
                    field: f as &dyn FieldSampler,
                    weight,
                    color,
                })
                .collect(),
            displace: self.displace.as_ref().map(|f| f as &dyn FieldSampler),
            amount: self.amount,
            color: self.color.as_ref().map(|f| f as &dyn FieldSampler),
            iterations: self.iterations,
            skip: self.skip,
        }
    }
}

/// Warns when many steps of the chaos game left the finite world.
fn warn_restarts(interp: &mut Interpreter, report: chaos::Report, dots: u64) {
    if report.restarts * 100 > dots && dots > 0 {
        interp.warnings.push(
            Diagnostic::warning(
                Stage::Runtime,
                interp.call_span,
                format!(
                    "{} steps of the chaos game left the finite world and restarted their chains ({} dots made)",
                    report.restarts, dots
                ),
            )
            .with_help("a map that sends points far away wastes work; scale it down or lower its weight"),
        );
    }
}

pub(super) fn flamewisp(interp: &mut Interpreter, a: Args) -> Outcome<Value> {
    let flame = FlameArgs::read(&a, "flamewisp")?;
    let (set, report) = chaos::generate(&flame.guides, flame.count, flame.seed, &flame.settings())?;
    warn_restarts(interp, report, set.len() as u64);
    Ok(Value::Particles(Arc::new(set)))
}

pub(super) fn flamesplat(interp: &mut Interpreter, a: Args) -> Outcome<Value> {
    let flame = FlameArgs::read(&a, "flamesplat")?;
    let kernel = match a.opt("kernel") {
        Some(k) => Kernel::parse(k.as_str()?)?,
        None => Kernel::Trilinear,
    };
    let count_var = super::grids::cache_var(&a)?;
    let color_var = match a.opt("colorcache") {
        Some(Value::Cache(c)) => Some(c),
        Some(other) => {
            return Err(Failure::new(format!(
                "colorcache must be a vectorcache, found {}",
                other.type_of()
            )));
        }
        None => None,
    };
    for var in std::iter::once(count_var).chain(color_var) {
        super::frustum::refuse(
            var,
            "flamesplat",
            "make the dots with flamewisp and splat them into the frustum cache",
        )?;
    }
    let count_before = count_var.state.borrow().clone();
    let color_before = color_var.map(|c| c.state.borrow().clone());
    let count_into = SplatInto {
        domain: &count_var.domain,
        kernel,
        background: &count_var.background,
        previous: count_before.as_deref(),
    };
    let color_into = color_var.map(|c| SplatInto {
        domain: &c.domain,
        kernel,
        background: &c.background,
        previous: color_before.as_ref().and_then(|s| s.as_deref()),
    });
    let (caches, report) = splat_flame(
        &flame.guides,
        flame.count,
        flame.seed,
        &flame.settings(),
        Some(&count_into),
        color_into.as_ref(),
    )?;
    let dots = (flame.guides.len() * flame.count) as u64;
    warn_restarts(interp, report, dots);
    let label = format!("flamesplat at {}", interp.location(interp.call_span));
    let mut warned = None;
    for ((cache, splat), var) in caches
        .into_iter()
        .zip(std::iter::once(count_var).chain(color_var))
    {
        // Two caches on one domain miss the same dots: one warning. A flame's attractor has
        // far-flung dots a domain framing the shot crops; only more than 1 % is a mistake.
        if warned != Some(splat.outside) && splat.outside * 100 > dots {
            warn_outside(interp, splat.outside, dots);
            warned = Some(splat.outside);
        }
        let cache = cache.with_label(label.clone()).with_profile("splat");
        *var.state.borrow_mut() = Some(Arc::new(cache));
    }
    Ok(Value::Void)
}
