//! The node builders that the grammar's actions call: they attach spans, apply the checks
//! that are easier in Rust than in grammar rules (assignment targets, argument order,
//! `param` placement), and enforce the nesting limit.
//!
//! The key decision is where nesting is bounded. The LR parser itself is iterative, but the
//! AST it builds is a tree of boxes, and everything downstream (dropping it, printing it,
//! checking it, running it) walks that tree recursively. So no expression deeper than
//! [`MAX_NESTING`] is ever built: each builder measures the node it makes and refuses with
//! "expression nested too deeply". Measuring recurses too, but only through nodes that
//! already passed the check, so it never goes deeper than the limit. What scripts repeat
//! without nesting is built flat and costs no depth: a left-associative operator continues
//! the chain to its left (`1 + 1 + ... + 1` is one node, and only each new operand is
//! measured), and an `else if` joins the `if` before it. Runs of prefix operators and `^`
//! chains are collected as lists by the grammar and folded here, so that `- - - - x` does not
//! deepen the parser's own stack either. Statement nesting (blocks and bare `if`/`for`/`while`
//! bodies) is bounded before parsing, by the bracket scan in `parse`.

use std::collections::VecDeque;

use lalrpop_util::{ErrorRecovery, ParseError};

use super::ast::*;
use super::lexer::Token;
use super::parse::SyntaxError;
use super::span::{FileId, Span};

/// The deepest expression (and statement) nesting a script may use. 256 is far beyond any
/// hand-written script, and small enough that a recursive walk over the tree needs well under
/// a megabyte of stack.
pub const MAX_NESTING: usize = 256;

/// The most `[]` a type may have (arrays of arrays of ...): what a `u8` holds.
pub const MAX_ARRAY_DEPTH: usize = u8::MAX as usize;

/// An error kept during parsing, either lalrpop's own (with its recovery) or one of ours.
pub type Recovery<'src> = ErrorRecovery<usize, Token<'src>, SyntaxError>;
/// What a fallible grammar action returns; an `Err` stops the parse.
pub type Built<'src, T> = Result<T, ParseError<usize, Token<'src>, SyntaxError>>;

/// Records an error that does not stop parsing (the rest of the file is still checked).
pub fn report(errors: &mut Vec<Recovery<'_>>, error: SyntaxError) {
    errors.push(ErrorRecovery {
        error: ParseError::User { error },
        dropped_tokens: Vec::new(),
    });
}

pub fn span(file: FileId, start: usize, end: usize) -> Span {
    Span::new(file, start, end)
}

/// Nesting depth of an expression: a chain of operations is one level, whatever its length.
/// Only called on children that were themselves checked, so the recursion is bounded by
/// [`MAX_NESTING`].
fn depth(e: &Expr) -> usize {
    1 + match &e.kind {
        ExprKind::Int(_)
        | ExprKind::Float(_)
        | ExprKind::Bool(_)
        | ExprKind::Str(_)
        | ExprKind::Var(_) => 0,
        ExprKind::Tuple(items) | ExprKind::Array(items) => {
            items.iter().map(depth).max().unwrap_or(0)
        }
        ExprKind::Unary(_, operand) | ExprKind::Member(operand, _) => depth(operand),
        ExprKind::Binary(first, operations) => operations
            .iter()
            .map(|o| depth(&o.operand))
            .fold(depth(first), usize::max),
        ExprKind::Index(a, b) => depth(a).max(depth(b)),
        ExprKind::Call { args, .. } => args.iter().map(|a| depth(&a.value)).max().unwrap_or(0),
    }
}

fn too_deep<'src>(span: Span) -> ParseError<usize, Token<'src>, SyntaxError> {
    ParseError::User {
        error: SyntaxError::new(
            format!("expression nested too deeply (more than {MAX_NESTING} levels)"),
            span,
        )
        .with_help("compute parts of this expression into variables first"),
    }
}

fn checked<'src>(kind: ExprKind, span: Span) -> Built<'src, Expr> {
    let e = Expr { kind, span };
    if depth(&e) > MAX_NESTING {
        return Err(too_deep(span));
    }
    Ok(e)
}

