//! The editor grammars in `editors/` agree with felt.
//!
//! felt's own parser is the judge throughout. Without any tool beyond Rust: every corpus test
//! of the tree-sitter grammar is a script felt's parser accepts, or, for those marked
//! `:error`, one it rejects; and the VS Code extension's TextMate grammar is valid JSON whose
//! lists of builtins and library functions are exactly the ones felt has now. Opt-in with
//! `FELT_PEER_TESTS=1` and the `tree-sitter` CLI on PATH: `tree-sitter generate` reproduces
//! the committed parser, the corpus passes, and every `.felt` file of the repository parses
//! without an ERROR or MISSING node exactly when felt's parser accepts it.

#[path = "tree_sitter/support.rs"]
mod support;

use felt::syntax::parse;
use felt::syntax::span::FileId;
use std::collections::BTreeSet;
use std::path::Path;
use std::process::Command;
use support::{copy_grammar, corpus, felt_files, grammar_dir, root, tree_has_error};

fn json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{} is not JSON: {e}", path.display()))
}

fn felt_accepts(source: &str) -> Result<(), String> {
    parse(FileId(0), source)
        .map(|_| ())
        .map_err(|errors| errors[0].message.clone())
}

#[test]
fn every_corpus_test_is_accepted_or_rejected_by_felts_parser_as_marked() {
    let entries = corpus();
    assert!(entries.len() >= 40, "only {} corpus tests", entries.len());
    for entry in &entries {
        let verdict = felt_accepts(&entry.input);
        match (entry.error, verdict) {
            (false, Err(message)) => panic!(
                "{} `{}`: felt's parser rejects it ({message}) but the corpus expects a tree",
                entry.file, entry.name
            ),
            (true, Ok(())) => panic!(
                "{} `{}`: marked :error but felt's parser accepts it",
                entry.file, entry.name
            ),
            _ => {}
        }
    }
}

/// The names in a `\b(?:a|b|c)\b(?=\s*\()` pattern of the TextMate grammar.
fn names_in_call_pattern(grammar: &serde_json::Value, entry: &str) -> BTreeSet<String> {
    let pattern = grammar["repository"][entry]["match"]
        .as_str()
        .unwrap_or_else(|| panic!("the TextMate grammar has no `{entry}` match"));
    let inner = pattern
        .strip_prefix(r"\b(?:")
        .and_then(|p| p.strip_suffix(r")\b(?=\s*\()"))
        .unwrap_or_else(|| panic!("`{entry}` is not a list of names: {pattern}"));
    inner.split('|').map(str::to_string).collect()
}

#[test]
fn the_textmate_grammar_lists_exactly_felts_builtins_and_library_functions() {
    let vscode = root().join("editors/vscode");
    let grammar = json(&vscode.join("syntaxes/felt.tmLanguage.json"));
    assert_eq!(grammar["scopeName"], "source.felt");
    let builtins: BTreeSet<String> = felt::interp::registry::registry()
        .names()
        .map(str::to_string)
        .collect();
    let library: BTreeSet<String> = felt::app::doc::stdlib_docs()
        .into_iter()
        .map(|d| d.name)
        .collect();
    let regenerate = "regenerate with `node editors/vscode/scripts/update-builtins.js`";
    assert_eq!(
        names_in_call_pattern(&grammar, "builtin-functions"),
        builtins,
        "builtins differ; {regenerate}"
    );
    assert_eq!(
        names_in_call_pattern(&grammar, "library-functions"),
        library,
        "library functions differ; {regenerate}"
    );
}

