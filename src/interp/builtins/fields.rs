//! Field builtins (docs/language.md, Fields): constructors, switching, calculus, warping and inspection.
//! Each only builds graph nodes, except `probe` and `stats`, which are outputs: they compile
//! the graph they need and evaluate it.

use crate::base::failure::grouped;
use crate::base::failure::{Failure, Outcome};
use crate::field::{self, Field, FieldValue};
use crate::interp::Interpreter;
use crate::interp::registry::{Args, Registry};
use crate::interp::value::Value;
use crate::space::GridSource;
use crate::syntax::diagnostic::{Diagnostic, Stage};

pub fn register(r: &mut Registry) {
    r.add(
        "fields",
        &["identity() -> vectorfield"],
        "the position x itself",
        |_, _| Ok(Value::Field(Field::identity())),
    );
    r.add(
        "fields",
        &["scalarfield(scalarfield f) -> scalarfield"],
        "a scalarfield; a number gives a constant field",
        |_, a| Ok(Value::Field(a.get("f")?.as_field()?)),
    );
    r.add(
        "fields",
        &[
            "vectorfield(vectorfield v) -> vectorfield",
            "vectorfield(scalarfield x, scalarfield y, scalarfield z) -> vectorfield",
        ],
        "a vectorfield from a vector (constant) or from three scalar components",
        |_, a| match a.form {
            0 => Ok(Value::Field(a.get("v")?.as_field()?)),
            _ => Ok(Value::Field(Field::vector_from(
                &a.get("x")?.as_field()?,
                &a.get("y")?.as_field()?,
                &a.get("z")?.as_field()?,
            )?)),
        },
    );
    r.add(
        "fields",
        &[
            "matrixfield(matrixfield m) -> matrixfield",
            "matrixfield(vectorfield row0, vectorfield row1, vectorfield row2) -> matrixfield",
        ],
        "a matrixfield from a matrix (constant) or from three row vectorfields",
        |_, a| match a.form {
            0 => Ok(Value::Field(a.get("m")?.as_field()?)),
            _ => Ok(Value::Field(Field::matrix_from_rows(
                &a.get("row0")?.as_field()?,
                &a.get("row1")?.as_field()?,
                &a.get("row2")?.as_field()?,
            )?)),
        },
    );
    r.add(
        "fields",
        &["mask(scalarfield f) -> scalarfield"],
        "1 where f >= 0, else 0 (a Heaviside step)",
        |_, a| Ok(Value::Field(a.get("f")?.as_field()?.mask()?)),
    );
    r.add(
        "fields",
        &[
            "select(scalarfield c, scalarfield a, scalarfield b) -> scalarfield",
            "select(scalarfield c, vectorfield a, vectorfield b) -> vectorfield",
            "select(scalarfield c, matrixfield a, matrixfield b) -> matrixfield",
        ],
        "a where c >= 0, else b",
        |_, a| {
            Ok(Value::Field(Field::select(
                &a.get("c")?.as_field()?,
                &a.get("a")?.as_field()?,
                &a.get("b")?.as_field()?,
            )?))
        },
    );
    r.add(
        "calculus",
        &[
            "grad(scalarfield f) -> vectorfield",
            "grad(vectorfield v) -> matrixfield",
        ],
        "exact gradient (of a vectorfield: the Jacobian, J[i][j] = dv_i/dx_j)",
        |_, a| {
            Ok(Value::Field(field::grad(
                &a.one_of(&["f", "v"])?.as_field()?,
            )?))
        },
    );
    r.add(
        "calculus",
        &["div(vectorfield v) -> scalarfield"],
        "divergence",
        |_, a| Ok(Value::Field(field::div(&a.get("v")?.as_field()?)?)),
    );
    r.add(
        "calculus",
        &["curl(vectorfield v) -> vectorfield"],
        "curl",
        |_, a| Ok(Value::Field(field::curl(&a.get("v")?.as_field()?)?)),
    );
    r.add(
        "calculus",
        &[
            "laplacian(scalarfield f) -> scalarfield",
            "laplacian(vectorfield v) -> vectorfield",
        ],
        "sum of second derivatives (componentwise for a vectorfield)",
        |_, a| {
            Ok(Value::Field(field::laplacian(
                &a.one_of(&["f", "v"])?.as_field()?,
            )?))
        },
    );
    r.add(
        "warping",
        &[
            "compose(scalarfield f, vectorfield x) -> scalarfield",
            "compose(vectorfield f, vectorfield x) -> vectorfield",
            "compose(matrixfield f, vectorfield x) -> matrixfield",
        ],
        "f evaluated at the points x(p)",
        |_, a| {
            Ok(Value::Field(field::compose(
                &a.get("f")?.as_field()?,
                &a.get("x")?.as_field()?,
            )?))
        },
    );
    r.add(
        "warping",
        &[
            "advect(scalarfield f, vectorfield u, scalarfield dt, int order?, string scheme?) -> scalarfield",
            "advect(vectorfield f, vectorfield u, scalarfield dt, int order?, string scheme?) -> vectorfield",
            "advect(matrixfield f, vectorfield u, scalarfield dt, int order?, string scheme?) -> matrixfield",
        ],
        "f carried along velocity u for time dt: a semi-Lagrangian back-trace (order 1, or Runge-Kutta 2, 3, 4); \
         scheme = \"maccormack\" or \"bfecc\" corrects the back-trace's error (clamped where f is a grid read)",
        |interp, a| {
            let order = a.opt_int("order")?.unwrap_or(1);
            if !(1..=4).contains(&order) {
                return Err(Failure::new(format!("advect order must be 1, 2, 3 or 4, found {order}")));
            }
            let scheme = match a.opt("scheme") {
                Some(v) => field::Scheme::named(v.as_str()?)?,
                None => field::Scheme::SemiLagrangian,
            };
            let (f, u, dt) = (a.get("f")?.as_field()?, a.get("u")?.as_field()?, a.get("dt")?.as_field()?);
            if let Some(FieldValue::Scalar(step)) = dt.as_constant()
                && !step.is_finite()
            {
                return Err(Failure::new(format!("the time step of advect must be finite, found {step}")));
            }
            if let Some(FieldValue::Vector(v)) = u.as_constant()
                && !v.is_finite()
            {
                return Err(Failure::new(format!("the velocity of advect must be finite, found {v}")));
            }
            let label = format!("advect scheme at {}", interp.location(interp.call_span));
            let resample = |f: &Field, grid: &dyn GridSource| super::grids::resample(f, grid, &label);
            Ok(Value::Field(field::advect_with(&f, &u, &dt, order as u32, scheme, &resample)?))
        },
    );
    r.choices(
        "advect",
        "scheme",
        "advection scheme",
        &["semilagrangian", "maccormack", "bfecc"],
    );
    r.add(
        "warping",
        &[
            "translate(scalarfield f, vector offset) -> scalarfield",
            "translate(vectorfield f, vector offset) -> vectorfield",
            "translate(matrixfield f, vector offset) -> matrixfield",
        ],
        "f moved by offset: f(x - offset)",
        |_, a| {
            Ok(Value::Field(field::translate(
                &a.get("f")?.as_field()?,
                a.get("offset")?.as_vector()?,
            )?))
        },
    );
    r.add(
        "warping",
        &[
            "rotate(scalarfield f, vector axis, float angle) -> scalarfield",
            "rotate(vectorfield f, vector axis, float angle) -> vectorfield",
            "rotate(matrixfield f, vector axis, float angle) -> matrixfield",
        ],
        "f rotated about the origin by angle (radians) around axis",
        |_, a| {
            let axis = a.get("axis")?.as_vector()?;
            if axis.length() == 0.0 {
                return Err(Failure::new("rotate needs a non-zero axis"));
            }
            Ok(Value::Field(field::rotate(
                &a.get("f")?.as_field()?,
                axis,
                a.float("angle")?,
            )?))
        },
    );
    r.add(
        "warping",
        &[
            "scale(scalarfield f, vector factor) -> scalarfield",
            "scale(vectorfield f, vector factor) -> vectorfield",
            "scale(matrixfield f, vector factor) -> matrixfield",
        ],
        "f stretched by factor about the origin: f(x / factor); a number scales all axes",
        |_, a| {
            let factor = match a.get("factor")? {
                Value::Vector(v) => *v,
                v => glam::DVec3::splat(v.as_float()?),
            };
            if factor.min_element().abs() == 0.0 || !factor.is_finite() {
                return Err(Failure::new(format!(
                    "scale factors must be finite and non-zero, found {factor}"
                )));
            }
            Ok(Value::Field(field::scale(
                &a.get("f")?.as_field()?,
                factor,
            )?))
        },
    );
    r.add(
        "inspection",
        &[
            "probe(scalarfield f, vector point) -> float",
            "probe(vectorfield f, vector point) -> vector",
            "probe(matrixfield f, vector point) -> matrix",
        ],
        "the value of a field at one point (evaluated in double precision)",
        probe,
    );
    r.add(
        "inspection",
        &["stats(scalarfield f, domain d) -> vector"],
        "(min, max, mean) of f over the cell centres of d, of its finite values (with a \
         warning when some are NaN or infinite)",
        |interp, a| {
            let Value::Domain(d) = a.get("d")? else {
                return Err(Failure::new("stats needs a domain"));
            };
            let (min, max, mean, bad) = field::stats_with_count(&a.get("f")?.as_field()?, d)?;
            if bad > 0 {
                let cells = d.cell_count() as u64;
                let left = if bad == cells {
                    "no value is finite, so min, max and mean are NaN".to_string()
                } else {
                    format!("min, max and mean are of the other {} cells", grouped(cells - bad))
                };
                interp.warnings.push(
                    Diagnostic::warning(
                        Stage::Runtime,
                        interp.call_span,
                        format!(
                            "stats: the field was NaN or infinite at {} of {} cells; {left}",
                            grouped(bad),
                            grouped(cells)
                        ),
                    )
                    .with_help("a division by a field that is zero somewhere gives infinities or NaN; guard it with select or max"),
                );
            }
            Ok(Value::Vector(glam::DVec3::new(min, max, mean)))
        },
    );
}

fn probe(_: &mut Interpreter, a: Args) -> Outcome<Value> {
    let f = a.get("f")?.as_field()?;
    let p = a.get("point")?.as_vector()?;
    if !p.is_finite() {
        return Err(Failure::new(format!(
            "probe point must be finite, found {p}"
        )));
    }
    Ok(match field::probe(&f, p)? {
        FieldValue::Scalar(x) => Value::Float(x),
        FieldValue::Vector(v) => Value::Vector(v),
        FieldValue::Matrix(m) => Value::Matrix(m),
    })
}
