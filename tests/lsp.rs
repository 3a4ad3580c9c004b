//! `felt lsp` driven as an editor drives it: a subprocess spoken to in JSON-RPC over its stdio.
//! What it says is compared with what the command line says: its diagnostics with `felt
//! check`'s on every script of the project, its hover with `felt doc`, its completions with the
//! checker's own lists of allowed values and arguments.

#[path = "lsp/client.rs"]
mod client;
#[path = "lsp/neovim.rs"]
mod neovim;
#[path = "lsp/prefixes.rs"]
mod prefixes;

use client::{Client, position, uri_of};
use serde_json::{Value, json};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

fn felt(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_felt"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

/// Every `.felt` file under the project's examples and test scripts, in a fixed order.
pub fn scripts() -> Vec<PathBuf> {
    fn walk(dir: &Path, found: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                walk(&path, found);
            } else if path.extension().is_some_and(|e| e == "felt") {
                found.push(path);
            }
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut found = Vec::new();
    walk(&root.join("examples"), &mut found);
    walk(&root.join("tests/scripts"), &mut found);
    found.sort();
    found
}

/// One diagnostic as (file URI, line, UTF-16 column, end column on the same line, message
/// without whitespace): whitespace goes because `felt check` wraps long messages.
type Found = (String, usize, usize, Option<usize>, String);

fn squeeze(text: &str) -> String {
    text.split_whitespace().collect()
}

/// The diagnostics `felt check FILE` prints, read back from its text: each `×` or `⚠` line
/// (and its wrapped continuation), the `[file:line:col]` after it (the column counted in
/// bytes), and the width of the underline miette draws under a one-line span (in characters).
fn felt_check(file: &Path) -> Vec<Found> {
    let output = felt(&["check", file.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&output.stderr).into_owned();
    let lines: Vec<&str> = text.lines().collect();
    let mut found = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let trimmed = lines[i].trim_start();
        let Some(first) = trimmed
            .strip_prefix("× ")
            .or_else(|| trimmed.strip_prefix("⚠ "))
        else {
            i += 1;
            continue;
        };
        let mut message = first.to_string();
        i += 1;
        while i < lines.len()
            && !lines[i].contains("╭─[")
            && !lines[i].trim().is_empty()
            && !lines[i].trim_start().starts_with("help:")
        {
            // A wrapped line is indented under a `│` in the left margin.
            message.push(' ');
            message.push_str(lines[i].trim().trim_start_matches('│'));
            i += 1;
        }
        let Some(header) = lines.get(i).filter(|l| l.contains("╭─[")) else {
            // No place: the server puts it at the buffer's start.
            found.push((uri_of(file), 0, 0, Some(0), squeeze(&message)));
            continue;
        };
        let place = header.split("╭─[").nth(1).unwrap().trim_end_matches(']');
        let mut parts = place.rsplitn(3, ':');
        let column: usize = parts.next().unwrap().parse().unwrap();
        let line: usize = parts.next().unwrap().parse().unwrap();
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(parts.next().unwrap());
        let path = clean(&path);
        let source = std::fs::read_to_string(&path).unwrap_or_default();
        let source_line = source.lines().nth(line - 1).unwrap_or("");
        // miette prints the column in bytes from the line's start.
        let byte = (column - 1).min(source_line.len());
        let start = source_line[..byte].encode_utf16().count();
        // The underline: the first run of `─┬` below the header, as wide as the span.
        let width = lines[i + 1..]
            .iter()
            .take_while(|l| !l.contains("╰────"))
            .find(|l| l.trim_start().starts_with('·') && l.contains(['─', '┬']))
            .map(|l| {
                let run: String = l
                    .chars()
                    .skip_while(|c| !matches!(c, '─' | '┬'))
                    .take_while(|c| matches!(c, '─' | '┬'))
                    .collect();
                run.chars().count()
            });
        let end = width.map(|w| {
            let span: usize = source_line[byte..]
                .chars()
                .take(w)
                .map(char::len_utf16)
                .sum();
            start + span
        });
        found.push((uri_of(&path), line - 1, start, end, squeeze(&message)));
        i += 1;
    }
    found
}

/// `.` and `..` taken out of a path by name.
fn clean(path: &Path) -> PathBuf {
    let mut clean = PathBuf::new();
    for part in path.components() {
        match part {
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir => {
                clean.pop();
            }
            other => clean.push(other),
        }
    }
    clean
}

/// What the server published, in the same form: each diagnostic and each of its related
/// places (which `felt check` prints as diagnostics of their own).
fn published(uri: &str, diagnostics: &[Value], found: &mut Vec<Found>) {
    for d in diagnostics {
        let message = d["message"].as_str().unwrap();
        let message = message.split("\nhelp: ").next().unwrap();
        let range = &d["range"];
        let line = range["start"]["line"].as_u64().unwrap() as usize;
        let end = (range["end"]["line"] == range["start"]["line"])
            .then(|| range["end"]["character"].as_u64().unwrap() as usize);
        let start = range["start"]["character"].as_u64().unwrap() as usize;
        found.push((uri.to_string(), line, start, end, squeeze(message)));
        for related in d["relatedInformation"].as_array().into_iter().flatten() {
            let location = &related["location"];
            let related_range = &location["range"];
            found.push((
                location["uri"].as_str().unwrap().to_string(),
                related_range["start"]["line"].as_u64().unwrap() as usize,
                related_range["start"]["character"].as_u64().unwrap() as usize,
                (related_range["end"]["line"] == related_range["start"]["line"])
                    .then(|| related_range["end"]["character"].as_u64().unwrap() as usize),
                squeeze(related["message"].as_str().unwrap()),
            ));
        }
    }
}

/// Compares diagnostics as sets; an end column is compared only where both sides know it
/// and the span is not empty (miette draws an empty span as wide as one character).
fn same(mut expected: Vec<Found>, mut actual: Vec<Found>) -> Result<(), String> {
    let key = |f: &Found| (f.0.clone(), f.1, f.2, f.4.clone());
    expected.sort_by_key(key);
    actual.sort_by_key(key);
    let expected_keys: Vec<_> = expected.iter().map(key).collect();
    let actual_keys: Vec<_> = actual.iter().map(key).collect();
    if expected_keys != actual_keys {
        return Err(format!(
            "felt check: {expected_keys:#?}\nfelt lsp: {actual_keys:#?}"
        ));
    }
    for (e, a) in expected.iter().zip(&actual) {
        if let (Some(e_end), Some(a_end)) = (e.3, a.3)
            && a_end > a.2
            && e_end != a_end
        {
            return Err(format!(
                "{a:?} ends at {a_end}, felt check underlines to {e_end}"
            ));
        }
    }
    Ok(())
}

#[test]
fn diagnostics_are_felt_checks_on_every_script() {
    let mut client = Client::start();
    let mut failures = Vec::new();
    let scripts = scripts();
    assert!(scripts.len() > 50, "found only {} scripts", scripts.len());
    for (n, path) in scripts.iter().enumerate() {
        let relative = path.strip_prefix(env!("CARGO_MANIFEST_DIR")).unwrap();
        let expected = felt_check(relative);
        let uri = uri_of(path);
        let text = std::fs::read_to_string(path).unwrap();
        let version = n as i64 + 1;
        client.open(&uri, &text, version);
        let own = client.diagnostics(&uri, version);
        let mut actual = Vec::new();
        published(&uri, &own, &mut actual);
        for other in client.take_published_elsewhere(&uri) {
            let params = &other["params"];
            let list = params["diagnostics"].as_array().unwrap();
            published(params["uri"].as_str().unwrap(), list, &mut actual);
        }
        client.close(&uri);
        if let Err(e) = same(expected, actual) {
            failures.push(format!("{}:\n{e}", relative.display()));
        }
    }
    client.stop();
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn a_place_after_wide_characters_is_counted_in_utf16() {
    // `𝜌` is one character, four bytes and two UTF-16 units; `felt check` counts bytes.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("wide.felt");
    let text = "string s = \"𝜌°\"; float a = \"text\";\n";
    std::fs::write(&path, text).unwrap();
    let expected = felt_check(&path);
    assert_eq!(expected.len(), 1, "{expected:?}");
    let mut client = Client::start();
    let uri = uri_of(&path);
    client.open(&uri, text, 1);
    let mut actual = Vec::new();
    published(&uri, &client.diagnostics(&uri, 1), &mut actual);
    client.stop();
    same(expected.clone(), actual).unwrap();
    let offset = text.find("\"text\"").unwrap();
    assert_eq!((expected[0].1, expected[0].2), position(text, offset));
}

/// The hover text of `name` at its first use in `text`, fences taken off.
fn hover_at(client: &mut Client, uri: &str, text: &str, name: &str) -> String {
    let offset = text.find(name).unwrap() + 1;
    let (line, character) = position(text, offset);
    let hover = client.at("textDocument/hover", uri, line, character);
    hover["contents"]["value"].as_str().unwrap().to_string()
}

#[test]
fn hover_shows_felt_doc_for_builtins_and_declarations_for_names() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.felt");
    let text = "param float radius = 0.8;   // the sphere\n\
                // A bumpy sphere.\n\
                func scalarfield ball(float r) { return r - length(identity()) + perlin(identity()); }\n\
                scalarfield d = ball(radius);\n\
                render(\"a.exr\", density = d, kappa = 2.0);\n";
    std::fs::write(&path, text).unwrap();
    let uri = uri_of(&path);
    let mut client = Client::start();
    client.open(&uri, text, 1);
    for builtin in ["perlin", "length"] {
        let doc = String::from_utf8(felt(&["doc", builtin]).stdout).unwrap();
        let hover = hover_at(&mut client, &uri, text, &format!("{builtin}("));
        assert_eq!(hover, format!("```text\n{doc}```"), "hover on `{builtin}`");
    }
    let param = hover_at(&mut client, &uri, text, "radius);");
    assert!(
        param.starts_with("```felt\nparam float radius = 0.8\n```"),
        "{param}"
    );
    assert!(param.contains("default `0.8`"), "{param}");
    let function = hover_at(&mut client, &uri, text, "ball(radius");
    assert!(
        function.starts_with("```felt\nfunc scalarfield ball(float r)\n```"),
        "{function}"
    );
    assert!(function.ends_with("A bumpy sphere."), "{function}");
    let variable = hover_at(&mut client, &uri, text, "d =");
    assert!(
        variable.ends_with("variable `d`: scalarfield"),
        "{variable}"
    );
    // A keyword argument: its types in render's forms, and its row of `felt doc render`.
    let render = String::from_utf8(felt(&["doc", "render"]).stdout).unwrap();
    let row = render
        .lines()
        .map(str::trim)
        .find(|l| l.starts_with("kappa "))
        .unwrap();
    let kappa = hover_at(&mut client, &uri, text, "kappa");
    assert_eq!(
        kappa,
        format!("argument `kappa` of `render`: float? or vector?\n```text\n{row}\n```")
    );
    let density = hover_at(&mut client, &uri, text, "density =");
    assert!(
        density.starts_with("argument `density` of `render`: scalarfield"),
        "{density}"
    );
    client.stop();
}

/// The labels of a completion answer.
fn labels(answer: &Value) -> Vec<String> {
    answer
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["label"].as_str().unwrap().to_string())
        .collect()
}

