//! What a buffer declares and where, read from its tokens: functions with their arguments,
//! `param`s with their defaults, variables, imports, and the block each name lives in; and,
//! at a cursor, the call it is inside. Hover, completion, signature help, definition and
//! symbols all read this.
//!
//! The key decision: it is built from felt's own lexer, not from the parser, because the text
//! an editor holds is mostly half-typed and does not parse, while the lexer never stops (an
//! unknown character or an open string is an error and lexing goes on). felt's declarations
//! are recognisable from tokens alone: every one starts with its type (`float x = ...`,
//! `param int frame = 1;`, `func scalarfield f(vector p) {...}`), and a name is in scope from
//! its declaration to the end of the braces around it. Nothing here judges the script: errors
//! are the checker's alone.

use crate::syntax::lexer::{Spanned, Token, tokenize};
use crate::syntax::span::FileId;
use std::ops::Range;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Function,
    /// A script `param`, which `felt run --set` may override.
    Param,
    Variable,
    /// A parameter of a function.
    Argument,
}

pub struct Declaration {
    pub kind: Kind,
    pub name: String,
    pub name_at: Range<usize>,
    /// The declared type as written (`scalarfield[]`); a function's return type.
    pub ty: String,
    /// The declaration as written, on one line: `param float step = 0.02`, or a function's
    /// signature `func scalarfield f(vector p)`.
    pub text: String,
    /// All of it: a function's body included.
    pub whole: Range<usize>,
    /// Where the name can be used.
    pub scope: Range<usize>,
    /// Braces around the declaration (0 at the top level).
    pub depth: usize,
    /// A function's arguments, as indices into the outline's declarations.
    pub arguments: Vec<usize>,
    /// The `//` lines right above a function.
    pub doc: String,
}

pub struct Import {
    pub path: String,
    /// The path's string literal.
    pub at: Range<usize>,
}

pub struct Outline {
    pub declarations: Vec<Declaration>,
    pub imports: Vec<Import>,
}

/// Tokens looked at past a declaration's name for the `;` that ends it.
const STATEMENT_SCAN: usize = 4096;
/// The longest declaration text kept for hover.
const TEXT_CHARS: usize = 240;

impl Outline {
    pub fn new(text: &str) -> Outline {
        let (tokens, _) = tokenize(FileId(0), text);
        let mut outline = Outline {
            declarations: Vec::new(),
            imports: Vec::new(),
        };
        // Per open brace: the declarations whose scope its `}` ends, and the function whose
        // body it is.
        let mut blocks: Vec<(Vec<usize>, Option<usize>)> = vec![(Vec::new(), None)];
        let mut arguments: Vec<usize> = Vec::new();
        let mut function: Option<usize> = None;
        let mut i = 0;
        while i < tokens.len() {
            let depth = blocks.len() - 1;
            match &tokens[i].1 {
                Token::LBrace => blocks.push((std::mem::take(&mut arguments), function.take())),
                Token::RBrace if blocks.len() > 1 => {
                    if let Some((closed, body_of)) = blocks.pop() {
                        for d in closed {
                            outline.declarations[d].scope.end = tokens[i].0;
                        }
                        if let Some(f) = body_of {
                            outline.declarations[f].whole.end = tokens[i].2;
                        }
                    }
                }
                Token::Import => {
                    if let Some((start, Token::Str(path), end)) = tokens.get(i + 1) {
                        outline.imports.push(Import {
                            path: path.clone(),
                            at: *start..*end,
                        });
                    }
                }
                Token::Func => {
                    if let Some((f, args, next)) = outline.read_function(text, &tokens, i, depth) {
                        if let Some(open) = blocks.last_mut() {
                            open.0.push(f);
                        }
                        arguments = args;
                        function = Some(f);
                        i = next;
                        continue;
                    }
                }
                Token::Param | Token::Type(_) => {
                    if let Some((d, next)) = outline.read_declaration(text, &tokens, i, depth) {
                        if let Some(open) = blocks.last_mut() {
                            open.0.push(d);
                        }
                        i = next;
                        continue;
                    }
                }
                _ => {}
            }
            i += 1;
        }
        outline
    }

