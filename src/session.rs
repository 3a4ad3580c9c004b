//! A session ties the stages together for one run or one REPL: it owns the source files, the
//! checker's environment and the interpreter, loads the standard library, follows imports
//! (relative to the importing file, each file once, cycles reported with the chain), checks
//! everything before running anything, and hands diagnostics back as values.
//!
//! A session owns its engine (`crate::engine`): memory budget, profile, interrupt flag and
//! output settings. It enters the engine while it runs code, so everything that code does —
//! on this thread and on the worker threads it starts — is accounted to this session alone.

use crate::base::suggest;
use crate::check::{self, CheckEnv};
use crate::engine::Engine;
use crate::interp::Interpreter;
use crate::interp::value::Value;
use crate::syntax;
use crate::syntax::ast::{DeclInit, Item, Program, StmtKind};
use crate::syntax::diagnostic::{Diagnostic, Stage};
use crate::syntax::span::{FileId, SourceMap, Span};
use std::cell::RefCell;
use std::collections::HashSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;

/// The standard library, compiled into the binary so felt runs from anywhere.
pub const STDLIB: &[(&str, &str)] = &[
    ("stdlib/cumulo.felt", include_str!("../stdlib/cumulo.felt")),
    ("stdlib/fluids.felt", include_str!("../stdlib/fluids.felt")),
    ("stdlib/knives.felt", include_str!("../stdlib/knives.felt")),
    (
        "stdlib/pyroclastic.felt",
        include_str!("../stdlib/pyroclastic.felt"),
    ),
];

/// One parsed file, ready to check and run.
pub struct Unit {
    pub file: FileId,
    pub program: Program,
}

/// The standard library failed to load: an installation problem, reported like a script error.
pub struct StartupFailure {
    pub sources: SourceMap,
    pub diagnostics: Vec<Diagnostic>,
}

pub struct Session {
    pub sources: Rc<RefCell<SourceMap>>,
    pub env: CheckEnv,
    pub interp: Interpreter,
    /// Canonical paths of the files already loaded (imports run once).
    loaded: HashSet<PathBuf>,
    repl_inputs: usize,
    /// An interactive session: relative paths stay relative to the current directory, also
    /// in files run with `:load`.
    pub at_prompt: bool,
    /// What this session's runs own: budget, profile, interrupt flag, output settings.
    engine: Arc<Engine>,
}

impl Session {
    /// A session with the standard library loaded and an engine of its own with the default
    /// memory budget; `print` writes to `out`.
    pub fn new(out: Box<dyn Write>) -> Result<Session, StartupFailure> {
        Session::with_engine(out, Engine::new())
    }

    /// A session that runs on `engine` (its memory budget, output settings ...), with the
    /// standard library loaded; `print` writes to `out`.
    pub fn with_engine(
        out: Box<dyn Write>,
        engine: Arc<Engine>,
    ) -> Result<Session, StartupFailure> {
        let sources = Rc::new(RefCell::new(SourceMap::default()));
        let _entered = engine.enter();
        let mut session = Session {
            engine: engine.clone(),
            interp: Interpreter::new(sources.clone(), out),
            sources,
            env: CheckEnv::new(crate::interp::registry::registry().signatures()),
            loaded: HashSet::new(),
            repl_inputs: 0,
            at_prompt: false,
        };
        let mut units = Vec::new();
        for (name, text) in STDLIB {
            match session.parse_text(name, text) {
                Ok(unit) => units.push(unit),
                Err(diagnostics) => return Err(session.startup_failure(diagnostics)),
            }
        }
        let mut diags = Vec::new();
        for unit in &units {
            diags.extend(check::collect_functions(
                &mut session.env,
                &unit.program,
                true,
            ));
        }
        for unit in &units {
            diags.extend(check::check_program(&mut session.env, &unit.program));
        }
        if diags.iter().any(|d| d.is_error()) {
            return Err(session.startup_failure(diags));
        }
        for unit in &units {
            session.interp.define_functions(&unit.program);
        }
        Ok(session)
    }

    /// The engine this session runs on; a Ctrl-C handler keeps a clone to interrupt it.
    pub fn engine(&self) -> &Arc<Engine> {
        &self.engine
    }

    fn startup_failure(self, diagnostics: Vec<Diagnostic>) -> StartupFailure {
        let sources = std::mem::take(&mut *self.sources.borrow_mut());
        StartupFailure {
            sources,
            diagnostics,
        }
    }

    fn parse_text(&mut self, name: &str, text: &str) -> Result<Unit, Vec<Diagnostic>> {
        let file = self.sources.borrow_mut().add(name, text);
        let program = syntax::parse(file, text).map_err(|errors| {
            errors
                .into_iter()
                .map(|e| Diagnostic::error(Stage::Syntax, e.span, e.message).with_help_opt(e.help))
                .collect::<Vec<_>>()
        })?;
        Ok(Unit { file, program })
    }

