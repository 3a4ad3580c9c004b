//! Statement checking: declarations, assignments and their targets, conditions, returns, and
//! whether every path through a function's body ends in `return`.

use super::types::{Type, binary_result};
use super::{Checker, constructor_exists};
use crate::syntax::ast::*;
use crate::syntax::diagnostic::Stage;
use crate::syntax::span::Span;
use std::collections::HashMap;

impl Checker<'_> {
    pub(super) fn stmt(&mut self, stmt: &Stmt) {
        match &stmt.kind {
            StmtKind::Decl {
                is_param,
                ty,
                name,
                init,
            } => self.declaration(stmt.span, *is_param, ty, name, init),
            StmtKind::Expr(e) => {
                self.expr(e);
            }
            StmtKind::Assign { target, op, value } => self.assignment(target, *op, value),
            StmtKind::IncDec { target, increment } => {
                let ty = self.target(target);
                if !(ty == Type::Int || ty.is_error()) {
                    let op = if *increment { "++" } else { "--" };
                    self.error(
                        Stage::Type,
                        target.span,
                        format!("`{op}` works on int variables, found {ty}"),
                    );
                }
            }
            StmtKind::If {
                branches,
                else_branch,
            } => {
                for (cond, block) in branches {
                    self.condition(cond);
                    self.block(block);
                }
                if let Some(block) = else_branch {
                    self.block(block);
                }
            }
            StmtKind::For {
                init,
                cond,
                step,
                body,
            } => {
                self.scopes.push(HashMap::new());
                if let Some(init) = init {
                    self.stmt(init);
                }
                if let Some(cond) = cond {
                    self.condition(cond);
                }
                if let Some(step) = step {
                    self.stmt(step);
                }
                self.loop_depth += 1;
                self.block(body);
                self.loop_depth -= 1;
                self.scopes.pop();
            }
            StmtKind::While { cond, body } => {
                self.condition(cond);
                self.loop_depth += 1;
                self.block(body);
                self.loop_depth -= 1;
            }
            StmtKind::Break | StmtKind::Continue => {
                if self.loop_depth == 0 {
                    let word = if matches!(stmt.kind, StmtKind::Break) {
                        "break"
                    } else {
                        "continue"
                    };
                    self.error(Stage::Type, stmt.span, format!("`{word}` outside a loop"));
                }
            }
            StmtKind::Return(value) => self.return_stmt(stmt.span, value.as_ref()),
            StmtKind::Block(b) => self.block(b),
        }
    }

    pub(super) fn condition(&mut self, cond: &Expr) {
        let ty = self.expr(cond);
        if !(ty == Type::Bool || ty.is_error()) {
            let d = self.error(
                Stage::Type,
                cond.span,
                format!("a condition must be a bool, found {ty}"),
            );
            if ty.is_number() {
                d.help = Some(String::from("compare explicitly, e.g. `x != 0`"));
            }
        }
    }

    pub(super) fn return_stmt(&mut self, span: Span, value: Option<&Expr>) {
        let ty = value.map(|v| self.expr(v));
        match (&self.function.clone(), ty) {
            (None, _) => {
                self.error(Stage::Type, span, "`return` outside a function");
            }
            (Some(Type::Void), Some(t)) if t != Type::Void => {
                self.error(
                    Stage::Type,
                    span,
                    format!("a void function cannot return a value (found {t})"),
                );
            }
            (Some(ret), None) if *ret != Type::Void => {
                self.error(
                    Stage::Type,
                    span,
                    format!("this function must return a {ret}"),
                );
            }
            (Some(ret), Some(t)) => {
                if let Some(v) = value {
                    self.expect(v.span, &t, ret, "wrong return type");
                }
            }
            _ => {}
        }
    }

    pub(super) fn declaration(
        &mut self,
        span: Span,
        is_param: bool,
        ty: &TypeExpr,
        name: &Ident,
        init: &DeclInit,
    ) {
        let declared = Type::from_expr(ty);
        if declared == Type::Void {
            self.error(Stage::Type, ty.span, "a variable cannot be void");
        }
        if is_param {
            if !self.scopes.is_empty() || self.function.is_some() {
                self.error(
                    Stage::Type,
                    span,
                    "`param` declarations belong at the top level of a script",
                );
            }
            if !matches!(
                declared,
                Type::Int | Type::Float | Type::Bool | Type::Str | Type::Vector
            ) {
                self.error(
                    Stage::Type,
                    ty.span,
                    format!("a param must be int, float, bool, string or vector, found {declared}"),
                );
            }
        }
        match init {
            DeclInit::Default => {
                if !declared.has_default() || declared == Type::Particles {
                    let builtins = self.env.builtins;
                    let d = self.error(
                        Stage::Type,
                        span,
                        format!(
                            "a {declared} has no default value; give `{}` one",
                            name.name
                        ),
                    );
                    if Type::from_base(ty.base) == declared && constructor_exists(builtins, ty.base)
                    {
                        d.help = Some(format!(
                            "use the constructor form: {}",
                            builtins
                                .get(ty.base.keyword())
                                .map(|b| b.forms().join(" or "))
                                .unwrap_or_default()
                        ));
                    }
                }
            }
            DeclInit::Expr(e) => {
                let found = self.expr(e);
                self.expect(
                    e.span,
                    &found,
                    &declared,
                    &format!("cannot initialise {declared} `{}`", name.name),
                );
            }
            DeclInit::Ctor(args) => {
                if ty.array_depth > 0 || !constructor_exists(self.env.builtins, ty.base) {
                    self.error(
                        Stage::Type,
                        span,
                        format!("{declared} has no constructor form"),
                    )
                    .help = Some(format!("write `{declared} {} = ...;`", name.name));
                    for a in args {
                        self.expr(&a.value);
                    }
                } else {
                    let found = self.builtin_call(ty.base.keyword(), span, args);
                    self.expect(span, &found, &declared, "constructor");
                }
            }
        }
        self.declare(name, declared);
    }

    pub(super) fn assignment(&mut self, target: &Expr, op: AssignOp, value: &Expr) {
        let target_ty = self.target(target);
        let value_ty = self.expr(value);
        let result = match op {
            AssignOp::Set => value_ty.clone(),
            AssignOp::Add | AssignOp::Sub | AssignOp::Mul | AssignOp::Div => {
                let bop = match op {
                    AssignOp::Add => BinaryOp::Add,
                    AssignOp::Sub => BinaryOp::Sub,
                    AssignOp::Mul => BinaryOp::Mul,
                    _ => BinaryOp::Div,
                };
                match binary_result(bop, &target_ty, &value_ty) {
                    Ok(t) => t,
                    Err(message) => {
                        self.error(Stage::Type, value.span, message);
                        Type::Error
                    }
                }
            }
        };
        self.expect(value.span, &result, &target_ty, "cannot assign");
    }

    /// The type of an assignable place: a declared variable or an element of an array.
    pub(super) fn target(&mut self, target: &Expr) -> Type {
        match &target.kind {
            ExprKind::Var(name) => match self.lookup(&name.name) {
                Some(info) => info.ty.clone(),
                None => {
                    let help = self.name_hint(&name.name);
                    let d = self.error(
                        Stage::Name,
                        name.span,
                        format!("assignment to undeclared variable `{}`", name.name),
                    );
                    d.help = Some(help.unwrap_or_else(|| {
                        format!("declare it first, e.g. `float {} = ...;`", name.name)
                    }));
                    Type::Error
                }
            },
            ExprKind::Index(base, index) => {
                let base_ty = self.target(base);
                self.index_type(index);
                match base_ty {
                    Type::Array(elem) => *elem,
                    Type::Error => Type::Error,
                    other => {
                        self.error(
                            Stage::Type,
                            base.span,
                            format!(
                                "only array elements can be assigned by index; this is a {other}"
                            ),
                        );
                        Type::Error
                    }
                }
            }
            _ => {
                self.error(
                    Stage::Type,
                    target.span,
                    "can only assign to a variable or an array element",
                );
                Type::Error
            }
        }
    }

    pub(super) fn index_type(&mut self, index: &Expr) {
        let t = self.expr(index);
        if !(t == Type::Int || t.is_error()) {
            self.error(
                Stage::Type,
                index.span,
                format!("an index must be an int, found {t}"),
            );
        }
    }
}

/// Does every path through the block end in `return`?
pub(super) fn block_returns(block: &Block) -> bool {
    block.stmts.iter().any(stmt_returns)
}

fn stmt_returns(stmt: &Stmt) -> bool {
    match &stmt.kind {
        StmtKind::Return(_) => true,
        StmtKind::Block(b) => block_returns(b),
        StmtKind::If {
            branches,
            else_branch: Some(otherwise),
        } => branches.iter().all(|(_, b)| block_returns(b)) && block_returns(otherwise),
        StmtKind::While { cond, body } => {
            matches!(cond.kind, ExprKind::Bool(true)) && !contains_break(body)
        }
        StmtKind::For {
            cond: None, body, ..
        } => !contains_break(body),
        _ => false,
    }
}

fn contains_break(block: &Block) -> bool {
    block.stmts.iter().any(|s| match &s.kind {
        StmtKind::Break => true,
        StmtKind::Block(b) => contains_break(b),
        StmtKind::If {
            branches,
            else_branch,
        } => {
            branches.iter().any(|(_, b)| contains_break(b))
                || else_branch.as_ref().is_some_and(contains_break)
        }
        _ => false,
    })
}
