//! Expressions and calls. Builtin calls resolve their signature again from the runtime types
//! (the same rules the checker used, so the same form is chosen) and receive their arguments
//! converted to that form's parameter types.

use super::registry::{self, Args, Resolution};
use super::value::{Value, matrix_from_rows};
use super::{CallSite, Flow, Frame, Interpreter, MAX_CALL_DEPTH};
use crate::base::failure::Failure;
use crate::check::types::{Type, unify};
use crate::field::Field;
use crate::interp::ops;
use crate::syntax::ast::*;
use crate::syntax::diagnostic::{Diagnostic, Stage};
use crate::syntax::span::Span;
use std::collections::HashMap;

impl Interpreter {
    pub fn eval(&mut self, e: &Expr) -> Result<Value, Diagnostic> {
        match &e.kind {
            ExprKind::Int(i) => Ok(Value::Int(*i)),
            ExprKind::Float(x) => Ok(Value::Float(*x)),
            ExprKind::Bool(b) => Ok(Value::Bool(*b)),
            ExprKind::Str(s) => Ok(Value::string(s)),
            ExprKind::Var(name) => match self.lookup(&name.name) {
                Some(slot) => Ok(slot.value.clone()),
                None => Err(self.error(
                    name.span,
                    Failure::new(format!(
                        "`{}` is used before its declaration has run",
                        name.name
                    )),
                )),
            },
            ExprKind::Tuple(items) => {
                let values = items
                    .iter()
                    .map(|i| self.eval(i))
                    .collect::<Result<Vec<_>, _>>()?;
                tuple(values).map_err(|f| self.error(e.span, f))
            }
            ExprKind::Array(items) => {
                let values = items
                    .iter()
                    .map(|i| self.eval(i))
                    .collect::<Result<Vec<_>, _>>()?;
                let mut elem: Option<Type> = None;
                for v in &values {
                    let t = v.type_of();
                    elem = Some(match elem {
                        None => t,
                        Some(prev) => unify(&prev, &t).unwrap_or(prev),
                    });
                }
                let elem = elem.unwrap_or(Type::Error);
                let converted = values.into_iter().map(|v| v.convert(&elem)).collect();
                Ok(Value::array(converted, elem))
            }
            ExprKind::Unary(op, operand) => {
                let v = self.eval(operand)?;
                ops::unary(*op, v).map_err(|f| self.error(e.span, f))
            }
            ExprKind::Binary(first, operations) => {
                let mut value = self.eval(first)?;
                let mut span = first.span;
                for operation in operations {
                    value = self.operation(value, span, operation)?;
                    span = operation.span;
                }
                Ok(value)
            }
            ExprKind::Call { callee, args } => self.call(e.span, callee, args),
            ExprKind::Index(base, index) => {
                let b = self.eval(base)?;
                let i = self
                    .eval(index)?
                    .as_int()
                    .map_err(|f| self.error(index.span, f))?;
                index_value(&b, i).map_err(|f| self.error(index.span, f))
            }
            ExprKind::Member(base, member) => {
                let b = self.eval(base)?;
                let axis = match member.name.as_str() {
                    "x" => 0,
                    "y" => 1,
                    "z" => 2,
                    other => {
                        return Err(self
                            .error(member.span, Failure::new(format!("no component `{other}`"))));
                    }
                };
                match b {
                    Value::Vector(v) => Ok(Value::Float(v[axis])),
                    Value::Field(f) => f
                        .component(axis)
                        .map(Value::Field)
                        .map_err(|f| self.error(e.span, f)),
                    other => Err(self.error(
                        member.span,
                        Failure::new(format!(
                            "a {} has no component `.{}`",
                            other.type_of(),
                            member.name
                        )),
                    )),
                }
            }
        }
    }

