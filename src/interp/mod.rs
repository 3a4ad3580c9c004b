//! The interpreter: runs checked programs statement by statement. It handles plain values
//! directly and *builds* fields — every arithmetic operation on a field adds a node to a graph
//! instead of computing anything — so the cost of a script's control flow is independent of
//! resolution. The heavy work happens later, when an output (a probe, a cache fill, a render)
//! compiles the graph it needs.
//!
//! Variables live in slots that remember their declared type, so assignments convert values
//! exactly as the checker allowed (`float x = 1` stores 1.0). Functions run in frames that see
//! their own scopes and the globals, never the caller's locals. Every runtime error becomes a
//! diagnostic at the expression that failed, with the FELT call stack attached.

pub mod builtins;
pub mod elements;
mod eval;
mod exec;

pub use exec::{override_value, parse_override};
pub mod ops;
pub mod paths;
pub mod provenance;
pub mod registry;
#[cfg(test)]
mod resolve_tests;
pub mod value;

use crate::base::failure::Failure;
use crate::check::types::Type;
use crate::syntax::ast::{FuncDecl, Program};
use crate::syntax::diagnostic::{Diagnostic, Stage};
use crate::syntax::span::{SourceMap, Span};
use std::cell::RefCell;
use std::collections::HashMap;
use std::io::Write;
use std::rc::Rc;
use std::time::Instant;
use value::Value;

/// The deepest chain of script function calls allowed before a clear error (instead of a
/// crash when a recursion has no base case).
pub const MAX_CALL_DEPTH: usize = 256;

/// A variable: its value and the type it was declared with.
#[derive(Clone, Debug)]
pub struct Slot {
    pub value: Value,
    pub ty: Type,
}

type Scope = HashMap<String, Slot>;

/// One activation of a script function (or the top level).
#[derive(Default)]
struct Frame {
    scopes: Vec<Scope>,
}

/// Where a call came from, for the call stack in runtime errors.
#[derive(Clone, Debug)]
struct CallSite {
    function: String,
    span: Span,
}

pub struct Interpreter {
    pub sources: Rc<RefCell<SourceMap>>,
    functions: HashMap<String, Rc<FuncDecl>>,
    globals: Scope,
    frames: Vec<Frame>,
    calls: Vec<CallSite>,
    /// Where `print` writes.
    pub out: Box<dyn Write>,
    /// When the run started, for `clock()`.
    pub start: Instant,
    /// The default seed for noise fields built from now on (`seed(n)`).
    pub noise_seed: u32,
    /// Values given on the command line with `--set NAME=VALUE`.
    pub overrides: HashMap<String, String>,
    /// Warnings found while running (NaN written into a cache, ...).
    pub warnings: Vec<Diagnostic>,
    /// The span of the builtin call being run, for labels in profiles and reports.
    pub call_span: Span,
    /// Every cache written, with the `cachewrite` call, to report non-finite values at the end.
    pub written_caches: Vec<(std::sync::Weak<crate::grid::cache::Cache>, Span)>,
    /// Vector caches watched for map reads outside their domain (see `grid/cache/map_watch`),
    /// and one tally per `cachewrite` line with the cache's name as written there.
    pub map_watched: Vec<std::sync::Weak<crate::grid::cache::Cache>>,
    pub map_tallies: Vec<(Span, String, std::sync::Arc<std::sync::atomic::AtomicU64>)>,
    /// Field graphs larger than this get a warning (once per run).
    pub graph_warning_nodes: usize,
    /// Where relative paths start and which files the run wrote (see `paths`).
    pub files: crate::interp::paths::ScriptFiles,
    /// Every `param` as it was set, in declaration order, with its value as text: what an
    /// output file records about the run that made it.
    pub param_values: Vec<(String, String)>,
    /// The node-table size at which field graphs are next counted (see `check_graph_size`).
    graph_check_at: usize,
    /// Whether the large-graph warning was given (it is given once per run).
    graph_warned: bool,
}

/// Control flow out of a statement.
pub(crate) enum Flow {
    Normal,
    Break,
    Continue,
    Return(Value),
}

impl Interpreter {
    pub fn new(sources: Rc<RefCell<SourceMap>>, out: Box<dyn Write>) -> Interpreter {
        Interpreter {
            sources,
            functions: HashMap::new(),
            globals: HashMap::new(),
            frames: vec![Frame::default()],
            calls: Vec::new(),
            out,
            start: Instant::now(),
            noise_seed: 0,
            overrides: HashMap::new(),
            warnings: Vec::new(),
            call_span: Span::default(),
            graph_warning_nodes: eval::GRAPH_WARNING_NODES,
            graph_check_at: 0,
            graph_warned: false,
            written_caches: Vec::new(),
            map_watched: Vec::new(),
            map_tallies: Vec::new(),
            files: crate::interp::paths::ScriptFiles::default(),
            param_values: Vec::new(),
        }
    }

