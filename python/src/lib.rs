//! The Python module `felt`: a `Session` that runs felt scripts in the calling process and
//! hands their values to Python — numbers, vectors, strings and arrays as Python values,
//! caches and sampled fields as NumPy arrays, rendered EXR images as NumPy channels — and takes
//! params and NumPy arrays in.
//!
//! The key decision is that a `Session` is a felt engine (memory budget, interrupt flag,
//! worker pool) that outlives its runs, while each run gets a fresh felt session on that
//! engine: a script is run the way `felt run` runs it, with nothing left from the run before
//! to redeclare, and `get`/`sample` read the globals of the latest run. Caches handed in with
//! `set_cache` are declared again in every run. Runs release the GIL; Ctrl-C reaches them
//! through the engine's interrupt flag (`sigint`).

mod diagnostics;
mod grids;
mod image;
mod run;
mod sigint;
mod values;

use pyo3::prelude::*;

pyo3::create_exception!(
    felt,
    FeltError,
    pyo3::exceptions::PyException,
    "A felt script failed: the text is the report `felt run` prints, and `diagnostics` holds \
     its diagnostics as `felt.Diagnostic` objects."
);

#[pymodule]
#[pyo3(name = "felt")]
fn felt_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<run::Session>()?;
    m.add_class::<diagnostics::PyDiagnostic>()?;
    m.add_class::<grids::Grid>()?;
    m.add_function(wrap_pyfunction!(image::read_image, m)?)?;
    m.add("FeltError", m.py().get_type::<FeltError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