/// `left op right`. When `left` is itself a chain of operations written without parentheses,
/// this one continues it: `a + b - c` is one node folding `a` with `+ b` then `- c`, which is
/// what the tree `(a + b) - c` computes, so a long sum stays one node. (Parenthesised, the
/// chain is left as it is: parentheses are nesting, and counted.) The chain passed the depth
/// check when it was built, so only the new operand is measured, and building a chain of n
/// terms takes time linear in n.
pub fn binary<'src>(left: Expr, op: BinaryOp, right: Expr) -> Built<'src, Expr> {
    let span = left.span.to(right.span);
    let operation = Operation {
        op,
        operand: right,
        span,
    };
    let Expr {
        kind,
        span: left_span,
    } = left;
    match kind {
        ExprKind::Binary(first, mut operations)
            if operations.last().is_some_and(|o| o.span == left_span) =>
        {
            if 1 + depth(&operation.operand) > MAX_NESTING {
                return Err(too_deep(span));
            }
            operations.push(operation);
            Ok(Expr {
                kind: ExprKind::Binary(first, operations),
                span,
            })
        }
        kind => {
            let left = Expr {
                kind,
                span: left_span,
            };
            checked(ExprKind::Binary(Box::new(left), vec![operation]), span)
        }
    }
}

/// Applies prefix operators (each with its start offset), innermost first. A `-` directly
/// applied to a number literal becomes part of the literal, so that `-1` is the constant
/// `-1` rather than a negation node.
pub fn prefix<'src>(ops: Vec<(UnaryOp, usize)>, operand: Expr) -> Built<'src, Expr> {
    let mut e = operand;
    for (op, start) in ops.into_iter().rev() {
        let span = Span {
            start: start as u32,
            ..e.span
        };
        e = match (op, e.kind) {
            (UnaryOp::Neg, ExprKind::Int(n)) => Expr {
                // Literals are non-negative from the lexer, and folding twice (`- -1`)
                // gives back a non-negative value, so this never overflows.
                kind: ExprKind::Int(n.wrapping_neg()),
                span,
            },
            (UnaryOp::Neg, ExprKind::Float(x)) => Expr {
                kind: ExprKind::Float(-x),
                span,
            },
            (op, kind) => {
                let inner = Expr { kind, span: e.span };
                checked(ExprKind::Unary(op, Box::new(inner)), span)?
            }
        };
    }
    Ok(e)
}

/// `base ^ (ops e1) ^ (ops e2) ...` folded from the right: `^` is right-associative, and each
/// right operand may carry prefix operators (`2^-1`), which apply to the whole power to its
/// right: in `2 ^ -x ^ 2` the minus negates `x ^ 2`.
pub fn power<'src>(base: Expr, mut rest: Vec<(Vec<(UnaryOp, usize)>, Expr)>) -> Built<'src, Expr> {
    let Some((ops, last)) = rest.pop() else {
        return Ok(base);
    };
    let mut exponent = prefix(ops, last)?;
    while let Some((ops, e)) = rest.pop() {
        exponent = prefix(ops, binary(e, BinaryOp::Pow, exponent)?)?;
    }
    binary(base, BinaryOp::Pow, exponent)
}

pub fn index<'src>(target: Expr, at: Expr, end: usize) -> Built<'src, Expr> {
    let span = Span {
        end: end as u32,
        ..target.span
    };
    checked(ExprKind::Index(Box::new(target), Box::new(at)), span)
}

pub fn member<'src>(target: Expr, name: Ident) -> Built<'src, Expr> {
    let span = target.span.to(name.span);
    checked(ExprKind::Member(Box::new(target), name), span)
}

pub fn tuple<'src>(items: Vec<Expr>, span: Span) -> Built<'src, Expr> {
    checked(ExprKind::Tuple(items), span)
}

pub fn array<'src>(items: Vec<Expr>, span: Span) -> Built<'src, Expr> {
    checked(ExprKind::Array(items), span)
}

/// A parenthesised expression is the expression itself; its span grows to cover the
/// parentheses so that diagnostics quote what the author wrote.
pub fn parenthesised(e: Expr, span: Span) -> Expr {
    Expr { span, ..e }
}

