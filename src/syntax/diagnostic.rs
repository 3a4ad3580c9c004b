//! Diagnostics: every problem felt reports to a script author, from a stray character to a
//! singular matrix inside a function call. A `Diagnostic` is plain data (spans, message, help,
//! call stack) so that the checker can collect all of a file's errors and tests can inspect
//! them; it becomes a `miette` report only when printed, where the span is resolved to file,
//! line and column and the source line is shown with the span underlined. Source lines longer
//! than a screen are cut to a window around the span before miette sees them (`Elided`): miette
//! 7.6 panics on a label past column ~65,530, and nobody reads such a line whole anyway.

use crate::syntax::span::{SourceFile, SourceMap, Span};
use miette::{
    GraphicalReportHandler, GraphicalTheme, LabeledSpan, MietteError, MietteSpanContents,
    NamedSource, SourceCode, SourceSpan, SpanContents,
};
use std::fmt;
use std::sync::Arc;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Severity {
    Error,
    Warning,
}

/// What kind of problem: shown as the diagnostic code (`felt::type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    Syntax,
    Name,
    Type,
    Runtime,
    Usage,
    /// A bug in felt, not in the script (`Failure::internal`): the command exits 70.
    Internal,
}

impl Stage {
    pub fn code(self) -> &'static str {
        match self {
            Stage::Syntax => "felt::syntax",
            Stage::Name => "felt::name",
            Stage::Type => "felt::type",
            Stage::Runtime => "felt::runtime",
            Stage::Usage => "felt::usage",
            Stage::Internal => "felt::internal",
        }
    }
}

/// One problem, with where it is and what might fix it.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    pub severity: Severity,
    pub stage: Stage,
    pub message: String,
    /// The span the message is about and the text written under it.
    pub span: Option<Span>,
    pub label: String,
    pub help: Option<String>,
    /// Further places worth showing: "called from here", "first defined here".
    pub related: Vec<Diagnostic>,
}

impl Diagnostic {
    pub fn error(stage: Stage, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            severity: Severity::Error,
            stage,
            message: message.into(),
            span: Some(span),
            label: String::from("here"),
            help: None,
            related: Vec::new(),
        }
    }

    pub fn warning(stage: Stage, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            severity: Severity::Warning,
            ..Diagnostic::error(stage, span, message)
        }
    }

    /// An error that belongs to no source text (a missing file named on the command line).
    pub fn bare(stage: Stage, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            severity: Severity::Error,
            stage,
            message: message.into(),
            span: None,
            label: String::new(),
            help: None,
            related: Vec::new(),
        }
    }

    pub fn with_label(mut self, label: impl Into<String>) -> Diagnostic {
        self.label = label.into();
        self
    }

    pub fn with_help(mut self, help: impl Into<String>) -> Diagnostic {
        self.help = Some(help.into());
        self
    }

    pub fn with_help_opt(mut self, help: Option<String>) -> Diagnostic {
        if help.is_some() {
            self.help = help;
        }
        self
    }

    pub fn with_related(mut self, related: Diagnostic) -> Diagnostic {
        self.related.push(related);
        self
    }

    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }
}

/// A source line longer than this many bytes is shown cut down to windows around the label.
const LONG_LINE_BYTES: usize = 1000;
/// Bytes of a long line kept on either side of the label's start and of its end.
const WINDOW_BYTES: usize = 80;
/// What stands in for each cut-out piece of a long line.
const ELLIPSIS: &str = "…";
/// Lines shown above and below the lines of a label.
const CONTEXT_LINES: usize = 1;
/// At most this many diagnostics are rendered; the rest are counted in one line. A script
/// with thousands of errors is fixed from the top, and the count says how far there is to go.
pub const MAX_RENDERED: usize = 100;

/// What miette is shown of a source file for one diagnostic: only the lines around the label
/// (so rendering a diagnostic costs the size of its excerpt, not of the file), with every
/// line longer than `LONG_LINE_BYTES` cut to a window around the label's ends (or its first
/// bytes, on lines without one) and an ellipsis for each piece left out. Offsets map both
/// ways, and the line and column miette prints are worked out from the whole file, so file,
/// line and column stay right.
struct Elided {
    file: Arc<SourceFile>,
    text: Arc<str>,
    /// The 0-based line of the file that `text` starts with.
    first_line: usize,
    /// The pieces of the file kept, in order: (start, end, start in `text`).
    kept: Vec<(usize, usize, usize)>,
}

