//! The 21 3D fractal-flame variations of the thesis's Appendix A (seed 004), as vectorfields.
//!
//! The key decision: each variation is built as an ordinary field graph from the position's
//! components, so `flame("swirl")` composes, differentiates, bounds and compiles like any
//! other field, and the chaos game evaluates it in blocks with the same compiled programs.
//! The conventions, chosen so that every variation restricted to z = 0 is flam3's 2D
//! variation (flam3 being the reference implementation of 2D flames):
//! - θ = atan2(x, y), x first, as flam3 computes it (the thesis prints tan(y/x)); θ₂ =
//!   atan2(x, z), the same with z in y's place. sin θ = x/r₁ and cos θ = y/r₁ in the plane.
//! - Singular denominators get flam3's EPS = 1e-10 where flam3 adds it (spherical r²,
//!   horseshoe, spiral and hyperbolic r), so z = 0 values match flam3's code; power takes
//!   max(r, EPS) so 0 to a negative power never happens.
//! - exponential and cosine clamp their exp arguments at 80 (e⁸⁰ ≈ 5.5e34): values stay
//!   finite in the `f32` that caches and renders use.
//! - Julia's random branch (flam3 adds π to θ/2 on a random bit) is a seeded hash of the
//!   position: `fract(sin(p·k + seed)·43758.5453) < ½` flips the result, so a field stays a
//!   function while a chaos-game orbit sees a branch that looks random.
//! - wave (V15) and popcorn (V17) take their own coefficients, named as the thesis prints them
//!   (wave b, c, e, f, h, i; popcorn c, f, g), instead of reading the pre-transform's: pass
//!   flam3's xform coefficients b, c, e, f (wave) or c, f (popcorn) for the same 2D flame.
//!   Popcorn's y term reads x (flam3) where the thesis prints z; its z term reads x.

use crate::base::failure::{Failure, Outcome};
use crate::field::Field;
use crate::field::node::MathFn;
use glam::{DMat3, DVec3};
use std::f64::consts::PI;

/// flam3's guard against division by zero.
pub const EPS: f64 = 1e-10;
/// Largest argument given to `exp` (keeps values finite in f32).
pub const EXP_LIMIT: f64 = 80.0;

/// The variations, in Appendix A order (V0 … V20).
pub const NAMES: [&str; 21] = [
    "linear",
    "sinusoidal",
    "spherical",
    "swirl",
    "horseshoe",
    "polar",
    "handkerchief",
    "heart",
    "disc",
    "spiral",
    "hyperbolic",
    "diamond",
    "ex",
    "julia",
    "bent",
    "wave",
    "fisheye",
    "popcorn",
    "exponential",
    "power",
    "cosine",
];

/// Default coefficients of the variations that have them.
pub fn default_params(name: &str) -> &'static [f64] {
    match name {
        // b, c, e, f, h, i
        "wave" => &[0.5, 1.0, 0.5, 1.0, 0.5, 1.0],
        // c, f, g
        "popcorn" => &[0.1, 0.1, 0.1],
        // seed of the branch hash
        "julia" => &[0.0],
        _ => &[],
    }
}

/// An affine map `m p + t` from the thesis's 12 coefficients, row by row:
/// `(a b c d | e f g h | k l m n)` gives `x' = a x + b y + c z + d`, and so on.
pub fn affine_from_coefficients(c: &[f64]) -> Outcome<(DMat3, DVec3)> {
    if c.len() != 12 {
        return Err(Failure::new(format!(
            "an affine transform takes 12 coefficients (a b c d e f g h k l m n), found {}",
            c.len()
        )));
    }
    if c.iter().any(|v| !v.is_finite()) {
        return Err(Failure::new("affine coefficients must be finite"));
    }
    // The coefficients are given row by row.
    let m = DMat3::from_cols(
        DVec3::new(c[0], c[1], c[2]),
        DVec3::new(c[4], c[5], c[6]),
        DVec3::new(c[8], c[9], c[10]),
    )
    .transpose();
    Ok((m, DVec3::new(c[3], c[7], c[11])))
}

/// Short names for building graphs.
struct B;

impl B {
    fn k(v: f64) -> Field {
        Field::constant_scalar(v)
    }
    fn f(g: &Field, m: MathFn) -> Outcome<Field> {
        g.math(m)
    }
}

fn sin(a: &Field) -> Outcome<Field> {
    B::f(a, MathFn::Sin)
}
fn cos(a: &Field) -> Outcome<Field> {
    B::f(a, MathFn::Cos)
}
fn sqrt(a: &Field) -> Outcome<Field> {
    B::f(a, MathFn::Sqrt)
}
fn cube(a: &Field) -> Outcome<Field> {
    a.mul(a)?.mul(a)
}
fn vec3(x: &Field, y: &Field, z: &Field) -> Outcome<Field> {
    Field::vector_from(x, y, z)
}
/// exp with its argument clamped at `EXP_LIMIT`.
fn exp_clamped(a: &Field) -> Outcome<Field> {
    Field::min(a, &B::k(EXP_LIMIT))?.math(MathFn::Exp)
}

