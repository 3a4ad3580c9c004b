//! Modeling builtins (docs/language.md "Noise and level sets"): noise fields and level sets.
//!
//! Every noise here is built from the three kernels of `field::noise` (Perlin, simplex,
//! Worley), which carry exact gradients and Hessians, so `grad` of any of these fields — fractal
//! sums with field-valued parameters and curl noise included — is exact. Level sets are
//! positive inside, negative outside and, where a closed form exists, exact signed distances.
//! Amplitude ranges (for displacement bounds): `perlin` and `simplex` lie in [-1, 1], `worley`
//! and `perlinworley` in [0, 1], `fbm` within ± the sum of its octave amplitudes
//! `Σ rough^i` times its noise's range.

use crate::base::failure::{Failure, Outcome};
use crate::field::noise::NoiseKind;
use crate::field::{self, Field, MathFn};
use crate::interp::Interpreter;
use crate::interp::registry::{Args, Registry};
use crate::interp::value::Value;
use glam::DVec3;

/// Offsets between the octaves of `fbm` and the components of `vnoise`/`curlnoise`: far apart
/// in lattice cells and irrational-looking, so the samples are uncorrelated.
const OCTAVE_SHIFT: DVec3 = DVec3::new(17.31, -41.47, 29.83);
const SECOND: DVec3 = DVec3::new(31.416, -47.853, 12.793);
const THIRD: DVec3 = DVec3::new(-53.21, 19.37, -71.09);