    /// Parses a script and, first, everything it imports (depth first, each file once).
    pub fn load(&mut self, path: &Path) -> Result<Vec<Unit>, Vec<Diagnostic>> {
        let mut units = Vec::new();
        let mut stack = Vec::new();
        self.load_recursive(path, None, &mut stack, &mut units)?;
        Ok(units)
    }

    fn load_recursive(
        &mut self,
        path: &Path,
        imported_at: Option<Span>,
        stack: &mut Vec<PathBuf>,
        units: &mut Vec<Unit>,
    ) -> Result<(), Vec<Diagnostic>> {
        let read_error = |message: String| match imported_at {
            Some(span) => Diagnostic::error(Stage::Name, span, message).with_label("imported here"),
            None => Diagnostic::bare(Stage::Usage, message),
        };
        let canonical = path.canonicalize().map_err(|e| {
            vec![read_error(format!(
                "cannot read `{}`: {}",
                path.display(),
                e
            ))]
        })?;
        if let Some(position) = stack.iter().position(|p| *p == canonical) {
            let mut chain: Vec<String> =
                stack[position..].iter().map(|p| display_name(p)).collect();
            chain.push(display_name(&canonical));
            return Err(vec![
                read_error(format!("import cycle: {}", chain.join(" → ")))
                    .with_help("a file cannot import itself, directly or through other files"),
            ]);
        }
        if !self.loaded.insert(canonical.clone()) {
            return Ok(());
        }
        let text = read_script(path).map_err(|message| vec![read_error(message)])?;
        let text = String::from_utf8(text).map_err(|e| {
            vec![read_error(format!(
                "`{}` is not UTF-8 text (invalid byte at offset {})",
                path.display(),
                e.utf8_error().valid_up_to()
            ))]
        })?;
        self.load_text(path, canonical, &text, stack, units)
    }

    /// Parses a script whose text is given (an editor's unsaved buffer) as the file at
    /// `path`, and, first, what it imports relative to that file, exactly as `load` does for
    /// the file on disk.
    pub fn load_buffer(&mut self, path: &Path, text: &str) -> Result<Vec<Unit>, Vec<Diagnostic>> {
        // A buffer not yet saved has no canonical form; its own path stands in, so an import
        // of itself is still a cycle.
        let canonical = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        self.loaded.insert(canonical.clone());
        let mut units = Vec::new();
        self.load_text(path, canonical, text, &mut Vec::new(), &mut units)?;
        Ok(units)
    }

    /// Parses one file's text, then loads its imports (before it, in `units`).
    fn load_text(
        &mut self,
        path: &Path,
        canonical: PathBuf,
        text: &str,
        stack: &mut Vec<PathBuf>,
        units: &mut Vec<Unit>,
    ) -> Result<(), Vec<Diagnostic>> {
        let unit = self.parse_text(&path.display().to_string(), text)?;
        stack.push(canonical.clone());
        // Imports resolve against the importing file's path as the user named it (not its
        // canonical form), so diagnostics in imported files show paths the author recognises
        // rather than absolute ones.
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        for item in &unit.program.items {
            if let Item::Import(import) = item {
                self.load_recursive(&base.join(&import.path), Some(import.span), stack, units)?;
            }
        }
        stack.pop();
        units.push(unit);
        Ok(())
    }

    /// Checks units against the session's environment; returns every diagnostic (warnings
    /// included). The environment keeps the new functions and globals only if there is no
    /// error.
    pub fn check(&mut self, units: &[Unit]) -> Vec<Diagnostic> {
        let mut env = self.env.clone();
        let mut diags = Vec::new();
        for unit in units {
            diags.extend(check::collect_functions(&mut env, &unit.program, false));
        }
        for unit in units {
            diags.extend(check::check_program(&mut env, &unit.program));
        }
        if !diags.iter().any(|d| d.is_error()) {
            self.env = env;
        }
        diags
    }

    /// The `param` declarations of the loaded script, in order, with their declared types.
    pub fn params(units: &[Unit]) -> Vec<(String, crate::check::types::Type)> {
        param_decls(units)
            .map(|(name, ty)| (name.name.clone(), ty))
            .collect()
    }

