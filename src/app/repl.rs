//! `felt repl`: an interactive session over the same `Session` a batch run uses. Input stays
//! open across lines while brackets, braces or a string are unclosed (the parser decides),
//! each further line read at its own `...> ` prompt; each input is checked, then run; an expression statement prints its value; an error is
//! shown as a diagnostic and the session keeps its state. Ctrl-C during an evaluation stops it
//! and returns to the prompt; at the prompt it clears the line. History persists in
//! `~/.felt_history` (or the file named by `FELT_HISTORY`).

use crate::app::doc;
use crate::interp::registry::registry;
use crate::session::Session;
use crate::syntax;
use crate::syntax::diagnostic::{self, Diagnostic};
use rustyline::completion::{Completer, Pair};
use rustyline::error::ReadlineError;
use rustyline::highlight::Highlighter;
use rustyline::hint::Hinter;
use rustyline::history::DefaultHistory;
use rustyline::validate::Validator;
use rustyline::{Context, Editor, Helper};
use std::cell::RefCell;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::rc::Rc;

const HELP: &str = "\
Type felt statements; an expression on its own prints its value.
Input continues over several lines while brackets or braces are open.
  :help          this text
  :type EXPR     the type of an expression
  :vars          the variables defined so far
  :load FILE     run a script in this session
  :doc NAME      documentation of a builtin or library function
  :quit          leave (also Ctrl-D)
Ctrl-C stops a running evaluation.";

const COMMANDS: &[&str] = &[":help", ":type", ":vars", ":load", ":doc", ":quit"];

/// Completion words, refreshed after every input with the session's variables and functions.
struct FeltHelper {
    words: Rc<RefCell<Vec<String>>>,
}

impl Completer for FeltHelper {
    type Candidate = Pair;

    fn complete(
        &self,
        line: &str,
        pos: usize,
        _: &Context<'_>,
    ) -> rustyline::Result<(usize, Vec<Pair>)> {
        let start = line[..pos]
            .rfind(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == ':'))
            .map(|i| i + 1)
            .unwrap_or(0);
        let prefix = &line[start..pos];
        if prefix.is_empty() {
            return Ok((pos, Vec::new()));
        }
        let words = self.words.borrow();
        let candidates = words
            .iter()
            .filter(|w| w.starts_with(prefix))
            .map(|w| Pair {
                display: w.clone(),
                replacement: w.clone(),
            })
            .collect();
        Ok((start, candidates))
    }
}

impl Hinter for FeltHelper {
    type Hint = String;
}

impl Highlighter for FeltHelper {}

/// Every line is accepted as typed: an input left open is continued by `read_input` at the
/// continuation prompt. (rustyline can keep an open input in one editing buffer, but then
/// shows the prompt on its first line only, and a TD cannot tell felt waiting for the rest
/// of a function from felt busy.)
impl Validator for FeltHelper {}

impl Helper for FeltHelper {}

fn history_path() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("FELT_HISTORY") {
        return Some(PathBuf::from(p));
    }
    std::env::var_os("HOME").map(|h| Path::new(&h).join(".felt_history"))
}

fn refresh_words(session: &Session, words: &RefCell<Vec<String>>) {
    let mut all: Vec<String> = registry().names().map(String::from).collect();
    all.extend(session.env.funcs.keys().cloned());
    all.extend(session.env.globals.keys().cloned());
    all.extend(COMMANDS.iter().map(|c| c.to_string()));
    all.sort();
    all.dedup();
    *words.borrow_mut() = all;
}

