//! felt's source is layered, and this test keeps it so: a module may name (`crate::NAME`) only
//! the modules of its own layer and of the layers below it. The layers, from the command down
//! to the failure type everything reports with, are written once, here; `src/lib.rs` describes
//! the same order.
//!
//! The imports that run up today are listed with the reason each is there: the test fails on
//! any other (a new module must be given a layer, a new import must go down), and on a listed
//! one that has gone (so the list only shrinks). Doc comments count: a link up is a
//! dependency of the reader's understanding, and the same move removes it.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The layers, top (the command) to bottom; a module names only its own layer and those below.
const LAYERS: &[&[&str]] = &[
    // The felt command: its subcommands and the tools they drive.
    &[
        "cli",
        "repl",
        "doc",
        "lsp",
        "study",
        "farm",
        "farm_command",
        "sequence",
    ],
    // A session: the standard library loaded, scripts checked and run.
    &["session"],
    // Running a script: values, statements, builtins, paths and provenance.
    &["interp", "paths", "provenance"],
    &["check"],
    // Source text and its diagnostics, which need only spans.
    &["syntax", "diagnostic"],
    // The producers and the renderer.
    &["render", "particles", "cloud", "geometry"],
    &["field", "grid"],
    // The sampling vocabulary fields, grids and the renderer share.
    &["sample"],
    &["engine", "budget"],
    // Files in and out, frame patterns, interrupts.
    &["output", "input", "frames", "interrupt", "usd"],
    &["failure", "test_random"],
];

/// Imports that run up today, `(from, to, why)`.
const KNOWN_UP: &[(&str, &str, &str)] = &[
    (
        "budget",
        "grid",
        "the budget frees the grids' spare buffers before refusing",
    ),
    (
        "engine",
        "grid",
        "the engine holds the profile, which lives in grid",
    ),
    (
        "engine",
        "render",
        "the engine holds the band a farm task renders",
    ),
    (
        "field",
        "cloud",
        "a pruning test builds a cloud ellipsoid field",
    ),
    (
        "interp",
        "session",
        "the checker/interpreter agreement test runs scripts in a session",
    ),
    ("interrupt", "engine", "the interrupt flag is the engine's"),
    (
        "output",
        "engine",
        "output settings (directory, overwrite) are the engine's",
    ),
    (
        "particles",
        "interp",
        "flame builds matrices and did-you-mean help with the interpreter's helpers",
    ),
    ("sample", "grid", "sample.rs names grid's Domain"),
];

/// Every `crate::NAME` named from each top-level module of `src/`.
fn imports(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    fn walk(dir: &Path, files: &mut Vec<std::path::PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, files);
            } else if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    let mut files = Vec::new();
    walk(src, &mut files);
    let mut named: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in files {
        let relative = file.strip_prefix(src).unwrap();
        let top = relative.components().next().unwrap().as_os_str();
        let module = top.to_string_lossy().trim_end_matches(".rs").to_string();
        if module == "lib" || module == "main" {
            continue;
        }
        let text = std::fs::read_to_string(&file).unwrap();
        let entry = named.entry(module.clone()).or_default();
        for (at, _) in text.match_indices("crate::") {
            let name: String = text[at + "crate::".len()..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() && name != module {
                entry.insert(name);
            }
        }
    }
    named
}

#[test]
fn modules_name_only_their_layer_and_those_below() {
    let layer_of: BTreeMap<&str, usize> = LAYERS
        .iter()
        .enumerate()
        .flat_map(|(i, layer)| layer.iter().map(move |m| (*m, i)))
        .collect();
    let named = imports(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    let unplaced: Vec<&String> = named
        .keys()
        .filter(|m| !layer_of.contains_key(m.as_str()))
        .collect();
    assert!(
        unplaced.is_empty(),
        "modules with no layer: {unplaced:?}; add each to LAYERS in tests/layers.rs"
    );
    let mut up = BTreeSet::new();
    for (from, names) in &named {
        for to in names {
            if let Some(&below) = layer_of.get(to.as_str())
                && below < layer_of[from.as_str()]
            {
                up.insert((from.clone(), to.clone()));
            }
        }
    }
    let known: BTreeSet<(String, String)> = KNOWN_UP
        .iter()
        .map(|(from, to, _)| (from.to_string(), to.to_string()))
        .collect();
    let new: Vec<_> = up.difference(&known).collect();
    assert!(
        new.is_empty(),
        "imports that run up the layers: {new:?}; move the shared part down instead"
    );
    let gone: Vec<_> = known.difference(&up).collect();
    assert!(
        gone.is_empty(),
        "these imports no longer run up: {gone:?}; take them off KNOWN_UP"
    );
}