    /// Verifies that every `--set NAME=VALUE` names a `param` of the loaded script and reads as
    /// its declared type.
    pub fn check_overrides(&self, units: &[Unit]) -> Result<(), Diagnostic> {
        let params: Vec<String> = Self::params(units).into_iter().map(|(n, _)| n).collect();
        for name in self.interp.overrides.keys() {
            if !params.contains(name) {
                let mut d = Diagnostic::bare(
                    Stage::Usage,
                    format!("--set {name}: the script has no param named `{name}`"),
                );
                d.help = suggest::closest(name, params.iter().map(|s| s.as_str()))
                    .map(|s| format!("did you mean `{s}`?"))
                    .or_else(|| {
                        Some(if params.is_empty() {
                            String::from("the script declares no params")
                        } else {
                            format!("the script's params are: {}", params.join(", "))
                        })
                    });
                return Err(d);
            }
        }
        // A value of the wrong type is found now, before any work, not when the run reaches
        // the declaration.
        for (name, declared) in param_decls(units) {
            if let Some(text) = self.interp.overrides.get(&name.name) {
                crate::interp::override_value(name, &declared, text)?;
            }
        }
        Ok(())
    }

    /// Runs checked units in order; expression statements' values go to `on_value`.
    pub fn run(
        &mut self,
        units: &[Unit],
        on_value: &mut dyn FnMut(&mut Interpreter, Value),
    ) -> Result<(), Diagnostic> {
        let _entered = self.engine.enter();
        for unit in units {
            self.interp.run_program(&unit.program, on_value)?;
        }
        Ok(())
    }

    /// Loads, checks and runs a script file. Returns warnings on success.
    pub fn run_file(&mut self, path: &Path) -> Result<Vec<Diagnostic>, Vec<Diagnostic>> {
        let units = self.load(path)?;
        // The script's folder is where its relative paths start (see `paths`).
        if !self.at_prompt && self.interp.files.script.is_none() {
            self.interp.files.script = path.canonicalize().ok();
        }
        self.check_and_run(&units)
    }

    /// Checks loaded units and `--set` values, then runs them; returns the warnings.
    fn check_and_run(&mut self, units: &[Unit]) -> Result<Vec<Diagnostic>, Vec<Diagnostic>> {
        let diags = self.check(units);
        if diags.iter().any(|d| d.is_error()) {
            return Err(diags);
        }
        self.check_overrides(units).map_err(|d| vec![d])?;
        self.run(units, &mut |_, _| {}).map_err(|d| {
            let mut all = diags.clone();
            all.push(d);
            all
        })?;
        Ok(diags)
    }

    /// Parses script text given in memory as a file named `name` and, first, what it imports
    /// (relative to the current directory), like `load` does for a file.
    pub fn load_source(&mut self, name: &str, text: &str) -> Result<Vec<Unit>, Vec<Diagnostic>> {
        let unit = self.parse_text(name, text)?;
        let mut units = Vec::new();
        let mut stack = Vec::new();
        for item in &unit.program.items {
            if let Item::Import(import) = item {
                self.load_recursive(
                    Path::new(&import.path),
                    Some(import.span),
                    &mut stack,
                    &mut units,
                )?;
            }
        }
        units.push(unit);
        Ok(units)
    }

    /// Checks and runs script text given in memory as if it were a file named `name` (for a
    /// host program that holds the text, not a file): imports resolve against the current
    /// directory, as at the prompt. Returns warnings on success.
    pub fn run_source(
        &mut self,
        name: &str,
        text: &str,
    ) -> Result<Vec<Diagnostic>, Vec<Diagnostic>> {
        let units = self.load_source(name, text)?;
        self.check_and_run(&units)
    }

    /// Declares a global before any script runs, for the checker and the interpreter alike
    /// (a host program handing the script a value, such as a cache it filled itself). The
    /// global is declared in a source named `<host>` holding just its name, so a script that
    /// declares the same name again is shown where the first one came from.
    pub fn define_global(&mut self, name: &str, ty: crate::check::types::Type, value: Value) {
        let file = self.sources.borrow_mut().add("<host>", name);
        self.env.globals.insert(
            name.to_string(),
            check::VarInfo {
                ty: ty.clone(),
                span: Span::new(file, 0, name.len()),
            },
        );
        self.interp.define_global(name, ty, value);
    }

    /// Evaluates one REPL input (possibly several statements and functions). Values of
    /// expression statements go to `on_value`. On an error the session's state stays as it
    /// was before the statement that failed.
    pub fn eval_input(
        &mut self,
        text: &str,
        on_value: &mut dyn FnMut(&mut Interpreter, Value),
    ) -> Result<Vec<Diagnostic>, Vec<Diagnostic>> {
        self.repl_inputs += 1;
        let name = format!("<input {}>", self.repl_inputs);
        self.env.allow_redeclare = true;
        // At the prompt a lone expression or statement may omit its final `;`.
        let trimmed = text.trim_end();
        let text = if trimmed.ends_with(';') || trimmed.ends_with('}') {
            trimmed.to_string()
        } else {
            format!("{trimmed};")
        };
        let units = self.load_source(&name, &text)?;
        let diags = self.check(&units);
        if diags.iter().any(|d| d.is_error()) {
            return Err(diags);
        }
        match self.run(&units, on_value) {
            Ok(()) => Ok(diags),
            Err(d) => {
                // Globals the checker now knows but whose declarations never ran are
                // forgotten, so the session stays consistent.
                let interp = &self.interp;
                self.env
                    .globals
                    .retain(|name, _| interp.global(name).is_some());
                Err(vec![d])
            }
        }
    }