    /// `func TYPE name(TYPE a, ...)` at token `at`: the function, its arguments and the token
    /// after what was read.
    fn read_function(
        &mut self,
        text: &str,
        tokens: &[Spanned],
        at: usize,
        depth: usize,
    ) -> Option<(usize, Vec<usize>, usize)> {
        let (ty, after_type) = type_at(text, tokens, at + 1)?;
        let (name_start, Token::Ident(name), name_end) = tokens.get(after_type)? else {
            return None;
        };
        let start = tokens[at].0;
        let mut next = after_type + 1;
        let mut signature_end = *name_end;
        let mut arguments = Vec::new();
        if let Some((_, Token::LParen, end)) = tokens.get(next) {
            signature_end = *end;
            next += 1;
            while let Some((arg_type, after)) = type_at(text, tokens, next) {
                let Some((s, Token::Ident(arg), e)) = tokens.get(after) else {
                    break;
                };
                arguments.push(self.push(Declaration {
                    kind: Kind::Argument,
                    name: arg.to_string(),
                    name_at: *s..*e,
                    text: format!("{arg_type} {arg}"),
                    ty: arg_type,
                    whole: tokens[next].0..*e,
                    scope: *e..text.len(),
                    depth: depth + 1,
                    arguments: Vec::new(),
                    doc: String::new(),
                }));
                signature_end = *e;
                next = after + 1;
                match tokens.get(next) {
                    Some((_, Token::Comma, _)) => next += 1,
                    _ => break,
                }
            }
            if let Some((_, Token::RParen, end)) = tokens.get(next) {
                signature_end = *end;
                next += 1;
            }
        }
        let f = self.push(Declaration {
            kind: Kind::Function,
            name: name.to_string(),
            name_at: *name_start..*name_end,
            ty,
            text: one_line(&text[start..signature_end]),
            whole: start..signature_end,
            scope: 0..text.len(),
            depth,
            arguments: arguments.clone(),
            doc: doc_above(text, start),
        });
        Some((f, arguments, next))
    }

    /// `[param] TYPE name ...;` at token `at` and the token after its name, or `None` when the
    /// tokens there are something else (a constructor call such as `scalarfield(1.0)`).
    fn read_declaration(
        &mut self,
        text: &str,
        tokens: &[Spanned],
        at: usize,
        depth: usize,
    ) -> Option<(usize, usize)> {
        let is_param = matches!(tokens[at].1, Token::Param);
        let (ty, after_type) = type_at(text, tokens, if is_param { at + 1 } else { at })?;
        let (name_start, Token::Ident(name), name_end) = tokens.get(after_type)? else {
            return None;
        };
        let start = tokens[at].0;
        let mut end = *name_end;
        let mut nesting = 0i32;
        for (_, token, token_end) in tokens.iter().skip(after_type + 1).take(STATEMENT_SCAN) {
            match token {
                Token::LParen | Token::LBracket => nesting += 1,
                Token::RParen | Token::RBracket if nesting > 0 => nesting -= 1,
                Token::RParen | Token::RBracket => break,
                Token::Semi if nesting == 0 => {
                    end = *token_end;
                    break;
                }
                Token::LBrace | Token::RBrace | Token::Semi => break,
                _ => {}
            }
            end = *token_end;
        }
        let d = self.push(Declaration {
            kind: if is_param {
                Kind::Param
            } else {
                Kind::Variable
            },
            name: name.to_string(),
            name_at: *name_start..*name_end,
            ty,
            text: one_line(text[start..end].trim_end_matches(';')),
            whole: start..end,
            scope: end..text.len(),
            depth,
            arguments: Vec::new(),
            doc: String::new(),
        });
        Some((d, after_type + 1))
    }

    fn push(&mut self, declaration: Declaration) -> usize {
        self.declarations.push(declaration);
        self.declarations.len() - 1
    }