impl Elided {
    /// The lines of `file` around the byte offsets `start..end` (the label), long ones cut
    /// around both ends.
    fn new(file: Arc<SourceFile>, start: usize, end: usize) -> Elided {
        let source: &str = &file.text;
        let (start, end) = (start.min(source.len()), end.min(source.len()));
        let first_line = file.line_index(start).saturating_sub(CONTEXT_LINES);
        let last_line = (file.line_index(end) + CONTEXT_LINES).min(file.line_count() - 1);
        let points = [start, end];
        let mut text = String::new();
        let mut kept: Vec<(usize, usize, usize)> = Vec::new();
        let mut keep = |text: &mut String, start: usize, end: usize| {
            match kept.last_mut() {
                Some(last) if last.1 == start => last.1 = end,
                _ => kept.push((start, end, text.len())),
            }
            text.push_str(&source[start..end]);
        };
        for line in first_line..=last_line {
            let (line_start, next) = (file.line_start(line), file.line_end(line));
            let line_end = if source[line_start..next].ends_with('\n') {
                next - 1
            } else {
                next
            };
            if line_end - line_start <= LONG_LINE_BYTES {
                keep(&mut text, line_start, next);
                continue;
            }
            let mut windows: Vec<(usize, usize)> = points
                .iter()
                .filter(|&&p| (line_start..=line_end).contains(&p))
                .map(|&p| {
                    (
                        p.saturating_sub(WINDOW_BYTES).max(line_start),
                        (p + WINDOW_BYTES).min(line_end),
                    )
                })
                .collect();
            if windows.is_empty() {
                windows.push((line_start, line_start + 2 * WINDOW_BYTES));
            }
            windows.sort_unstable();
            let mut cursor = line_start;
            for (start, end) in windows {
                // Windows may overlap: each starts where the last one stopped, at the latest.
                let start = floor_char_boundary(source, start.max(cursor));
                let end = ceil_char_boundary(source, end);
                if end <= start {
                    continue;
                }
                if start > cursor {
                    text.push_str(ELLIPSIS);
                }
                keep(&mut text, start, end);
                cursor = end;
            }
            if cursor < line_end {
                text.push_str(ELLIPSIS);
            }
            keep(&mut text, line_end, next);
        }
        Elided {
            text: text.into(),
            first_line,
            kept,
            file,
        }
    }

    /// Where an offset of the file lies in `text`; one inside a cut-out piece goes to the
    /// start of its ellipsis, or to its end when `end` is set (for the end of a span).
    fn to_text(&self, offset: usize, end: bool) -> usize {
        let i = self.kept.partition_point(|&(start, _, _)| start <= offset);
        let Some(&(start, stop, at)) = i.checked_sub(1).and_then(|i| self.kept.get(i)) else {
            return 0;
        };
        if offset <= stop {
            at + (offset - start)
        } else if end {
            (at + (stop - start) + ELLIPSIS.len()).min(self.text.len())
        } else {
            at + (stop - start)
        }
    }

    /// Where an offset of `text` came from in the file.
    fn to_original(&self, offset: usize) -> usize {
        let i = self.kept.partition_point(|&(_, _, at)| at <= offset);
        let Some(&(start, stop, at)) = i.checked_sub(1).and_then(|i| self.kept.get(i)) else {
            return offset;
        };
        (start + (offset - at)).min(stop)
    }
}

impl SourceCode for Elided {
    fn read_span<'a>(
        &'a self,
        span: &SourceSpan,
        context_lines_before: usize,
        context_lines_after: usize,
    ) -> Result<Box<dyn SpanContents<'a> + 'a>, MietteError> {
        let inner = self
            .text
            .read_span(span, context_lines_before, context_lines_after)?;
        // miette counts lines from the start of the text it is given, and columns in bytes
        // from the line start: count both in the file.
        let offset = self.to_original(inner.span().offset());
        let line = self.file.line_index(offset);
        let column = if inner.column() == 0 {
            0
        } else {
            offset - self.file.line_start(line)
        };
        Ok(Box::new(MietteSpanContents::new(
            inner.data(),
            *inner.span(),
            inner.line() + self.first_line,
            column,
            inner.line_count(),
        )))
    }
}

fn floor_char_boundary(text: &str, mut i: usize) -> usize {
    i = i.min(text.len());
    while !text.is_char_boundary(i) {
        i -= 1;
    }
    i
}

fn ceil_char_boundary(text: &str, mut i: usize) -> usize {
    i = i.min(text.len());
    while !text.is_char_boundary(i) {
        i += 1;
    }
    i
}