    /// After a run: the warnings found while running, including caches that ended up holding
    /// non-finite values.
    pub fn finish(&mut self) -> Vec<Diagnostic> {
        let _entered = self.engine.enter();
        for (cache, span) in std::mem::take(&mut self.interp.written_caches) {
            if let Some(cache) = cache.upgrade() {
                crate::interp::builtins::grids::report_nonfinite(&mut self.interp, &cache, span);
            }
        }
        crate::interp::builtins::grids::report_map_reads(&mut self.interp);
        std::mem::take(&mut self.interp.warnings)
    }

    /// The `--profile` table: every grid-producing operation that ran (kind, source line,
    /// bricks filled of total, seconds, bytes), then how many of the grids the run made were
    /// never evaluated, and where: grids, not lines, so a loop's solves that never ran count
    /// one each.
    pub fn profile_report(&self) -> String {
        let entries = self.engine.profile.report();
        let ran: Vec<_> = entries
            .iter()
            .filter(|e| e.bricks_filled + e.bricks_skipped > 0 || e.seconds > 0.0)
            .cloned()
            .collect();
        let mut text = String::from("profile: grids computed\n");
        text.push_str(&crate::engine::profile::format_table(&ran));
        let made: u64 = entries.iter().map(|e| e.instances).sum();
        let idle: Vec<(u64, &crate::engine::profile::ProfileEntry)> = entries
            .iter()
            .map(|e| (e.instances.saturating_sub(e.evaluated), e))
            .filter(|(n, _)| *n > 0)
            .collect();
        let never: u64 = idle.iter().map(|(n, _)| n).sum();
        text.push_str(&format!(
            "{never} of {made} grid{} never evaluated",
            if made == 1 { "" } else { "s" }
        ));
        if !idle.is_empty() {
            let labels: Vec<String> = idle
                .iter()
                .map(|(n, e)| format!("{} ({}): {n} of {}", e.label, e.kind, e.instances))
                .collect();
            text.push_str(&format!(": {}", labels.join(", ")));
        }
        text.push('\n');
        text
    }

    /// The type of an expression, for the REPL's `:type`.
    pub fn type_of(&mut self, text: &str) -> Result<String, Vec<Diagnostic>> {
        self.repl_inputs += 1;
        let name = format!("<input {}>", self.repl_inputs);
        let unit = self.parse_text(&name, &format!("{text};"))?;
        let [Item::Stmt(stmt)] = unit.program.items.as_slice() else {
            return Err(vec![Diagnostic::bare(
                Stage::Usage,
                ":type takes one expression",
            )]);
        };
        let (StmtKind::Expr(e)
        | StmtKind::Decl {
            init: DeclInit::Expr(e),
            ..
        }) = &stmt.kind
        else {
            return Err(vec![Diagnostic::bare(
                Stage::Usage,
                ":type takes one expression",
            )]);
        };
        let mut env = self.env.clone();
        check::type_of_expr(&mut env, e).map(|t| t.to_string())
    }
}

/// Largest script felt reads: far past any file written by hand or by a generator, and small
/// enough that a wrong path (a log, a disk image) fails at once instead of filling memory.
pub const MAX_SCRIPT_BYTES: u64 = 64 << 20;

/// The bytes of a script or an import: a regular file of at most `MAX_SCRIPT_BYTES`.
fn read_script(path: &Path) -> Result<Vec<u8>, String> {
    crate::io::input::read_whole(path, MAX_SCRIPT_BYTES, "a script")
        .map_err(|reason| format!("cannot read `{}`: {reason}", path.display()))
}

fn display_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

/// The `param` declarations of the units, in order: name and declared type.
fn param_decls(
    units: &[Unit],
) -> impl Iterator<Item = (&crate::syntax::ast::Ident, crate::check::types::Type)> {
    units
        .iter()
        .flat_map(|unit| &unit.program.items)
        .filter_map(|item| match item {
            Item::Stmt(stmt) => match &stmt.kind {
                StmtKind::Decl {
                    is_param: true,
                    name,
                    ty,
                    ..
                } => Some((name, crate::check::types::Type::from_expr(ty))),
                _ => None,
            },
            _ => None,
        })
}