pub fn run() -> ExitCode {
    let color = std::io::stderr().is_terminal();
    let mut session = match Session::new(Box::new(std::io::stdout())) {
        Ok(s) => s,
        Err(failure) => {
            eprint!(
                "{}",
                diagnostic::render(&failure.diagnostics, &failure.sources, color)
            );
            return ExitCode::from(1);
        }
    };
    // At the prompt relative paths are relative to the current directory.
    session.at_prompt = true;
    let words = Rc::new(RefCell::new(Vec::new()));
    refresh_words(&session, &words);
    let mut editor: Editor<FeltHelper, DefaultHistory> = match Editor::new() {
        Ok(e) => e,
        Err(e) => {
            eprintln!("felt repl: cannot start the line editor: {e}");
            return ExitCode::from(1);
        }
    };
    editor.set_helper(Some(FeltHelper {
        words: words.clone(),
    }));
    let history = history_path();
    if let Some(path) = &history {
        let _ = editor.load_history(path);
    }
    // Ctrl-C while an evaluation runs (the terminal is not in raw mode then).
    let engine = session.engine().clone();
    let _ = ctrlc::set_handler(move || engine.interrupt());
    println!(
        "felt {} — :help for help, :quit to leave",
        env!("CARGO_PKG_VERSION")
    );
    loop {
        match read_input(&mut editor) {
            Ok(line) => {
                if line.trim().is_empty() {
                    continue;
                }
                let _ = editor.add_history_entry(line.as_str());
                if let Some(path) = &history {
                    let _ = editor.save_history(path);
                }
                session.engine().clear_interrupt();
                if !handle(&mut session, &line, color) {
                    break;
                }
                refresh_words(&session, &words);
            }
            Err(ReadlineError::Interrupted) => continue,
            Err(ReadlineError::Eof) => break,
            Err(e) => {
                eprintln!("felt repl: {e}");
                return ExitCode::from(1);
            }
        }
    }
    ExitCode::SUCCESS
}

/// The prompt of an input's first line, and of the lines that continue an open input.
const PROMPT: &str = "felt> ";
const CONTINUATION_PROMPT: &str = "...> ";

/// Reads one input: a line at `PROMPT`, then, while the parser says it is unfinished (an open
/// bracket, brace or string; a `:` command never is), further lines at `CONTINUATION_PROMPT`,
/// joined by newlines. Ctrl-C on a continuation line drops the whole input.
fn read_input(editor: &mut Editor<FeltHelper, DefaultHistory>) -> rustyline::Result<String> {
    let mut input = editor.readline(PROMPT)?;
    while !input.trim_start().starts_with(':') && syntax::is_incomplete(&input) {
        let line = editor.readline(CONTINUATION_PROMPT)?;
        input.push('\n');
        input.push_str(&line);
    }
    Ok(input)
}

/// Handles one input; returns false to leave.
fn handle(session: &mut Session, line: &str, color: bool) -> bool {
    let show = |session: &Session, diags: &[Diagnostic]| {
        if !diags.is_empty() {
            eprint!(
                "{}",
                diagnostic::render(diags, &session.sources.borrow(), color)
            );
        }
    };
    let trimmed = line.trim();
    if let Some(command) = trimmed.strip_prefix(':') {
        let (name, rest) = command
            .split_once(char::is_whitespace)
            .unwrap_or((command, ""));
        let rest = rest.trim();
        match name {
            "quit" | "q" | "exit" => return false,
            "help" | "h" => println!("{HELP}"),
            "vars" => {
                for (name, slot) in session.interp.globals() {
                    println!("{} {} = {}", slot.ty, name, slot.value);
                }
            }
            "type" | "t" => match session.type_of(rest) {
                Ok(t) => println!("{t}"),
                Err(diags) => show(session, &diags),
            },
            "doc" => match doc::describe(rest) {
                Some(text) => print!("{text}"),
                None => eprintln!("no builtin or library function named `{rest}`"),
            },
            "load" | "l" => {
                session.env.allow_redeclare = true;
                match session.run_file(Path::new(rest)) {
                    Ok(warnings) => show(session, &warnings),
                    Err(diags) => show(session, &diags),
                }
            }
            other => eprintln!("unknown command `:{other}`; :help lists the commands"),
        }
        return true;
    }
    let result = session.eval_input(line, &mut |interp, value| {
        let _ = writeln!(interp.out, "{value}");
    });
    match result {
        Ok(warnings) => show(session, &warnings),
        Err(diags) => show(session, &diags),
    }
    true
}

use std::io::Write as _;
