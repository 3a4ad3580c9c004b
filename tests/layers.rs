//! felt's source is layered, and this test keeps it so: a module may name (`crate::NAME`) only
//! the modules of its own layer and of the layers below it. The layers, from the command down
//! to the failure type everything reports with, are written once, here; `src/lib.rs` describes
//! the same order.
//!
//! No import runs up: a new module must be given a layer, and what two layers share moves
//! down to the lower one. Doc comments count: a link up is a dependency of the reader's
//! understanding, and the same move removes it. The folders are the layers, so besides
//! `lib.rs`, `main.rs` and `session.rs` (the front door) no file sits loose in `src/`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The layers, top (the command) to bottom; a module names only its own layer and those below.
const LAYERS: &[&[&str]] = &[
    // The felt command: its tools (`app`), and the binary's own modules, whose files are in
    // `app/` too.
    &["app", "cli", "farm_command"],
    // A session: the standard library loaded, scripts checked and run.
    &["session"],
    // Running a script: values, statements, builtins, paths and provenance.
    &["interp"],
    &["check"],
    // Source text and its diagnostics, which need only spans.
    &["syntax"],
    // The producers and the renderer.
    &["render", "particles", "cloud", "geometry", "fluids"],
    // Fields as graphs, which read grids through `space`'s traits and fill caches.
    &["field"],
    // Caches and grid files.
    &["grid"],
    // The sampling vocabulary fields, grids and the renderer share.
    &["space"],
    // The run's context: budget, profile, pools, interrupts.
    &["engine"],
    // Files in and out, frame patterns.
    &["io"],
    &["base"],
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
        assert!(
            !text.contains("crate::{"),
            "{}: name each module in its own `use crate::...` so this test can read it",
            relative.display()
        );
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
    assert!(
        up.is_empty(),
        "imports that run up the layers: {up:?}; move the shared part down instead"
    );
}

#[test]
fn only_the_front_door_is_loose() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut loose: Vec<String> = std::fs::read_dir(&src)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .filter(|name| !["lib.rs", "main.rs", "session.rs"].contains(&name.as_str()))
        .collect();
    loose.sort();
    assert!(
        loose.is_empty(),
        "files loose in src/: {loose:?}; each belongs in the folder of its layer"
    );
}
