//! Cloud-automaton builtins (seed 003): `cloudsim` makes a state, `cloudstep` steps it,
//! `cloudellipsoid` is the source's region-volume profile, `clouddensity` smooths a state into
//! a field and `cloudcover` reports what fraction of cells hold each bit.
//!
//! A `cloudsim` is a value: `cloudstep` returns the next state and leaves its argument as it
//! was, so `sky = cloudstep(sky, ...)` in a loop is the animation, and a frame is recomputed by
//! stepping its predecessor again. Probabilities are scalar fields sampled at the cells; a
//! state remembers the fields its probabilities came from, so stepping again with the same
//! fields (the same graph) reuses the sampled region volume instead of sampling it anew.

use crate::base::failure::{Failure, Outcome};
use crate::cloud::{
    CloudState, Planes, Probabilities, Probability, SmoothedCloud, Smoothing, Wind,
};
use crate::engine::profile;
use crate::field::shapes::ellipsoid_field;
use crate::field::{CompiledField, Field};
use crate::grid::cache::Cache;
use crate::interp::Interpreter;
use crate::interp::registry::{Args, Registry};
use crate::interp::value::Value;
use crate::space::GridSource;
use crate::space::domain::Domain;
use glam::DVec3;
use std::rc::Rc;
use std::sync::Arc;
use std::time::Instant;

/// A `cloudsim` value: a state, and the region volume its last step sampled.
#[derive(Debug)]
pub struct CloudVar {
    pub state: CloudState,
    regions: Option<Regions>,
}

/// Sampled probabilities and the fields they came from (`None`: not given).
#[derive(Clone, Debug)]
struct Regions {
    fields: [Option<Field>; 3],
    probabilities: Arc<Probabilities>,
    /// The budget the sampled probabilities hold for as long as a state uses them.
    _memory: Option<Arc<crate::engine::budget::Reservation>>,
}

/// The channels' parameter names, in the order of `Probabilities`' fields.
const STEP_CHANNELS: [&str; 3] = ["hum", "act", "ext"];
const INITIAL_CHANNELS: [&str; 3] = ["hum", "act", "cld"];

pub fn register(r: &mut Registry) {
    r.add(
        "clouds",
        &["cloudsim(domain d, int seed?, scalarfield hum?, scalarfield act?, scalarfield cld?) -> cloudsim"],
        "a cloud automaton over d's cells (y is up), each cell's hum, act and cld bits set with \
         the given probabilities (default 0); seed picks the random draws",
        |interp, a| {
            let Value::Domain(domain) = a.get("d")? else {
                return Err(Failure::new("cloudsim needs a domain"));
            };
            let resolution = cells(domain)?;
            let seed = seed(&a)?;
            let label = format!("cloudsim at {}", interp.location(interp.call_span));
            let started = Instant::now();
            let regions = sample_regions(&a, domain, resolution, INITIAL_CHANNELS, None, &label)?;
            let state = CloudState::initial((**domain).clone(), resolution, seed, &regions.probabilities);
            let stats = profile::register("cloudsim", &label);
            stats.add_instance(0);
            stats.add_evaluated();
            stats.add_work(started.elapsed().as_nanos() as u64, state_bytes(&state));
            Ok(Value::CloudSim(Rc::new(CloudVar { state, regions: None })))
        },
    );
    r.add(
        "clouds",
        &["cloudstep(cloudsim c, scalarfield hum?, scalarfield act?, scalarfield ext?, vector wind?, vector windtop?, bool wrap?, int steps?) -> cloudsim"],
        "the state after steps (default 1, at most 1000000) steps of the growth, extinction and regeneration rules \
         with probabilities p_hum, p_act, p_ext (default 0) and wind in cells per step along x and \
         z (wind at the bottom layer, windtop at the top, linear between); wrap = true carries \
         cells leaving one side in at the other, otherwise they are lost",
        cloudstep,
    );
    r.add(
        "clouds",
        &["cloudellipsoid(vector center, vector radii) -> scalarfield"],
        "the region-volume profile of an axis-aligned ellipsoid: 1 at center, falling linearly to \
         0 on the surface, 0 outside (combine several with max)",
        |_, a| {
            let (center, radii) = (a.get("center")?.as_vector()?, a.get("radii")?.as_vector()?);
            if !(radii.is_finite() && radii.min_element() > 0.0) {
                return Err(Failure::new(format!(
                    "cloudellipsoid radii must be positive, found ({}, {}, {})",
                    radii.x, radii.y, radii.z
                )));
            }
            if !center.is_finite() {
                return Err(Failure::new("cloudellipsoid center must be finite"));
            }
            Ok(Value::Field(ellipsoid_field(center, radii)?))
        },
    );
    r.add(
        "clouds",
        &["clouddensity(cloudsim c, int radius?, int window?) -> scalarfield"],
        "c's cld bits smoothed into a density in [0, 1]: a weighted average over radius cells \
         either side (default 1, at most 3) and the window earlier steps (default 1, at most 3); \
         computed brick by brick when first read",
        |interp, a| {
            let var = cloud(&a)?;
            let radius = bounded(&a, "radius", 1, crate::cloud::smooth_limits().0)?;
            let window = bounded(&a, "window", 1, crate::cloud::smooth_limits().1)?;
            let state = &var.state;
            let sampler = SmoothedCloud::new(
                state.domain.clone(),
                state.planes,
                state.cloud_frames(window + 1),
                Smoothing { radius, window },
            );
            let label = format!("clouddensity at {}", interp.location(interp.call_span));
            let cache = Cache::from_source(
                state.domain.clone(),
                1,
                Arc::new(sampler),
                vec![0.0],
                "clouddensity",
                label,
            )?;
            let grid: Arc<dyn GridSource> = Arc::new(cache);
            Ok(Value::Field(Field::from_linear_grid(grid)?))
        },
    );
    r.add(
        "clouds",
        &["cloudcover(cloudsim c) -> vector"],
        "the fractions of c's cells whose hum, act and cld bits are set",
        |_, a| {
            let state = &cloud(&a)?.state;
            let total = state.planes.cells().max(1) as f64;
            let [h, c, d] = state.counts().map(|n| n as f64 / total);
            Ok(Value::Vector(DVec3::new(h, c, d)))
        },
    );
}

