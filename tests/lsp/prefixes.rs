//! Half-typed text: the server is fed every prefix of every example and test script, cut at
//! each line end, and of a few scripts at every character, typed one character at a time as
//! ranged edits. Each prefix must get its diagnostics published, and hover and completion at
//! its end must be answered; the server must never stop. After the typed scripts, the
//! diagnostics of the buffer built by edits must equal those of the whole file opened at once.

use super::client::{Client, position, uri_of};
use super::scripts;
use serde_json::json;

/// Scripts typed character by character: one with strings, comments and a call with
/// keywords, one with functions and blocks, one whose string never ends.
const TYPED: &[&str] = &[
    "examples/first_cloud.felt",
    "tests/scripts/lang/functions.felt",
    "tests/scripts/errors/unterminated_string.felt",
];

/// Hover and completion at the end of the text, both answered (their content may be empty).
fn ask_at_end(client: &mut Client, uri: &str, text: &str) {
    let (line, character) = position(text, text.len());
    let at =
        json!({"textDocument": {"uri": uri}, "position": {"line": line, "character": character}});
    let hover = client.ask("textDocument/hover", at.clone());
    let completion = client.ask("textDocument/completion", at);
    client.answer(hover);
    client.answer(completion);
}

#[test]
fn every_prefix_of_every_script_is_answered() {
    let mut client = Client::start();
    let mut version = 0;
    let mut prefixes = 0;
    for path in scripts() {
        let text = std::fs::read_to_string(&path).unwrap();
        let uri = uri_of(&path);
        version += 1;
        client.open(&uri, "", version);
        client.diagnostics(&uri, version);
        let ends = text
            .match_indices('\n')
            .map(|(i, _)| i + 1)
            .chain([text.len()]);
        for end in ends {
            version += 1;
            client.replace(&uri, &text[..end], version);
            ask_at_end(&mut client, &uri, &text[..end]);
            client.diagnostics(&uri, version);
            prefixes += 1;
        }
        client.close(&uri);
        client.take_published_elsewhere(&uri);
    }
    assert!(prefixes > 1000, "only {prefixes} prefixes");
    client.stop();
}

#[test]
fn scripts_typed_a_character_at_a_time_end_as_opened_whole() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut client = Client::start();
    let mut version = 0;
    for script in TYPED {
        let path = root.join(script);
        let text = std::fs::read_to_string(&path).unwrap();
        let uri = uri_of(&path);
        version += 1;
        client.open(&uri, "", version);
        let mut typed = String::new();
        let mut typed_diagnostics = Vec::new();
        for c in text.chars() {
            let (line, character) = position(&typed, typed.len());
            let at = json!({"line": line, "character": character});
            typed.push(c);
            version += 1;
            client.notify(
                "textDocument/didChange",
                json!({
                    "textDocument": {"uri": uri, "version": version},
                    "contentChanges": [{"range": {"start": at, "end": at}, "text": c.to_string()}],
                }),
            );
            ask_at_end(&mut client, &uri, &typed);
            typed_diagnostics = client.diagnostics(&uri, version);
        }
        client.close(&uri);
        version += 1;
        client.open(&uri, &text, version);
        assert_eq!(
            client.diagnostics(&uri, version),
            typed_diagnostics,
            "{script}"
        );
        client.close(&uri);
        client.take_published_elsewhere(&uri);
    }
    client.stop();
}
