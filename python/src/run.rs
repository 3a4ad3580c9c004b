//! `felt.Session`: runs scripts on one engine and reads back what the latest run made.

use crate::diagnostics::{self, PyDiagnostic};
use crate::grids::{self, Grid};
use crate::{sigint, values};
use felt::check::types::{Shape, Type};
use felt::syntax::diagnostic::Diagnostic;
use felt::engine::Engine;
use felt::grid::cache::Cache;
use felt::space::domain::Domain;
use felt::interp::value::{CacheVar, Value};
use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::{PyKeyError, PyKeyboardInterrupt, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::cell::RefCell;
use std::io::Write;
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::Arc;

/// What a run's `print` wrote, kept for `Session.output`.
#[derive(Clone, Default)]
struct Printed(Rc<RefCell<Vec<u8>>>);

impl Write for Printed {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.borrow_mut().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// A value that is not `Send` lent to `Python::detach`, whose closure runs on this thread.
struct OnThisThread<T>(T);

// SAFETY: `Python::detach` calls its closure on the calling thread and returns only after it
// has finished, so the wrapped value (a felt session, which holds `Rc`s) is never touched from
// another thread; `Send` is asked for only to keep Python objects out of the closure.
unsafe impl<T> Send for OnThisThread<T> {}

impl<T> OnThisThread<T> {
    fn get(&mut self) -> &mut T {
        &mut self.0
    }
}

/// A cache handed in by `set_cache`, declared again in every run.
struct HostCache {
    name: String,
    shape: Shape,
    domain: Rc<Domain>,
    background: Vec<f64>,
    cache: Arc<Cache>,
}

/// Where the script comes from.
enum Script {
    File(PathBuf),
    Text { name: String, text: String },
}

/// A felt session: a memory budget, a worker pool and an interrupt flag that its runs share.
#[pyclass(module = "felt", unsendable)]
pub struct Session {
    engine: Arc<Engine>,
    latest: Option<felt::session::Session>,
    printed: Printed,
    host_caches: Vec<HostCache>,
    /// What the latest run printed.
    #[pyo3(get)]
    output: String,
    /// The warnings of the latest run.
    #[pyo3(get)]
    warnings: Vec<Py<PyDiagnostic>>,
}

#[pymethods]
impl Session {
    /// `memory_limit` is the memory budget in bytes (default: half the memory felt may use);
    /// `threads` the worker threads of the calling thread's pool (default: all cores).
    #[new]
    #[pyo3(signature = (memory_limit=None, threads=None))]
    fn new(memory_limit: Option<u64>, threads: Option<usize>) -> PyResult<Session> {
        if threads == Some(0) {
            return Err(PyValueError::new_err("threads must be at least 1"));
        }
        // The pool belongs to the thread (see `felt::engine`): the first session made on a
        // thread sizes it, and a later one asking for another size is told so.
        felt::engine::attach_pool(threads)
            .map_err(|e| PyValueError::new_err(format!("cannot start the worker threads: {e}")))?;
        if let Some(wanted) = threads {
            let have = rayon::current_num_threads();
            if have != wanted {
                return Err(PyValueError::new_err(format!(
                    "this thread's worker pool already has {have} threads; a session on \
                     another thread can have {wanted}"
                )));
            }
        }
        let engine = match memory_limit {
            Some(bytes) => Engine::with_memory_limit(bytes),
            None => Engine::new(),
        };
        Ok(Session {
            engine,
            latest: None,
            printed: Printed::default(),
            host_caches: Vec::new(),
            output: String::new(),
            warnings: Vec::new(),
        })
    }

    /// Runs a script file with `params` (name → value); returns what it printed.
    #[pyo3(signature = (path, params=None))]
    fn run_file(
        &mut self,
        py: Python<'_>,
        path: PathBuf,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<String> {
        self.execute(py, Script::File(path), params)
    }

    /// Runs script text as a file named `name` (imports are relative to the current
    /// directory); returns what it printed.
    #[pyo3(signature = (source, params=None, name="<python>"))]
    fn run(
        &mut self,
        py: Python<'_>,
        source: String,
        params: Option<&Bound<'_, PyDict>>,
        name: &str,
    ) -> PyResult<String> {
        let script = Script::Text {
            name: name.to_string(),
            text: source,
        };
        self.execute(py, script, params)
    }

    /// Checks a script (text, or a file with `path=`) without running it; returns every
    /// diagnostic, warnings included.
    #[pyo3(signature = (source=None, path=None, params=None, name="<python>"))]
    fn check(
        &mut self,
        py: Python<'_>,
        source: Option<String>,
        path: Option<PathBuf>,
        params: Option<&Bound<'_, PyDict>>,
        name: &str,
    ) -> PyResult<Vec<Py<PyDiagnostic>>> {
        let mut session = self.fresh_session(params)?;
        let units = match (source, path) {
            (Some(text), None) => session.load_source(name, &text),
            (None, Some(path)) => session.load(&path),
            _ => {
                return Err(PyTypeError::new_err(
                    "check takes the script's text or path=, one of them",
                ));
            }
        };
        let diags = match units {
            Ok(units) => {
                let mut diags = session.check(&units);
                if !diags.iter().any(Diagnostic::is_error) {
                    diags.extend(session.check_overrides(&units).err());
                }
                diags
            }
            Err(diags) => diags,
        };
        diagnostics::to_python(py, &diags, &session.sources.borrow())
    }

    /// A global of the latest run: a number, bool, string, vector (3-tuple), matrix (rows),
    /// array (list), or a cache as a `felt.Grid` (its cells read into a NumPy array).
    fn get(&mut self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
        let session = self.latest_run()?;
        let Some(value) = session.interp.global(name).cloned() else {
            return Err(PyKeyError::new_err(format!(
                "the latest run has no global named `{name}`"
            )));
        };
        if let Some(plain) = values::plain(py, &value)? {
            return Ok(plain);
        }
        match value {
            Value::Cache(var) => Ok(Py::new(py, self.read_cache(py, &var)?)?.into_any()),
            other => Err(PyTypeError::new_err(format!(
                "`{name}` is a {}; a field is read with session.sample(\"{name}\", domain)",
                other.type_of()
            ))),
        }
    }

    /// Samples a field — a global's name or any expression over the latest run's globals —
    /// at the cell centres of `domain`: the name of a domain with cells, or a tuple
    /// `(origin, lengths, cell)`. Returns a `felt.Grid`.
    fn sample(
        &mut self,
        py: Python<'_>,
        expression: &str,
        domain: &Bound<'_, PyAny>,
    ) -> PyResult<Py<Grid>> {
        let domain = match domain.extract::<String>() {
            Ok(name) => name,
            Err(_) => {
                let ((ox, oy, oz), (lx, ly, lz), cell): ((f64, f64, f64), (f64, f64, f64), f64) =
                    domain.extract().map_err(|_| {
                        PyTypeError::new_err(
                            "domain: the name of a domain, or (origin, lengths, cell)",
                        )
                    })?;
                format!(
                    "domain(({ox:?}, {oy:?}, {oz:?}), ({lx:?}, {ly:?}, {lz:?}), (0, 0, 0), {cell:?})"
                )
            }
        };
        if self.latest.is_none() {
            self.latest = Some(self.fresh_session(None)?);
        }
        let session = self.latest_run()?;
        let ty = session
            .type_of(expression)
            .map_err(|d| diagnostics::felt_error(py, &d, &session.sources.borrow()))?;
        let (kind, read) = match ty.as_str() {
            "float" | "int" | "scalarfield" => ("scalarcache", expression.to_string()),
            "vector" | "vectorfield" => ("vectorcache", expression.to_string()),
            "matrix" | "matrixfield" => ("matrixcache", expression.to_string()),
            "scalarcache" | "vectorcache" | "matrixcache" => {
                (ty.as_str(), format!("cacheread({expression})"))
            }
            other => {
                return Err(PyTypeError::new_err(format!(
                    "`{expression}` is a {other}, not a field"
                )));
            }
        };
        let text = format!("{kind} __felt_sample({domain});\ncachewrite(__felt_sample, {read});\n");
        self.evaluate(py, &text)?;
        let session = self.latest_run()?;
        let Some(Value::Cache(var)) = session.interp.global("__felt_sample").cloned() else {
            return Err(PyValueError::new_err("the sample made no cache"));
        };
        Py::new(py, self.read_cache(py, &var)?)
    }

    /// Hands a NumPy array (`float32` or `float64`, indexed `[i, j, k]` or `[i, j, k, c]` with
    /// 3 or 9 components) to the next runs as a cache global `name` over cells of size `cell`
    /// from `origin`; `background` is what it reads outside.
    #[pyo3(signature = (name, array, origin, cell, background=0.0))]
    fn set_cache(
        &mut self,
        name: &str,
        array: &Bound<'_, PyAny>,
        origin: (f64, f64, f64),
        cell: f64,
        background: f64,
    ) -> PyResult<()> {
        let array: PyReadonlyArrayDyn<'_, f32> = match array.extract() {
            Ok(a) => a,
            Err(_) => array
                .call_method1("astype", ("float32",))?
                .extract()
                .map_err(|_| PyTypeError::new_err("set_cache takes a NumPy array of floats"))?,
        };
        let shape = array.shape().to_vec();
        let (cells, width) = match shape.as_slice() {
            [nx, ny, nz] => ([*nx, *ny, *nz], 1),
            [nx, ny, nz, w @ (3 | 9)] => ([*nx, *ny, *nz], *w),
            _ => {
                return Err(PyValueError::new_err(format!(
                    "set_cache takes an array of shape (nx, ny, nz) or (nx, ny, nz, 3 or 9), \
                     got {shape:?}"
                )));
            }
        };
        if cells.contains(&0) || !(cell.is_finite() && cell > 0.0) || !background.is_finite() {
            return Err(PyValueError::new_err(
                "set_cache needs at least one cell, a positive cell size and a finite background",
            ));
        }
        let values = array.as_array();
        let values: Vec<f32> = values.iter().copied().collect();
        if let Some(at) = values.iter().position(|v| !v.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "set_cache: value {} at flat index {at} is not finite",
                values[at]
            )));
        }
        let shape_kind = match width {
            1 => Shape::Scalar,
            3 => Shape::Vector,
            _ => Shape::Matrix,
        };
        let origin = glam::DVec3::new(origin.0, origin.1, origin.2);
        let lengths = glam::DVec3::new(cells[0] as f64, cells[1] as f64, cells[2] as f64) * cell;
        let failure = |f: felt::base::failure::Failure| PyValueError::new_err(f.message);
        let _entered = self.engine.enter();
        let domain =
            Domain::with_cells(origin, lengths, glam::DVec3::ZERO, cell, cell).map_err(failure)?;
        let background = vec![background; width];
        let data = grids::dense_components(&values, cells, width);
        let cache =
            Cache::from_dense(domain.clone(), width, data, background.clone()).map_err(failure)?;
        self.host_caches.retain(|c| c.name != name);
        self.host_caches.push(HostCache {
            name: name.to_string(),
            shape: shape_kind,
            domain: Rc::new(domain),
            background,
            cache: Arc::new(cache),
        });
        Ok(())
    }
}