/// The words the TextMate grammar colours as keywords and types, and the keywords of the
/// tree-sitter grammar, are keywords to felt's lexer, not names.
#[test]
fn the_editor_grammars_keywords_are_felts_keywords() {
    use felt::syntax::lexer::{Token, tokenize};
    let grammar = json(&root().join("editors/vscode/syntaxes/felt.tmLanguage.json"));
    let repository = &grammar["repository"];
    let mut patterns = vec![repository["types"]["match"].clone()];
    patterns.extend(
        repository["keywords"]["patterns"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|p| p["match"].clone()),
    );
    let mut words = BTreeSet::new();
    for pattern in &patterns {
        let pattern = pattern.as_str().expect("a match pattern");
        let inner = pattern
            .trim_start_matches(r"\b(?:")
            .trim_start_matches(r"\b");
        let inner = inner.trim_end_matches(r"\b").trim_end_matches(')');
        words.extend(inner.split('|').map(str::to_string));
    }
    let tree_sitter = json(&grammar_dir().join("src/grammar.json"));
    let mut strings = Vec::new();
    collect_strings(&tree_sitter["rules"], &mut strings);
    words.extend(
        strings
            .into_iter()
            .filter(|s| s.chars().all(|c| c.is_ascii_alphabetic())),
    );
    assert!(words.len() >= 30, "{words:?}");
    for word in &words {
        let (tokens, errors) = tokenize(FileId(0), word);
        assert!(errors.is_empty(), "{word}: {errors:?}");
        assert!(
            tokens.len() == 1 && !matches!(tokens[0].1, Token::Ident(_)),
            "`{word}` is not a keyword of felt's lexer"
        );
    }
}

/// Every `"type": "STRING"` value of a tree-sitter grammar.json.
fn collect_strings(rule: &serde_json::Value, out: &mut Vec<String>) {
    match rule {
        serde_json::Value::Object(map) => {
            if map.get("type").and_then(|t| t.as_str()) == Some("STRING")
                && let Some(value) = map.get("value").and_then(|v| v.as_str())
            {
                out.push(value.to_string());
            }
            map.values().for_each(|v| collect_strings(v, out));
        }
        serde_json::Value::Array(items) => items.iter().for_each(|v| collect_strings(v, out)),
        _ => {}
    }
}

/// Every kind of node the grammar makes appears in some corpus test's expected tree.
#[test]
fn the_corpus_covers_every_node_of_the_grammar() {
    let node_types = json(&grammar_dir().join("src/node-types.json"));
    let mut trees = String::new();
    for entry in std::fs::read_dir(grammar_dir().join("test/corpus"))
        .expect("corpus")
        .flatten()
    {
        trees.push_str(&std::fs::read_to_string(entry.path()).expect("corpus file"));
    }
    let mut uncovered = Vec::new();
    for node in node_types.as_array().expect("a list of node types") {
        let name = node["type"].as_str().expect("type");
        // Hidden supertypes never appear in a tree.
        if node["named"] == true && !name.starts_with('_') {
            let shown = [format!("({name})"), format!("({name}\n")];
            if !shown.iter().any(|s| trees.contains(s.as_str())) {
                uncovered.push(name.to_string());
            }
        }
    }
    assert!(uncovered.is_empty(), "no corpus test shows {uncovered:?}");
}

#[test]
fn the_vscode_extension_declares_what_it_uses() {
    let vscode = root().join("editors/vscode");
    let package = json(&vscode.join("package.json"));
    assert!(
        vscode
            .join(package["main"].as_str().expect("main"))
            .is_file()
    );
    assert!(package["dependencies"]["vscode-languageclient"].is_string());
    let language = &package["contributes"]["languages"][0];
    assert_eq!(language["id"], "felt");
    assert_eq!(language["extensions"][0], ".felt");
    let configuration = language["configuration"].as_str().expect("configuration");
    let configuration = json(&vscode.join(configuration));
    assert_eq!(configuration["comments"]["lineComment"], "//");
    let grammar = &package["contributes"]["grammars"][0];
    assert_eq!(grammar["scopeName"], "source.felt");
    assert!(
        vscode
            .join(grammar["path"].as_str().expect("path"))
            .is_file()
    );
    assert!(package["contributes"]["configuration"]["properties"]["felt.path"].is_object());
    let extension = std::fs::read_to_string(vscode.join("extension.js")).expect("extension.js");
    for used in [
        "vscode-languageclient/node",
        "args: ['lsp']",
        "getConfiguration('felt').get('path')",
    ] {
        assert!(extension.contains(used), "extension.js does not use {used}");
    }
}