pub fn call<'src>(
    callee: Ident,
    args: Vec<Arg>,
    span: Span,
    errors: &mut Vec<Recovery<'src>>,
) -> Built<'src, Expr> {
    check_argument_order(&args, errors);
    checked(ExprKind::Call { callee, args }, span)
}

/// A type keyword used as a constructor (`scalarfield(1.0)`): a call whose callee is the
/// type's canonical keyword (`scalarmcache(...)` calls `scalarcache`).
pub fn type_call<'src>(
    base: BaseType,
    keyword_span: Span,
    args: Vec<Arg>,
    span: Span,
    errors: &mut Vec<Recovery<'src>>,
) -> Built<'src, Expr> {
    let callee = Ident {
        name: base.keyword().to_string(),
        span: keyword_span,
    };
    call(callee, args, span, errors)
}

/// Keyword arguments come after all positional ones (`render("a.exr", step = 0.01)`).
pub fn check_argument_order(args: &[Arg], errors: &mut Vec<Recovery<'_>>) {
    let Some(first_named) = args.iter().position(|a| a.name.is_some()) else {
        return;
    };
    let keyword = args[first_named]
        .name
        .as_ref()
        .map(|n| n.name.clone())
        .unwrap_or_default();
    for arg in &args[first_named..] {
        if arg.name.is_none() {
            report(
                errors,
                SyntaxError::new("positional argument after a keyword argument", arg.span)
                    .with_help(format!(
                        "put positional arguments before `{keyword} = ...`, \
                         or give this one a name too"
                    )),
            );
        }
    }
}

/// A type as written: `base` followed by `dims` pairs of `[]`.
pub fn type_expr<'src>(base: BaseType, dims: usize, span: Span) -> Built<'src, TypeExpr> {
    match u8::try_from(dims) {
        Ok(array_depth) if dims <= MAX_ARRAY_DEPTH => Ok(TypeExpr {
            base,
            array_depth,
            span,
        }),
        _ => Err(ParseError::User {
            error: SyntaxError::new(
                format!("too many `[]` in a type (more than {MAX_ARRAY_DEPTH})"),
                span,
            ),
        }),
    }
}

/// One `name`, `name = e` or `name(args)` of a declaration.
pub struct Declarator {
    pub name: Ident,
    pub init: DeclInit,
    pub span: Span,
}

/// `[param] T a = 1, b, c(x)`: one statement per declarator, all with the same type. The
/// first statement's span starts at the beginning of the declaration (so it covers the
/// type); the others cover their own declarator.
pub fn declare(
    is_param: bool,
    ty: TypeExpr,
    declarators: Vec<Declarator>,
    start: usize,
) -> Vec<Stmt> {
    declarators
        .into_iter()
        .enumerate()
        .map(|(i, d)| Stmt {
            span: if i == 0 {
                Span {
                    start: start as u32,
                    ..d.span
                }
            } else {
                d.span
            },
            kind: StmtKind::Decl {
                is_param,
                ty: ty.clone(),
                name: d.name,
                init: d.init,
            },
        })
        .collect()
}

/// Grows the last statement's span to cover the `;` that ends the list.
pub fn terminated(mut stmts: Vec<Stmt>, end: usize) -> Vec<Stmt> {
    if let Some(last) = stmts.last_mut() {
        last.span.end = last.span.end.max(end as u32);
    }
    stmts
}

/// Only variables and array elements (`x`, `a[i]`, `a[i][j]`) can be assigned to.
fn is_assignable(target: &Expr) -> bool {
    let mut e = target;
    while let ExprKind::Index(inner, _) = &e.kind {
        e = inner;
    }
    matches!(e.kind, ExprKind::Var(_))
}

fn check_target(target: &Expr, what: &str, errors: &mut Vec<Recovery<'_>>) {
    if is_assignable(target) {
        return;
    }
    let help = match &target.kind {
        ExprKind::Member(..) => {
            "vector components cannot be assigned one by one; \
             build a new vector, e.g. `v = (x, v.y, v.z)`"
        }
        _ => "the left side must be a name such as `x` or an element such as `a[i]`",
    };
    report(
        errors,
        SyntaxError::new(
            format!("can only {what} a variable or an array element"),
            target.span,
        )
        .with_help(help),
    );
}

