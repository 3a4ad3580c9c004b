//! felt values as Python values, and Python values as the text of a `param` override.
//!
//! Params go in the way `felt run --set NAME=VALUE` sends them (`Interpreter::overrides`), so
//! a param set from Python is checked against its declared type by the same code, with the
//! same diagnostics, as one set on the command line.

use felt::interp::value::Value;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyFloat, PyInt, PyList, PyString, PyTuple};

/// A plain felt value as a Python one: `int`, `float`, `bool`, `str`, a vector as a 3-tuple of
/// floats, a matrix as a 3-tuple of rows, an array as a list; `None` for what has no plain
/// form (the caller handles caches; fields need a domain to be sampled over).
pub fn plain(py: Python<'_>, value: &Value) -> PyResult<Option<Py<PyAny>>> {
    Ok(Some(match value {
        Value::Void => py.None(),
        Value::Int(n) => n.into_pyobject(py)?.into_any().unbind(),
        Value::Float(x) => x.into_pyobject(py)?.into_any().unbind(),
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any().unbind(),
        Value::Str(s) => PyString::new(py, s).into_any().unbind(),
        Value::Vector(v) => (v.x, v.y, v.z).into_pyobject(py)?.into_any().unbind(),
        Value::Matrix(m) => {
            let row = |r: usize| {
                let row = m.row(r);
                (row.x, row.y, row.z)
            };
            (row(0), row(1), row(2))
                .into_pyobject(py)?
                .into_any()
                .unbind()
        }
        Value::Array(items, _) => {
            let mut list = Vec::with_capacity(items.len());
            for item in items.iter() {
                match plain(py, item)? {
                    Some(value) => list.push(value),
                    None => return Ok(None),
                }
            }
            PyList::new(py, list)?.into_any().unbind()
        }
        _ => return Ok(None),
    }))
}

/// A Python value as the text `--set` would carry for a param: `bool` as true/false, `int`,
/// `float` (shortest text that reads back to the same double), `str` as is, a 3-sequence of
/// numbers as a vector `(x, y, z)`.
pub fn override_text(name: &str, value: &Bound<'_, PyAny>) -> PyResult<String> {
    if value.is_instance_of::<PyBool>() {
        return Ok(value.extract::<bool>()?.to_string());
    }
    if value.is_instance_of::<PyInt>() {
        return Ok(value.extract::<i64>()?.to_string());
    }
    if value.is_instance_of::<PyFloat>() {
        return Ok(format!("{:?}", value.extract::<f64>()?));
    }
    if let Ok(text) = value.cast::<PyString>() {
        return Ok(text.to_str()?.to_string());
    }
    if (value.is_instance_of::<PyTuple>() || value.is_instance_of::<PyList>())
        && let Ok([x, y, z]) = value.extract::<Vec<f64>>().as_deref()
    {
        return Ok(format!("({x:?}, {y:?}, {z:?})"));
    }
    Err(PyTypeError::new_err(format!(
        "param `{name}`: expected an int, float, bool, str or a vector (x, y, z), got {}",
        value.get_type().name()?
    )))
}