/// The `tree-sitter` CLI, when the opt-in tests are asked for and it is installed.
fn tree_sitter_cli() -> Option<String> {
    if std::env::var("FELT_PEER_TESTS").as_deref() != Ok("1") {
        eprintln!("skipped: set FELT_PEER_TESTS=1 to check the grammar with the tree-sitter CLI");
        return None;
    }
    match Command::new("tree-sitter").arg("--version").output() {
        Ok(out) if out.status.success() => {
            Some(String::from_utf8_lossy(&out.stdout).trim().to_string())
        }
        _ => {
            eprintln!(
                "skipped: the tree-sitter CLI is not installed \
                 (cargo install tree-sitter-cli --locked)"
            );
            None
        }
    }
}

fn run_tree_sitter(dir: &Path, args: &[&str]) -> std::process::Output {
    Command::new("tree-sitter")
        .args(args)
        .current_dir(dir)
        // Compiled parsers go to the temporary folder, not the user's cache.
        .env("TREE_SITTER_LIBDIR", dir.join("lib"))
        .output()
        .unwrap_or_else(|e| panic!("tree-sitter {args:?}: {e}"))
}

/// Opt-in: generate, the corpus, and every script of the repository, against felt's parser.
#[test]
fn the_tree_sitter_grammar_parses_what_felt_parses() {
    let Some(version) = tree_sitter_cli() else {
        return;
    };
    let dir = tempfile::tempdir().expect("temporary folder");
    let copy = dir.path().join("tree-sitter-felt");
    copy_grammar(&grammar_dir(), &copy);

    // `generate` writes src/ in place: into the copy, to compare with what is committed.
    // At the ABI version the committed parser was generated for.
    let committed = std::fs::read_to_string(grammar_dir().join("src/parser.c")).expect("parser.c");
    let abi = committed
        .lines()
        .find_map(|l| l.strip_prefix("#define LANGUAGE_VERSION "))
        .expect("parser.c defines LANGUAGE_VERSION")
        .trim()
        .to_string();
    let generated = run_tree_sitter(&copy, &["generate", "--abi", &abi]);
    assert!(
        generated.status.success(),
        "tree-sitter generate: {}",
        String::from_utf8_lossy(&generated.stderr)
    );
    for file in ["grammar.json", "node-types.json"] {
        let committed = std::fs::read_to_string(grammar_dir().join("src").join(file)).expect(file);
        let fresh = std::fs::read_to_string(copy.join("src").join(file)).expect(file);
        assert!(
            committed == fresh,
            "src/{file} is not what grammar.js generates; run `tree-sitter generate` in editors/tree-sitter-felt"
        );
    }
    // parser.c differs between CLI versions: it is compared when this CLI is the one the
    // grammar's package.json names.
    let package = json(&grammar_dir().join("package.json"));
    let pinned = package["devDependencies"]["tree-sitter-cli"]
        .as_str()
        .expect("CLI version");
    if version.split_whitespace().nth(1) == Some(pinned) {
        let fresh = std::fs::read_to_string(copy.join("src/parser.c")).expect("parser.c");
        assert!(
            committed == fresh,
            "src/parser.c is not what grammar.js generates; \
             run `tree-sitter generate --abi {abi}` in editors/tree-sitter-felt"
        );
    } else {
        eprintln!(
            "{version} is not the CLI {pinned} that generated src/parser.c; \
             compared grammar.json and node-types.json only"
        );
    }

    let tested = run_tree_sitter(&copy, &["test"]);
    assert!(
        tested.status.success(),
        "tree-sitter test:\n{}{}",
        String::from_utf8_lossy(&tested.stdout),
        String::from_utf8_lossy(&tested.stderr)
    );

    let mut rejected = Vec::new();
    let mut disagreements = Vec::new();
    let files = felt_files();
    assert!(files.len() >= 50, "only {} scripts found", files.len());
    for file in &files {
        let source = std::fs::read_to_string(file).expect("script");
        let parsed = run_tree_sitter(&copy, &["parse", &file.display().to_string()]);
        let tree = String::from_utf8_lossy(&parsed.stdout);
        let name = file
            .strip_prefix(root())
            .unwrap_or(file)
            .display()
            .to_string();
        match (felt_accepts(&source), tree_has_error(&tree)) {
            (Ok(()), true) => {
                let errors: Vec<&str> = tree.lines().filter(|l| tree_has_error(l)).collect();
                disagreements.push(format!(
                    "{name}: felt parses it, tree-sitter finds an error:\n{}",
                    errors.join("\n")
                ))
            }
            (Err(message), false) => disagreements.push(format!(
                "{name}: felt rejects it ({message}), tree-sitter finds no error"
            )),
            (Err(_), true) => rejected.push(name),
            (Ok(()), false) => {}
        }
    }
    assert!(disagreements.is_empty(), "{}", disagreements.join("\n"));
    // The error scripts that are syntax errors, so the cross-check above saw some.
    assert!(rejected.len() >= 3, "{rejected:?}");
    eprintln!(
        "{} scripts agree; felt's parser and tree-sitter both reject {rejected:?}",
        files.len()
    );
}