/// The quoted words of a help line: `"cache", "march" or "sweep"`.
fn quoted(help: &str) -> Vec<String> {
    help.split('"')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

#[test]
fn completion_offers_option_strings_keywords_and_names_in_scope() {
    // The allowed values and render's arguments as `felt check` lists them in its help.
    let check = |script: &str| {
        let output = felt(&["check", script]);
        let text = String::from_utf8_lossy(&output.stderr).into_owned();
        let help = text.split("help: ").nth(1).unwrap().to_string();
        help.split_whitespace().collect::<Vec<_>>().join(" ")
    };
    let shadows = quoted(&check("tests/scripts/errors/unknown_shadows_mode.felt"));
    let arguments = check("tests/scripts/errors/unknown_keyword.felt");
    let arguments: BTreeSet<String> = arguments
        .trim_start_matches("the arguments of `render` are ")
        .split(", ")
        .map(str::to_string)
        .collect();
    assert!(
        shadows.len() >= 3 && arguments.len() > 20,
        "{shadows:?} {arguments:?}"
    );

    let mut client = Client::start();
    let uri = "file:///nowhere/complete.felt";
    let text = "float inner = 1.0;\nfunc float f(float x) { float hidden = x; return hidden; }\n\
                render(\"out.exr\", density = scalarfield(inner), shadows = \"";
    client.open(uri, text, 1);
    let (line, end) = position(text, text.len());
    let values = labels(&client.at("textDocument/completion", uri, line, end));
    assert_eq!(values, shadows);

    let before_shadows = text.rfind("shadows").unwrap();
    let (line, character) = position(text, before_shadows);
    let offered = labels(&client.at("textDocument/completion", uri, line, character));
    let keywords: BTreeSet<String> = offered
        .iter()
        .filter(|l| arguments.contains(*l))
        .cloned()
        .collect();
    // Every argument not given yet; `density` is given.
    let mut wanted = arguments.clone();
    wanted.remove("density");
    assert_eq!(keywords, wanted);
    assert!(offered.contains(&"inner".to_string()));
    assert!(offered.contains(&"f".to_string()));
    assert!(
        !offered.contains(&"hidden".to_string()),
        "a name out of its scope"
    );
    assert!(offered.contains(&"perlin".to_string()));
    client.stop();
}

#[test]
fn signature_help_definition_and_symbols() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("lib.felt"),
        "func float twice(float x) { return 2 * x; }\n",
    )
    .unwrap();
    let path = dir.path().join("main.felt");
    let text = "import \"lib.felt\";\nparam int frame = 1;\n\
                func float half(float y) { return y / 2; }\n\
                float a = clamp(0.5, twice(half(frame)), 1.0);\n";
    std::fs::write(&path, text).unwrap();
    let uri = uri_of(&path);
    let mut client = Client::start();
    client.open(&uri, text, 1);

    let after = |s: &str| position(text, text.find(s).unwrap() + s.len());
    let (line, character) = after("clamp(0.5, ");
    let help = client.at("textDocument/signatureHelp", &uri, line, character);
    let doc = String::from_utf8(felt(&["doc", "clamp"]).stdout).unwrap();
    let forms: Vec<&str> = doc.lines().filter(|l| l.starts_with("clamp(")).collect();
    let labels: Vec<&str> = help["signatures"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["label"].as_str().unwrap())
        .collect();
    assert_eq!(labels, forms);
    assert_eq!(help["signatures"][0]["activeParameter"], 1);
    let (line, character) = after("twice(");
    let help = client.at("textDocument/signatureHelp", &uri, line, character);
    assert_eq!(help["signatures"][0]["label"], "float twice(float x)");

    let (line, character) = after("half(fr");
    let definition = client.at("textDocument/definition", &uri, line, character);
    let declared = position(text, text.find("frame =").unwrap());
    assert_eq!(definition["uri"], uri);
    assert_eq!(
        definition["range"]["start"],
        json!({"line": declared.0, "character": declared.1})
    );
    let (line, character) = after("tw");
    let definition = client.at("textDocument/definition", &uri, line, character);
    assert_eq!(definition["uri"], uri_of(&dir.path().join("lib.felt")));
    assert_eq!(
        definition["range"]["start"],
        json!({"line": 0, "character": 11})
    );
    let (line, character) = after("import \"li");
    let definition = client.at("textDocument/definition", &uri, line, character);
    assert_eq!(definition["uri"], uri_of(&dir.path().join("lib.felt")));

    let symbols = client.request(
        "textDocument/documentSymbol",
        json!({"textDocument": {"uri": uri}}),
    );
    let outline: Vec<(String, u64)> = symbols
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            (
                s["name"].as_str().unwrap().to_string(),
                s["kind"].as_u64().unwrap(),
            )
        })
        .collect();
    // Constant 14 for a param, Function 12, Variable 13.
    let expected = [("frame", 14), ("half", 12), ("a", 13)];
    let expected: Vec<(String, u64)> = expected.iter().map(|(n, k)| (n.to_string(), *k)).collect();
    assert_eq!(outline, expected);
    assert_eq!(symbols[1]["children"][0]["name"], "y");
    client.stop();
}

#[test]
fn edits_are_applied_and_a_burst_ends_checked_at_its_last_text() {
    let mut client = Client::start();
    let uri = "file:///nowhere/edits.felt";
    client.open(uri, "float a = 1.0;\n", 1);
    assert!(client.diagnostics(uri, 1).is_empty());
    // Twenty keystrokes sent at once, each a ranged insertion at the end of line 0, typing
    // ` + "s"` one character at a time; only the last text has to be checked.
    let typed = " + \"s\"";
    let mut version = 1;
    for (i, c) in typed.chars().enumerate() {
        version += 1;
        let at = json!({"line": 0, "character": 13 + i});
        client.notify(
            "textDocument/didChange",
            json!({
                "textDocument": {"uri": uri, "version": version},
                "contentChanges": [{"range": {"start": at, "end": at}, "text": c.to_string()}],
            }),
        );
    }
    let last = client.diagnostics(uri, version);
    assert_eq!(last.len(), 1, "{last:?}");
    let message = last[0]["message"].as_str().unwrap();
    assert!(
        message.contains("float") && message.contains("string"),
        "{message}"
    );
    client.stop();
}