pub fn register(r: &mut Registry) {
    r.add(
        "noise",
        &["perlin(float frequency?, int seed?) -> scalarfield"],
        "improved Perlin gradient noise at x * frequency, in [-1, 1]",
        |interp, a| base_noise(interp, &a, NoiseKind::Perlin).map(Value::Field),
    );
    r.add(
        "noise",
        &["simplex(float frequency?, int seed?) -> scalarfield"],
        "simplex noise at x * frequency, in [-1, 1]",
        |interp, a| base_noise(interp, &a, NoiseKind::Simplex).map(Value::Field),
    );
    r.add(
        "noise",
        &["worley(float frequency?, int seed?, bool inverted?) -> scalarfield"],
        "Worley (cellular) noise F1: distance to the nearest feature point, in [0, 1]; inverted gives 1 - F1",
        |interp, a| {
            let f = base_noise(interp, &a, NoiseKind::Worley)?;
            let inverted = matches!(a.opt("inverted"), Some(Value::Bool(true)));
            Ok(Value::Field(if inverted { Field::constant_scalar(1.0).sub(&f)? } else { f }))
        },
    );
    r.add(
        "noise",
        &["perlinworley(float frequency?, int seed?) -> scalarfield"],
        "Perlin noise dilated by inverted Worley noise (billowy but connected), in [0, 1]",
        |interp, a| {
            let p = base_noise(interp, &a, NoiseKind::Perlin)?;
            let w = base_noise(interp, &a, NoiseKind::Worley)?;
            let one = Field::constant_scalar(1.0);
            // Perlin mapped to [0, 1], remapped from [w - 1, 1] to [0, 1] with w = 1 - F1.
            let p01 = p.add(&one)?.mul(&Field::constant_scalar(0.5))?;
            let inverted = one.sub(&w)?;
            let shifted = p01.add(&one)?.sub(&inverted)?;
            let span = Field::constant_scalar(2.0).sub(&inverted)?;
            Ok(Value::Field(shifted.div(&span)?))
        },
    );
    r.add(
        "noise",
        &["curlnoise(float frequency?, int seed?) -> vectorfield"],
        "divergence-free noise: the curl of a vector of three offset Perlin noises",
        |interp, a| {
            let n = base_noise(interp, &a, NoiseKind::Perlin)?;
            let potential = vnoise_of(&n, SECOND, THIRD)?;
            Ok(Value::Field(field::curl(&potential)?))
        },
    );
    r.add(
        "noise",
        &["vnoise(scalarfield noise, vector offset1, vector offset2) -> vectorfield"],
        "the vector (noise(x), noise(x + offset1), noise(x + offset2))",
        |_, a| {
            let n = a.get("noise")?.as_field()?;
            Ok(Value::Field(vnoise_of(
                &n,
                a.get("offset1")?.as_vector()?,
                a.get("offset2")?.as_vector()?,
            )?))
        },
    );
    r.add(
        "noise",
        &["fbm(scalarfield noise, int octaves, scalarfield freq, scalarfield fjump, scalarfield rough) -> scalarfield"],
        "fractal sum: octave i is rough^i * noise(x * freq * fjump^i); parameters may vary in space",
        |_, a| {
            let octaves = a.int("octaves")?;
            if !(1..=32).contains(&octaves) {
                return Err(Failure::new(format!("fbm takes 1 to 32 octaves, found {octaves}")));
            }
            let noise = a.get("noise")?.as_field()?;
            let (freq, fjump, rough) = (a.get("freq")?.as_field()?, a.get("fjump")?.as_field()?, a.get("rough")?.as_field()?);
            Ok(Value::Field(fbm(&noise, octaves as usize, &freq, &fjump, &rough)?))
        },
    );
    r.add(
        "noise",
        &[
            "gaussiannoise(domain d, float correlation, int seed?) -> scalarfield",
            "gaussiannoise(domain d, float correlation, int seed, bool divfree) -> vectorfield",
        ],
        "an FFT-synthesised Gaussian random field over d's cells (periodic; zero mean, unit \
         variance, covariance exp(-r^2 / (2 correlation^2)), correlation above 0 and at most \
         1e150); the four-argument form is a vectorfield, divergence-free when divfree is true",
        |interp, a| {
            let Value::Domain(d) = a.get("d")? else {
                return Err(Failure::new("gaussiannoise needs a domain"));
            };
            let seed = match a.opt_int_in("seed", 0..=u32::MAX as i64)? {
                Some(s) => s as u32,
                None => interp.noise_seed,
            };
            let vector = a.form == 1;
            let divfree = matches!(a.opt("divfree"), Some(Value::Bool(true)));
            let correlation = a.float("correlation")?;
            let field = |seed: u32, divfree: bool| {
                crate::fluids::fft::gaussian_random_field(d, correlation, seed, divfree)
            };
            let data: Vec<Vec<f32>> = match (vector, divfree) {
                (false, _) => vec![field(seed, false)?],
                (true, true) => {
                    let all = field(seed, true)?;
                    let n = all.len() / 3;
                    all.chunks(n.max(1)).map(<[f32]>::to_vec).collect()
                }
                // Three independent components, from consecutive seeds.
                (true, false) => (0..3)
                    .map(|c| field(seed.wrapping_add(c), false))
                    .collect::<Outcome<_>>()?,
            };
            let width = data.len();
            let cache = crate::grid::cache::Cache::from_dense(
                (**d).clone(),
                width,
                data,
                vec![0.0; width],
            )?
            .with_label(format!(
                "gaussiannoise at {}",
                interp.location(interp.call_span)
            ))
            .with_profile("gaussiannoise");
            let grid: std::sync::Arc<dyn crate::space::GridSource> = std::sync::Arc::new(cache);
            Ok(Value::Field(Field::from_grid(
                grid,
                crate::space::Interp::Linear,
                crate::space::GridDerivative::Interpolant,
            )?))
        },
    );
    levelsets(r);
}

/// A noise kernel at `x * frequency`, with the script's seed unless one is given.
fn base_noise(interp: &Interpreter, a: &Args, kind: NoiseKind) -> Outcome<Field> {
    let frequency = a.opt_positive_float("frequency")?.unwrap_or(1.0);
    let seed = match a.opt_int_in("seed", 0..=u32::MAX as i64)? {
        Some(s) => s as u32,
        None => interp.noise_seed,
    };
    let n = Field::noise(kind, seed);
    if frequency == 1.0 {
        return Ok(n);
    }
    n.compose(&Field::identity().mul(&Field::constant_scalar(frequency))?)
}

fn vnoise_of(n: &Field, off1: DVec3, off2: DVec3) -> Outcome<Field> {
    let shifted = |o: DVec3| n.compose(&Field::identity().add(&Field::constant_vector(o))?);
    Field::vector_from(n, &shifted(off1)?, &shifted(off2)?)
}

pub fn fbm(
    noise: &Field,
    octaves: usize,
    freq: &Field,
    fjump: &Field,
    rough: &Field,
) -> Outcome<Field> {
    let mut total = Field::constant_scalar(0.0);
    let mut frequency = freq.clone();
    let mut amplitude = Field::constant_scalar(1.0);
    for i in 0..octaves {
        let at = Field::identity()
            .mul(&frequency)?
            .add(&Field::constant_vector(OCTAVE_SHIFT * i as f64))?;
        total = total.add(&amplitude.mul(&noise.compose(&at)?)?)?;
        frequency = frequency.mul(fjump)?;
        amplitude = amplitude.mul(rough)?;
    }
    Ok(total)
}

