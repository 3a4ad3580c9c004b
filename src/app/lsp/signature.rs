//! Signature help: the forms of the call the cursor is in, as `felt doc` writes them, with the
//! parameter being given marked: by its keyword when the argument is `name = ...`, by its
//! position otherwise. The form marked active is the first that has that parameter, as the
//! checker tries forms in order. A script function, of the buffer, an imported file or the
//! standard library, has its one signature, as declared; one the script declares is the one
//! meant even where it shadows a builtin, as it is when the script runs.

use super::completion::library;
use super::definition::imported_function;
use super::outline::{Outline, call_at};
use crate::interp::registry::{Builtin, format_signature, registry};
use lsp_types::{
    Documentation, ParameterInformation, ParameterLabel, SignatureHelp, SignatureInformation,
};
use std::path::Path;

pub fn signature_help(
    path: &Path,
    text: &str,
    outline: &Outline,
    offset: usize,
) -> Option<SignatureHelp> {
    let call = call_at(text, offset)?;
    let arguments_of = |outline: &Outline, arguments: &[usize]| -> Vec<String> {
        arguments
            .iter()
            .filter_map(|&a| outline.declarations.get(a))
            .map(|a| a.text.clone())
            .collect()
    };
    if let Some(f) = outline.function(&call.callee) {
        let arguments = arguments_of(outline, &f.arguments);
        return Some(declared(&f.text, &f.doc, arguments, call.argument));
    }
    if let Some(found) = imported_function(path, outline, &call.callee) {
        let imported = Outline::new(&found.text);
        let arguments = imported
            .function(&call.callee)
            .map(|f| arguments_of(&imported, &f.arguments))
            .unwrap_or_default();
        let f = &found.declaration;
        return Some(declared(&f.text, &f.doc, arguments, call.argument));
    }
    if let Some(builtin) = registry().get(&call.callee) {
        return Some(forms(builtin, call.keyword.as_deref(), call.argument));
    }
    let (_, signature, doc) = library().iter().find(|(n, _, _)| *n == call.callee)?;
    let inside = signature
        .split_once('(')
        .and_then(|(_, rest)| rest.rsplit_once(')'))
        .map_or("", |(inside, _)| inside);
    let arguments = inside
        .split(',')
        .map(|a| a.trim().to_string())
        .filter(|a| !a.is_empty())
        .collect();
    Some(declared(signature, doc, arguments, call.argument))
}

/// A builtin's forms, the active one and its active parameter marked.
fn forms(builtin: &Builtin, keyword: Option<&str>, argument: usize) -> SignatureHelp {
    let mut active_signature = None;
    let mut signatures = Vec::new();
    for (i, signature) in builtin.signatures.iter().enumerate() {
        let active = match keyword {
            Some(keyword) => signature.param_index(keyword),
            None if argument < signature.params.len() => Some(argument),
            // Further arguments of a variadic form are its last parameter's.
            None if signature.variadic.is_some() => Some(signature.params.len()),
            None => None,
        };
        if active.is_some() && active_signature.is_none() {
            active_signature = Some(i as u32);
        }
        let mut parameters: Vec<ParameterInformation> = signature
            .params
            .iter()
            .map(|p| {
                let optional = if p.optional { "?" } else { "" };
                parameter(format!("{} {}{optional}", p.ty, p.name))
            })
            .collect();
        if let Some(rest) = &signature.variadic {
            parameters.push(parameter(format!("{rest}...")));
        }
        signatures.push(SignatureInformation {
            label: format_signature(builtin.name, signature),
            documentation: Some(Documentation::String(builtin.doc.to_string())),
            parameters: Some(parameters),
            active_parameter: active.map(|a| a as u32),
        });
    }
    SignatureHelp {
        signatures,
        active_signature: Some(active_signature.unwrap_or(0)),
        active_parameter: None,
    }
}

/// A script function's one signature.
fn declared(text: &str, doc: &str, arguments: Vec<String>, argument: usize) -> SignatureHelp {
    SignatureHelp {
        signatures: vec![SignatureInformation {
            label: text.trim_start_matches("func ").to_string(),
            documentation: (!doc.is_empty()).then(|| Documentation::String(doc.to_string())),
            parameters: Some(arguments.into_iter().map(parameter).collect()),
            active_parameter: Some(argument as u32),
        }],
        active_signature: Some(0),
        active_parameter: None,
    }
}

fn parameter(label: String) -> ParameterInformation {
    ParameterInformation {
        label: ParameterLabel::Simple(label),
        documentation: None,
    }
}
