//! Hover: what a name under the cursor is. A builtin's keyword argument shows its type and
//! its line of `felt doc` (render's keyword table); a name the script declares shows its
//! declaration as written (a `param` with its default, a variable with its type, a function
//! with its signature and the comment above it), found in the buffer or in a file it imports;
//! any other name shows what `felt doc NAME` prints for a builtin or library function, from
//! the same text (`crate::app::doc::describe`), so the two never differ.

use super::definition::imported_function;
use super::outline::{Declaration, Kind, Outline, call_at, word_at};
use crate::interp::registry::registry;
use lsp_types::{Hover, HoverContents, MarkupContent, MarkupKind};
use std::ops::Range;
use std::path::Path;

pub fn hover(path: &Path, text: &str, outline: &Outline, offset: usize) -> Option<Hover> {
    let (at, name) = word_at(text, offset)?;
    let value = match keyword_argument(text, at.clone(), name) {
        Some(value) => value,
        None => declared_or_documented(path, outline, offset, name)?,
    };
    Some(Hover {
        contents: HoverContents::Markup(MarkupContent {
            kind: MarkupKind::Markdown,
            value,
        }),
        range: None,
    })
}

fn declared_or_documented(
    path: &Path,
    outline: &Outline,
    offset: usize,
    name: &str,
) -> Option<String> {
    Some(match outline.resolve(name, offset) {
        Some(declaration) => describe(declaration),
        None => match imported_function(path, outline, name) {
            Some(found) => describe(&found.declaration),
            None => format!("```text\n{}```", crate::app::doc::describe(name)?),
        },
    })
}

/// A builtin's keyword argument (`kappa` in `render(..., kappa = 2)`): its types in the
/// builtin's forms, and its line of `felt doc` where there is one (render's keyword table).
fn keyword_argument(text: &str, at: Range<usize>, name: &str) -> Option<String> {
    let after = text[at.end..].trim_start();
    if !after.starts_with('=') || after.starts_with("==") {
        return None;
    }
    let call = call_at(text, at.start)?;
    let builtin = registry().get(&call.callee)?;
    let mut types: Vec<String> = Vec::new();
    for param in builtin.signatures.iter().flat_map(|s| &s.params) {
        let ty = format!("{}{}", param.ty, if param.optional { "?" } else { "" });
        if param.name == name && !types.contains(&ty) {
            types.push(ty);
        }
    }
    if types.is_empty() {
        return None;
    }
    let mut value = format!(
        "argument `{name}` of `{}`: {}",
        builtin.name,
        types.join(" or ")
    );
    let documented = crate::app::doc::describe(builtin.name).unwrap_or_default();
    if let Some(row) = documented
        .lines()
        .map(str::trim)
        .find(|l| l.split_whitespace().next() == Some(name))
    {
        value.push_str(&format!("\n```text\n{row}\n```"));
    }
    Some(value)
}

/// A declaration as hover shows it: as written, then what it is.
pub fn describe(d: &Declaration) -> String {
    let what = match d.kind {
        Kind::Function if d.doc.is_empty() => format!("function `{}` → {}", d.name, d.ty),
        Kind::Function => d.doc.clone(),
        Kind::Param => {
            let default = d.text.split_once('=').map(|(_, v)| v.trim());
            match default {
                Some(value) => format!(
                    "param `{}`: {}, default `{value}`; `felt run --set {}=VALUE` overrides it",
                    d.name, d.ty, d.name
                ),
                None => format!("param `{}`: {}", d.name, d.ty),
            }
        }
        Kind::Variable => format!("variable `{}`: {}", d.name, d.ty),
        Kind::Argument => format!("argument `{}`: {}", d.name, d.ty),
    };
    format!("```felt\n{}\n```\n{what}", d.text)
}