    /// Makes the functions of a program callable.
    pub fn define_functions(&mut self, program: &Program) {
        for item in &program.items {
            if let crate::syntax::ast::Item::Func(f) = item {
                self.functions
                    .insert(f.name.name.clone(), Rc::new(f.clone()));
            }
        }
    }

    /// Runs the top-level statements of a program. Expression statements hand their value to
    /// `on_value` (the REPL prints them; a batch run ignores them).
    pub fn run_program(
        &mut self,
        program: &Program,
        on_value: &mut dyn FnMut(&mut Interpreter, Value),
    ) -> Result<(), Diagnostic> {
        self.define_functions(program);
        crate::engine::interrupt::clear();
        for item in &program.items {
            let crate::syntax::ast::Item::Stmt(stmt) = item else {
                continue;
            };
            if let crate::syntax::ast::StmtKind::Expr(e) = &stmt.kind {
                let value = self.eval(e)?;
                if !matches!(value, Value::Void) {
                    on_value(self, value);
                }
                continue;
            }
            match self.exec(stmt)? {
                Flow::Normal => {}
                _ => unreachable!("the checker rejects break/continue/return at the top level"),
            }
        }
        let _ = self.out.flush();
        Ok(())
    }

    /// The global variables and their values (for the REPL's `:vars`).
    pub fn globals(&self) -> Vec<(String, Slot)> {
        let mut all: Vec<_> = self
            .globals
            .iter()
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect();
        all.sort_by(|a, b| a.0.cmp(&b.0));
        all
    }

    /// Sets a global outside any script (see `Session::define_global`).
    pub fn define_global(&mut self, name: &str, ty: Type, value: Value) {
        let value = value.convert(&ty);
        self.globals.insert(name.to_string(), Slot { value, ty });
    }

    pub fn global(&self, name: &str) -> Option<&Value> {
        self.globals.get(name).map(|s| &s.value)
    }

    /// "file:line:column" of a span.
    pub fn location(&self, span: Span) -> String {
        crate::syntax::diagnostic::location(span, &self.sources.borrow())
    }

    /// A runtime error at `span`, with the current FELT call stack attached.
    pub(crate) fn error(&self, span: Span, failure: Failure) -> Diagnostic {
        let stage = if failure.internal {
            Stage::Internal
        } else {
            Stage::Runtime
        };
        let mut d = Diagnostic::error(stage, span, failure.message).with_help_opt(failure.help);
        for site in self.calls.iter().rev() {
            d.related.push(
                Diagnostic::error(
                    Stage::Runtime,
                    site.span,
                    format!("in `{}`, called from here", site.function),
                )
                .with_label("called here"),
            );
        }
        d
    }

    fn check_interrupt(&self, span: Span) -> Result<(), Diagnostic> {
        if crate::engine::interrupt::requested() {
            return Err(self.error(span, Failure::new("interrupted")));
        }
        Ok(())
    }

    fn lookup(&self, name: &str) -> Option<&Slot> {
        let frame = self.frames.last().expect("there is always a frame");
        frame
            .scopes
            .iter()
            .rev()
            .find_map(|s| s.get(name))
            .or_else(|| self.globals.get(name))
    }

    fn lookup_mut(&mut self, name: &str) -> Option<&mut Slot> {
        let frame = self.frames.last_mut().expect("there is always a frame");
        for scope in frame.scopes.iter_mut().rev() {
            if let Some(slot) = scope.get_mut(name) {
                return Some(slot);
            }
        }
        self.globals.get_mut(name)
    }

    fn declare(&mut self, name: &str, ty: Type, value: Value) {
        let slot = Slot {
            value: value.convert(&ty),
            ty,
        };
        let frame = self.frames.last_mut().expect("there is always a frame");
        match frame.scopes.last_mut() {
            Some(scope) => scope.insert(name.to_string(), slot),
            None => self.globals.insert(name.to_string(), slot),
        };
    }

    fn push_scope(&mut self) {
        self.frames
            .last_mut()
            .expect("frame")
            .scopes
            .push(HashMap::new());
    }

    fn pop_scope(&mut self) {
        self.frames.last_mut().expect("frame").scopes.pop();
    }
}