fn levelsets(r: &mut Registry) {
    r.add(
        "levelsets",
        &["sphere(vector center, float radius) -> scalarfield"],
        "signed distance to a sphere, positive inside",
        |_, a| {
            let (c, radius) = (a.get("center")?.as_vector()?, a.positive_float("radius")?);
            Ok(Value::Field(sphere(c, radius)?))
        },
    );
    r.add(
        "levelsets",
        &["box(vector center, vector halfsize) -> scalarfield"],
        "signed distance to an axis-aligned box, positive inside",
        |_, a| {
            let (c, h) = (
                a.get("center")?.as_vector()?,
                a.get("halfsize")?.as_vector()?,
            );
            if !(h.is_finite() && h.min_element() > 0.0) {
                return Err(Failure::new(format!(
                    "box half sizes must be positive, found {h}"
                )));
            }
            // Outside: length of the positive part of q; inside: the largest (negative) q.
            let q = local(c)?
                .math_each(MathFn::Abs)?
                .sub(&Field::constant_vector(h))?;
            let zero = Field::constant_scalar(0.0);
            let qc = |i| q.component(i);
            let outside = Field::vector_from(
                &Field::max(&qc(0)?, &zero)?,
                &Field::max(&qc(1)?, &zero)?,
                &Field::max(&qc(2)?, &zero)?,
            )?
            .length()?;
            let inside = Field::min(&Field::max(&Field::max(&qc(0)?, &qc(1)?)?, &qc(2)?)?, &zero)?;
            Ok(Value::Field(outside.add(&inside)?.neg()))
        },
    );
    r.add(
        "levelsets",
        &["torus(vector center, float major, float minor) -> scalarfield"],
        "signed distance to a torus around the y axis through center, positive inside",
        |_, a| {
            let (c, big, small) = (
                a.get("center")?.as_vector()?,
                a.positive_float("major")?,
                a.positive_float("minor")?,
            );
            let p = local(c)?;
            let (x, y, z) = (p.component(0)?, p.component(1)?, p.component(2)?);
            let ring = x
                .mul(&x)?
                .add(&z.mul(&z)?)?
                .math(MathFn::Sqrt)?
                .sub(&Field::constant_scalar(big))?;
            let d = ring.mul(&ring)?.add(&y.mul(&y)?)?.math(MathFn::Sqrt)?;
            Ok(Value::Field(Field::constant_scalar(small).sub(&d)?))
        },
    );
    r.add(
        "levelsets",
        &["cylinder(vector center, vector axis, float radius, float height) -> scalarfield"],
        "a capped cylinder around axis through center, positive inside (exact away from the rims)",
        |_, a| {
            let (c, axis, radius, height) = (
                a.get("center")?.as_vector()?,
                a.get("axis")?.as_vector()?,
                a.positive_float("radius")?,
                a.positive_float("height")?,
            );
            let (along, radial) = axial(c, axis)?;
            let side = Field::constant_scalar(radius).sub(&radial)?;
            let caps = Field::constant_scalar(height / 2.0).sub(&along.math(MathFn::Abs)?)?;
            Ok(Value::Field(Field::min(&side, &caps)?))
        },
    );
    r.add(
        "levelsets",
        &["cone(vector apex, vector axis, float angle, float height) -> scalarfield"],
        "a cone opening from apex along axis with half-angle angle (radians), cut at height; positive inside (exact away from the rims)",
        |_, a| {
            let (apex, axis, angle, height) = (a.get("apex")?.as_vector()?, a.get("axis")?.as_vector()?, a.float("angle")?, a.positive_float("height")?);
            if !(angle > 0.0 && angle < std::f64::consts::FRAC_PI_2) {
                return Err(Failure::new(format!("cone half-angle must be between 0 and pi/2 radians, found {angle}")));
            }
            let (along, radial) = axial(apex, axis)?;
            // Distance to the infinite cone's surface, measured across it.
            let side = along.mul(&Field::constant_scalar(angle.sin()))?.sub(&radial.mul(&Field::constant_scalar(angle.cos()))?)?;
            let cap = Field::constant_scalar(height).sub(&along)?;
            Ok(Value::Field(Field::min(&side, &cap)?))
        },
    );
    r.add(
        "levelsets",
        &["plane(vector point, vector normal) -> scalarfield"],
        "signed distance to a plane, positive on the side away from the normal",
        |_, a| {
            let (p, n) = (a.get("point")?.as_vector()?, a.get("normal")?.as_vector()?);
            if !(n.is_finite() && n.length() > 0.0) {
                return Err(Failure::new("a plane needs a non-zero normal"));
            }
            let n = n.normalize();
            Ok(Value::Field(Field::constant_scalar(p.dot(n)).sub(
                &Field::identity().mul(&Field::constant_vector(n))?,
            )?))
        },
    );
    r.add(
        "levelsets",
        &["union(scalarfield a, scalarfield b) -> scalarfield"],
        "inside either: max(a, b)",
        |_, a| {
            Ok(Value::Field(Field::max(
                &a.get("a")?.as_field()?,
                &a.get("b")?.as_field()?,
            )?))
        },
    );
    r.add(
        "levelsets",
        &["intersection(scalarfield a, scalarfield b) -> scalarfield"],
        "inside both: min(a, b)",
        |_, a| {
            Ok(Value::Field(Field::min(
                &a.get("a")?.as_field()?,
                &a.get("b")?.as_field()?,
            )?))
        },
    );
    r.add(
        "levelsets",
        &["difference(scalarfield a, scalarfield b) -> scalarfield"],
        "inside a but not b: min(a, -b)",
        |_, a| {
            Ok(Value::Field(Field::min(
                &a.get("a")?.as_field()?,
                &a.get("b")?.as_field()?.neg(),
            )?))
        },
    );
    r.add(
        "levelsets",
        &["softunion(scalarfield a, scalarfield b, float r) -> scalarfield"],
        "union blended over a band of width r: max(a, b) + e^2/(4r), e = max(r - |a - b|, 0)",
        |_, a| {
            let radius = a.positive_float("r")?;
            let (x, y) = (a.get("a")?.as_field()?, a.get("b")?.as_field()?);
            let e = Field::max(
                &Field::constant_scalar(radius).sub(&x.sub(&y)?.math(MathFn::Abs)?)?,
                &Field::constant_scalar(0.0),
            )?;
            let bump = e.mul(&e)?.mul(&Field::constant_scalar(0.25 / radius))?;
            Ok(Value::Field(Field::max(&x, &y)?.add(&bump)?))
        },
    );
    r.add(
        "levelsets",
        &["levelsetsurface(scalarfield ls, int iterations) -> vectorfield"],
        "the map moving each point onto the zero set: x <- x - ls grad(ls) / |grad(ls)|^2, repeated",
        |_, a| {
            let iterations = a.int("iterations")?;
            if !(0..=64).contains(&iterations) {
                return Err(Failure::new(format!("levelsetsurface takes 0 to 64 iterations, found {iterations}")));
            }
            Ok(Value::Field(levelset_surface(&a.get("ls")?.as_field()?, iterations as usize)?))
        },
    );
}

