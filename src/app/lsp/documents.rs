//! The buffers the editor has open, as the editor has them: the text is the unsaved one, kept
//! up to date from the edits the client sends (whole texts or ranges), and marked stale until
//! it has been checked again. Marking instead of checking is what lets the server coalesce a
//! burst of keystrokes into one check.

use super::position::LineIndex;
use lsp_types::{TextDocumentContentChangeEvent, Url};
use std::collections::BTreeMap;
use std::path::PathBuf;

pub struct Document {
    pub text: String,
    pub lines: LineIndex,
    pub version: i32,
    /// Edited since its diagnostics were last published.
    pub stale: bool,
}

impl Document {
    fn new(text: String, version: i32) -> Document {
        Document {
            lines: LineIndex::new(&text),
            text,
            version,
            stale: true,
        }
    }

    /// Applies edits in the order given, each against the text the previous one left.
    fn edit(&mut self, changes: Vec<TextDocumentContentChangeEvent>, version: i32) {
        for change in changes {
            match change.range {
                Some(range) => {
                    let start = self.lines.offset(&self.text, range.start);
                    let end = self.lines.offset(&self.text, range.end).max(start);
                    self.text.replace_range(start..end, &change.text);
                }
                None => self.text = change.text,
            }
            self.lines = LineIndex::new(&self.text);
        }
        self.version = version;
        self.stale = true;
    }
}

/// The open documents by URI.
#[derive(Default)]
pub struct Documents {
    open: BTreeMap<Url, Document>,
}

impl Documents {
    pub fn open(&mut self, uri: Url, text: String, version: i32) {
        self.open.insert(uri, Document::new(text, version));
    }

    pub fn change(
        &mut self,
        uri: &Url,
        changes: Vec<TextDocumentContentChangeEvent>,
        version: i32,
    ) {
        if let Some(document) = self.open.get_mut(uri) {
            document.edit(changes, version);
        }
    }

    pub fn close(&mut self, uri: &Url) {
        self.open.remove(uri);
    }

    pub fn get(&self, uri: &Url) -> Option<&Document> {
        self.open.get(uri)
    }

    /// Whether any document waits to be checked.
    pub fn any_stale(&self) -> bool {
        self.open.values().any(|d| d.stale)
    }

    /// Marks every document to be checked again (a file they may import was saved).
    pub fn mark_all_stale(&mut self) {
        for document in self.open.values_mut() {
            document.stale = true;
        }
    }

    /// The documents edited since they were last checked; they are marked checked.
    pub fn take_stale(&mut self) -> Vec<Url> {
        let mut stale = Vec::new();
        for (uri, document) in &mut self.open {
            if document.stale {
                document.stale = false;
                stale.push(uri.clone());
            }
        }
        stale
    }
}

/// The file a URI names, for `file:` URIs; a buffer with no file (`untitled:`) is checked as
/// if it were in the current folder.
pub fn path_of(uri: &Url) -> PathBuf {
    uri.to_file_path().unwrap_or_else(|_| {
        let name = uri.path().rsplit('/').next().unwrap_or("untitled.felt");
        PathBuf::from(if name.is_empty() {
            "untitled.felt"
        } else {
            name
        })
    })
}