/// Opt-in: every script of the repository cut after each of its lines, a few thousand
/// mostly unfinished files, is rejected by tree-sitter exactly when felt's parser rejects it.
#[test]
fn tree_sitter_and_felt_agree_on_every_line_prefix_of_every_script() {
    let Some(_) = tree_sitter_cli() else {
        return;
    };
    let dir = tempfile::tempdir().expect("temporary folder");
    let copy = dir.path().join("tree-sitter-felt");
    copy_grammar(&grammar_dir(), &copy);
    let prefixes = dir.path().join("prefixes");
    std::fs::create_dir(&prefixes).expect("prefix folder");
    let mut verdicts = Vec::new();
    for file in felt_files() {
        let source = std::fs::read_to_string(&file).expect("script");
        let mut end = 0;
        for line in source.split_inclusive('\n') {
            end += line.len();
            let path = prefixes.join(format!("{}.felt", verdicts.len()));
            std::fs::write(&path, &source[..end]).expect("prefix");
            let name = format!(
                "{}:{}",
                file.strip_prefix(root()).unwrap_or(&file).display(),
                source[..end].lines().count()
            );
            verdicts.push((path, name, felt_accepts(&source[..end]).is_ok()));
        }
    }
    let list = dir.path().join("paths.txt");
    let paths: Vec<String> = verdicts
        .iter()
        .map(|(p, _, _)| p.display().to_string())
        .collect();
    std::fs::write(&list, paths.join("\n")).expect("path list");
    let parsed = run_tree_sitter(
        &copy,
        &["parse", "--quiet", "--paths", &list.display().to_string()],
    );
    let report = String::from_utf8_lossy(&parsed.stdout);
    // In quiet mode tree-sitter prints one line for each file with an error.
    let with_error: BTreeSet<&str> = report
        .lines()
        .filter(|l| tree_has_error(l))
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    let mut disagreements = Vec::new();
    for (path, name, accepted) in &verdicts {
        let flagged = with_error.contains(path.display().to_string().as_str());
        if *accepted == flagged {
            disagreements.push(format!(
                "{name}: felt {}, tree-sitter {}",
                if *accepted { "accepts" } else { "rejects" },
                if flagged {
                    "finds an error"
                } else {
                    "finds none"
                }
            ));
        }
    }
    let rejected = verdicts.iter().filter(|(_, _, accepted)| !accepted).count();
    eprintln!(
        "{} prefixes: both reject {rejected}, tree-sitter flags {}",
        verdicts.len(),
        with_error.len()
    );
    assert!(rejected > 500 && with_error.len() == rejected);
    assert!(
        disagreements.is_empty(),
        "{} of {} prefixes:\n{}",
        disagreements.len(),
        verdicts.len(),
        disagreements.join("\n")
    );
}