/// The position's pieces every variation uses.
struct Polar {
    x: Field,
    y: Field,
    z: Field,
    r2: Field,
    r: Field,
    theta: Field,
    theta2: Field,
}

fn polar() -> Outcome<Polar> {
    let p = Field::identity();
    let (x, y, z) = (p.component(0)?, p.component(1)?, p.component(2)?);
    let r2 = x.mul(&x)?.add(&y.mul(&y)?)?.add(&z.mul(&z)?)?;
    let r = sqrt(&r2)?;
    let theta = Field::atan2(&x, &y)?;
    let theta2 = Field::atan2(&x, &z)?;
    Ok(Polar {
        x,
        y,
        z,
        r2,
        r,
        theta,
        theta2,
    })
}

/// The variation `name` as a vectorfield of the position, with its coefficients.
pub fn variation(name: &str, params: &[f64]) -> Outcome<Field> {
    if !NAMES.contains(&name) {
        let hint = crate::base::suggest::closest(name, NAMES.iter().copied())
            .map(|s| format!("did you mean \"{s}\"? "))
            .unwrap_or_default();
        return Err(
            Failure::new(format!("there is no flame variation \"{name}\""))
                .with_help(format!("{hint}the variations are {}", NAMES.join(", "))),
        );
    }
    let wanted = default_params(name).len();
    if params.len() != wanted {
        return Err(Failure::new(format!(
            "flame \"{name}\" takes {wanted} coefficient{}, found {}",
            if wanted == 1 { "" } else { "s" },
            params.len()
        )));
    }
    if params.iter().any(|v| !v.is_finite()) {
        return Err(Failure::new("flame coefficients must be finite"));
    }
    let Polar {
        x,
        y,
        z,
        r2,
        r,
        theta,
        theta2,
    } = polar()?;
    let k = B::k;
    let one_over_pi = k(1.0 / PI);
    Ok(match name {
        "linear" => Field::identity(),
        "sinusoidal" => vec3(&sin(&x)?, &sin(&y)?, &sin(&z)?)?,
        "spherical" => Field::identity().div(&r2.add(&k(EPS))?)?,
        "swirl" => {
            let (s, c) = (sin(&r2)?, cos(&r2)?);
            vec3(
                &x.mul(&s)?.sub(&y.mul(&c)?)?,
                &x.mul(&c)?.add(&y.mul(&s)?)?,
                &x.mul(&c)?.sub(&z.mul(&s)?)?,
            )?
        }
        "horseshoe" => {
            let inv = k(1.0).div(&r.add(&k(EPS))?)?;
            vec3(
                &x.sub(&y)?.mul(&x.add(&y)?)?.mul(&inv)?,
                &k(2.0).mul(&x)?.mul(&y)?.mul(&inv)?,
                &x.sub(&z)?.mul(&x.add(&z)?)?.mul(&inv)?,
            )?
        }
        "polar" => vec3(
            &theta.mul(&one_over_pi)?,
            &r.sub(&k(1.0))?,
            &theta2.mul(&one_over_pi)?,
        )?,
        "handkerchief" => vec3(
            &r.mul(&sin(&theta.add(&r)?)?)?,
            &r.mul(&cos(&theta.sub(&r)?)?)?,
            &r.mul(&sin(&theta2.add(&r)?)?)?,
        )?,
        "heart" => {
            let r1 = sqrt(&x.mul(&x)?.add(&y.mul(&y)?)?)?;
            let rz = sqrt(&x.mul(&x)?.add(&z.mul(&z)?)?)?;
            let a = theta.mul(&r1)?;
            vec3(
                &r.mul(&sin(&a)?)?,
                &r.mul(&cos(&a)?)?.neg(),
                &r.mul(&cos(&theta2.mul(&rz)?)?)?.neg(),
            )?
        }
        "disc" => {
            let pr = k(PI).mul(&r)?;
            let a = theta.mul(&one_over_pi)?;
            let a2 = theta2.mul(&one_over_pi)?;
            vec3(
                &a.mul(&sin(&pr)?)?,
                &a.mul(&cos(&pr)?)?,
                &a2.mul(&cos(&pr)?)?,
            )?
        }
        "spiral" => {
            let re = r.add(&k(EPS))?;
            let inv = k(1.0).div(&re)?;
            vec3(
                &cos(&theta)?.add(&sin(&re)?)?.mul(&inv)?,
                &sin(&theta)?.sub(&cos(&re)?)?.mul(&inv)?,
                &cos(&theta2)?.add(&sin(&re)?)?.mul(&inv)?,
            )?
        }
        "hyperbolic" => {
            let re = r.add(&k(EPS))?;
            vec3(
                &sin(&theta)?.div(&re)?,
                &cos(&theta)?.mul(&re)?,
                &sin(&theta2)?.div(&re)?,
            )?
        }
        "diamond" => vec3(
            &sin(&theta)?.mul(&cos(&r)?)?,
            &cos(&theta)?.mul(&sin(&r)?)?,
            &sin(&theta2)?.mul(&cos(&r)?)?,
        )?,
        "ex" => {
            let p0 = cube(&sin(&theta.add(&r)?)?)?;
            let p1 = cube(&cos(&theta.sub(&r)?)?)?;
            let p2 = cube(&sin(&theta2.add(&r)?)?)?;
            let p3 = cube(&cos(&theta2.sub(&r)?)?)?;
            vec3(
                &r.mul(&p0.add(&p1)?)?,
                &r.mul(&p0.sub(&p1)?)?,
                &r.mul(&p2.sub(&p3)?)?,
            )?
        }
        "julia" => {
            let half = k(0.5);
            let sr = sqrt(&r)?;
            let principal = vec3(
                &sr.mul(&cos(&theta.mul(&half)?)?)?,
                &sr.mul(&sin(&theta.mul(&half)?)?)?,
                &sr.mul(&sin(&theta2.mul(&half)?)?)?,
            )?;
            // Adding π to every half angle negates the result.
            let phase = x
                .mul(&k(12.9898))?
                .add(&y.mul(&k(78.233))?)?
                .add(&z.mul(&k(37.719))?)?
                .add(&k(params[0]))?;
            let hash = sin(&phase)?.mul(&k(43758.5453))?.math(MathFn::Fract)?;
            Field::select(&hash.sub(&half)?, &principal, &principal.neg())?
        }
        "bent" => {
            let sx = Field::select(&x, &k(1.0), &k(2.0))?;
            let sy = Field::select(&y, &k(1.0), &k(0.5))?;
            vec3(&x.mul(&sx)?, &y.mul(&sy)?, &z.mul(&sx)?.mul(&sy)?)?
        }
        "wave" => {
            let [b, c, e, f, h, i] = [0, 1, 2, 3, 4, 5].map(|n| k(params[n]));
            let over = |v: &Field, d: &Field| -> Outcome<Field> { v.div(&d.mul(d)?.add(&k(EPS))?) };
            vec3(
                &x.add(&b.mul(&sin(&over(&y, &c)?)?)?)?,
                &y.add(&e.mul(&sin(&over(&x, &f)?)?)?)?,
                &z.add(&h.mul(&sin(&over(&z, &i)?)?)?)?,
            )?
        }
        "fisheye" => {
            let s = k(2.0).div(&r.add(&k(1.0))?)?;
            vec3(&s.mul(&y)?, &s.mul(&x)?, &s.mul(&z)?)?
        }
        "popcorn" => {
            let [c, f, g] = [0, 1, 2].map(|n| k(params[n]));
            let st = |v: &Field| -> Outcome<Field> { sin(&k(3.0).mul(v)?.math(MathFn::Tan)?) };
            vec3(
                &x.add(&c.mul(&st(&y)?)?)?,
                &y.add(&f.mul(&st(&x)?)?)?,
                &z.add(&g.mul(&st(&x)?)?)?,
            )?
        }
        "exponential" => {
            let ex = exp_clamped(&x.sub(&k(1.0))?)?;
            let ey = exp_clamped(&y.sub(&k(1.0))?)?;
            let py = k(PI).mul(&y)?;
            vec3(
                &ex.mul(&cos(&py)?)?,
                &ex.mul(&sin(&py)?)?,
                &ey.mul(&sin(&k(PI).mul(&z)?)?)?,
            )?
        }
        "power" => {
            let st = sin(&theta)?;
            let rs = Field::max(&r, &k(EPS))?.pow(&st)?;
            vec3(
                &rs.mul(&cos(&theta)?)?,
                &rs.mul(&st)?,
                &rs.mul(&cos(&theta2)?)?,
            )?
        }
        "cosine" => {
            let px = k(PI).mul(&x)?;
            let ep = exp_clamped(&y)?;
            let em = exp_clamped(&y.neg())?;
            let cosh = ep.add(&em)?.mul(&k(0.5))?;
            let sinh = ep.sub(&em)?.mul(&k(0.5))?;
            vec3(
                &cos(&px)?.mul(&cosh)?,
                &sin(&px)?.mul(&sinh)?.neg(),
                &sin(&x)?,
            )?
        }
        _ => unreachable!("checked against NAMES above"),
    })
}

/// `post(V(pre(p)))`: the variation between two affine maps (either may be the identity).
pub fn flame(
    name: &str,
    params: &[f64],
    pre: Option<(DMat3, DVec3)>,
    post: Option<(DMat3, DVec3)>,
) -> Outcome<Field> {
    let mut f = variation(name, params)?;
    if let Some((m, t)) = pre {
        let map = affine_field(&Field::identity(), m, t)?;
        f = f.compose(&map)?;
    }
    if let Some((m, t)) = post {
        f = affine_field(&f, m, t)?;
    }
    Ok(f)
}

/// `m v + t` for a vectorfield `v`.
fn affine_field(v: &Field, m: DMat3, t: DVec3) -> Outcome<Field> {
    Field::constant_matrix(m)
        .mul(v)?
        .add(&Field::constant_vector(t))
}