    /// The declaration `name` means at `offset`: the innermost one in scope there, the latest
    /// of those; or the one whose name is at `offset`.
    pub fn resolve(&self, name: &str, offset: usize) -> Option<&Declaration> {
        if let Some(d) = self
            .declarations
            .iter()
            .find(|d| d.name_at.contains(&offset) || d.name_at.end == offset)
            .filter(|d| d.name == name)
        {
            return Some(d);
        }
        self.visible(offset)
            .filter(|d| d.name == name)
            .max_by_key(|d| (d.depth, d.name_at.start))
    }

    /// Every declaration whose name can be used at `offset`.
    pub fn visible(&self, offset: usize) -> impl Iterator<Item = &Declaration> {
        self.declarations
            .iter()
            .filter(move |d| d.scope.start <= offset && offset <= d.scope.end)
    }

    /// A function declared in this buffer.
    pub fn function(&self, name: &str) -> Option<&Declaration> {
        self.declarations
            .iter()
            .find(|d| d.kind == Kind::Function && d.name == name)
    }
}

/// A type at token `at` with its `[]`s, as written, and the token after it.
fn type_at(text: &str, tokens: &[Spanned], at: usize) -> Option<(String, usize)> {
    let &(start, Token::Type(_), end) = tokens.get(at)? else {
        return None;
    };
    let mut end = end;
    let mut next = at + 1;
    while let (Some((_, Token::LBracket, _)), Some((_, Token::RBracket, close))) =
        (tokens.get(next), tokens.get(next + 1))
    {
        end = *close;
        next += 2;
    }
    Some((text[start..end].split_whitespace().collect(), next))
}

/// Text on one line, whitespace runs as single spaces, cut to a readable length.
fn one_line(text: &str) -> String {
    let line = text.split_whitespace().collect::<Vec<_>>().join(" ");
    match line.char_indices().nth(TEXT_CHARS) {
        Some((cut, _)) => format!("{} …", &line[..cut]),
        None => line,
    }
}

/// The `//` comment lines right above `start`, joined, as `felt doc` reads the standard
/// library's.
fn doc_above(text: &str, start: usize) -> String {
    let lines: Vec<&str> = text[..start]
        .lines()
        .rev()
        .skip_while(|l| l.trim().is_empty())
        .take_while(|l| l.trim_start().starts_with("//"))
        .map(|l| l.trim_start().trim_start_matches('/').trim())
        .collect();
    lines.into_iter().rev().collect::<Vec<_>>().join(" ")
}

/// The name at or just before `offset`, and where it is.
pub fn word_at(text: &str, offset: usize) -> Option<(Range<usize>, &str)> {
    let is_word = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let bytes = text.as_bytes();
    let offset = offset.min(text.len());
    let mut start = offset;
    while start > 0 && is_word(bytes[start - 1]) {
        start -= 1;
    }
    let mut end = offset;
    while end < bytes.len() && is_word(bytes[end]) {
        end += 1;
    }
    let word = &text[start..end];
    (!word.is_empty() && !word.as_bytes()[0].is_ascii_digit()).then_some((start..end, word))
}

/// The call a cursor is in the argument list of.
#[derive(Debug, PartialEq)]
pub struct Call {
    pub callee: String,
    /// The argument the cursor is in, counted from 0.
    pub argument: usize,
    /// The keyword of that argument, when it is given as `name = ...`.
    pub keyword: Option<String>,
    /// Keywords already given, in any argument.
    pub given: Vec<String>,
    /// The cursor is where an argument starts, or in a bare name there, so a keyword may be
    /// typed.
    pub at_keyword: bool,
}

