//! Provenance: what an output file records about the run that made it.
//!
//! A compositor or a pipeline tool looking at a render or a cache should be able to tell which
//! felt, which script and which parameter values produced it. The one key decision: the record
//! is plain text pairs, written as string attributes of an EXR header and string metadata of a
//! VDB file under the same names (`felt/version`, `felt/script`, `felt/param/NAME`), so a
//! script's `param`s can be read back from either without knowing felt.

use crate::interp::Interpreter;

/// The name and value pairs an output of `interp`'s run records.
pub fn of(interp: &Interpreter) -> Vec<(String, String)> {
    let mut record = vec![(
        String::from("felt/version"),
        String::from(env!("CARGO_PKG_VERSION")),
    )];
    if let Some(script) = &interp.files.script {
        record.push((String::from("felt/script"), script.display().to_string()));
    }
    for (name, value) in &interp.param_values {
        record.push((format!("felt/param/{name}"), value.clone()));
    }
    record
}

/// What OpenVDB's own tools put in a grid's `creator` field: the program and its version.
pub fn creator() -> String {
    format!("felt {}", env!("CARGO_PKG_VERSION"))
}
