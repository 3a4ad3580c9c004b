//! Expression typing: what each expression's type is, by the operator table of `types`, the
//! scopes of the checker, and the builtin registry for calls. A bad expression gets the type
//! `Error`, which fits anywhere, so one mistake is reported once.

use super::Checker;
use super::resolve::{self, Culprit, Resolution};
use super::signature::Param;
use super::types::{self, Type, binary_result, unary_result, unify};
use crate::base::suggest;
use crate::syntax::ast::*;
use crate::syntax::diagnostic::{Diagnostic, Stage};
use crate::syntax::span::Span;

impl Checker<'_> {
    pub(super) fn expr(&mut self, e: &Expr) -> Type {
        match &e.kind {
            ExprKind::Int(_) => Type::Int,
            ExprKind::Float(_) => Type::Float,
            ExprKind::Bool(_) => Type::Bool,
            ExprKind::Str(_) => Type::Str,
            ExprKind::Var(name) => match self.lookup(&name.name) {
                Some(info) => info.ty.clone(),
                None => {
                    let help = self.name_hint(&name.name).or_else(|| {
                        (self.env.funcs.contains_key(&name.name)
                            || self.env.builtins.get(&name.name).is_some())
                        .then(|| {
                            format!(
                                "`{}` is a function; call it with `{}(...)`",
                                name.name, name.name
                            )
                        })
                    });
                    let d = self.error(
                        Stage::Name,
                        name.span,
                        format!("unknown variable `{}`", name.name),
                    );
                    d.label = String::from("not declared");
                    d.help = help;
                    Type::Error
                }
            },
            ExprKind::Tuple(items) => self.tuple(e.span, items),
            ExprKind::Array(items) => {
                let mut elem: Option<Type> = None;
                for item in items {
                    let t = self.expr(item);
                    elem = match elem {
                        None => Some(t),
                        Some(prev) => match unify(&prev, &t) {
                            Some(u) => Some(u),
                            None => {
                                self.error(
                                    Stage::Type,
                                    item.span,
                                    format!(
                                        "array elements must share a type: found {prev} and {t}"
                                    ),
                                );
                                Some(Type::Error)
                            }
                        },
                    };
                }
                match elem {
                    None => Type::EmptyArray,
                    Some(Type::Void) => {
                        self.error(Stage::Type, e.span, "an array cannot hold void values");
                        Type::Error
                    }
                    Some(t) => Type::array_of(t),
                }
            }
            ExprKind::Unary(op, operand) => {
                let t = self.expr(operand);
                unary_result(*op, &t).unwrap_or_else(|message| {
                    self.error(Stage::Type, e.span, message);
                    Type::Error
                })
            }
            ExprKind::Binary(first, operations) => {
                let mut lt = self.expr(first);
                for operation in operations {
                    let rt = self.expr(&operation.operand);
                    lt = self.binary(operation, &lt, &rt);
                }
                lt
            }
            ExprKind::Call { callee, args } => self.call(e.span, callee, args),
            ExprKind::Index(base, index) => {
                let bt = self.expr(base);
                self.index_type(index);
                match bt {
                    Type::Array(elem) => *elem,
                    Type::Vector => Type::Float,
                    Type::Matrix => Type::Vector,
                    Type::Error => Type::Error,
                    Type::EmptyArray => {
                        self.error(Stage::Type, e.span, "indexing an empty array literal");
                        Type::Error
                    }
                    other => {
                        self.error(
                            Stage::Type,
                            base.span,
                            format!("a {other} cannot be indexed"),
                        );
                        Type::Error
                    }
                }
            }
            ExprKind::Member(base, member) => {
                let bt = self.expr(base);
                let is_component = matches!(member.name.as_str(), "x" | "y" | "z");
                match bt {
                    Type::Vector if is_component => Type::Float,
                    Type::VectorField if is_component => Type::ScalarField,
                    Type::Error => Type::Error,
                    Type::Vector | Type::VectorField => {
                        self.error(
                            Stage::Type,
                            member.span,
                            format!("`{}` is not a component of a {bt}", member.name),
                        )
                        .help = Some(String::from("the components are .x, .y and .z"));
                        Type::Error
                    }
                    other => {
                        self.error(
                            Stage::Type,
                            member.span,
                            format!("a {other} has no component `.{}`", member.name),
                        );
                        Type::Error
                    }
                }
            }
        }
    }

    /// The type of one operation of a chain, from the types of its two sides.
    fn binary(&mut self, operation: &Operation, lt: &Type, rt: &Type) -> Type {
        let op = operation.op;
        binary_result(op, lt, rt).unwrap_or_else(|message| {
            let d = self.error(Stage::Type, operation.span, message);
            if lt.is_field() || rt.is_field() {
                if matches!(
                    op,
                    BinaryOp::Lt
                        | BinaryOp::Le
                        | BinaryOp::Gt
                        | BinaryOp::Ge
                        | BinaryOp::Eq
                        | BinaryOp::Ne
                ) {
                    d.help = Some(String::from(
                        "use mask(f) (1 where f >= 0) or select(c, a, b) for pointwise choices",
                    ));
                }
            } else if op == BinaryOp::Add && (*lt == Type::Str || *rt == Type::Str) {
                d.help = Some(String::from("convert with str(x) before joining strings"));
            }
            Type::Error
        })
    }

    pub(super) fn tuple(&mut self, span: Span, items: &[Expr]) -> Type {
        let types: Vec<Type> = items.iter().map(|i| self.expr(i)).collect();
        if types.iter().any(|t| t.is_error()) {
            return Type::Error;
        }
        if types.len() != 3 {
            self.error(
                Stage::Type,
                span,
                format!("a vector literal has 3 components, found {}", types.len()),
            );
            return Type::Error;
        }
        let shapes: Vec<_> = types.iter().map(|t| t.shape()).collect();
        let any_field = types.iter().any(|t| t.is_field());
        if shapes
            .iter()
            .all(|s| matches!(s, Some((types::Shape::Scalar, _))))
        {
            return if any_field {
                Type::VectorField
            } else {
                Type::Vector
            };
        }
        if shapes
            .iter()
            .all(|s| matches!(s, Some((types::Shape::Vector, _))))
        {
            return if any_field {
                Type::MatrixField
            } else {
                Type::Matrix
            };
        }
        let shown: Vec<String> = types.iter().map(|t| t.to_string()).collect();
        self.error(
            Stage::Type,
            span,
            format!("a vector literal needs three numbers and a matrix literal three vectors, found ({})", shown.join(", ")),
        );
        Type::Error
    }

    pub(super) fn call(&mut self, span: Span, callee: &Ident, args: &[Arg]) -> Type {
        if let Some(sig) = self.env.funcs.get(&callee.name).cloned() {
            let types: Vec<Type> = args.iter().map(|a| self.expr(&a.value)).collect();
            if let Some(a) = args.iter().find(|a| a.name.is_some()) {
                self.error(
                    Stage::Type,
                    a.span,
                    format!(
                        "`{}` is a script function; it takes positional arguments only",
                        callee.name
                    ),
                );
                return sig.ret;
            }
            if types.len() != sig.params.len() {
                let d = self.error(
                    Stage::Type,
                    span,
                    format!(
                        "`{}` takes {} argument{}, found {}",
                        callee.name,
                        sig.params.len(),
                        if sig.params.len() == 1 { "" } else { "s" },
                        types.len()
                    ),
                );
                d.related.push(
                    Diagnostic::error(Stage::Type, sig.span, "defined here")
                        .with_label("definition"),
                );
                return sig.ret;
            }
            for ((arg, found), expected) in args.iter().zip(&types).zip(&sig.params) {
                self.expect(
                    arg.value.span,
                    found,
                    expected,
                    &format!("wrong argument to `{}`", callee.name),
                );
            }
            return sig.ret;
        }
        if self.env.builtins.get(&callee.name).is_some() {
            return self.builtin_call(&callee.name, span, args);
        }
        for a in args {
            self.expr(&a.value);
        }
        let help = if self.take_hint() {
            let mut names: Vec<String> = self.env.funcs.keys().cloned().collect();
            names.extend(self.env.builtins.names().map(String::from));
            suggest::closest(&callee.name, names.iter().map(|s| s.as_str()))
                .map(|s| format!("did you mean `{s}`?"))
        } else {
            None
        };
        let is_var = self.lookup(&callee.name).is_some();
        let d = self.error(
            Stage::Name,
            callee.span,
            format!("unknown function `{}`", callee.name),
        );
        d.label = String::from("not defined");
        d.help = if is_var {
            Some(format!("`{}` is a variable, not a function", callee.name))
        } else {
            help
        };
        Type::Error
    }
}

