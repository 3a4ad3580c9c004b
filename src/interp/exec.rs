//! Statements: declarations, assignment (with the append-at-`size` rule for arrays), control
//! flow and the `param` overrides from the command line.

use super::value::Value;
use super::{Flow, Interpreter};
use crate::base::failure::Failure;
use crate::check::types::Type;
use crate::interp::ops;
use crate::syntax::ast::*;
use crate::syntax::diagnostic::{Diagnostic, Stage};
use crate::syntax::span::Span;
use std::rc::Rc;

impl Interpreter {
    pub(crate) fn exec_block(&mut self, block: &Block) -> Result<Flow, Diagnostic> {
        self.push_scope();
        let result = self.exec_stmts(&block.stmts);
        self.pop_scope();
        result
    }

    fn exec_stmts(&mut self, stmts: &[Stmt]) -> Result<Flow, Diagnostic> {
        for stmt in stmts {
            match self.exec(stmt)? {
                Flow::Normal => {}
                other => return Ok(other),
            }
        }
        Ok(Flow::Normal)
    }

    pub(crate) fn exec(&mut self, stmt: &Stmt) -> Result<Flow, Diagnostic> {
        match &stmt.kind {
            StmtKind::Decl {
                is_param,
                ty,
                name,
                init,
            } => {
                let declared = Type::from_expr(ty);
                let value = if *is_param && self.overrides.contains_key(&name.name) {
                    override_value(name, &declared, &self.overrides[&name.name])?
                } else {
                    match init {
                        DeclInit::Default => Value::default_of(&declared).ok_or_else(|| {
                            self.error(
                                stmt.span,
                                Failure::new(format!("a {declared} needs a value")),
                            )
                        })?,
                        DeclInit::Expr(e) => self.eval(e)?,
                        DeclInit::Ctor(args) => {
                            self.call_builtin(ty.base.keyword(), stmt.span, args)?
                        }
                    }
                };
                if *is_param {
                    self.param_values
                        .push((name.name.clone(), value.to_string()));
                }
                if let (true, "frame", Value::Int(frame)) = (*is_param, name.name.as_str(), &value)
                {
                    // Frame patterns in paths (`####`) name this frame from now on.
                    crate::engine::output::set_frame(*frame);
                }
                self.declare(&name.name, declared, value);
                Ok(Flow::Normal)
            }
            StmtKind::Expr(e) => {
                self.eval(e)?;
                Ok(Flow::Normal)
            }
            StmtKind::Assign { target, op, value } => {
                let rhs = self.eval(value)?;
                let new_value = match op {
                    AssignOp::Set => rhs,
                    _ => {
                        let current = self.eval(target)?;
                        let bop = match op {
                            AssignOp::Add => BinaryOp::Add,
                            AssignOp::Sub => BinaryOp::Sub,
                            AssignOp::Mul => BinaryOp::Mul,
                            _ => BinaryOp::Div,
                        };
                        ops::binary(bop, current, rhs).map_err(|f| self.error(stmt.span, f))?
                    }
                };
                self.assign(target, new_value)?;
                Ok(Flow::Normal)
            }
            StmtKind::IncDec { target, increment } => {
                let current = self
                    .eval(target)?
                    .as_int()
                    .map_err(|f| self.error(target.span, f))?;
                let next = if *increment {
                    current.checked_add(1)
                } else {
                    current.checked_sub(1)
                };
                let next =
                    next.ok_or_else(|| self.error(stmt.span, Failure::new("integer overflow")))?;
                self.assign(target, Value::Int(next))?;
                Ok(Flow::Normal)
            }
            StmtKind::If {
                branches,
                else_branch,
            } => {
                for (cond, block) in branches {
                    if self.condition(cond)? {
                        return self.exec_block(block);
                    }
                }
                match else_branch {
                    Some(block) => self.exec_block(block),
                    None => Ok(Flow::Normal),
                }
            }
            StmtKind::For {
                init,
                cond,
                step,
                body,
            } => {
                self.push_scope();
                let flow = self.for_loop(init.as_deref(), cond.as_ref(), step.as_deref(), body);
                self.pop_scope();
                flow
            }
            StmtKind::While { cond, body } => {
                while self.condition(cond)? {
                    self.check_interrupt(stmt.span)?;
                    match self.exec_block(body)? {
                        Flow::Break => break,
                        Flow::Return(v) => return Ok(Flow::Return(v)),
                        Flow::Normal | Flow::Continue => {}
                    }
                }
                Ok(Flow::Normal)
            }
            StmtKind::Break => Ok(Flow::Break),
            StmtKind::Continue => Ok(Flow::Continue),
            StmtKind::Return(value) => {
                let v = match value {
                    Some(e) => self.eval(e)?,
                    None => Value::Void,
                };
                Ok(Flow::Return(v))
            }
            StmtKind::Block(b) => self.exec_block(b),
        }
    }

    fn for_loop(
        &mut self,
        init: Option<&Stmt>,
        cond: Option<&Expr>,
        step: Option<&Stmt>,
        body: &Block,
    ) -> Result<Flow, Diagnostic> {
        if let Some(init) = init {
            self.exec(init)?;
        }
        loop {
            if let Some(cond) = cond
                && !self.condition(cond)?
            {
                break;
            }
            self.check_interrupt(body.span)?;
            match self.exec_block(body)? {
                Flow::Break => break,
                Flow::Return(v) => return Ok(Flow::Return(v)),
                Flow::Normal | Flow::Continue => {}
            }
            if let Some(step) = step {
                self.exec(step)?;
            }
        }
        Ok(Flow::Normal)
    }