/// The most steps one `cloudstep` call takes. The source's sequences run a few hundred steps;
/// a million is over eleven hours of footage at a step a frame and 24 frames a second, so a
/// larger count is a typo or an overflowed computation, refused at once rather than left
/// running for as long as 9.2e18 steps would take.
const MAX_STEPS: i64 = 1_000_000;

fn cloudstep(interp: &mut Interpreter, a: Args) -> Outcome<Value> {
    let var = cloud(&a)?;
    let steps = a.opt_int_in("steps", 0..=MAX_STEPS)?.unwrap_or(1);
    let horizontal = |name: &str| -> Outcome<Option<[f64; 2]>> {
        let Some(v) = a.opt(name) else {
            return Ok(None);
        };
        let v = v.as_vector()?;
        if !v.is_finite() {
            return Err(Failure::new(format!("{name} must be finite")));
        }
        if v.y != 0.0 {
            return Err(Failure::new(format!(
                "{name} moves cells along x and z only; its y component must be 0, found {}",
                v.y
            ))
            .with_help("the automaton's wind is horizontal, one speed per height layer"));
        }
        Ok(Some([v.x, v.z]))
    };
    let bottom = horizontal("wind")?.unwrap_or([0.0, 0.0]);
    let top = horizontal("windtop")?.unwrap_or(bottom);
    let wrap = match a.opt("wrap") {
        Some(v) => v.as_bool()?,
        None => false,
    };
    let wind = Wind { bottom, top, wrap };
    let location = interp.location(interp.call_span);
    let state = &var.state;
    let resolution = [state.planes.nx, state.planes.ny, state.planes.nz];
    let region_label = format!("cloudstep regions at {location}");
    let regions = sample_regions(
        &a,
        &state.domain,
        resolution,
        STEP_CHANNELS,
        var.regions.as_ref(),
        &region_label,
    )?;
    let stats = profile::register("cloudstep", &format!("cloudstep at {location}"));
    let mut next = None;
    for _ in 0..steps {
        if crate::engine::interrupt::requested() {
            return Err(Failure::new("interrupted"));
        }
        let started = Instant::now();
        let from = next.as_ref().unwrap_or(state);
        let stepped = from.step(&regions.probabilities, &wind);
        stats.add_instance(0);
        stats.add_evaluated();
        stats.add_work(started.elapsed().as_nanos() as u64, 0);
        next = Some(stepped);
    }
    let state = next.unwrap_or_else(|| state.clone());
    Ok(Value::CloudSim(Rc::new(CloudVar {
        state,
        regions: Some(regions),
    })))
}

