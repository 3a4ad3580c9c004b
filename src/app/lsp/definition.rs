//! Where things are: go to definition (a name to its declaration in the buffer or to a
//! function in a file it imports; an `import` path to that file) and the buffer's symbols
//! (its functions with their arguments, its params and its top-level declarations), for an
//! editor's outline view and its jump-to-symbol.

use super::outline::{Declaration, Kind, Outline, word_at};
use super::position::LineIndex;
use lsp_types::{DocumentSymbol, Location, Position, Range, SymbolKind, Url};
use std::path::{Path, PathBuf};

/// A function declared in a file the buffer imports.
pub struct Imported {
    pub path: PathBuf,
    pub text: String,
    pub declaration: Declaration,
}

/// The function `name` from the files the buffer imports (read from disk, as a run reads
/// them), the first import that declares it.
pub fn imported_function(path: &Path, outline: &Outline, name: &str) -> Option<Imported> {
    let base = path.parent().unwrap_or(Path::new(""));
    outline.imports.iter().find_map(|import| {
        let path = base.join(&import.path);
        let text = std::fs::read_to_string(&path).ok()?;
        let mut imported = Outline::new(&text);
        let at = imported
            .declarations
            .iter()
            .position(|d| d.kind == Kind::Function && d.name == name)?;
        let declaration = imported.declarations.swap_remove(at);
        Some(Imported {
            path,
            text,
            declaration,
        })
    })
}

/// The functions of the files the buffer imports.
pub fn imported_functions(path: &Path, outline: &Outline) -> Vec<Declaration> {
    let base = path.parent().unwrap_or(Path::new(""));
    let mut functions = Vec::new();
    for import in &outline.imports {
        if let Ok(text) = std::fs::read_to_string(base.join(&import.path)) {
            functions.extend(
                Outline::new(&text)
                    .declarations
                    .into_iter()
                    .filter(|d| d.kind == Kind::Function),
            );
        }
    }
    functions
}

pub fn definition(
    uri: &Url,
    path: &Path,
    text: &str,
    lines: &LineIndex,
    outline: &Outline,
    offset: usize,
) -> Option<Location> {
    let base = path.parent().unwrap_or(Path::new(""));
    if let Some(import) = outline
        .imports
        .iter()
        .find(|i| i.at.start <= offset && offset <= i.at.end)
    {
        let target =
            Url::from_file_path(std::path::absolute(base.join(&import.path)).ok()?).ok()?;
        return Some(Location::new(target, Range::default()));
    }
    let (_, name) = word_at(text, offset)?;
    if let Some(d) = outline.resolve(name, offset) {
        return Some(Location::new(
            uri.clone(),
            lines.range(text, d.name_at.start, d.name_at.end),
        ));
    }
    let found = imported_function(path, outline, name)?;
    let target = Url::from_file_path(std::path::absolute(&found.path).ok()?).ok()?;
    let at = &found.declaration.name_at;
    let range = LineIndex::new(&found.text).range(&found.text, at.start, at.end);
    Some(Location::new(target, range))
}

/// The buffer's functions (their arguments inside), params and top-level declarations.
pub fn symbols(text: &str, lines: &LineIndex, outline: &Outline) -> Vec<DocumentSymbol> {
    let symbol = |d: &Declaration, children: Option<Vec<DocumentSymbol>>| {
        let kind = match d.kind {
            Kind::Function => SymbolKind::FUNCTION,
            Kind::Param => SymbolKind::CONSTANT,
            Kind::Variable | Kind::Argument => SymbolKind::VARIABLE,
        };
        let selection = lines.range(text, d.name_at.start, d.name_at.end);
        let mut range = lines.range(text, d.whole.start, d.whole.end);
        // The protocol wants the name inside the whole.
        if position_key(selection.end) > position_key(range.end) {
            range.end = selection.end;
        }
        #[allow(deprecated)] // `deprecated` is a field every DocumentSymbol must still spell
        DocumentSymbol {
            name: d.name.clone(),
            detail: Some(d.ty.clone()),
            kind,
            tags: None,
            deprecated: None,
            range,
            selection_range: selection,
            children,
        }
    };
    outline
        .declarations
        .iter()
        .filter(|d| d.depth == 0 && d.kind != Kind::Argument)
        .map(|d| {
            let children = (d.kind == Kind::Function).then(|| {
                d.arguments
                    .iter()
                    .filter_map(|&a| outline.declarations.get(a))
                    .map(|a| symbol(a, None))
                    .collect()
            });
            symbol(d, children)
        })
        .collect()
}

fn position_key(p: Position) -> (u32, u32) {
    (p.line, p.character)
}
