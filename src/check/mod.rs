//! The checker: every name, type and arity in a program is verified before anything runs, and
//! all of a file's errors are reported together, not only the first. It walks the AST once
//! with a stack of scopes, computing each expression's type with the rules of `types` and the
//! builtin registry, and never stops at an error: a bad expression gets the type `Error`,
//! which fits anywhere, so one mistake produces one diagnostic.
//!
//! Scoping follows C: functions are visible everywhere (all signatures are collected first);
//! a function body sees its parameters, its locals, and the global variables declared before
//! the function in the source.
//!
//! The checker owns the builtins' signatures (`signature`) and the rules that match a call to
//! one of them (`resolve`), but not the table of builtins: its environment is handed that
//! table by the session, from the interpreter's registry. So the interpreter depends on the
//! checker (types, signatures, resolution) and the checker never on the interpreter.

mod expr;
pub mod resolve;
pub mod signature;
mod stmt;

use stmt::block_returns;
pub mod types;

use crate::syntax::ast::*;
use crate::syntax::diagnostic::{Diagnostic, MAX_RENDERED, Stage};
use crate::syntax::span::Span;
use signature::Signatures;
use std::collections::HashMap;
use types::Type;

/// A user function's signature, collected before bodies are checked.
#[derive(Clone, Debug)]
pub struct FuncSig {
    pub name: String,
    pub params: Vec<Type>,
    pub ret: Type,
    pub span: Span,
    /// Defined in the standard library (user definitions may shadow it).
    pub stdlib: bool,
}

#[derive(Clone, Debug)]
pub struct VarInfo {
    pub ty: Type,
    pub span: Span,
}

/// What persists between checks: global variables and functions. The REPL keeps one across
/// inputs; a batch run makes one per run.
#[derive(Clone, Debug)]
pub struct CheckEnv {
    pub globals: HashMap<String, VarInfo>,
    pub funcs: HashMap<String, FuncSig>,
    /// At the REPL a declaration may replace an earlier global of the same name.
    pub allow_redeclare: bool,
    /// The builtins' signatures. Handed in by whoever runs the checker (the session, from the
    /// interpreter's registry), so the checker does not depend on the interpreter.
    pub builtins: &'static Signatures,
}

impl CheckEnv {
    /// An environment with no globals or functions yet, checking calls against `builtins`.
    pub fn new(builtins: &'static Signatures) -> CheckEnv {
        CheckEnv {
            globals: HashMap::new(),
            funcs: HashMap::new(),
            allow_redeclare: false,
            builtins,
        }
    }
}

/// Registers the functions of a program in the environment. Returns the diagnostics for
/// duplicates; shadowing a standard-library function is a warning.
pub fn collect_functions(env: &mut CheckEnv, program: &Program, stdlib: bool) -> Vec<Diagnostic> {
    let mut diags = Vec::new();
    for item in &program.items {
        let Item::Func(f) = item else { continue };
        let sig = FuncSig {
            name: f.name.name.clone(),
            params: f.params.iter().map(|p| Type::from_expr(&p.ty)).collect(),
            ret: Type::from_expr(&f.ret),
            span: f.name.span,
            stdlib,
        };
        if let Some(previous) = env.funcs.get(&f.name.name) {
            if previous.stdlib && !stdlib {
                diags.push(
                    Diagnostic::warning(
                        Stage::Name,
                        f.name.span,
                        format!(
                            "`{}` shadows the standard library function of the same name",
                            f.name.name
                        ),
                    )
                    .with_label("this definition is used instead"),
                );
            } else if !env.allow_redeclare {
                diags.push(
                    Diagnostic::error(
                        Stage::Name,
                        f.name.span,
                        format!("function `{}` is defined twice", f.name.name),
                    )
                    .with_label("second definition")
                    .with_related(
                        Diagnostic::error(Stage::Name, previous.span, "first defined here")
                            .with_label("first definition"),
                    ),
                );
                continue;
            }
        } else if env.builtins.get(&f.name.name).is_some() && !stdlib {
            diags.push(
                Diagnostic::warning(
                    Stage::Name,
                    f.name.span,
                    format!("`{}` shadows the builtin of the same name", f.name.name),
                )
                .with_label("this definition is used instead"),
            );
        }
        for p in &f.params {
            if p.ty.base == BaseType::Void {
                diags.push(Diagnostic::error(
                    Stage::Type,
                    p.ty.span,
                    "a parameter cannot be void",
                ));
            }
        }
        env.funcs.insert(f.name.name.clone(), sig);
    }
    diags
}

/// Checks the statements and function bodies of a program against `env`, adding its globals.
pub fn check_program(env: &mut CheckEnv, program: &Program) -> Vec<Diagnostic> {
    // A `frame` declared at an earlier REPL input counts: its value fills patterns too.
    let has_frame = env.globals.contains_key("frame")
        || program.items.iter().any(|item| {
            matches!(item, Item::Stmt(Stmt { kind: StmtKind::Decl { is_param: true, ty, name, .. }, .. })
                if name.name == "frame" && Type::from_expr(ty) == Type::Int)
        });
    let mut checker = Checker {
        env,
        scopes: Vec::new(),
        diags: Vec::new(),
        function: None,
        loop_depth: 0,
        hints_left: MAX_RENDERED,
        has_frame,
    };
    for item in &program.items {
        match item {
            Item::Func(f) => checker.function(f),
            Item::Stmt(s) => checker.stmt(s),
            Item::Import(_) => {}
        }
    }
    checker.diags
}

