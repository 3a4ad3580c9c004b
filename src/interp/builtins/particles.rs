//! Particle builtins: construction, attributes and files; splatting into caches and
//! point-attribute fields; wisps and 3D fractal flames (seed 004; the flames' work is in
//! `flames.rs`).
//!
//! A particle set is a plain value: `addattr` returns a new set and leaves its argument as it
//! was. Generators (`scatter`, `wisp`, `flamewisp`) are seeded by an explicit `seed`, so the
//! same call gives the same points whatever else the script does.

use crate::base::failure::{Failure, Outcome};
use crate::field::{CompiledField, Field};
use crate::interp::Interpreter;
use crate::interp::elements::check_array;
use crate::interp::registry::{Args, Registry};
use crate::interp::value::Value;
use crate::particles::io::{self, FileKind};
use crate::particles::pointfield::{Blend, PointField};
use crate::particles::splat::{Deposit, Kernel};
use crate::particles::{Particles, Values, flame, guide, scatter, wisp};
use crate::space::{FieldSampler, GridSource};
use crate::syntax::diagnostic::{Diagnostic, Stage};
use glam::DVec3;
use std::sync::Arc;

/// Largest particle file read (the run's memory budget applies as well).
const MAX_FILE_BYTES: u64 = 16 << 30;