    /// One operation of a chain applied to the value so far (`left`, written at `left_span`).
    fn operation(
        &mut self,
        left: Value,
        left_span: Span,
        operation: &Operation,
    ) -> Result<Value, Diagnostic> {
        let right = &operation.operand;
        match operation.op {
            BinaryOp::And | BinaryOp::Or => {
                let left = left.as_bool().map_err(|f| self.error(left_span, f))?;
                // The right side is evaluated only when it decides the value.
                if left == (operation.op == BinaryOp::Or) {
                    return Ok(Value::Bool(left));
                }
                let value = self.eval(right)?;
                let right = value.as_bool().map_err(|f| self.error(right.span, f))?;
                Ok(Value::Bool(right))
            }
            op => {
                let value = self.eval(right)?;
                let value =
                    ops::binary(op, left, value).map_err(|f| self.error(operation.span, f))?;
                if matches!(value, Value::Field(_)) {
                    crate::field::node::check_graph_memory()
                        .map_err(|f| self.error(operation.span, f))?;
                }
                Ok(value)
            }
        }
    }

    fn call(&mut self, span: Span, callee: &Ident, args: &[Arg]) -> Result<Value, Diagnostic> {
        if let Some(function) = self.functions.get(&callee.name).cloned() {
            return self.call_function(span, &function, args);
        }
        self.call_builtin(&callee.name, span, args)
    }

    fn call_function(
        &mut self,
        span: Span,
        function: &FuncDecl,
        args: &[Arg],
    ) -> Result<Value, Diagnostic> {
        self.check_interrupt(span)?;
        if self.calls.len() >= MAX_CALL_DEPTH {
            return Err(self.error(
                span,
                Failure::new(format!(
                    "function calls nested deeper than {MAX_CALL_DEPTH}"
                ))
                .with_help("a recursive function needs a case that stops the recursion"),
            ));
        }
        let mut scope = HashMap::new();
        for (param, arg) in function.params.iter().zip(args) {
            let value = self.eval(&arg.value)?;
            let ty = Type::from_expr(&param.ty);
            scope.insert(
                param.name.name.clone(),
                super::Slot {
                    value: value.convert(&ty),
                    ty,
                },
            );
        }
        self.calls.push(CallSite {
            function: function.name.name.clone(),
            span,
        });
        self.frames.push(Frame {
            scopes: vec![scope],
        });
        let flow = self.exec_block(&function.body);
        self.frames.pop();
        self.calls.pop();
        let ret = Type::from_expr(&function.ret);
        match flow? {
            Flow::Return(v) => Ok(v.convert(&ret)),
            _ if ret == Type::Void => Ok(Value::Void),
            _ => Err(self.error(
                span,
                Failure::new(format!(
                    "`{}` ended without returning a value",
                    function.name.name
                )),
            )),
        }
    }

    /// Calls builtin `name` with script arguments: resolves the form, converts, runs.
    pub(crate) fn call_builtin(
        &mut self,
        name: &str,
        span: Span,
        args: &[Arg],
    ) -> Result<Value, Diagnostic> {
        let Some(builtin) = registry::registry().get(name) else {
            return Err(self.error(span, Failure::new(format!("unknown function `{name}`"))));
        };
        let mut values = Vec::with_capacity(args.len());
        for a in args {
            values.push(self.eval(&a.value)?);
        }
        let types: Vec<Type> = values.iter().map(|v| v.type_of()).collect();
        let names: Vec<Option<String>> = args
            .iter()
            .map(|a| a.name.as_ref().map(|n| n.name.clone()))
            .collect();
        let (form, slots, rest) = match registry::resolve(builtin, &types, &names) {
            Resolution::Match { form, slots, rest } => (form, slots, rest),
            Resolution::Mismatch {
                message, at, help, ..
            } => {
                let mut f = Failure::new(message);
                f.help = help;
                return Err(self.error(at.span(args, span), f));
            }
        };
        let sig = &builtin.signatures[form];
        for (slot, param) in slots.iter().zip(&sig.params) {
            if let Some(i) = *slot
                && param.choices.is_some()
            {
                for text in strings_of(&values[i]) {
                    registry::check_choice(param, text)
                        .map_err(|f| self.error(args[i].value.span, f))?;
                }
            }
        }
        let mut taken: Vec<Option<Value>> = values.into_iter().map(Some).collect();
        let converted = slots
            .iter()
            .zip(&sig.params)
            .map(|(slot, param)| {
                slot.and_then(|i| taken[i].take()).map(|v| match &param.ty {
                    registry::ParamType::Exact(t) => v.convert(t),
                    _ => v,
                })
            })
            .collect();
        let rest = rest.iter().filter_map(|i| taken[*i].take()).collect();
        let previous = std::mem::replace(&mut self.call_span, span);
        let run = registry::registry()
            .implementation(name)
            .expect("every registered builtin has an implementation");
        let result = run(self, Args::new(builtin, form, converted, rest));
        self.call_span = previous;
        let value = result.map_err(|f| self.error(span, f))?;
        if matches!(value, Value::Field(_)) {
            crate::field::node::check_graph_memory().map_err(|f| self.error(span, f))?;
        }
        self.check_graph_size(&value, span);
        Ok(value)
    }