/// The three probabilities named `names`, from the fields given (0 where not given). Fields
/// that are the same graphs as `previous`'s are not sampled again.
fn sample_regions(
    a: &Args,
    domain: &Domain,
    resolution: [usize; 3],
    names: [&str; 3],
    previous: Option<&Regions>,
    label: &str,
) -> Outcome<Regions> {
    let mut fields: [Option<Field>; 3] = [None, None, None];
    for (slot, name) in fields.iter_mut().zip(names) {
        if let Some(v) = a.opt(name) {
            *slot = Some(v.as_field()?);
        }
    }
    if let Some(previous) = previous {
        let same = fields.iter().zip(&previous.fields).all(|pair| match pair {
            (None, None) => true,
            (Some(now), Some(before)) => now.same_as(before),
            _ => false,
        });
        if same {
            return Ok(previous.clone());
        }
    }
    let started = Instant::now();
    let planes = Planes::new(resolution);
    // Constant probabilities are uniform; the rest are sampled together in one pass, so what
    // the three share (a region field) is evaluated once per cell.
    let mut uniform: [Option<Probability>; 3] = [None, None, None];
    let mut components = Vec::with_capacity(3);
    for ((field, name), slot) in fields.iter().zip(names).zip(&mut uniform) {
        match field {
            None => *slot = Some(Probability::Uniform(0)),
            Some(field) => {
                if let Some(crate::field::FieldValue::Scalar(p)) = field.as_constant() {
                    if !p.is_finite() {
                        return Err(Failure::new(format!(
                            "probability {name} must be finite, found {p}"
                        )));
                    }
                    *slot = Some(Probability::uniform(p));
                }
            }
        }
        components.push(match (field, &slot) {
            (Some(field), None) => field.clone(),
            _ => Field::constant_scalar(0.0),
        });
    }
    let (probabilities, memory) = if uniform.iter().all(Option::is_some) {
        let [hum, act, ext] = uniform.map(|p| p.expect("all uniform"));
        (Probabilities { hum, act, ext }, None)
    } else {
        // Sampling fills three 16-bit thresholds and three bits a cell; what is kept (the
        // channels that are not uniform) is held for as long as a state uses it.
        let cells = (planes.nx * planes.ny * planes.nz) as f64;
        let sampling = crate::engine::budget::reserve(
            3.0 * (2.0 * cells + 8.0 * planes.len() as f64),
            "the automaton's region probabilities",
        )?;
        let joint = Field::vector_from(&components[0], &components[1], &components[2])?;
        let compiled = CompiledField::prepared(&joint)?;
        let sampled = Probabilities::sample(&compiled, domain, &planes);
        let [hum, act, ext] = [
            (uniform[0].take(), sampled.hum),
            (uniform[1].take(), sampled.act),
            (uniform[2].take(), sampled.ext),
        ]
        .map(|(uniform, sampled)| uniform.unwrap_or(sampled));
        let bytes = (hum.bytes() + act.bytes() + ext.bytes()) as u64;
        let stats = profile::register("cloudregion", label);
        stats.add_instance(0);
        stats.add_evaluated();
        stats.add_work(started.elapsed().as_nanos() as u64, bytes);
        drop(sampling);
        let kept =
            crate::engine::budget::reserve(bytes as f64, "the automaton's region probabilities")?;
        (Probabilities { hum, act, ext }, Some(Arc::new(kept)))
    };
    Ok(Regions {
        fields,
        probabilities: Arc::new(probabilities),
        _memory: memory,
    })
}

fn cloud(a: &Args) -> Outcome<&Rc<CloudVar>> {
    match a.get("c")? {
        Value::CloudSim(c) => Ok(c),
        other => Err(Failure::new(format!(
            "expected a cloudsim, found {}",
            other.type_of()
        ))),
    }
}

fn cells(domain: &Domain) -> Outcome<[usize; 3]> {
    domain.resolution.ok_or_else(|| {
        Failure::new("a cloud automaton needs a domain with cells")
            .with_help("give the domain a cell size: domain(origin, lengths, orientation, cell)")
    })
}

fn seed(a: &Args) -> Outcome<u64> {
    Ok(a.opt_int("seed")?.unwrap_or(0) as u64)
}

fn bounded(a: &Args, name: &str, default: usize, max: usize) -> Outcome<usize> {
    Ok(a.opt_int_in(name, 0..=max as i64)?
        .map_or(default, |n| n as usize))
}

fn state_bytes(state: &CloudState) -> u64 {
    (state.planes.len() * 8 * 3) as u64
}