pub fn register(r: &mut Registry) {
    r.add(
        "particles",
        &["particles(vector[] positions) -> particles"],
        "points at the given positions, without attributes",
        |_, a| {
            let positions = vectors_of(a.get("positions")?)?;
            let set = Particles::new(positions);
            set.check_finite("particles")?;
            Ok(Value::Particles(Arc::new(set)))
        },
    );
    r.add(
        "particles",
        &["loadparticles(string path) -> particles"],
        "reads points and their attributes from a PLY (ASCII or binary) or CSV file",
        |interp, a| {
            let path = a.string("path")?;
            let bytes = crate::io::input::read_whole(
                &interp.files.reading(path)?,
                MAX_FILE_BYTES,
                "a particle file",
            )
            .map_err(|e| Failure::new(format!("cannot read particles '{path}': {e}")))?;
            let set = io::read(&bytes, path)
                .map_err(|e| Failure::new(format!("'{path}': {}", e.message)))?;
            set.check_finite(&format!("'{path}'"))?;
            Ok(Value::Particles(Arc::new(set)))
        },
    );
    r.add(
        "particles",
        &["saveparticles(particles p, string path, bool ascii?) -> void"],
        "writes p to a PLY file (binary little endian, or ASCII with ascii = true) or, for a \
         path ending in .csv, a CSV file with a header row",
        |interp, a| {
            let set = particles_of(a.get("p")?)?;
            let path = a.string("path")?;
            let target = interp.files.writing(path)?;
            let ascii = matches!(a.opt("ascii"), Some(Value::Bool(true)));
            let kind = if path.to_ascii_lowercase().ends_with(".csv") {
                FileKind::Csv
            } else if ascii {
                FileKind::PlyAscii
            } else {
                FileKind::PlyBinary
            };
            let bytes = io::write(set, kind)?;
            crate::io::output::write_atomically(&target, |file| {
                use std::io::Write;
                file.write_all(&bytes).map_err(|e| e.to_string())
            })
            .map_err(|e| Failure::new(format!("cannot write particles '{path}': {e}")))?;
            Ok(Value::Void)
        },
    );
    r.add(
        "particles",
        &["scatter(scalarfield ls, int count, int seed, domain region?) -> particles"],
        "count points uniformly inside the level set ls (positive inside), seeded; searched \
         over region, or over the box where ls can be positive",
        |_, a| {
            let ls = a.get("ls")?.as_field()?;
            let sampler = CompiledField::prepared(&ls)?;
            let region = match a.opt("region") {
                Some(Value::Domain(d)) => d.bounds(),
                _ => match CompiledField::prepared(&ls.mask()?)?.bounds() {
                    Some(b) if b.is_finite() && !b.is_empty() => b,
                    _ => {
                        return Err(Failure::new(
                            "the level set does not report finite bounds to scatter in",
                        )
                        .with_help("give the region: scatter(ls, count, seed, domain)"));
                    }
                },
            };
            let count = count_of(&a, "count")?;
            let set = scatter::scatter(&sampler, region, count, seed_of(&a)?)?;
            Ok(Value::Particles(Arc::new(set)))
        },
    );
    r.add(
        "particles",
        &[
            "addattr(particles p, string name, float value) -> particles",
            "addattr(particles p, string name, vector value) -> particles",
            "addattr(particles p, string name, float[] values) -> particles",
            "addattr(particles p, string name, vector[] values) -> particles",
            "addattr(particles p, string name, scalarfield f) -> particles",
            "addattr(particles p, string name, vectorfield f) -> particles",
        ],
        "p with the attribute name set (added or replaced): one value for every point, one per \
         point, or a field sampled at each point; \"P\" moves the points",
        addattr,
    );
    r.add(
        "particles",
        &["getattr(particles p, string name) -> float[]"],
        "the values of p's float attribute name, one per point",
        |_, a| {
            let set = particles_of(a.get("p")?)?;
            let values = set.floats(a.string("name")?)?;
            check_array(values.len(), 0, "getattr's array")?;
            let items = values.iter().map(|&v| Value::Float(v as f64)).collect();
            Ok(Value::array(items, crate::check::types::Type::Float))
        },
    );
    r.add(
        "particles",
        &["getvattr(particles p, string name) -> vector[]"],
        "the values of p's vector attribute name (\"P\" for the positions), one per point",
        |_, a| {
            let set = particles_of(a.get("p")?)?;
            let values = set.vectors(a.string("name")?)?;
            check_array(values.len(), 0, "getvattr's array")?;
            let items = values
                .iter()
                .map(|v| Value::Vector(DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)))
                .collect();
            Ok(Value::array(items, crate::check::types::Type::Vector))
        },
    );
    r.add(
        "particles",
        &[
            "splat(scalarcache c, particles p, string attr?, string kernel?) -> void",
            "splat(vectorcache c, particles p, string attr, string kernel?) -> void",
        ],
        "adds p's attribute attr (1 per point when not given) into c's cells, kernel \
         \"trilinear\" (default) or \"nearest\"; the total is preserved and the result is the \
         same for any thread count",
        splat,
    );
    r.add(
        "particles",
        &["pointfield(particles p, string attr, float radius, string mode?) -> scalarfield"],
        "a sphere of radius around every point carrying its float attribute attr, smoothly \
         falling to 0 at the radius: mode \"sum\" (default) adds them, \"average\" blends them",
        |_, a| {
            let set = particles_of(a.get("p")?)?;
            let blend = match a.opt("mode") {
                Some(m) => Blend::parse(m.as_str()?)?,
                None => Blend::Sum,
            };
            let attr = a.string("attr")?;
            set.floats(attr)?;
            let field = PointField::new(set, attr, a.float("radius")?, blend)?;
            let grid: Arc<dyn GridSource> = Arc::new(field);
            Ok(Value::Field(Field::from_linear_grid(grid)?))
        },
    );
    r.add(
        "particles",
        &["flame(string name, float[] pre?, float[] post?, float[] params?) -> vectorfield"],
        "the 3D fractal-flame variation name (linear, sinusoidal, spherical, swirl, horseshoe, \
         polar, handkerchief, heart, disc, spiral, hyperbolic, diamond, ex, julia, bent, wave, \
         fisheye, popcorn, exponential, power, cosine) between affine maps pre and post, each \
         12 coefficients a b c d e f g h k l m n",
        |_, a| {
            let name = a.string("name")?;
            let affine = |key: &str| -> Outcome<Option<(glam::DMat3, DVec3)>> {
                match a.opt(key) {
                    Some(v) => Ok(Some(flame::affine_from_coefficients(&floats_of(v)?)?)),
                    None => Ok(None),
                }
            };
            let params = match a.opt("params") {
                Some(v) => floats_of(v)?,
                None => flame::default_params(name).to_vec(),
            };
            Ok(Value::Field(flame::flame(
                name,
                &params,
                affine("pre")?,
                affine("post")?,
            )?))
        },
    );
    r.add(
        "particles",
        &[
            "flamewisp(particles guides, vectorfield[] maps, float[] weights, vector[] colors, \
           int count, int seed, vectorfield displace?, float amount?, vectorfield color?, \
           int iterations?, int skip?) -> particles",
        ],
        "count dots per guide from the chaos game over maps (picked by weight, each with its \
         colour), displaced by amount * displace, coloured (color + map colour)/2 or by the \
         running average of map colours; chains of iterations stamped steps after skip",
        super::flames::flamewisp,
    );
    r.add(
        "particles",
        &[
            "flamesplat(scalarcache c, particles guides, vectorfield[] maps, float[] weights, \
           vector[] colors, int count, int seed, vectorcache colorcache?, string kernel?, \
           vectorfield displace?, float amount?, vectorfield color?, int iterations?, \
           int skip?) -> void",
        ],
        "the dots of flamewisp with the same arguments, splatted as they are made: their count \
         into c and their colours into colorcache, kernel \"trilinear\" (default) or \
         \"nearest\"; no dot is stored, and the count equals splat(c, flamewisp(...)) bit for \
         bit",
        super::flames::flamesplat,
    );
    r.add(
        "particles",
        &["wisp(particles guides, int count, int seed, string walk?, float epsilon?, float q?, \
           scalarfield radial?, float alpha?, vectorfield displace?, vectorfield color?) -> particles"],
        "count dots per guide from a walk (\"random\", \"correlated\" with correlation epsilon, \
         \"levy\" with epsilon and q) on the unit sphere, pushed out by |radial|^alpha, placed \
         in the guide's frame, displaced by displace and coloured by color",
        wisp_builtin,
    );
}

