//! The entry points of the front end: [`parse`] (source text to AST or syntax errors) and
//! [`is_incomplete`] (does the REPL need another line?).
//!
//! The key decision is that every message is written in the script author's terms, not the
//! parser generator's: lalrpop reports "unrecognized token, expected one of 40 terminals";
//! this module names the token as written (`` unexpected `}` ``), summarises large expected
//! sets ("expected an expression", "expected a statement"), puts a missing `;` at the end of
//! the line it belongs to, names the line of a bracket that is never closed, and drops the
//! echo errors that recovery produces. Before the parser runs, one linear scan over the
//! tokens bounds the nesting depth, so no input can build a tree too deep for the recursive
//! passes downstream, nor make error recovery slow.

use std::fmt;

use lalrpop_util::ParseError;

use super::ast::Program;
use super::grammar::ProgramParser;
use super::lexer::{LexError, Spanned, Token, tokenize};
use super::span::{FileId, Span};

pub use super::actions::MAX_NESTING;

/// At most this many errors are reported for one file; after that they are mostly echoes.
const MAX_ERRORS: usize = 50;

/// A lexical or syntactic error, with the text it points at and an optional hint.
#[derive(Clone, Debug, PartialEq)]
pub struct SyntaxError {
    pub message: String,
    pub span: Span,
    pub help: Option<String>,
}

impl SyntaxError {
    pub fn new(message: impl Into<String>, span: Span) -> SyntaxError {
        SyntaxError {
            message: message.into(),
            span,
            help: None,
        }
    }

    pub fn with_help(mut self, help: impl Into<String>) -> SyntaxError {
        self.help = Some(help.into());
        self
    }
}

impl fmt::Display for SyntaxError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for SyntaxError {}

/// Parses one source file. On failure returns every error found (lexical errors, or syntax
/// errors with recovery at statement boundaries), sorted by position; the first one is
/// always exact, later ones may follow from it.
pub fn parse(file: FileId, source: &str) -> Result<Program, Vec<SyntaxError>> {
    let (tokens, lex_errors) = tokenize(file, source);
    if !lex_errors.is_empty() {
        return Err(lex_errors);
    }
    let brackets = scan_brackets(file, &tokens);
    if let Some(error) = brackets.too_deep {
        return Err(vec![error]);
    }

    let mut recovered = Vec::new();
    let result = ProgramParser::new().parse(file, &mut recovered, tokens.iter().cloned().map(Ok));

    let context = Context {
        file,
        source,
        tokens: &tokens,
        brackets: &brackets,
    };
    let mut errors: Vec<(SyntaxError, bool)> = recovered
        .into_iter()
        .map(|r| context.describe(r.error))
        .collect();
    let program = match result {
        Ok(program) => Some(program),
        Err(error) => {
            errors.push(context.describe(error));
            None
        }
    };
    match program {
        Some(program) if errors.is_empty() => Ok(program),
        _ => Err(context.without_echoes(errors)),
    }
}

/// True when `source` stops in the middle of something that more text could finish: an
/// open `(`, `[` or `{`, an unterminated string, or an unterminated block comment. False for
/// complete input and for input with an error that no continuation can fix (a `}` with no
/// `{`, a stray character).
pub fn is_incomplete(source: &str) -> bool {
    use logos::Logos;
    let mut open: Vec<Token<'_>> = Vec::new();
    let source = &source[super::lexer::byte_order_mark_len(source)..];
    for token in Token::lexer(source) {
        match token {
            Ok(t) if t.is_opening_bracket() => open.push(t),
            Ok(t) => {
                if let Some(opener) = t.closes()
                    && open.pop() != Some(opener)
                {
                    return false;
                }
            }
            // These two consume the rest of the input, so they are at its end.
            Err(LexError::UnterminatedString | LexError::UnterminatedComment) => return true,
            Err(_) => return false,
        }
    }
    !open.is_empty()
}

