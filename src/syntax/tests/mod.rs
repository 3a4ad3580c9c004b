//! Tests of the front end as a whole: the AST that scripts produce (rendered as compact
//! S-expressions so that whole trees can be compared), the exact position of every kind of
//! syntax error, and robustness against arbitrary input.

mod errors;
mod robustness;
mod trees;

use super::ast::*;
use super::parse::{SyntaxError, parse};
use super::span::{FileId, SourceFile};

/// Parses `source`, panicking with the errors if it does not parse.
fn program(source: &str) -> Program {
    match parse(FileId(0), source) {
        Ok(p) => p,
        Err(errors) => panic!("{source:?} did not parse: {errors:#?}"),
    }
}

/// All errors of `source`, which must not parse.
fn errors(source: &str) -> Vec<SyntaxError> {
    match parse(FileId(0), source) {
        Ok(p) => panic!("{source:?} parsed, expected an error: {p:#?}"),
        Err(errors) => errors,
    }
}

/// The first error, with its 1-based line and column.
fn first_error(source: &str) -> (String, usize, usize, Option<String>) {
    let e = errors(source).remove(0);
    let (line, column) = SourceFile::new("test.felt", source).line_col(e.span.start as usize);
    (e.message, line, column, e.help)
}

/// The whole program as S-expressions, one item per line.
fn render(source: &str) -> String {
    program(source)
        .items
        .iter()
        .map(|item| match item {
            Item::Func(f) => render_func(f),
            Item::Import(i) => format!("(import {:?})", i.path),
            Item::Stmt(s) => render_stmt(s),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// One expression, written as an expression statement.
fn expr(source: &str) -> String {
    render(&format!("{source};"))
}

fn render_type(t: &TypeExpr) -> String {
    format!(
        "{}{}",
        t.base.keyword(),
        "[]".repeat(t.array_depth as usize)
    )
}

fn render_func(f: &FuncDecl) -> String {
    let params: Vec<String> = f
        .params
        .iter()
        .map(|p| format!("{} {}", render_type(&p.ty), p.name.name))
        .collect();
    format!(
        "(func {} {} ({}) {})",
        render_type(&f.ret),
        f.name.name,
        params.join(", "),
        render_block(&f.body)
    )
}

fn render_block(b: &Block) -> String {
    let stmts: Vec<String> = b.stmts.iter().map(render_stmt).collect();
    format!("{{{}}}", stmts.join(" "))
}

fn render_stmt(s: &Stmt) -> String {
    match &s.kind {
        StmtKind::Decl {
            is_param,
            ty,
            name,
            init,
        } => {
            let init = match init {
                DeclInit::Default => String::new(),
                DeclInit::Expr(e) => format!(" = {}", render_expr(e)),
                DeclInit::Ctor(args) => format!(" ({})", render_args(args)),
            };
            let param = if *is_param { "param " } else { "" };
            format!("(decl {param}{} {}{init})", render_type(ty), name.name)
        }
        StmtKind::Expr(e) => render_expr(e),
        StmtKind::Assign { target, op, value } => {
            let op = match op {
                AssignOp::Set => "=",
                AssignOp::Add => "+=",
                AssignOp::Sub => "-=",
                AssignOp::Mul => "*=",
                AssignOp::Div => "/=",
            };
            format!("({op} {} {})", render_expr(target), render_expr(value))
        }
        StmtKind::IncDec { target, increment } => {
            format!(
                "({} {})",
                if *increment { "++" } else { "--" },
                render_expr(target)
            )
        }
        StmtKind::If {
            branches,
            else_branch,
        } => {
            // Written as nested `if`s, the way the chain reads.
            let mut text = else_branch.as_ref().map(render_block);
            for (cond, block) in branches.iter().rev() {
                text = Some(match text {
                    Some(e) => format!(
                        "(if {} {} else {e})",
                        render_expr(cond),
                        render_block(block)
                    ),
                    None => format!("(if {} {})", render_expr(cond), render_block(block)),
                });
            }
            text.unwrap_or_default()
        }
        StmtKind::For {
            init,
            cond,
            step,
            body,
        } => format!(
            "(for {}; {}; {} {})",
            init.as_ref().map(|s| render_stmt(s)).unwrap_or_default(),
            cond.as_ref().map(render_expr).unwrap_or_default(),
            step.as_ref().map(|s| render_stmt(s)).unwrap_or_default(),
            render_block(body)
        ),
        StmtKind::While { cond, body } => {
            format!("(while {} {})", render_expr(cond), render_block(body))
        }
        StmtKind::Break => "break".to_string(),
        StmtKind::Continue => "continue".to_string(),
        StmtKind::Return(Some(e)) => format!("(return {})", render_expr(e)),
        StmtKind::Return(None) => "(return)".to_string(),
        StmtKind::Block(b) => render_block(b),
    }
}

fn render_args(args: &[Arg]) -> String {
    args.iter()
        .map(|a| match &a.name {
            Some(n) => format!("{}={}", n.name, render_expr(&a.value)),
            None => render_expr(&a.value),
        })
        .collect::<Vec<_>>()
        .join(" ")
}

fn render_list(tag: &str, items: &[Expr]) -> String {
    let mut parts = vec![tag.to_string()];
    parts.extend(items.iter().map(render_expr));
    format!("({})", parts.join(" "))
}

fn render_expr(e: &Expr) -> String {
    match &e.kind {
        ExprKind::Int(n) => n.to_string(),
        ExprKind::Float(x) => format!("{x:?}"),
        ExprKind::Bool(b) => b.to_string(),
        ExprKind::Str(s) => format!("{s:?}"),
        ExprKind::Var(v) => v.name.clone(),
        ExprKind::Tuple(items) => render_list("tuple", items),
        ExprKind::Array(items) => render_list("array", items),
        ExprKind::Unary(op, x) => {
            let op = match op {
                UnaryOp::Neg => "neg",
                UnaryOp::Not => "!",
                UnaryOp::Plus => "pos",
            };
            format!("({op} {})", render_expr(x))
        }
        // Written as the nested operations it folds, `(- (+ a b) c)` for `a + b - c`.
        ExprKind::Binary(first, operations) => {
            operations.iter().fold(render_expr(first), |acc, o| {
                format!("({} {acc} {})", o.op.symbol(), render_expr(&o.operand))
            })
        }
        ExprKind::Call { callee, args } if args.is_empty() => format!("({})", callee.name),
        ExprKind::Call { callee, args } => format!("({} {})", callee.name, render_args(args)),
        ExprKind::Index(a, i) => format!("(index {} {})", render_expr(a), render_expr(i)),
        ExprKind::Member(a, m) => format!("(. {} {})", render_expr(a), m.name),
    }
}