pub(super) fn particles_of(v: &Value) -> Outcome<&Particles> {
    match v {
        Value::Particles(p) => Ok(p),
        other => Err(Failure::new(format!(
            "expected particles, found {}",
            other.type_of()
        ))),
    }
}

pub(super) fn vectors_of(v: &Value) -> Outcome<Vec<[f32; 3]>> {
    v.as_array()?
        .iter()
        .map(|item| Ok(item.as_vector()?.to_array().map(|c| c as f32)))
        .collect()
}

pub(super) fn floats_of(v: &Value) -> Outcome<Vec<f64>> {
    v.as_array()?.iter().map(|item| item.as_float()).collect()
}

pub(super) fn count_of(a: &Args, key: &str) -> Outcome<usize> {
    let n = a.int(key)?;
    usize::try_from(n).map_err(|_| Failure::new(format!("{key} must not be negative, found {n}")))
}

pub(super) fn seed_of(a: &Args) -> Outcome<u64> {
    let n = a.int("seed")?;
    u64::try_from(n).map_err(|_| Failure::new(format!("a seed must not be negative, found {n}")))
}

/// A field sampled at every point of `set`, `width` values per point.
fn sample_at_points(field: &Field, set: &Particles) -> Outcome<Vec<f32>> {
    let sampler = CompiledField::prepared(field)?;
    let width = field.kind().width();
    let points: Vec<[f64; 3]> = set.positions.iter().map(|p| p.map(|c| c as f64)).collect();
    use rayon::prelude::*;
    const RUN: usize = 16 * crate::space::BLOCK;
    let runs: Vec<Vec<f32>> = points
        .par_chunks(RUN)
        .map(|chunk| {
            let mut out = Vec::new();
            crate::particles::evaluate::at_points(
                sampler.evaluator().as_mut(),
                width,
                chunk,
                &mut out,
            );
            out
        })
        .collect();
    let values: Vec<f32> = runs.into_iter().flatten().collect();
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(Failure::new(format!(
            "the field is not a finite number at point {} of the particles",
            i / width
        )));
    }
    Ok(values)
}