/// The innermost call whose parentheses are open at `offset`; `None` inside a vector, array
/// or block that is not a call's argument list.
pub fn call_at(text: &str, offset: usize) -> Option<Call> {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let (tokens, _) = tokenize(FileId(0), &text[..offset]);
    let mut depth = 0usize;
    let mut open = None;
    for (i, (_, token, _)) in tokens.iter().enumerate().rev() {
        match token {
            Token::RParen | Token::RBracket | Token::RBrace => depth += 1,
            Token::LParen | Token::LBracket | Token::LBrace if depth > 0 => depth -= 1,
            Token::LParen => {
                open = Some(i);
                break;
            }
            Token::LBracket | Token::LBrace => return None,
            Token::Semi if depth == 0 => return None,
            _ => {}
        }
    }
    let open = open?;
    let callee = match tokens.get(open.checked_sub(1)?)? {
        (_, Token::Ident(name), _) => name.to_string(),
        (start, Token::Type(_), end) => text[*start..*end].to_string(),
        _ => return None,
    };
    let mut arguments: Vec<&[Spanned]> = Vec::new();
    let (mut from, mut depth) = (open + 1, 0usize);
    for (i, (_, token, _)) in tokens.iter().enumerate().skip(open + 1) {
        match token {
            Token::LParen | Token::LBracket | Token::LBrace => depth += 1,
            Token::RParen | Token::RBracket | Token::RBrace => depth = depth.saturating_sub(1),
            Token::Comma if depth == 0 => {
                arguments.push(&tokens[from..i]);
                from = i + 1;
            }
            _ => {}
        }
    }
    arguments.push(&tokens[from..]);
    let keyword_of = |argument: &[Spanned]| match argument {
        [(_, Token::Ident(name), _), (_, Token::Assign, _), ..] => Some(name.to_string()),
        _ => None,
    };
    let current = arguments.last().copied().unwrap_or_default();
    Some(Call {
        callee,
        argument: arguments.len() - 1,
        keyword: keyword_of(current),
        given: arguments.iter().filter_map(|a| keyword_of(a)).collect(),
        at_keyword: matches!(current, [] | [(_, Token::Ident(_), _)]),
    })
}

/// The start of the string literal `offset` is inside (its opening quote), on the cursor's
/// line; `None` outside strings and in comments.
pub fn string_at(text: &str, offset: usize) -> Option<usize> {
    let offset = offset.min(text.len());
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line = &text.as_bytes()[line_start..offset];
    let mut open = None;
    let mut i = 0;
    while i < line.len() {
        match (open, line[i]) {
            (Some(_), b'\\') => i += 1,
            (Some(_), b'"') => open = None,
            (None, b'"') => open = Some(line_start + i),
            (None, b'/') if line.get(i + 1) == Some(&b'/') => return None,
            _ => {}
        }
        i += 1;
    }
    open
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn declarations_scopes_and_calls_are_read_from_tokens() {
        let text = "param float step = 0.02;\n\
                    // The density.\n\
                    func scalarfield d(vector p, float r) {\n  float k = r * 2;\n  return k;\n}\n\
                    render(\"a.exr\", density = d, shadows = \"m";
        let outline = Outline::new(text);
        let names: Vec<(&str, Kind)> = outline
            .declarations
            .iter()
            .map(|d| (d.name.as_str(), d.kind))
            .collect();
        assert_eq!(
            names,
            [
                ("step", Kind::Param),
                ("p", Kind::Argument),
                ("r", Kind::Argument),
                ("d", Kind::Function),
                ("k", Kind::Variable)
            ]
        );
        assert_eq!(outline.declarations[0].text, "param float step = 0.02");
        assert_eq!(
            outline.declarations[3].text,
            "func scalarfield d(vector p, float r)"
        );
        assert_eq!(outline.declarations[3].doc, "The density.");
        // `k` and `r` end with the function's body; `step` lasts to the end.
        let after_body = text.find("render").unwrap_or(0);
        assert!(outline.resolve("k", after_body).is_none());
        assert!(outline.resolve("r", after_body).is_none());
        assert_eq!(
            outline.resolve("step", after_body).map(|d| d.kind),
            Some(Kind::Param)
        );
        let inside = text.find("return").unwrap_or(0);
        assert_eq!(
            outline.resolve("k", inside).map(|d| d.kind),
            Some(Kind::Variable)
        );
        let call = call_at(text, text.len()).map(|c| (c.callee, c.argument, c.keyword));
        assert_eq!(call, Some(("render".into(), 2, Some("shadows".into()))));
        assert_eq!(string_at(text, text.len()), text.rfind('"'));
        assert_eq!(string_at(text, text.find("a.exr").unwrap_or(0) + 6), None);
    }
}