    fn condition(&mut self, cond: &Expr) -> Result<bool, Diagnostic> {
        let v = self.eval(cond)?;
        v.as_bool().map_err(|f| self.error(cond.span, f))
    }

    /// Stores `value` into a variable or array element, converting it to the declared type.
    fn assign(&mut self, target: &Expr, value: Value) -> Result<(), Diagnostic> {
        // Collect the index path from the variable outwards: a[i][j] → (a, [i, j]).
        let mut indices = Vec::new();
        let mut place = target;
        while let ExprKind::Index(base, index) = &place.kind {
            indices.push((self.eval(index)?, index.span));
            place = base;
        }
        indices.reverse();
        let ExprKind::Var(name) = &place.kind else {
            return Err(self.error(
                target.span,
                Failure::new("can only assign to a variable or an array element"),
            ));
        };
        let mut indices_checked = Vec::with_capacity(indices.len());
        for (index, span) in indices {
            let i = index.as_int().map_err(|f| self.error(span, f))?;
            indices_checked.push((i, span));
        }
        let error_at = |span: Span, message: String| {
            let f = Failure::new(message)
                .with_help("an array grows only by assigning at index size(a)");
            (span, f)
        };
        let slot = match self.lookup_mut(&name.name) {
            Some(slot) => slot,
            None => {
                let f = Failure::new(format!("`{}` is not declared yet at this point", name.name));
                return Err(self.error(name.span, f));
            }
        };
        let ty = slot.ty.clone();
        let result = store(&mut slot.value, &ty, &indices_checked, value, &error_at);
        result.map_err(|(span, f)| self.error(span, f))
    }
}

/// Writes `value` at the index path inside `target` (value semantics: shared arrays are copied
/// on write).
fn store(
    target: &mut Value,
    ty: &Type,
    path: &[(i64, Span)],
    value: Value,
    error_at: &dyn Fn(Span, String) -> (Span, Failure),
) -> Result<(), (Span, Failure)> {
    let Some(((index, span), rest)) = path.split_first() else {
        *target = value.convert(ty);
        return Ok(());
    };
    let Value::Array(items, elem) = target else {
        return Err((*span, Failure::new("only arrays can be assigned by index")));
    };
    let elem_ty = match ty {
        Type::Array(e) => (**e).clone(),
        _ => elem.clone(),
    };
    // Copying a shared array on write makes a second storage as large: it must fit first.
    if Rc::strong_count(items) > 1 {
        let what = format!("a copy of an array of {} elements", items.len());
        crate::field::node::check_beside_graphs(0.0, items.copy_bytes(), &what)
            .map_err(|f| (*span, f))?;
    }
    let items = Rc::make_mut(items);
    let len = items.len() as i64;
    if *index < 0 || *index > len {
        return Err(error_at(
            *span,
            format!("index {index} is out of range for an array of size {len}"),
        ));
    }
    if *index == len {
        if !rest.is_empty() {
            return Err(error_at(
                *span,
                format!("index {index} is out of range for an array of size {len}"),
            ));
        }
        return items.push(value.convert(&elem_ty)).map_err(|f| (*span, f));
    }
    items.update(*index as usize, |item| {
        store(item, &elem_ty, rest, value, error_at)
    })
}

/// The value `--set NAME=TEXT` gives the param declared as `name` of type `declared`, or the
/// diagnostic at the declaration (shared by `felt check --set` and the run itself).
pub fn override_value(name: &Ident, declared: &Type, text: &str) -> Result<Value, Diagnostic> {
    parse_override(text, declared).map_err(|message| {
        Diagnostic::error(
            Stage::Usage,
            name.span,
            format!("--set {}={}: {}", name.name, text, message),
        )
        .with_label("this param")
    })
}

/// Reads a `--set` value as the param's declared type.
pub fn parse_override(text: &str, ty: &Type) -> Result<Value, String> {
    let text = text.trim();
    match ty {
        Type::Int => text
            .parse::<i64>()
            .map(Value::Int)
            .map_err(|_| format!("expected an int, found `{text}`")),
        Type::Float => text
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .map(Value::Float)
            .ok_or_else(|| format!("expected a float, found `{text}`")),
        Type::Bool => match text {
            "true" | "1" => Ok(Value::Bool(true)),
            "false" | "0" => Ok(Value::Bool(false)),
            _ => Err(format!("expected true or false, found `{text}`")),
        },
        Type::Str => Ok(Value::string(text)),
        Type::Vector => {
            let inner = text.trim_start_matches('(').trim_end_matches(')');
            let parts: Vec<Option<f64>> = inner.split(',').map(|p| p.trim().parse().ok()).collect();
            match parts.as_slice() {
                [Some(x), Some(y), Some(z)] => Ok(Value::Vector(glam::DVec3::new(*x, *y, *z))),
                _ => Err(format!("expected a vector like (1, 2, 3), found `{text}`")),
            }
        }
        other => Err(format!(
            "a {other} param cannot be set from the command line"
        )),
    }
}
