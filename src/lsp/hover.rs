//! Hover: what a name under the cursor is. A name the script declares shows its declaration
//! as written (a `param` with its default, a variable with its type, a function with its
//! signature and the comment above it), found in the buffer or in a file it imports; any
//! other name shows what `felt doc NAME` prints for a builtin or library function, from the
//! same text (`crate::doc::describe`), so the two never differ.

use super::definition::imported_function;
use super::outline::{Declaration, Kind, Outline, word_at};
use lsp_types::{Hover, HoverContents, MarkupContent, MarkupKind};
use std::path::Path;

pub fn hover(path: &Path, text: &str, outline: &Outline, offset: usize) -> Option<Hover> {
    let (_, name) = word_at(text, offset)?;
    let value = match outline.resolve(name, offset) {
        Some(declaration) => describe(declaration),
        None => match imported_function(path, outline, name) {
            Some(found) => describe(&found.declaration),
            None => format!("```text\n{}```", crate::doc::describe(name)?),
        },
    };
    Some(Hover {
        contents: HoverContents::Markup(MarkupContent {
            kind: MarkupKind::Markdown,
            value,
        }),
        range: None,
    })
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
