//! printf-style formatting for `format("out.%04d.exr", frame)`: the conversions `%d %i %f %e
//! %g %s %%` with the flags `- + 0 space`, a width and a precision, following C's rules so that
//! frame-numbered file names and tables come out exactly as a TD expects.

use crate::base::failure::{Failure, Outcome};
use crate::interp::value::Value;

struct Spec {
    left: bool,
    plus: bool,
    space: bool,
    zero: bool,
    width: usize,
    precision: Option<usize>,
}

pub fn format(template: &str, args: &[Value]) -> Outcome<String> {
    let mut out = String::new();
    let mut chars = template.chars().peekable();
    let mut next = 0;
    while let Some(c) = chars.next() {
        if c != '%' {
            out.push(c);
            continue;
        }
        if chars.peek() == Some(&'%') {
            chars.next();
            out.push('%');
            continue;
        }
        let mut spec = Spec {
            left: false,
            plus: false,
            space: false,
            zero: false,
            width: 0,
            precision: None,
        };
        while let Some(&f) = chars.peek() {
            match f {
                '-' => spec.left = true,
                '+' => spec.plus = true,
                ' ' => spec.space = true,
                '0' => spec.zero = true,
                _ => break,
            }
            chars.next();
        }
        while let Some(d) = chars.peek().and_then(|c| c.to_digit(10)) {
            spec.width = (spec.width * 10 + d as usize).min(1000);
            chars.next();
        }
        if chars.peek() == Some(&'.') {
            chars.next();
            let mut p = 0usize;
            while let Some(d) = chars.peek().and_then(|c| c.to_digit(10)) {
                p = (p * 10 + d as usize).min(100);
                chars.next();
            }
            spec.precision = Some(p);
        }
        let conversion = chars
            .next()
            .ok_or_else(|| Failure::new("format string ends inside a `%` conversion"))?;
        let arg = args.get(next).ok_or_else(|| {
            Failure::new(format!(
                "format string has more conversions than the {} argument(s) given",
                args.len()
            ))
        })?;
        next += 1;
        let (sign, body) = match conversion {
            'd' | 'i' => {
                let i = match arg {
                    Value::Int(i) => *i,
                    other => {
                        return Err(Failure::new(format!(
                            "`%{conversion}` needs an int, found {}",
                            other.type_of()
                        ))
                        .with_help("use %f or %g for floats"));
                    }
                };
                (i < 0, i.unsigned_abs().to_string())
            }
            'f' | 'F' | 'e' | 'E' | 'g' | 'G' => {
                let x = arg.as_float().map_err(|_| {
                    Failure::new(format!(
                        "`%{conversion}` needs a number, found {}",
                        arg.type_of()
                    ))
                })?;
                let p = spec.precision.unwrap_or(6);
                let body = match conversion {
                    'f' | 'F' => format!("{:.*}", p, x.abs()),
                    'e' | 'E' => exponential(x.abs(), p, conversion == 'E'),
                    _ => general(x.abs(), p, conversion == 'G'),
                };
                (x.is_sign_negative(), body)
            }
            's' => {
                let mut s = arg.to_string();
                if let Some(p) = spec.precision {
                    s = s.chars().take(p).collect();
                }
                out.push_str(&pad(&s, &spec, false));
                continue;
            }
            other => {
                return Err(Failure::new(format!(
                    "unknown conversion `%{other}` in format string"
                ))
                .with_help("the conversions are %d %f %e %g %s and %% for a percent sign"));
            }
        };
        let sign = if sign {
            "-"
        } else if spec.plus {
            "+"
        } else if spec.space {
            " "
        } else {
            ""
        };
        out.push_str(&pad_number(sign, &body, &spec));
    }
    if next < args.len() {
        return Err(Failure::new(format!(
            "format string has {} conversion(s) but {} argument(s) were given",
            next,
            args.len()
        )));
    }
    Ok(out)
}

fn pad(s: &str, spec: &Spec, _numeric: bool) -> String {
    let len = s.chars().count();
    if len >= spec.width {
        return s.to_string();
    }
    let fill = " ".repeat(spec.width - len);
    if spec.left {
        format!("{s}{fill}")
    } else {
        format!("{fill}{s}")
    }
}

