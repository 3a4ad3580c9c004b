//! `felt doc`: the reference for builtins and standard-library functions, read from the same
//! registry the checker uses and from the doc comments (`//` lines directly above a `func`) of
//! the standard library, so what it prints is what the checker enforces.

use crate::base::suggest;
use crate::interp::registry::registry;
use crate::syntax::ast::Item;
use crate::syntax::span::FileId;
use std::collections::BTreeMap;
use std::process::ExitCode;

/// A standard-library function as documented: its signature and doc comment.
pub struct StdlibDoc {
    pub name: String,
    pub signature: String,
    pub doc: String,
    pub file: &'static str,
}

/// The documented functions of the standard library.
pub fn stdlib_docs() -> Vec<StdlibDoc> {
    let mut docs = Vec::new();
    for (file, text) in crate::session::STDLIB {
        let Ok(program) = crate::syntax::parse(FileId(0), text) else {
            continue;
        };
        for item in &program.items {
            let Item::Func(f) = item else { continue };
            let start = f.span.start as usize;
            let signature_end = text[start..].find('{').map(|i| start + i).unwrap_or(start);
            let signature = text[start..signature_end]
                .split_whitespace()
                .collect::<Vec<_>>()
                .join(" ");
            let signature = signature.trim_start_matches("func ").to_string();
            let comment: Vec<&str> = text[..start]
                .lines()
                .rev()
                .skip_while(|l| l.trim().is_empty())
                .take_while(|l| l.trim_start().starts_with("//"))
                .map(|l| l.trim_start().trim_start_matches('/').trim())
                .collect();
            let doc = comment.into_iter().rev().collect::<Vec<_>>().join(" ");
            docs.push(StdlibDoc {
                name: f.name.name.clone(),
                signature,
                doc,
                file,
            });
        }
    }
    docs
}

/// Prints one entry, or the whole index when `name` is `None`.
pub fn print(name: Option<&str>) -> ExitCode {
    match name {
        Some(name) => match describe(name) {
            Some(text) => {
                print!("{text}");
                ExitCode::SUCCESS
            }
            None => {
                let stdlib = stdlib_docs();
                let mut names: Vec<&str> = registry().names().collect();
                names.extend(stdlib.iter().map(|d| d.name.as_str()));
                let hint = suggest::closest(name, names.into_iter())
                    .map(|s| format!(" (did you mean `{s}`?)"))
                    .unwrap_or_default();
                eprintln!("felt doc: no builtin or library function named `{name}`{hint}");
                ExitCode::from(1)
            }
        },
        None => {
            print!("{}", index());
            ExitCode::SUCCESS
        }
    }
}

/// The documentation of one name, as `felt doc NAME` and the REPL's `:doc` show it.
pub fn describe(name: &str) -> Option<String> {
    if let Some(b) = registry().get(name) {
        let mut text = String::new();
        for form in b.forms() {
            text.push_str(&form);
            text.push('\n');
        }
        text.push_str(&format!("    {}\n", b.doc));
        if let Some(details) = &b.details {
            text.push_str(details);
        }
        return Some(text);
    }
    stdlib_docs().into_iter().find(|d| d.name == name).map(|d| {
        format!(
            "{}\n    {}\n    (standard library, {})\n",
            d.signature, d.doc, d.file
        )
    })
}

/// Every builtin by group, then the standard library.
pub fn index() -> String {
    let mut groups: BTreeMap<&str, Vec<String>> = BTreeMap::new();
    for b in registry().all() {
        groups
            .entry(b.group)
            .or_default()
            .push(format!("  {:<16} {}", b.name, b.doc));
    }
    let mut text = String::new();
    for (group, entries) in groups {
        text.push_str(&format!("{group}\n"));
        for e in entries {
            text.push_str(&e);
            text.push('\n');
        }
    }
    let stdlib = stdlib_docs();
    if !stdlib.is_empty() {
        text.push_str("standard library\n");
        for d in stdlib {
            text.push_str(&format!("  {:<16} {}\n", d.name, d.doc));
        }
    }
    text.push_str("\n`felt doc NAME` shows the forms of one entry.\n");
    text
}
