//! Completion: what may be typed at the cursor. Inside a string given to a parameter with a
//! fixed set of values (`shadows = "`, an AOV name), those values and nothing else. Elsewhere:
//! in a builtin's argument list, its keywords not yet given, with their types (and, for
//! `render`, the default and meaning from its keyword table); then the names in scope at the
//! cursor, the functions of imported files, every builtin and library function, and felt's
//! keywords and types. The lists come from the checker's signature table and the registry,
//! so what completion offers is what `felt check` accepts.

use super::definition::imported_functions;
use super::outline::{Kind, Outline, call_at, string_at};
use crate::interp::registry::{Param, registry};
use crate::render::keywords::KEYWORDS;
use lsp_types::{
    CompletionItem, CompletionItemKind, Documentation, InsertTextFormat, MarkupContent, MarkupKind,
};
use std::collections::BTreeSet;
use std::path::Path;
use std::sync::OnceLock;

const KEYWORDS_OF_FELT: &[&str] = &[
    "func",
    "param",
    "import",
    "if",
    "else",
    "for",
    "while",
    "return",
    "break",
    "continue",
    "true",
    "false",
    "int",
    "float",
    "bool",
    "string",
    "vector",
    "matrix",
    "scalarfield",
    "vectorfield",
    "matrixfield",
    "domain",
    "scalarcache",
    "vectorcache",
    "matrixcache",
    "shape",
    "particles",
    "camera",
    "light",
    "cloudsim",
    "void",
];

pub fn complete(path: &Path, text: &str, outline: &Outline, offset: usize) -> Vec<CompletionItem> {
    if let Some(quote) = string_at(text, offset) {
        return choices(text, quote);
    }
    let mut items = Vec::new();
    if let Some(call) = call_at(text, offset).filter(|c| c.at_keyword)
        && let Some(builtin) = registry().get(&call.callee)
    {
        let mut offered = BTreeSet::new();
        for param in builtin.signatures.iter().flat_map(|s| &s.params) {
            if call.given.contains(&param.name) || !offered.insert(param.name.clone()) {
                continue;
            }
            items.push(keyword_item(&call.callee, param));
        }
    }
    let mut named = BTreeSet::new();
    let mut in_scope: Vec<_> = outline.visible(offset).collect();
    // Innermost first, so a shadowing declaration is the one offered.
    in_scope.sort_by_key(|d| std::cmp::Reverse((d.depth, d.name_at.start)));
    let imported = imported_functions(path, outline);
    for d in in_scope.into_iter().chain(imported.iter()) {
        if !named.insert(d.name.clone()) {
            continue;
        }
        items.push(CompletionItem {
            label: d.name.clone(),
            kind: Some(match d.kind {
                Kind::Function => CompletionItemKind::FUNCTION,
                Kind::Param => CompletionItemKind::CONSTANT,
                Kind::Variable | Kind::Argument => CompletionItemKind::VARIABLE,
            }),
            detail: Some(d.text.clone()),
            sort_text: Some(format!("1{}", d.name)),
            ..CompletionItem::default()
        });
    }
    for builtin in registry().all() {
        if named.insert(builtin.name.to_string()) {
            items.push(CompletionItem {
                label: builtin.name.to_string(),
                kind: Some(CompletionItemKind::FUNCTION),
                detail: builtin.forms().into_iter().next(),
                documentation: Some(Documentation::String(builtin.doc.to_string())),
                sort_text: Some(format!("2{}", builtin.name)),
                ..CompletionItem::default()
            });
        }
    }
    for (name, signature, doc) in library() {
        if named.insert(name.clone()) {
            items.push(CompletionItem {
                label: name.clone(),
                kind: Some(CompletionItemKind::FUNCTION),
                detail: Some(signature.clone()),
                documentation: Some(Documentation::String(doc.clone())),
                sort_text: Some(format!("2{name}")),
                ..CompletionItem::default()
            });
        }
    }
    for keyword in KEYWORDS_OF_FELT {
        if named.insert(keyword.to_string()) {
            items.push(CompletionItem {
                label: keyword.to_string(),
                kind: Some(CompletionItemKind::KEYWORD),
                sort_text: Some(format!("3{keyword}")),
                ..CompletionItem::default()
            });
        }
    }
    items
}

/// A keyword argument: `name = `, with its type, and what render's table says of it.
fn keyword_item(callee: &str, param: &Param) -> CompletionItem {
    let optional = if param.optional { " (optional)" } else { "" };
    let row = (callee == "render")
        .then(|| KEYWORDS.iter().find(|k| k.name == param.name))
        .flatten();
    let documentation = row.map(|k| {
        Documentation::MarkupContent(MarkupContent {
            kind: MarkupKind::Markdown,
            value: format!("{} (default: {})", k.doc, k.default),
        })
    });
    CompletionItem {
        label: param.name.clone(),
        kind: Some(CompletionItemKind::FIELD),
        detail: Some(format!("{}{optional}", param.ty)),
        documentation,
        insert_text: Some(format!("{} = ", param.name)),
        insert_text_format: Some(InsertTextFormat::PLAIN_TEXT),
        sort_text: Some(format!("0{}", param.name)),
        ..CompletionItem::default()
    }
}

/// The values allowed in the string that opens at `quote`, when it is an argument with a
/// fixed set of them.
fn choices(text: &str, quote: usize) -> Vec<CompletionItem> {
    let Some(call) = call_at(text, quote) else {
        return Vec::new();
    };
    let Some(builtin) = registry().get(&call.callee) else {
        return Vec::new();
    };
    let param = builtin.signatures.iter().find_map(|s| match &call.keyword {
        Some(keyword) => s.params.iter().find(|p| &p.name == keyword),
        None => s.params.get(call.argument),
    });
    let Some(choices) = param.and_then(|p| p.choices.as_ref()) else {
        return Vec::new();
    };
    choices
        .values
        .iter()
        .enumerate()
        .map(|(i, value)| CompletionItem {
            label: value.to_string(),
            kind: Some(CompletionItemKind::ENUM_MEMBER),
            detail: Some(choices.noun.to_string()),
            sort_text: Some(format!("{i:03}")),
            ..CompletionItem::default()
        })
        .collect()
}

/// The standard library's functions: name, signature, doc line.
pub fn library() -> &'static [(String, String, String)] {
    static LIBRARY: OnceLock<Vec<(String, String, String)>> = OnceLock::new();
    LIBRARY.get_or_init(|| {
        crate::app::doc::stdlib_docs()
            .into_iter()
            .map(|d| (d.name, d.signature, d.doc))
            .collect()
    })
}