/// A diagnostic bound to its source text, in the form miette prints.
struct Report {
    diagnostic: Diagnostic,
    source: Option<NamedSource<Elided>>,
    /// The diagnostic's span as an offset and length in the (elided) source text.
    label_span: Option<(usize, usize)>,
    related: Vec<Report>,
}

impl Report {
    fn new(diagnostic: &Diagnostic, sources: &SourceMap) -> Report {
        let mut label_span = diagnostic
            .span
            .map(|span| (span.start as usize, span.len()));
        let source = diagnostic.span.and_then(|span| {
            let file = sources.try_get(span.file)?;
            let (start, end) = (span.start as usize, span.end as usize);
            let elided = Elided::new(file.clone(), start, end);
            let (from, to) = (elided.to_text(start, false), elided.to_text(end, true));
            label_span = Some((from, to.max(from) - from));
            Some(NamedSource::new(file.name.clone(), elided))
        });
        Report {
            diagnostic: diagnostic.clone(),
            source,
            label_span,
            related: diagnostic
                .related
                .iter()
                .map(|d| Report::new(d, sources))
                .collect(),
        }
    }
}

impl fmt::Debug for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.diagnostic.message)
    }
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.diagnostic.message)
    }
}

impl std::error::Error for Report {}

impl miette::Diagnostic for Report {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        Some(Box::new(self.diagnostic.stage.code()))
    }

    fn severity(&self) -> Option<miette::Severity> {
        Some(match self.diagnostic.severity {
            Severity::Error => miette::Severity::Error,
            Severity::Warning => miette::Severity::Warning,
        })
    }

    fn help<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.diagnostic
            .help
            .as_ref()
            .map(|h| Box::new(h.as_str()) as Box<dyn fmt::Display>)
    }

    fn source_code(&self) -> Option<&dyn SourceCode> {
        self.source.as_ref().map(|s| s as &dyn SourceCode)
    }

    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        let (offset, len) = self.label_span?;
        let label = (!self.diagnostic.label.is_empty()).then(|| self.diagnostic.label.clone());
        Some(Box::new(std::iter::once(LabeledSpan::new(
            label, offset, len,
        ))))
    }

    fn related<'a>(&'a self) -> Option<Box<dyn Iterator<Item = &'a dyn miette::Diagnostic> + 'a>> {
        if self.related.is_empty() {
            return None;
        }
        Some(Box::new(
            self.related.iter().map(|r| r as &dyn miette::Diagnostic),
        ))
    }
}

/// Renders diagnostics as text: with colours for a terminal, plain for files and tests. The
/// first `MAX_RENDERED` are shown in full, the rest counted in a last line.
pub fn render(diagnostics: &[Diagnostic], sources: &SourceMap, color: bool) -> String {
    let theme = if color {
        GraphicalTheme::unicode()
    } else {
        GraphicalTheme::unicode_nocolor()
    };
    let handler = GraphicalReportHandler::new_themed(theme)
        .with_width(100)
        .with_links(false)
        .with_context_lines(CONTEXT_LINES);
    let mut out = String::new();
    let shown = diagnostics.len().min(MAX_RENDERED);
    for diagnostic in &diagnostics[..shown] {
        let report = Report::new(diagnostic, sources);
        if handler.render_report(&mut out, &report).is_err() {
            out.push_str(&diagnostic.message);
            out.push('\n');
        }
    }
    if let Some(line) = left_out(&diagnostics[shown..]) {
        out.push_str(&line);
        out.push('\n');
    }
    out
}

/// "… and 12 more errors and 1 more warning": the diagnostics not rendered.
fn left_out(rest: &[Diagnostic]) -> Option<String> {
    let errors = rest.iter().filter(|d| d.is_error()).count();
    let warnings = rest.len() - errors;
    let count = |n: usize, what: &str| match n {
        0 => None,
        1 => Some(format!("1 more {what}")),
        n => Some(format!("{n} more {what}s")),
    };
    let parts: Vec<String> = [count(errors, "error"), count(warnings, "warning")]
        .into_iter()
        .flatten()
        .collect();
    (!parts.is_empty()).then(|| format!("{ELLIPSIS} and {}", parts.join(" and ")))
}