    /// Warns, once per run, when a builtin returns a field whose graph has passed
    /// `graph_warning_nodes`: typically a velocity advected by itself and never gridded, whose
    /// graph doubles every step. Counting a graph walks it, so it is only counted when the
    /// node table as a whole is that large, and then not again until the table has doubled.
    fn check_graph_size(&mut self, value: &Value, span: Span) {
        let table = crate::field::node::table_len();
        if self.graph_warned || table < self.graph_check_at.max(self.graph_warning_nodes) {
            return;
        }
        self.graph_check_at = table * 2;
        let Value::Field(field) = value else { return };
        let nodes = crate::field::node::postorder(field.components()).len();
        if nodes < self.graph_warning_nodes {
            return;
        }
        self.graph_warned = true;
        self.warnings.push(
            Diagnostic::warning(
                Stage::Runtime,
                span,
                format!("this field's graph has grown to {nodes} nodes; every value of it evaluates all of them"),
            )
            .with_help(
                "a field advected by itself step after step doubles each time, and each nested \
                 derivative multiplies it: sample it into a cache (cachewrite/cacheread), or \
                 project an advected velocity with fftdivfree every step",
            ),
        );
    }
}

/// The size of a field graph that gets a warning, unless a session sets another.
pub const GRAPH_WARNING_NODES: usize = 1_000_000;

/// `(a, b, c)`: a vector from numbers, a matrix from vectors (rows), or the field versions.
fn tuple(values: Vec<Value>) -> Result<Value, Failure> {
    let [a, b, c]: [Value; 3] = values.try_into().map_err(|v: Vec<Value>| {
        Failure::new(format!(
            "a vector literal has 3 components, found {}",
            v.len()
        ))
    })?;
    let any_field = [&a, &b, &c].iter().any(|v| matches!(v, Value::Field(_)));
    match (&a, &b, &c) {
        (Value::Vector(r0), Value::Vector(r1), Value::Vector(r2)) => {
            Ok(Value::Matrix(matrix_from_rows(*r0, *r1, *r2)))
        }
        _ if any_field => {
            let (fa, fb, fc) = (a.as_field()?, b.as_field()?, c.as_field()?);
            if fa.kind() == crate::field::FieldKind::Vector {
                Field::matrix_from_rows(&fa, &fb, &fc).map(Value::Field)
            } else {
                Field::vector_from(&fa, &fb, &fc).map(Value::Field)
            }
        }
        _ => Ok(Value::Vector(glam::DVec3::new(
            a.as_float()?,
            b.as_float()?,
            c.as_float()?,
        ))),
    }
}

fn index_value(base: &Value, i: i64) -> Result<Value, Failure> {
    let out_of_range =
        |len: usize| Failure::new(format!("index {i} is out of range for size {len}"));
    match base {
        Value::Array(items, _) => usize::try_from(i)
            .ok()
            .and_then(|u| items.get(u).cloned())
            .ok_or_else(|| out_of_range(items.len())),
        Value::Vector(v) => match i {
            0..=2 => Ok(Value::Float(v[i as usize])),
            _ => Err(out_of_range(3)),
        },
        Value::Matrix(m) => match i {
            0..=2 => Ok(Value::Vector(m.row(i as usize))),
            _ => Err(out_of_range(3)),
        },
        other => Err(Failure::new(format!(
            "a {} cannot be indexed",
            other.type_of()
        ))),
    }
}

/// The strings a string or string-array argument holds (none for any other value).
fn strings_of(value: &Value) -> Vec<&str> {
    match value {
        Value::Array(items, _) => items.iter().filter_map(|v| v.as_str().ok()).collect(),
        other => other.as_str().ok().into_iter().collect(),
    }
}
