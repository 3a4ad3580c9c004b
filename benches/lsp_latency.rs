//! How long an editor waits for `felt lsp` after an edit: the round trip from sending a
//! `didChange` to reading the `publishDiagnostics` for that version, over the server's stdio
//! as an editor sees it (process, JSON framing and the whole check included). Measured on a
//! generated 5,000-line script that checks clean (params, functions, fields, arithmetic) and on
//! every example; each edit changes one number in the middle of the text, so every round trip
//! checks the whole script again.
//!
//! Run with `cargo bench --bench lsp_latency`.

// The tests' client; the benchmark uses only part of it.
#[allow(dead_code)]
#[path = "../tests/lsp/client.rs"]
mod client;

use client::{Client, position, uri_of};
use serde_json::json;
use std::path::Path;
use std::time::{Duration, Instant};

/// Edits timed per script.
const EDITS: usize = 21;

/// A clean script of `blocks` ten-line blocks, each declaring a param, a function, fields and
/// numbers that use them.
fn generated(blocks: usize) -> String {
    let mut text = String::new();
    for i in 0..blocks {
        text.push_str(&format!(
            "// Layer {i}: a sphere pushed out by noise.\n\
             param float radius{i} = 0.5;\n\
             func scalarfield layer{i}(scalarfield base, float r) {{\n\
             \x20   scalarfield bumps = perlin() * 0.1;\n\
             \x20   return softunion(base, sphere((0, 0, 0), r), 0.25) + bumps;\n\
             }}\n\
             scalarfield shape{i} = layer{i}(sphere((0, {i}, 0), 0.5), radius{i});\n\
             float weight{i} = clamp(radius{i} * 2.0, 0.0, 1.0);\n\
             vector offset{i} = (weight{i}, 0.0, 1.0);\n\
             shape{i} = shape{i} * weight{i};\n"
        ));
    }
    text
}

/// Round trips of `EDITS` edits to `text` (opened as `path`): each replaces the digit at
/// `digit` with the next one. Returns the sorted times.
fn round_trips(client: &mut Client, path: &Path, text: &str, digit: usize) -> Vec<Duration> {
    let uri = uri_of(path);
    client.open(&uri, text, 0);
    let clean = client.diagnostics(&uri, 0);
    let (line, character) = position(text, digit);
    let mut times = Vec::new();
    for version in 1..=EDITS as i64 {
        let start = json!({"line": line, "character": character});
        let end = json!({"line": line, "character": character + 1});
        let value = (version % 10).to_string();
        let began = Instant::now();
        client.notify(
            "textDocument/didChange",
            json!({
                "textDocument": {"uri": uri, "version": version},
                "contentChanges": [{"range": {"start": start, "end": end}, "text": value}],
            }),
        );
        let found = client.diagnostics(&uri, version);
        times.push(began.elapsed());
        assert_eq!(
            found.len(),
            clean.len(),
            "an edit of a digit changed the diagnostics"
        );
    }
    client.close(&uri);
    client.take_published_elsewhere(&uri);
    times.sort();
    times
}

fn report(name: &str, lines: usize, times: &[Duration]) {
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    println!(
        "{name:<42} {lines:>6} {:>10.2} {:>10.2}",
        ms(times[times.len() / 2]),
        ms(times[times.len() - 1])
    );
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().expect("a temporary folder");
    let mut client = Client::start();
    println!("felt lsp: edit → publishDiagnostics round trip, {EDITS} edits per script");
    println!(
        "{:<42} {:>6} {:>10} {:>10}",
        "script", "lines", "median ms", "max ms"
    );

    let text = generated(500);
    let path = dir.path().join("generated.felt");
    std::fs::write(&path, &text).expect("the generated script written");
    let check = std::process::Command::new(env!("CARGO_BIN_EXE_felt"))
        .arg("check")
        .arg(&path)
        .output()
        .expect("felt check runs");
    assert!(
        check.status.success(),
        "the generated script does not check clean"
    );
    // The `5` of `radius250 = 0.5`, in the middle of the script.
    let middle = text.find("radius250 = 0.5").expect("block 250") + "radius250 = 0.".len();
    let times = round_trips(&mut client, &path, &text, middle);
    report("generated (500 blocks)", text.lines().count(), &times);

    // A burst: edits written all at once, as queue up while a long check runs.
    let uri = uri_of(&path);
    client.open(&uri, &text, 0);
    client.diagnostics(&uri, 0);
    let burst = 50;
    for version in 1..=burst {
        let at = json!({"line": 0, "character": 0});
        client.notify(
            "textDocument/didChange",
            json!({
                "textDocument": {"uri": uri, "version": version},
                "contentChanges": [{"range": {"start": at, "end": at}, "text": " "}],
            }),
        );
    }
    client.diagnostics(&uri, burst);
    let checks = client
        .take_published_elsewhere("")
        .iter()
        .filter(|m| m["params"]["uri"] == uri.as_str() && m["params"]["version"].as_i64() > Some(0))
        .count()
        + 1;
    println!("a burst of {burst} edits sent at once to the generated script: {checks} check(s)");
    client.close(&uri);

    let mut examples: Vec<_> = std::fs::read_dir(root.join("examples"))
        .expect("examples/")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "felt"))
        .collect();
    examples.sort();
    for path in examples {
        let text = std::fs::read_to_string(&path).expect("an example");
        // The first digit outside a comment line.
        let digit = text
            .match_indices(|c: char| c.is_ascii_digit())
            .map(|(i, _)| i)
            .find(|&i| {
                let line_start = text[..i].rfind('\n').map_or(0, |n| n + 1);
                !text[line_start..i].contains("//")
            });
        let Some(digit) = digit else { continue };
        let times = round_trips(&mut client, &path, &text, digit);
        let name = path
            .strip_prefix(root)
            .unwrap_or(&path)
            .display()
            .to_string();
        report(&name, text.lines().count(), &times);
    }
    client.stop();
}