/// The type of one expression in `env` (the REPL's `:type`).
pub fn type_of_expr(env: &mut CheckEnv, e: &Expr) -> Result<Type, Vec<Diagnostic>> {
    let mut checker = Checker {
        env,
        scopes: Vec::new(),
        diags: Vec::new(),
        function: None,
        loop_depth: 0,
        hints_left: MAX_RENDERED,
        has_frame: true,
    };
    let ty = checker.expr(e);
    if checker.diags.iter().any(|d| d.is_error()) {
        Err(checker.diags)
    } else {
        Ok(ty)
    }
}

struct Checker<'e> {
    env: &'e mut CheckEnv,
    /// Local scopes, innermost last; empty at the top level, where declarations are globals.
    scopes: Vec<HashMap<String, VarInfo>>,
    diags: Vec<Diagnostic>,
    /// The return type of the function being checked.
    function: Option<Type>,
    loop_depth: usize,
    /// Did-you-mean lookups still allowed. Each compares a name with every name in scope, so
    /// a script with thousands of unknown names would take quadratic time; only as many get a
    /// hint as diagnostics are ever shown.
    hints_left: usize,
    /// Whether the script has a `param int frame` to fill frame patterns in output paths.
    has_frame: bool,
}

impl Checker<'_> {
    fn error(&mut self, stage: Stage, span: Span, message: impl Into<String>) -> &mut Diagnostic {
        self.diags.push(Diagnostic::error(stage, span, message));
        self.diags.last_mut().expect("just pushed")
    }

    fn lookup(&self, name: &str) -> Option<&VarInfo> {
        self.scopes
            .iter()
            .rev()
            .find_map(|s| s.get(name))
            .or_else(|| self.env.globals.get(name))
    }

    fn declare(&mut self, name: &Ident, ty: Type) {
        let info = VarInfo {
            ty,
            span: name.span,
        };
        let replace_allowed = self.env.allow_redeclare && self.scopes.is_empty();
        let previous = match self.scopes.last() {
            Some(scope) => scope.get(&name.name),
            None => self.env.globals.get(&name.name),
        };
        if let (Some(previous), false) = (previous, replace_allowed) {
            let first = previous.span;
            let d = self.error(
                Stage::Name,
                name.span,
                format!("`{}` is already declared in this scope", name.name),
            );
            d.label = String::from("declared again here");
            d.related.push(
                Diagnostic::error(Stage::Name, first, "first declared here")
                    .with_label("first declaration"),
            );
            return;
        }
        let scope = match self.scopes.last_mut() {
            Some(scope) => scope,
            None => &mut self.env.globals,
        };
        scope.insert(name.name.clone(), info);
    }

    fn expect(&mut self, span: Span, found: &Type, expected: &Type, what: &str) {
        if !found.converts_to(expected) {
            let d = self.error(
                Stage::Type,
                span,
                format!("{what}: expected {expected}, found {found}"),
            );
            d.label = format!("this is {found}");
            if let Some(fix) = resolve::cache_hint(found, expected) {
                d.help = Some(fix);
            } else if expected.is_field() && found.is_field() {
                d.help = Some(String::from(
                    "fields of different kinds do not convert; take a component with .x/.y/.z or build one with vectorfield(sx, sy, sz)",
                ));
            }
        }
    }

    fn function(&mut self, f: &FuncDecl) {
        let ret = Type::from_expr(&f.ret);
        self.function = Some(ret.clone());
        self.scopes.push(HashMap::new());
        for p in &f.params {
            self.declare(&p.name, Type::from_expr(&p.ty));
        }
        self.block_in_scope(&f.body);
        self.scopes.pop();
        self.function = None;
        if ret != Type::Void && !block_returns(&f.body) {
            let d = self.error(
                Stage::Type,
                f.name.span,
                format!(
                    "function `{}` can reach its end without returning a {}",
                    f.name.name, ret
                ),
            );
            d.label = String::from("declared here");
            d.help = Some(String::from(
                "add a `return` statement at the end of the function",
            ));
        }
    }

    fn block(&mut self, block: &Block) {
        self.scopes.push(HashMap::new());
        self.block_in_scope(block);
        self.scopes.pop();
    }

    fn block_in_scope(&mut self, block: &Block) {
        for s in &block.stmts {
            self.stmt(s);
        }
    }

    /// Spends one did-you-mean lookup; false when none are left.
    fn take_hint(&mut self) -> bool {
        let allowed = self.hints_left > 0;
        self.hints_left = self.hints_left.saturating_sub(1);
        allowed
    }

    fn name_hint(&mut self, name: &str) -> Option<String> {
        if !self.take_hint() {
            return None;
        }
        let mut names: Vec<&str> = self
            .scopes
            .iter()
            .flat_map(|s| s.keys().map(|k| k.as_str()))
            .collect();
        names.extend(self.env.globals.keys().map(|k| k.as_str()));
        crate::base::suggest::closest(name, names.into_iter())
            .map(|s| format!("did you mean `{s}`?"))
    }
}

fn constructor_exists(builtins: &Signatures, base: BaseType) -> bool {
    builtins.get(base.keyword()).is_some()
}
