//! Utilities (docs/language.md, "Printing and formatting"): printing, strings, array size,
//! timing, conversions and the default noise seed.

use super::format;
use crate::base::failure::{Failure, Outcome};
use crate::interp::Interpreter;
use crate::interp::registry::{Args, Registry};
use crate::interp::value::Value;

pub fn register(r: &mut Registry) {
    r.add(
        "core",
        &["print(any...)"],
        "writes its arguments separated by spaces, then a newline",
        print,
    );
    r.add(
        "core",
        &["str(any x) -> string"],
        "the text `print` would write for x",
        str_of,
    );
    r.add(
        "core",
        &["format(string template, any...) -> string"],
        "printf-style formatting with %d %f %e %g %s, widths and precisions",
        format_builtin,
    );
    r.add(
        "core",
        &["size(any[] a) -> int", "size(particles p) -> int"],
        "the number of elements of an array",
        size,
    );
    r.add(
        "core",
        &["clock() -> float"],
        "seconds since the run started",
        clock,
    );
    r.add(
        "core",
        &["seed(int n)"],
        "sets the default seed of noise fields built after this call",
        seed,
    );
    r.add(
        "core",
        &["int(float x) -> int"],
        "x rounded toward zero; an error if x is not finite or too large",
        to_int,
    );
    r.add(
        "core",
        &["float(float x) -> float"],
        "x as a float",
        to_float,
    );
}

fn print(interp: &mut Interpreter, args: Args) -> Outcome<Value> {
    let text: Vec<String> = args.rest.iter().map(|v| v.to_string()).collect();
    writeln!(interp.out, "{}", text.join(" "))
        .map_err(|e| Failure::new(format!("cannot write output: {e}")))?;
    Ok(Value::Void)
}

fn str_of(_: &mut Interpreter, args: Args) -> Outcome<Value> {
    Ok(Value::string(&args.get("x")?.to_string()))
}

fn format_builtin(_: &mut Interpreter, args: Args) -> Outcome<Value> {
    Ok(Value::string(&format::format(
        args.string("template")?,
        &args.rest,
    )?))
}

fn size(_: &mut Interpreter, args: Args) -> Outcome<Value> {
    if let Some(Value::Particles(p)) = args.opt("p") {
        return Ok(Value::Int(p.len() as i64));
    }
    Ok(Value::Int(args.get("a")?.as_array()?.len() as i64))
}

fn clock(interp: &mut Interpreter, _: Args) -> Outcome<Value> {
    Ok(Value::Float(interp.start.elapsed().as_secs_f64()))
}

fn seed(interp: &mut Interpreter, args: Args) -> Outcome<Value> {
    interp.noise_seed = args.int_in("n", 0..=u32::MAX as i64)? as u32;
    Ok(Value::Void)
}

fn to_int(_: &mut Interpreter, args: Args) -> Outcome<Value> {
    let x = args.float("x")?;
    if !x.is_finite() || x.abs() >= 9.2e18 {
        return Err(Failure::new(format!("{x} does not fit in an int")));
    }
    Ok(Value::Int(x.trunc() as i64))
}

fn to_float(_: &mut Interpreter, args: Args) -> Outcome<Value> {
    Ok(Value::Float(args.float("x")?))
}