pub fn assign(target: Expr, op: AssignOp, value: Expr, errors: &mut Vec<Recovery<'_>>) -> StmtKind {
    check_target(&target, "assign to", errors);
    StmtKind::Assign { target, op, value }
}

pub fn inc_dec(target: Expr, increment: bool, errors: &mut Vec<Recovery<'_>>) -> StmtKind {
    check_target(
        &target,
        if increment { "increment" } else { "decrement" },
        errors,
    );
    StmtKind::IncDec { target, increment }
}

/// `param` declarations are the script's command-line inputs, so they live at its top level.
fn check_no_params(stmts: &[Stmt], errors: &mut Vec<Recovery<'_>>) {
    for stmt in stmts {
        if let StmtKind::Decl { is_param: true, .. } = stmt.kind {
            report(
                errors,
                SyntaxError::new(
                    "`param` declarations must be at the top level of the script",
                    stmt.span,
                )
                .with_help("move it out of the block, or drop `param` to make it a local variable"),
            );
        }
    }
}

/// A braced block `{ ... }`.
pub fn block(stmts: Vec<Stmt>, span: Span, errors: &mut Vec<Recovery<'_>>) -> Block {
    check_no_params(&stmts, errors);
    Block { stmts, span }
}

/// The body of `if`/`for`/`while`: a braced block as is, or a single statement wrapped in a
/// block of its own (a declaration there is local to the body).
pub fn body(mut stmts: Vec<Stmt>, span: Span, errors: &mut Vec<Recovery<'_>>) -> Block {
    if stmts.len() == 1
        && let Some(Stmt {
            kind: StmtKind::Block(b),
            ..
        }) = stmts.pop_if(|s| matches!(s.kind, StmtKind::Block(_)))
    {
        return b;
    }
    block(stmts, span, errors)
}

/// The `else` part: another `if` (an `else if`) or a block.
pub fn else_branch(mut stmts: Vec<Stmt>, span: Span, errors: &mut Vec<Recovery<'_>>) -> Stmt {
    if stmts.len() == 1
        && let Some(stmt) =
            stmts.pop_if(|s| matches!(s.kind, StmtKind::If { .. } | StmtKind::Block(_)))
    {
        return stmt;
    }
    Stmt {
        kind: StmtKind::Block(block(stmts, span, errors)),
        span,
    }
}

/// `if (cond) then_branch` with its `else` part, if any. An `if` as the `else` part is an
/// `else if`: its branches join this one's, so the chain is one statement however long.
/// Each is added in front of the chain in constant time (the chain is built from its end).
pub fn if_else(cond: Expr, then_branch: Block, else_part: Option<Stmt>, span: Span) -> Stmt {
    let (mut branches, else_branch) = match else_part {
        None => (VecDeque::new(), None),
        Some(Stmt {
            kind:
                StmtKind::If {
                    branches,
                    else_branch,
                },
            ..
        }) => (branches, else_branch),
        Some(Stmt {
            kind: StmtKind::Block(b),
            ..
        }) => (VecDeque::new(), Some(b)),
        Some(other) => {
            let span = other.span;
            (
                VecDeque::new(),
                Some(Block {
                    stmts: vec![other],
                    span,
                }),
            )
        }
    };
    branches.push_front((cond, then_branch));
    Stmt {
        kind: StmtKind::If {
            branches,
            else_branch,
        },
        span,
    }
}

/// A declaration in a `for` header: the header is not the top level.
pub fn for_init(stmt: Stmt, errors: &mut Vec<Recovery<'_>>) -> Box<Stmt> {
    check_no_params(std::slice::from_ref(&stmt), errors);
    Box::new(stmt)
}

/// `func` and `import` inside a block: parsed (so the rest of the file is still checked) and
/// reported.
pub fn misplaced(what: &str, span: Span, errors: &mut Vec<Recovery<'_>>) -> Vec<Stmt> {
    let (message, help) = match what {
        "func" => (
            "functions can only be declared at the top level of a file",
            "move this function out of the block; functions are visible in the whole file",
        ),
        _ => (
            "`import` can only appear at the top level of a file",
            "move the import to the top of the file",
        ),
    };
    report(errors, SyntaxError::new(message, span).with_help(help));
    Vec::new()
}