/// The closest-point map of a level set by Newton steps; where the gradient vanishes (a
/// sphere's centre) the step is zero rather than infinite.
pub fn levelset_surface(ls: &Field, iterations: usize) -> Outcome<Field> {
    let g = field::grad(ls)?;
    let g2 = g.mul(&g)?;
    let step = Field::identity().sub(&g.mul(&ls.guarded_div(&g2)?)?)?;
    let mut map = Field::identity();
    for _ in 0..iterations {
        map = step.compose(&map)?;
    }
    Ok(map)
}

fn sphere(c: DVec3, radius: f64) -> Outcome<Field> {
    Field::constant_scalar(radius).sub(&local(c)?.length()?)
}

/// The position relative to `c`.
fn local(c: DVec3) -> Outcome<Field> {
    Field::identity().sub(&Field::constant_vector(c))
}

/// (distance along the axis from `c`, distance from the axis).
fn axial(c: DVec3, axis: DVec3) -> Outcome<(Field, Field)> {
    if !(axis.is_finite() && axis.length() > 0.0) {
        return Err(Failure::new("the axis must be a non-zero vector"));
    }
    let n = axis.normalize();
    let p = local(c)?;
    let along = p.mul(&Field::constant_vector(n))?;
    let radial = p.sub(&Field::constant_vector(n).mul(&along)?)?.length()?;
    Ok((along, radial))
}