/// The builtins that write their `path` argument (through `paths::ScriptFiles::writing`), whose
/// frame patterns need a frame.
const WRITERS: [&str; 4] = ["render", "cachesave", "saveshape", "saveparticles"];

impl Checker<'_> {
    pub(super) fn builtin_call(&mut self, name: &str, span: Span, args: &[Arg]) -> Type {
        let builtin = self.env.builtins.get(name).expect("checked by the caller");
        let types: Vec<Type> = args.iter().map(|a| self.expr(&a.value)).collect();
        if types.iter().any(|t| t.is_error()) {
            return builtin
                .signatures
                .first()
                .map(|s| s.ret.clone())
                .unwrap_or(Type::Error);
        }
        let names: Vec<Option<String>> = args
            .iter()
            .map(|a| a.name.as_ref().map(|n| n.name.clone()))
            .collect();
        match resolve::resolve(builtin, &types, &names) {
            Resolution::Match { form, slots, .. } => {
                let sig = &builtin.signatures[form];
                for (slot, param) in slots.iter().zip(&sig.params) {
                    if let Some(i) = *slot
                        && param.choices.is_some()
                    {
                        self.literal_choices(param, &args[i].value);
                    }
                    if let Some(i) = *slot
                        && param.name == "path"
                        && WRITERS.contains(&name)
                    {
                        self.framed_output(&args[i].value, name == "cachesave");
                    }
                }
                sig.ret.clone()
            }
            Resolution::Mismatch {
                message,
                at,
                help,
                others,
            } => {
                // Every argument that does not fit, so one `felt check` shows them all.
                let first = resolve::Problem { message, at, help };
                for problem in std::iter::once(first).chain(others) {
                    let d = self.error(Stage::Type, problem.at.span(args, span), problem.message);
                    if let Culprit::Keyword(_) = problem.at {
                        d.label = String::from("no such argument");
                    }
                    d.help = problem.help;
                }
                Type::Error
            }
        }
    }

    /// A literal output path with a frame pattern (`####`, `%04d`, `$F4`) in a script with no
    /// `param int frame` to fill it: `felt run` refuses it when the file is opened
    /// (`output::check_frame`), so the checker says so before any work.
    fn framed_output(&mut self, value: &Expr, grid_name: bool) {
        if self.has_frame {
            return;
        }
        let ExprKind::Str(text) = &value.kind else {
            return;
        };
        // In `cachesave` the last `#` starts the grid name, not a frame pattern.
        let file = match text.rsplit_once('#') {
            Some((file, _)) if grid_name => file,
            _ => text.as_str(),
        };
        if crate::io::frames::has_pattern(file) {
            let d = self.error(
                Stage::Type,
                value.span,
                format!(
                    "cannot write '{text}': its name has a frame pattern but the script declares \
                     no `param int frame`"
                ),
            );
            d.help = Some(String::from(
                "declare `param int frame = 1;` (felt run --frames sets it), or take the \
                 pattern out of the name",
            ));
        }
    }

    /// Checks the string literals given for a parameter with a fixed set of values (a string,
    /// or an array of them); other expressions are known only at run time, which checks them.
    fn literal_choices(&mut self, param: &Param, value: &Expr) {
        let literals: Vec<(&str, Span)> = match &value.kind {
            ExprKind::Str(s) => vec![(s.as_str(), value.span)],
            ExprKind::Array(items) => items
                .iter()
                .filter_map(|item| match &item.kind {
                    ExprKind::Str(s) => Some((s.as_str(), item.span)),
                    _ => None,
                })
                .collect(),
            _ => Vec::new(),
        };
        for (text, at) in literals {
            if let Err(failure) = resolve::check_choice(param, text) {
                let d = self.error(Stage::Type, at, failure.message);
                d.help = failure.help;
            }
        }
    }
}
