//! Checking a buffer and saying what is wrong in the protocol's terms. The check is `felt
//! check`'s: a fresh session (standard library and builtins as every run has them) loads the
//! buffer's text as the file its URI names, follows its imports from the files on disk, and
//! checks it all; nothing is run. Each diagnostic goes to the file it is in (an error in an
//! imported file is shown in that file), its byte span turned into a UTF-16 range, its help
//! line kept as the message's second line (every client shows the message; not every client
//! shows related information), and its further places ("first defined here") as related
//! information.

use super::documents::{Document, path_of};
use super::position::LineIndex;
use crate::session::Session;
use crate::syntax::diagnostic::{self as felt, Severity};
use crate::syntax::span::SourceMap;
use lsp_types::{
    Diagnostic, DiagnosticRelatedInformation, DiagnosticSeverity, Location, NumberOrString,
    Position, Range, Url,
};
use std::collections::BTreeMap;
use std::path::Path;

/// The diagnostics of a check, by the URI of the file each is in; the checked buffer's own
/// URI is always present (with none, when the buffer is clean), so a publish clears it.
pub fn check(uri: &Url, document: &Document) -> BTreeMap<Url, Vec<Diagnostic>> {
    let path = path_of(uri);
    let (sources, found) = match Session::new(Box::new(std::io::sink())) {
        Ok(mut session) => {
            let found = match session.load_buffer(&path, &document.text) {
                Ok(units) => session.check(&units),
                Err(diagnostics) => diagnostics,
            };
            (session.sources.take(), found)
        }
        Err(failure) => (failure.sources, failure.diagnostics),
    };
    let place = Places {
        sources: &sources,
        uri,
        name: path.display().to_string(),
        document,
    };
    let mut by_file: BTreeMap<Url, Vec<Diagnostic>> = BTreeMap::new();
    by_file.insert(uri.clone(), Vec::new());
    for diagnostic in &found {
        let location = place.locate(diagnostic);
        let related = diagnostic
            .related
            .iter()
            .map(|r| DiagnosticRelatedInformation {
                location: place.locate(r),
                message: r.message.clone(),
            })
            .collect::<Vec<_>>();
        let mut message = diagnostic.message.clone();
        if let Some(help) = &diagnostic.help {
            message.push_str("\nhelp: ");
            message.push_str(help);
        }
        by_file.entry(location.uri).or_default().push(Diagnostic {
            range: location.range,
            severity: Some(match diagnostic.severity {
                Severity::Error => DiagnosticSeverity::ERROR,
                Severity::Warning => DiagnosticSeverity::WARNING,
            }),
            code: Some(NumberOrString::String(diagnostic.stage.code().to_string())),
            source: Some("felt".to_string()),
            message,
            related_information: (!related.is_empty()).then_some(related),
            ..Diagnostic::default()
        });
    }
    by_file
}

/// Where the spans of one check lie, in URIs and ranges.
struct Places<'a> {
    sources: &'a SourceMap,
    uri: &'a Url,
    /// The name the buffer was loaded under.
    name: String,
    document: &'a Document,
}

impl Places<'_> {
    /// The location of a diagnostic. One with no span (a file that cannot be read) is put at
    /// the buffer's start.
    fn locate(&self, diagnostic: &felt::Diagnostic) -> Location {
        let start = Location::new(
            self.uri.clone(),
            Range::new(Position::new(0, 0), Position::new(0, 0)),
        );
        let Some(span) = diagnostic.span else {
            return start;
        };
        let Some(file) = self.sources.try_get(span.file) else {
            return start;
        };
        let (begin, end) = (span.start as usize, span.end as usize);
        if file.name == self.name {
            let text = &self.document.text;
            return Location::new(
                self.uri.clone(),
                self.document.lines.range(text, begin, end),
            );
        }
        match Url::from_file_path(absolute(Path::new(&file.name))) {
            Ok(uri) => {
                let lines = LineIndex::new(&file.text);
                Location::new(uri, lines.range(&file.text, begin, end))
            }
            Err(()) => start,
        }
    }
}

/// A path as an absolute one with `.` and `..` taken out by name, so an imported file gets the
/// same URI the editor gives it when it is opened.
fn absolute(path: &Path) -> std::path::PathBuf {
    let joined = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir().unwrap_or_default().join(path)
    };
    let mut clean = std::path::PathBuf::new();
    for part in joined.components() {
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
