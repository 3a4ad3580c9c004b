//! Signature help: the forms of the call the cursor is in, as `felt doc` writes them, with the
//! parameter being given marked: by its keyword when the argument is `name = ...`, by its
//! position otherwise. The form marked active is the first that has that parameter, as the
//! checker tries forms in order. A script function has its one signature, as declared.

use super::definition::imported_function;
use super::outline::{Declaration, Outline, call_at};
use crate::interp::registry::{format_signature, registry};
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
    if let Some(builtin) = registry().get(&call.callee) {
        let mut active_signature = None;
        let mut signatures = Vec::new();
        for (i, signature) in builtin.signatures.iter().enumerate() {
            let active = match &call.keyword {
                Some(keyword) => signature.param_index(keyword),
                None if call.argument < signature.params.len() => Some(call.argument),
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
        return Some(SignatureHelp {
            signatures,
            active_signature: Some(active_signature.unwrap_or(0)),
            active_parameter: None,
        });
    }
    let declared = |f: &Declaration, arguments: Vec<String>| SignatureHelp {
        signatures: vec![SignatureInformation {
            label: f.text.trim_start_matches("func ").to_string(),
            documentation: (!f.doc.is_empty()).then(|| Documentation::String(f.doc.clone())),
            parameters: Some(arguments.into_iter().map(parameter).collect()),
            active_parameter: Some(call.argument as u32),
        }],
        active_signature: Some(0),
        active_parameter: None,
    };
    if let Some(f) = outline.function(&call.callee) {
        let arguments = f
            .arguments
            .iter()
            .filter_map(|&a| outline.declarations.get(a))
            .map(|a| a.text.clone())
            .collect();
        return Some(declared(f, arguments));
    }
    let found = imported_function(path, outline, &call.callee)?;
    let imported = Outline::new(&found.text);
    let arguments = imported
        .function(&call.callee)
        .map(|f| {
            f.arguments
                .iter()
                .filter_map(|&a| imported.declarations.get(a))
                .map(|a| a.text.clone())
                .collect()
        })
        .unwrap_or_default();
    Some(declared(&found.declaration, arguments))
}

fn parameter(label: String) -> ParameterInformation {
    ParameterInformation {
        label: ParameterLabel::Simple(label),
        documentation: None,
    }
}