/// "file:line:column" of a span, for one-line messages (warnings in a profile, the REPL).
pub fn location(span: Span, sources: &SourceMap) -> String {
    let file = sources.get(span.file);
    let (line, column) = file.line_col(span.start as usize);
    format!("{}:{}:{}", file.name, line, column)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rendered(text: &str, start: usize, end: usize) -> String {
        let mut sources = SourceMap::default();
        let file = sources.add("t.felt", text);
        let diagnostic = Diagnostic::error(Stage::Name, Span::new(file, start, end), "bad");
        render(&[diagnostic], &sources, false)
    }

    fn file(text: &str) -> Arc<SourceFile> {
        Arc::new(SourceFile::new("t.felt", text))
    }

    #[test]
    fn short_lines_are_shown_whole() {
        let elided = Elided::new(file("a = 1;\nb = 2;\n"), 0, 1);
        assert_eq!(elided.kept, [(0, 14, 0)]);
        assert_eq!(&*elided.text, "a = 1;\nb = 2;\n");
    }

    #[test]
    fn only_the_lines_around_the_label_are_shown() {
        let text: String = (1..=1000).map(|i| format!("line{i};\n")).collect();
        let start = text.find("line500;").unwrap();
        let elided = Elided::new(file(&text), start, start + 7);
        assert_eq!(&*elided.text, "line499;\nline500;\nline501;\n");
        let out = rendered(&text, start, start + 7);
        assert!(out.contains("[t.felt:500:1]"), "{out}");
        assert!(out.contains(" 499 │ line499;"), "{out}");
        assert!(out.contains(" 501 │ line501;"), "{out}");
        assert!(!out.contains("line498"), "{out}");
        // The last line, with and without a newline after it.
        for text in ["a;\nb;\nlast", "a;\nb;\nlast\n"] {
            let out = rendered(text, 6, 10);
            assert!(out.contains("[t.felt:3:1]"), "{out}");
            assert!(out.contains("last"), "{out}");
        }
        let out = rendered("a;\n", 3, 3);
        assert!(out.contains("[t.felt:2:1]"), "{out}");
    }

    #[test]
    fn many_diagnostics_are_cut_to_the_first_hundred_and_a_count() {
        let mut sources = SourceMap::default();
        let text = "x;\n".repeat(MAX_RENDERED + 30);
        let file = sources.add("t.felt", text);
        let mut diagnostics: Vec<Diagnostic> = (0..MAX_RENDERED + 25)
            .map(|i| Diagnostic::error(Stage::Name, Span::new(file, 3 * i, 3 * i + 1), "bad"))
            .collect();
        diagnostics.push(Diagnostic::warning(
            Stage::Name,
            Span::new(file, 0, 1),
            "odd",
        ));
        let out = render(&diagnostics, &sources, false);
        assert_eq!(out.matches("× bad").count(), MAX_RENDERED, "{out}");
        assert!(out.contains("[t.felt:100:1]"), "{out}");
        assert!(!out.contains("[t.felt:101:1]"), "{out}");
        assert!(
            out.ends_with("… and 25 more errors and 1 more warning\n"),
            "{out}"
        );
        let out = render(&diagnostics[..MAX_RENDERED], &sources, false);
        assert!(!out.contains("more error"), "{out}");
    }

    #[test]
    fn long_lines_are_cut_around_both_ends_of_the_label() {
        // Multi-byte characters on either side, so cuts must fall on character boundaries.
        let text = format!(
            "x;\n{}name{}tail\n{}\nend",
            "é".repeat(40_000),
            "ü".repeat(40_000),
            "y".repeat(5000)
        );
        let start = text.find("name").unwrap();
        let end = text.find("tail").unwrap() + 4;
        let elided = Elided::new(file(&text), start, end);
        // The label's line and one on either side.
        assert_eq!(elided.text.lines().count(), 3);
        assert!(
            elided.text.lines().all(|l| l.len() < 1000),
            "{}",
            elided.text
        );
        let (from, to) = (elided.to_text(start, false), elided.to_text(end, true));
        assert!(elided.text[from..].starts_with("name"));
        assert!(elided.text[..to].ends_with("tail"));
        assert_eq!(elided.to_original(from), start);
        let out = rendered(&text, start, end);
        // miette counts columns in bytes: 'é' is two.
        assert!(out.contains("[t.felt:2:80001]"), "{out}");
        assert!(out.contains('…'), "{out}");
    }

    #[test]
    fn a_label_far_along_a_line_does_not_panic() {
        let text = format!("{}undefined;", " ".repeat(70_000));
        let out = rendered(&text, 70_000, 70_009);
        assert!(out.contains("[t.felt:1:70001]"), "{out}");
    }
}