impl Session {
    fn latest_run(&mut self) -> PyResult<&mut felt::session::Session> {
        self.latest
            .as_mut()
            .ok_or_else(|| PyValueError::new_err("nothing has run in this session yet"))
    }

    /// A felt session on this engine with the host's caches declared and `params` set.
    fn fresh_session(
        &self,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<felt::session::Session> {
        let mut session = felt::session::Session::with_engine(
            Box::new(self.printed.clone()),
            self.engine.clone(),
        )
        .map_err(|f| {
            Python::attach(|py| diagnostics::felt_error(py, &f.diagnostics, &f.sources))
        })?;
        for host in &self.host_caches {
            let ty = match host.shape {
                Shape::Scalar => Type::ScalarCache,
                Shape::Vector => Type::VectorCache,
                Shape::Matrix => Type::MatrixCache,
            };
            let var = CacheVar {
                shape: host.shape,
                domain: host.domain.clone(),
                frustum: None,
                background: host.background.clone(),
                state: RefCell::new(Some(host.cache.clone())),
            };
            session.define_global(&host.name, ty, Value::Cache(Rc::new(var)));
        }
        if let Some(params) = params {
            for (key, value) in params.iter() {
                let key: String = key.extract()?;
                let text = values::override_text(&key, &value)?;
                session.interp.overrides.insert(key, text);
            }
        }
        Ok(session)
    }

    /// Runs a script in a fresh felt session, which becomes the latest.
    fn execute(
        &mut self,
        py: Python<'_>,
        script: Script,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<String> {
        let session = self.fresh_session(params)?;
        self.printed.0.borrow_mut().clear();
        let main_thread = is_main_thread(py)?;
        let hook = sigint::Hook::install(&self.engine, main_thread);
        let mut lent = OnThisThread(session);
        let outcome = py.detach(|| {
            let session = lent.get();
            let result = match &script {
                Script::File(path) => session.run_file(path),
                Script::Text { name, text } => session.run_source(name, text),
            };
            let late = session.finish();
            OnThisThread((result, late))
        });
        let interrupted = hook.interrupted();
        drop(hook);
        let session = lent.0;
        let (result, late) = outcome.0;
        self.output = String::from_utf8_lossy(&self.printed.0.borrow()).into_owned();
        let sources = session.sources.clone();
        self.latest = Some(session);
        if interrupted {
            return Err(PyKeyboardInterrupt::new_err("felt run interrupted"));
        }
        match result {
            Ok(mut warnings) => {
                warnings.extend(late);
                self.warnings = diagnostics::to_python(py, &warnings, &sources.borrow())?;
                Ok(self.output.clone())
            }
            Err(mut diags) => {
                diags.extend(late);
                self.warnings = Vec::new();
                Err(diagnostics::felt_error(py, &diags, &sources.borrow()))
            }
        }
    }

    /// Runs statements in the latest session (as at the prompt: they may replace globals).
    fn evaluate(&mut self, py: Python<'_>, text: &str) -> PyResult<()> {
        let Some(session) = self.latest.take() else {
            return Err(PyValueError::new_err("nothing has run in this session yet"));
        };
        let mut lent = OnThisThread(session);
        let text = text.to_string();
        let outcome = py.detach(|| {
            let session = lent.get();
            OnThisThread(session.eval_input(&text, &mut |_, _| {}))
        });
        let session = lent.0;
        let sources = session.sources.clone();
        self.latest = Some(session);
        match outcome.0 {
            Ok(_) => Ok(()),
            Err(diags) => Err(diagnostics::felt_error(py, &diags, &sources.borrow())),
        }
    }

    /// A cache's cells as a `Grid`, read with the GIL released and the engine entered (a
    /// cache filled on demand computes its bricks now).
    fn read_cache(&self, py: Python<'_>, var: &Rc<CacheVar>) -> PyResult<Grid> {
        // A frustum cache's cells are laid along the camera's rays, not on a world box, so
        // they have no `Grid` (whose domain is an axis-aligned box of equal cells).
        if var.frustum.is_some() {
            return Err(PyValueError::new_err(
                "a frustum cache's cells follow the camera's frustum, not a box of equal cells; \
                 sample it into a cache over a domain (cache + cachewrite) to read it as a Grid",
            ));
        }
        let Some(cache) = var.state.borrow().clone() else {
            return Err(PyValueError::new_err(
                "the cache was never written (no cachewrite ran)",
            ));
        };
        let engine = self.engine.clone();
        let reader = cache.clone();
        let values = py.detach(move || {
            let _entered = engine.enter();
            grids::cache_values(&reader)
        });
        grids::grid(py, values, cache.width(), cache.domain())
    }
}

fn is_main_thread(py: Python<'_>) -> PyResult<bool> {
    let threading = py.import("threading")?;
    let current = threading.call_method0("current_thread")?;
    let main = threading.call_method0("main_thread")?;
    Ok(current.is(&main))
}