/// What the bracket scan learned: used to bound nesting and to explain errors.
struct Brackets {
    /// Openers never closed, outermost first: (token, start offset).
    unclosed: Vec<(Token<'static>, usize)>,
    /// Start offsets of closers with no opener to match.
    unmatched: Vec<usize>,
    /// Start offsets of the tokens that separate statements: `{`, `}`, and `;` outside
    /// parentheses (so not the ones in a `for` header).
    boundaries: Vec<usize>,
    too_deep: Option<SyntaxError>,
}

/// One pass over the tokens that tracks open brackets and the statement heads (`if`,
/// `while`, `for`, `else`) whose bodies are still being read, which together bound how deep
/// the parser's stack and the resulting tree can get. A head is pending until the statement
/// it governs ends: at a `;` or `}` not followed by `else` (an `else` continues the chain).
/// The `else if` of a chain is no new head: the chain is one statement in the tree.
fn scan_brackets(file: FileId, tokens: &[Spanned<'_>]) -> Brackets {
    let mut open: Vec<(Token<'static>, usize)> = Vec::new();
    let mut unmatched = Vec::new();
    let mut boundaries = Vec::new();
    // Pending heads per brace level; level 0 is the top level of the file.
    let mut heads: Vec<usize> = vec![0];
    let mut pending = 0usize;
    let at_statement_level =
        |open: &[(Token<'static>, usize)]| matches!(open.last(), None | Some((Token::LBrace, _)));

    for (i, (start, token, end)) in tokens.iter().enumerate() {
        let next_is_else = matches!(tokens.get(i + 1), Some((_, Token::Else, _)));
        let next_is_if = matches!(tokens.get(i + 1), Some((_, Token::If, _)));
        let previous_is_else = matches!(
            i.checked_sub(1).and_then(|j| tokens.get(j)),
            Some((_, Token::Else, _))
        );
        let mut statement_ended = false;
        let mut deeper = None;
        match token {
            Token::LParen | Token::LBracket | Token::LBrace => {
                let opener = match token {
                    Token::LParen => Token::LParen,
                    Token::LBracket => Token::LBracket,
                    _ => Token::LBrace,
                };
                if opener == Token::LBrace {
                    heads.push(0);
                    boundaries.push(*start);
                    deeper = Some("blocks nested too deeply");
                } else {
                    deeper = Some("expression nested too deeply");
                }
                open.push((opener, *start));
            }
            Token::RParen | Token::RBracket | Token::RBrace => {
                let closes = token.closes();
                match open.last() {
                    Some((opener, _)) if Some(opener) == closes.as_ref() => {
                        open.pop();
                        if *token == Token::RBrace {
                            boundaries.push(*start);
                            pending -= heads.pop().unwrap_or(0);
                            statement_ended = at_statement_level(&open);
                        }
                    }
                    None => unmatched.push(*start),
                    // A mismatched closer: the parser reports it.
                    Some(_) => {}
                }
            }
            // An `else if` continues its chain (one statement in the tree) rather than
            // nesting in it: neither word is a new head.
            Token::Else if next_is_if => {}
            Token::If if previous_is_else => {}
            Token::If | Token::While | Token::For | Token::Else if at_statement_level(&open) => {
                if let Some(level) = heads.last_mut() {
                    *level += 1;
                    pending += 1;
                }
                deeper = Some("statements nested too deeply");
            }
            Token::Semi if at_statement_level(&open) => {
                statement_ended = true;
                boundaries.push(*start);
            }
            _ => {}
        }
        if statement_ended
            && !next_is_else
            && let Some(level) = heads.last_mut()
        {
            pending -= *level;
            *level = 0;
        }
        if let Some(mut message) = deeper
            && open.len() + pending > MAX_NESTING
        {
            // Name what most of the depth is made of.
            if pending >= open.len() {
                message = "statements nested too deeply";
            }
            let error = SyntaxError::new(
                format!("{message} (more than {MAX_NESTING} levels)"),
                Span::new(file, *start, *end),
            )
            .with_help("move inner parts into variables or functions");
            return Brackets {
                unclosed: open,
                unmatched,
                boundaries,
                too_deep: Some(error),
            };
        }
    }
    Brackets {
        unclosed: open,
        unmatched,
        boundaries,
        too_deep: None,
    }
}

/// Everything needed to turn lalrpop's errors into messages.
struct Context<'a, 'src> {
    file: FileId,
    source: &'src str,
    tokens: &'a [Spanned<'src>],
    brackets: &'a Brackets,
}

impl Context<'_, '_> {
    fn span(&self, start: usize, end: usize) -> Span {
        Span::new(self.file, start, end)
    }

    /// End of the token before the one starting at `start` (or `start` for the first).
    fn end_of_previous(&self, start: usize) -> usize {
        let i = self.tokens.partition_point(|(s, _, _)| *s < start);
        match i.checked_sub(1).and_then(|j| self.tokens.get(j)) {
            Some((_, _, end)) => *end,
            None => start,
        }
    }

    /// 1-based line of a byte offset, for hints that mention another place in the file.
    fn line_of(&self, offset: usize) -> usize {
        let before = self.source.get(..offset).unwrap_or(self.source);
        before.bytes().filter(|&b| b == b'\n').count() + 1
    }

    /// Sorts errors by position and drops echoes: after the parser recovers from an error
    /// it often trips again over the rest of the same statement, so a parser error is only
    /// kept when a statement boundary (`;`, `{` or `}`) lies between it and the previous one.
    /// Errors from the grammar's own checks (second flag false) are always kept.
    fn without_echoes(&self, mut errors: Vec<(SyntaxError, bool)>) -> Vec<SyntaxError> {
        errors.sort_by_key(|(e, _)| (e.span.start, e.span.end));
        let mut kept: Vec<SyntaxError> = Vec::new();
        let mut last_parser_error: Option<usize> = None;
        for (error, from_parser) in errors {
            if kept.len() == MAX_ERRORS || kept.last() == Some(&error) {
                continue;
            }
            let start = error.span.start as usize;
            if from_parser {
                if let Some(previous) = last_parser_error
                    && !self.boundary_between(previous, start)
                {
                    continue;
                }
                last_parser_error = Some(start);
            }
            kept.push(error);
        }
        kept
    }

    fn boundary_between(&self, from: usize, to: usize) -> bool {
        let boundaries = &self.brackets.boundaries;
        let first = boundaries.partition_point(|&b| b < from);
        boundaries.get(first).is_some_and(|&b| b < to)
    }

    /// The message for one error, and whether the parser (rather than a grammar check)
    /// raised it.
    fn describe(&self, error: ParseError<usize, Token<'_>, SyntaxError>) -> (SyntaxError, bool) {
        let from_parser = !matches!(error, ParseError::User { .. });
        (self.message(error), from_parser)
    }

    fn message(&self, error: ParseError<usize, Token<'_>, SyntaxError>) -> SyntaxError {
        match error {
            ParseError::User { error } => error,
            ParseError::UnrecognizedToken {
                token: (start, token, end),
                expected,
            } => self.unexpected_token(start, &token, end, &expected),
            ParseError::ExtraToken {
                token: (start, token, end),
            } => {
                let text = self.source.get(start..end).unwrap_or("");
                SyntaxError::new(
                    format!("unexpected {}", token.describe(text)),
                    self.span(start, end),
                )
            }
            ParseError::UnrecognizedEof { location, expected } => {
                self.unexpected_end(location, &expected)
            }
            ParseError::InvalidToken { location } => {
                SyntaxError::new("invalid token", self.span(location, location))
            }
        }
    }

    fn unexpected_token(
        &self,
        start: usize,
        token: &Token<'_>,
        end: usize,
        expected: &[String],
    ) -> SyntaxError {
        let text = self.source.get(start..end).unwrap_or("");
        let found = token.describe(text);
        let expected = Expected::new(expected);
        if expected.missing_semicolon() && *token != Token::Semi {
            let at = self.end_of_previous(start);
            return SyntaxError::new(
                format!("unexpected {found}, expected `;`"),
                self.span(at, at),
            )
            .with_help("add `;` at the end of the statement");
        }
        let message = match expected.summary() {
            Some(summary) => format!("unexpected {found}, expected {summary}"),
            None => format!("unexpected {found}"),
        };
        let error = SyntaxError::new(message, self.span(start, end));
        let help = if token.closes().is_some() && self.brackets.unmatched.contains(&start) {
            let opener = match token {
                Token::RParen => "(",
                Token::RBracket => "[",
                _ => "{",
            };
            Some(format!("this `{text}` has no matching `{opener}`"))
        } else {
            match token {
                Token::Else => Some("this `else` has no `if` to belong to".to_string()),
                Token::Assign if !expected.starts_expression() => {
                    Some("to compare two values, use `==`".to_string())
                }
                Token::MinusMinus | Token::PlusPlus if expected.starts_expression() => {
                    let sign = &text[..1];
                    Some(format!(
                        "`{text}` changes a variable by one; for two signs write `{sign} {sign}`"
                    ))
                }
                _ => None,
            }
        };
        match help {
            Some(help) => error.with_help(help),
            None => error,
        }
    }

    fn unexpected_end(&self, location: usize, expected: &[String]) -> SyntaxError {
        let expected = Expected::new(expected);
        let at = self.span(location, location);
        if let Some((opener, start)) = self.brackets.unclosed.last() {
            let (open, close) = match opener {
                Token::LParen => ("(", ")"),
                Token::LBracket => ("[", "]"),
                _ => ("{", "}"),
            };
            if expected.has(close) {
                return SyntaxError::new(format!("unexpected end of file, expected `{close}`"), at)
                    .with_help(format!(
                        "the `{open}` on line {} is never closed",
                        self.line_of(*start)
                    ));
            }
        }
        if expected.missing_semicolon() {
            return SyntaxError::new("unexpected end of file, expected `;`", at)
                .with_help("add `;` at the end of the statement");
        }
        match expected.summary() {
            Some(summary) => {
                SyntaxError::new(format!("unexpected end of file, expected {summary}"), at)
            }
            None => SyntaxError::new("unexpected end of file", at),
        }
    }
}

/// lalrpop's expected-terminal list, as the grammar names them (`";"`, `"identifier"`).
struct Expected<'a> {
    names: Vec<&'a str>,
}

/// Tokens that can continue an expression; listing them says little, so they are left out of
/// a summary when anything else is expected.
const CONTINUATIONS: &[&str] = &[
    "+", "-", "*", "/", "%", "^", "==", "!=", "<", "<=", ">", ">=", "&&", "||", "[", ".", "(", "=",
    "+=", "-=", "*=", "/=", "++", "--",
];

impl<'a> Expected<'a> {
    fn new(expected: &'a [String]) -> Expected<'a> {
        Expected {
            names: expected.iter().map(|s| s.trim_matches('"')).collect(),
        }
    }

    fn has(&self, name: &str) -> bool {
        self.names.contains(&name)
    }

    fn starts_expression(&self) -> bool {
        self.has("identifier") && self.has("int literal")
    }

    fn starts_statement(&self) -> bool {
        self.has("if")
    }

    /// A `;` could end what came before, and nothing else could start here: the statement is
    /// complete and its `;` is missing. (At the start of a statement `;` is expected too, as
    /// the empty statement, and after `return` an expression is as likely.)
    fn missing_semicolon(&self) -> bool {
        self.has(";") && !self.starts_statement() && !self.starts_expression()
    }

    /// A short description of what could have come next, or `None` if nothing is expected.
    fn summary(&self) -> Option<String> {
        if self.starts_statement() {
            return Some(if self.has("}") {
                "a statement or `}`".to_string()
            } else {
                "a statement".to_string()
            });
        }
        if self.starts_expression() {
            return Some(if self.has(";") {
                "an expression or `;`".to_string()
            } else {
                "an expression".to_string()
            });
        }
        if self.has("int") && self.has("scalarfield") {
            return Some("a type".to_string());
        }
        let mut shown: Vec<&str> = self
            .names
            .iter()
            .copied()
            .filter(|n| !CONTINUATIONS.contains(n))
            .collect();
        if shown.is_empty() {
            if self.names.is_empty() {
                return None;
            }
            shown = self.names.clone();
            if shown.len() > 4 {
                return Some("an operator".to_string());
            }
        }
        let mut words: Vec<String> = Vec::new();
        for name in shown {
            let word = match name {
                "identifier" => "identifier".to_string(),
                "int literal" | "float literal" => "number".to_string(),
                "string literal" => "string".to_string(),
                other => format!("`{other}`"),
            };
            if !words.contains(&word) {
                words.push(word);
            }
        }
        Some(match words.as_slice() {
            [] => return None,
            [one] => one.clone(),
            [init @ .., last] => format!("{} or {last}", init.join(", ")),
        })
    }
}
