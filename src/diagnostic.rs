//! Diagnostics: every problem felt reports to a script author, from a stray character to a
//! singular matrix inside a function call. A `Diagnostic` is plain data (spans, message, help,
//! call stack) so that the checker can collect all of a file's errors and tests can inspect
//! them; it becomes a `miette` report only when printed, where the span is resolved to file,
//! line and column and the source line is shown with the span underlined. Source lines longer
//! than a screen are cut to a window around the span before miette sees them (`Elided`): miette
//! 7.6 panics on a label past column ~65,530, and nobody reads such a line whole anyway.

use crate::syntax::span::{SourceMap, Span};
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
}

impl Stage {
    fn code(self) -> &'static str {
        match self {
            Stage::Syntax => "felt::syntax",
            Stage::Name => "felt::name",
            Stage::Type => "felt::type",
            Stage::Runtime => "felt::runtime",
            Stage::Usage => "felt::usage",
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

/// `1234567` as `1,234,567`: counts in messages are written this way, so a large one reads
/// at a glance.
pub fn grouped(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// A vector in messages as felt prints one, `(0.5, 1e155, -3.0)`: each component in its
/// shortest round-trip form, so huge and tiny values stay short.
pub fn vector_text(v: glam::DVec3) -> String {
    format!("({:?}, {:?}, {:?})", v.x, v.y, v.z)
}

/// A source line longer than this many bytes is shown cut down to windows around the label.
const LONG_LINE_BYTES: usize = 1000;
/// Bytes of a long line kept on either side of the label's start and of its end.
const WINDOW_BYTES: usize = 80;
/// What stands in for each cut-out piece of a long line.
const ELLIPSIS: &str = "…";

/// Source text as miette is shown it: every line longer than `LONG_LINE_BYTES` is cut to a
/// window around the label's ends (or its first bytes, on lines without one) with an ellipsis
/// for each piece left out. Line numbers are unchanged, offsets map both ways, and the column
/// miette prints in its header is worked out from the original text, so file, line and column
/// stay right.
struct Elided {
    original: Arc<str>,
    text: Arc<str>,
    /// The pieces of `original` kept, in order: (start, end, start in `text`). Empty when no line
    /// was cut and `text` is `original`.
    kept: Vec<(usize, usize, usize)>,
}

impl Elided {
    /// `original` with long lines cut around the byte offsets in `points` (the label's ends).
    fn new(original: Arc<str>, points: &[usize]) -> Elided {
        if !original
            .split('\n')
            .any(|line| line.len() > LONG_LINE_BYTES)
        {
            return Elided {
                text: original.clone(),
                original,
                kept: Vec::new(),
            };
        }
        let source: &str = &original;
        let mut text = String::with_capacity(source.len().min(1 << 20));
        let mut kept: Vec<(usize, usize, usize)> = vec![(0, 0, 0)];
        let mut keep = |text: &mut String, start: usize, end: usize| {
            match kept.last_mut() {
                Some(last) if last.1 == start => last.1 = end,
                _ => kept.push((start, end, text.len())),
            }
            text.push_str(&source[start..end]);
        };
        let mut line_start = 0;
        while line_start < source.len() {
            let next = source[line_start..]
                .find('\n')
                .map_or(source.len(), |i| line_start + i + 1);
            let line_end = if source[..next].ends_with('\n') {
                next - 1
            } else {
                next
            };
            if line_end - line_start <= LONG_LINE_BYTES {
                keep(&mut text, line_start, next);
                line_start = next;
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
            line_start = next;
        }
        Elided {
            original,
            text: text.into(),
            kept,
        }
    }

    /// Where an offset of the original text lies in `text`; one inside a cut-out piece goes to
    /// the start of its ellipsis, or to its end when `end` is set (for the end of a span).
    fn to_text(&self, offset: usize, end: bool) -> usize {
        let i = self.kept.partition_point(|&(start, _, _)| start <= offset);
        let Some(&(start, stop, at)) = i.checked_sub(1).and_then(|i| self.kept.get(i)) else {
            return offset.min(self.text.len());
        };
        if offset <= stop {
            at + (offset - start)
        } else if end {
            (at + (stop - start) + ELLIPSIS.len()).min(self.text.len())
        } else {
            at + (stop - start)
        }
    }

    /// Where an offset of `text` came from in the original text.
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
        if self.kept.is_empty() {
            return Ok(inner);
        }
        // miette counts the column in bytes from the line start; count it in the original.
        let offset = self.to_original(inner.span().offset());
        let line_start = self.original[..offset].rfind('\n').map_or(0, |i| i + 1);
        let column = if inner.column() == 0 {
            0
        } else {
            offset - line_start
        };
        Ok(Box::new(MietteSpanContents::new(
            inner.data(),
            *inner.span(),
            inner.line(),
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
            let elided = Elided::new(file.text.clone(), &[start, end]);
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

/// Renders diagnostics as text: with colours for a terminal, plain for files and tests.
pub fn render(diagnostics: &[Diagnostic], sources: &SourceMap, color: bool) -> String {
    let theme = if color {
        GraphicalTheme::unicode()
    } else {
        GraphicalTheme::unicode_nocolor()
    };
    let handler = GraphicalReportHandler::new_themed(theme)
        .with_width(100)
        .with_links(false);
    let mut out = String::new();
    for diagnostic in diagnostics {
        let report = Report::new(diagnostic, sources);
        if handler.render_report(&mut out, &report).is_err() {
            out.push_str(&diagnostic.message);
            out.push('\n');
        }
    }
    out
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

    #[test]
    fn short_lines_are_shown_whole() {
        let elided = Elided::new(Arc::from("a = 1;\nb = 2;\n"), &[0, 1]);
        assert!(elided.kept.is_empty());
        assert_eq!(&*elided.text, "a = 1;\nb = 2;\n");
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
        let elided = Elided::new(Arc::from(text.as_str()), &[start, end]);
        assert_eq!(elided.text.lines().count(), text.lines().count());
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