fn pad_number(sign: &str, body: &str, spec: &Spec) -> String {
    let len = sign.len() + body.chars().count();
    if len >= spec.width {
        return format!("{sign}{body}");
    }
    let fill = spec.width - len;
    if spec.left {
        format!("{sign}{body}{}", " ".repeat(fill))
    } else if spec.zero
        && body
            .chars()
            .all(|c| c.is_ascii_digit() || c == '.' || c == 'e' || c == 'E' || c == '+' || c == '-')
    {
        format!("{sign}{}{body}", "0".repeat(fill))
    } else {
        format!("{}{sign}{body}", " ".repeat(fill))
    }
}

/// C's `%e`: one digit, point, `p` digits, `e`, sign, at least two exponent digits.
fn exponential(x: f64, p: usize, upper: bool) -> String {
    if !x.is_finite() {
        return non_finite(x, upper);
    }
    let s = format!("{:.*e}", p, x);
    let (mantissa, exponent) = s.split_once('e').unwrap_or((&s, "0"));
    let exponent: i32 = exponent.parse().unwrap_or(0);
    let e = if upper { 'E' } else { 'e' };
    format!(
        "{mantissa}{e}{}{:02}",
        if exponent < 0 { '-' } else { '+' },
        exponent.abs()
    )
}

/// C's `%g`: `%e` or `%f` by the exponent, trailing zeros removed.
fn general(x: f64, p: usize, upper: bool) -> String {
    if !x.is_finite() {
        return non_finite(x, upper);
    }
    let p = p.max(1);
    if x == 0.0 {
        return String::from("0");
    }
    let exponent = format!("{:.*e}", p - 1, x)
        .split_once('e')
        .and_then(|(_, e)| e.parse::<i32>().ok())
        .unwrap_or(0);
    if exponent < -4 || exponent >= p as i32 {
        let s = exponential(x, p - 1, upper);
        let (m, e) = s.split_at(s.find(['e', 'E']).unwrap_or(s.len()));
        format!("{}{e}", strip_zeros(m))
    } else {
        strip_zeros(&format!(
            "{:.*}",
            (p as i32 - 1 - exponent).max(0) as usize,
            x
        ))
        .to_string()
    }
}

fn strip_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

fn non_finite(x: f64, upper: bool) -> String {
    let s = if x.is_nan() { "nan" } else { "inf" };
    if upper {
        s.to_uppercase()
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(t: &str, args: &[Value]) -> String {
        format(t, args).unwrap()
    }

    #[test]
    fn matches_c_printf() {
        // Expected strings are what C's printf prints for the same conversions.
        assert_eq!(f("out.%04d.exr", &[Value::Int(7)]), "out.0007.exr");
        assert_eq!(
            f(
                "%5.2f|%-6d|%+d",
                &[Value::Float(1.23456), Value::Int(42), Value::Int(5)]
            ),
            " 1.23|42    |+5"
        );
        assert_eq!(f("%e", &[Value::Float(1234.5)]), "1.234500e+03");
        assert_eq!(f("%.2E", &[Value::Float(-0.000123)]), "-1.23E-04");
        assert_eq!(
            f(
                "%g %g %g",
                &[
                    Value::Float(0.0001),
                    Value::Float(123456789.0),
                    Value::Float(100.0)
                ]
            ),
            "0.0001 1.23457e+08 100"
        );
        assert_eq!(f("%g", &[Value::Float(0.00001)]), "1e-05");
        assert_eq!(f("%s=%d%%", &[Value::string("n"), Value::Int(-3)]), "n=-3%");
        assert_eq!(f("%05d", &[Value::Int(-42)]), "-0042");
        assert_eq!(f("%.3s", &[Value::string("abcdef")]), "abc");
    }

    #[test]
    fn mismatches_are_errors() {
        assert!(format("%d", &[Value::Float(1.0)]).is_err());
        assert!(format("%d %d", &[Value::Int(1)]).is_err());
        assert!(format("%d", &[Value::Int(1), Value::Int(2)]).is_err());
        assert!(format("%q", &[Value::Int(1)]).is_err());
        assert!(format("50%", &[]).is_err());
    }
}
