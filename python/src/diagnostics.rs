//! Diagnostics as Python objects, and `FeltError`, whose text is the report the CLI prints
//! (`felt::syntax::diagnostic::render`, without colour) so a log shows what a terminal would.

use crate::FeltError;
use felt::syntax::diagnostic::{Diagnostic, Severity};
use felt::syntax::span::SourceMap;
use pyo3::prelude::*;

/// One diagnostic: where (file, line, column, the source line), what, and how to fix it.
#[pyclass(name = "Diagnostic", module = "felt", frozen, get_all)]
pub struct PyDiagnostic {
    /// "error" or "warning".
    severity: String,
    message: String,
    help: Option<String>,
    /// `None` for a diagnostic about no place in a source (a bad param name).
    file: Option<String>,
    /// 1-based, like the CLI's report.
    line: Option<usize>,
    column: Option<usize>,
    source_line: Option<String>,
}

#[pymethods]
impl PyDiagnostic {
    fn __repr__(&self) -> String {
        match (&self.file, self.line, self.column) {
            (Some(file), Some(line), Some(column)) => format!(
                "<felt.Diagnostic {} at {file}:{line}:{column}: {}>",
                self.severity, self.message
            ),
            _ => format!("<felt.Diagnostic {}: {}>", self.severity, self.message),
        }
    }
}

impl PyDiagnostic {
    pub fn new(d: &Diagnostic, sources: &SourceMap) -> PyDiagnostic {
        let place = d.span.map(|span| {
            let file = sources.get(span.file);
            let (line, column) = file.line_col(span.start as usize);
            let index = file.line_index(span.start as usize);
            let text = file
                .text
                .get(file.line_start(index)..file.line_end(index))
                .unwrap_or("")
                .trim_end_matches(['\r', '\n']);
            (file.name.clone(), line, column, text.to_string())
        });
        PyDiagnostic {
            severity: match d.severity {
                Severity::Error => "error",
                Severity::Warning => "warning",
            }
            .to_string(),
            message: d.message.clone(),
            help: d.help.clone(),
            file: place.as_ref().map(|p| p.0.clone()),
            line: place.as_ref().map(|p| p.1),
            column: place.as_ref().map(|p| p.2),
            source_line: place.map(|p| p.3),
        }
    }
}

/// The diagnostics as Python objects.
pub fn to_python(
    py: Python<'_>,
    diags: &[Diagnostic],
    sources: &SourceMap,
) -> PyResult<Vec<Py<PyDiagnostic>>> {
    diags
        .iter()
        .map(|d| Py::new(py, PyDiagnostic::new(d, sources)))
        .collect()
}

/// A `FeltError` carrying the CLI's report as its text and the diagnostics as an attribute.
pub fn felt_error(py: Python<'_>, diags: &[Diagnostic], sources: &SourceMap) -> PyErr {
    let report = felt::syntax::diagnostic::render(diags, sources, false);
    let error = FeltError::new_err(report.trim_end().to_string());
    match to_python(py, diags, sources) {
        Ok(list) => match error.value(py).setattr("diagnostics", list) {
            Ok(()) => error,
            Err(e) => e,
        },
        Err(e) => e,
    }
}