fn addattr(_: &mut Interpreter, a: Args) -> Outcome<Value> {
    let set = particles_of(a.get("p")?)?;
    let name = a.string("name")?;
    let n = set.len();
    // Checked before anything is built, so the refusal comes before the peak.
    let width = if a.form.is_multiple_of(2) { 1 } else { 3 };
    crate::particles::check_added_attribute(set, width, a.form >= 2)?;
    let values = match a.form {
        0 => Values::Float(vec![a.float("value")? as f32; n]),
        1 => Values::Vector(vec![
            a.get("value")?
                .as_vector()?
                .to_array()
                .map(|c| c as f32);
            n
        ]),
        2 => Values::Float(
            floats_of(a.get("values")?)?
                .iter()
                .map(|&v| v as f32)
                .collect(),
        ),
        3 => Values::Vector(vectors_of(a.get("values")?)?),
        4 => Values::Float(sample_at_points(&a.get("f")?.as_field()?, set)?),
        _ => {
            let flat = sample_at_points(&a.get("f")?.as_field()?, set)?;
            Values::Vector(flat.chunks(3).map(|c| [c[0], c[1], c[2]]).collect())
        }
    };
    let mut out = set.clone();
    out.set(name, values)?;
    out.check_finite("addattr")?;
    Ok(Value::Particles(Arc::new(out)))
}

fn splat(interp: &mut Interpreter, a: Args) -> Outcome<Value> {
    let var = super::grids::cache_var(&a)?;
    let set = particles_of(a.get("p")?)?;
    let kernel = match a.opt("kernel") {
        Some(k) => Kernel::parse(k.as_str()?)?,
        None => Kernel::Trilinear,
    };
    set.check_finite("splat")?;
    let deposit = match a.opt("attr") {
        None => Deposit::One,
        Some(name) => {
            let name = name.as_str()?;
            match (a.form, set.require(name)?) {
                (0, Values::Float(v)) => Deposit::Float(v),
                (1, _) => Deposit::Vector(set.vectors(name)?),
                (_, Values::Vector(_)) => {
                    return Err(Failure::new(format!(
                        "attribute \"{name}\" is a vector; splat it into a vectorcache"
                    )));
                }
                (_, Values::Float(_)) => {
                    return Err(Failure::new(format!(
                        "attribute \"{name}\" is a float; splat it into a scalarcache"
                    )));
                }
            }
        }
    };
    let previous = var.state.borrow().clone();
    let placed = super::frustum::particles_in_cells(var, set)?;
    let (cache, report) = crate::particles::splat::splat(
        &placed,
        deposit,
        kernel,
        &var.domain,
        &var.background,
        previous.as_deref(),
    )?;
    warn_outside(interp, report.outside, set.len() as u64);
    let label = format!("splat at {}", interp.location(interp.call_span));
    let cache = cache.with_label(label).with_profile("splat");
    *var.state.borrow_mut() = Some(Arc::new(cache));
    Ok(Value::Void)
}

/// Compiled fields of an optional argument.
pub(super) fn compiled(a: &Args, key: &str) -> Outcome<Option<CompiledField>> {
    a.opt(key)
        .map(|v| CompiledField::prepared(&v.as_field()?))
        .transpose()
}

/// Warns when particles fell outside a cache's domain.
pub(super) fn warn_outside(interp: &mut Interpreter, outside: u64, of: u64) {
    if outside > 0 {
        interp.warnings.push(
            Diagnostic::warning(
                Stage::Runtime,
                interp.call_span,
                format!(
                    "{outside} of {of} particles lie outside the cache's domain and were not splatted"
                ),
            )
            .with_help("enlarge the cache's domain to hold every particle"),
        );
    }
}

fn wisp_builtin(_: &mut Interpreter, a: Args) -> Outcome<Value> {
    let guides = guide::guides(particles_of(a.get("guides")?)?)?;
    let walk = wisp::Walk::new(
        a.opt("walk")
            .map(|w| w.as_str())
            .transpose()?
            .unwrap_or("random"),
        a.opt_float("epsilon")?.unwrap_or(0.7),
        a.opt_float("q")?.unwrap_or(0.5),
    )?;
    let radial = compiled(&a, "radial")?;
    let displace = compiled(&a, "displace")?;
    let color = compiled(&a, "color")?;
    let settings = wisp::Settings {
        walk,
        radial: radial.as_ref().map(|f| f as &dyn FieldSampler),
        alpha: a.opt_float("alpha")?.unwrap_or(1.0),
        displace: displace.as_ref().map(|f| f as &dyn FieldSampler),
        color: color.as_ref().map(|f| f as &dyn FieldSampler),
    };
    let set = wisp::generate(&guides, count_of(&a, "count")?, seed_of(&a)?, &settings)?;
    Ok(Value::Particles(Arc::new(set)))
}
