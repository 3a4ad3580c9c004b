//! `felt farm`: job descriptions for render farms that already exist (Open Job Description,
//! Slurm), never a scheduler of felt's own.
//!
//! A job is a script, a frame range, optionally a split of each frame into bands, optionally a
//! simulation script, and the `--set` values. Every render task is one `felt run --frames F
//! [--tile I/N]` process, idempotent and atomic as any felt run is; with bands, a dependent step
//! runs `felt merge` per frame. With a simulation, one task before all of them runs the
//! simulation script over every frame from the range's first to its last, in order (a
//! simulation carries its state from frame to frame through the caches it writes), and the
//! render tasks read those caches, so the simulation runs once however many tasks render. The one
//! key decision: a farm node shares the file system but not the working directory, so every
//! command names the felt binary and the script by absolute path and first changes into the
//! script's folder; relative paths in the script (outputs, caches, imports) then resolve there,
//! as they do for `felt run` started in that folder. A task's command is a list of `Word`s,
//! each format writing a word in its own syntax: paths and values are never pasted into shell
//! text, only through `shell::word` (Slurm) or as whole arguments (Open Job Description).

pub mod merge;
pub mod openjd;
pub mod shell;
pub mod slurm;

use crate::base::failure::{Failure, Outcome};
use crate::io::frames::FrameRange;
use crate::syntax::ast::{Arg, Block, DeclInit, Expr, ExprKind, Item, Program, Stmt, StmtKind};
use std::path::{Path, PathBuf};

/// What every task of a job runs.
#[derive(Clone, Debug)]
pub struct Job {
    /// The felt binary, absolute.
    pub felt: String,
    /// The script, absolute.
    pub script: String,
    /// Where every task runs: the script's folder.
    pub folder: String,
    pub frames: FrameRange,
    /// Bands per frame, when frames are split.
    pub tiles: Option<usize>,
    pub set: Vec<(String, String)>,
    /// The images `felt merge` assembles, as the script names them (relative to `folder`).
    pub images: Vec<String>,
    /// The simulation every render task waits for, when there is one.
    pub sim: Option<Simulation>,
}

/// The one task that simulates the whole frame range before any frame is rendered.
#[derive(Clone, Debug)]
pub struct Simulation {
    /// The simulation script, absolute.
    pub script: String,
    /// Where the simulation task runs: its script's folder.
    pub folder: String,
    /// The `--sim-set` values, for the simulation script only.
    pub set: Vec<(String, String)>,
}

/// One argument of a task's command.
#[derive(Clone, Debug, PartialEq)]
pub enum Word {
    /// Text known when the job is written: a path, an option, a `--set` value.
    Text(String),
    /// The task's frame, known only when the engine starts the task.
    Frame,
    /// The task's band `I/count`, `I` known only when the engine starts the task.
    Band { count: usize },
}

impl Job {
    /// A job for `script` run by the felt binary `felt`. With `tiles`, `images` are the images
    /// to merge; when none are given they are read from the script's `render` calls.
    pub fn new(
        felt: &Path,
        script: &Path,
        program: &[&Program],
        frames: FrameRange,
        tiles: Option<usize>,
        set: Vec<(String, String)>,
        images: Vec<String>,
    ) -> Outcome<Job> {
        let script = absolute(script, "the script")?;
        let folder = parent(&script);
        let mut images = images;
        if tiles.is_some() && images.is_empty() {
            let mut found = Vec::new();
            for p in program {
                render_targets(p, &mut found);
            }
            if found.iter().any(Option::is_none) || found.is_empty() {
                return Err(Failure::new(if found.is_empty() {
                    "the script has no render call whose image --tiles could split".to_string()
                } else {
                    "a render call's image path is computed, so the merge step cannot know it"
                        .to_string()
                })
                .with_help("name every image to merge with --image PATH (frame pattern and all)"));
            }
            images = found.into_iter().flatten().collect();
            images.dedup();
        }
        Ok(Job {
            felt: text(absolute(felt, "the felt binary")?, "the felt binary's path")?,
            script: text(script, "the script's path")?,
            folder: text(folder, "the script's folder")?,
            frames,
            tiles,
            set,
            images,
            sim: None,
        })
    }

    /// The job with the simulation script `script` run once before every render task, given
    /// the `--sim-set` values `set`.
    pub fn with_sim(mut self, script: &Path, set: Vec<(String, String)>) -> Outcome<Job> {
        let script = absolute(script, "the simulation script")?;
        self.sim = Some(Simulation {
            folder: text(parent(&script), "the simulation script's folder")?,
            script: text(script, "the simulation script's path")?,
            set,
        });
        Ok(self)
    }

    /// The arguments of one render task's `felt run`.
    pub fn run_args(&self) -> Vec<Word> {
        let mut args: Vec<Word> = [self.felt.as_str(), "run", self.script.as_str(), "--frames"]
            .into_iter()
            .map(|t| Word::Text(t.to_string()))
            .collect();
        args.push(Word::Frame);
        if let Some(count) = self.tiles {
            args.extend([Word::Text("--tile".to_string()), Word::Band { count }]);
        }
        for (name, value) in &self.set {
            args.push(Word::Text("--set".to_string()));
            args.push(Word::Text(format!("{name}={value}")));
        }
        args
    }

    /// The arguments of the simulation's one `felt run`: every frame from the first to the
    /// last, in order, even when the render takes only some of them (a simulation steps
    /// through each frame). `None` without a simulation.
    pub fn sim_args(&self) -> Option<Vec<Word>> {
        let sim = self.sim.as_ref()?;
        let mut args: Vec<Word> = [
            self.felt.as_str(),
            "run",
            sim.script.as_str(),
            "--frames",
            &self.sim_frames(),
        ]
        .into_iter()
        .map(|t| Word::Text(t.to_string()))
        .collect();
        for (name, value) in &sim.set {
            args.push(Word::Text("--set".to_string()));
            args.push(Word::Text(format!("{name}={value}")));
        }
        Some(args)
    }

    /// The simulation's frames: `FIRST-LAST` of the render's range.
    pub fn sim_frames(&self) -> String {
        let first = self.frames.frames.iter().min().copied().unwrap_or(1);
        let last = self.frames.frames.iter().max().copied().unwrap_or(first);
        if first == last {
            first.to_string()
        } else {
            format!("{first}-{last}")
        }
    }

    /// The arguments of one frame's `felt merge`. `--` ends the options, so an image whose
    /// name starts with `-` is still an image.
    pub fn merge_args(&self) -> Vec<Word> {
        let count = self.tiles.unwrap_or(1).to_string();
        let mut args: Vec<Word> = [self.felt.as_str(), "merge", "--frames"]
            .into_iter()
            .map(|t| Word::Text(t.to_string()))
            .collect();
        args.push(Word::Frame);
        args.extend(["--tiles", &count, "--"].map(|t| Word::Text(t.to_string())));
        args.extend(self.images.iter().cloned().map(Word::Text));
        args
    }

    /// Every path and value the job files carry, with what it is, for the formats to check
    /// against what they can hold.
    pub fn texts(&self) -> Vec<(String, &str)> {
        let mut texts = vec![
            ("the felt binary's path".to_string(), self.felt.as_str()),
            ("the script's folder".to_string(), self.folder.as_str()),
            ("the script's path".to_string(), self.script.as_str()),
        ];
        for (name, value) in &self.set {
            texts.push((format!("the value of --set {name}"), value.as_str()));
        }
        for image in &self.images {
            texts.push(("the --image path".to_string(), image.as_str()));
        }
        if let Some(sim) = &self.sim {
            texts.push((
                "the simulation script's folder".to_string(),
                sim.folder.as_str(),
            ));
            texts.push((
                "the simulation script's path".to_string(),
                sim.script.as_str(),
            ));
            for (name, value) in &sim.set {
                texts.push((format!("the value of --sim-set {name}"), value.as_str()));
            }
        }
        texts
    }

    /// The frame range as written, without the blanks the range syntax ignores, so it is one
    /// line wherever it goes.
    pub fn frames_text(&self) -> String {
        self.frames.text.split_whitespace().collect()
    }

    /// A name for the job: the script's file name.
    pub fn name(&self) -> String {
        Path::new(&self.script)
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| String::from("felt"))
    }
}

/// `p` made absolute, every link resolved; `what` names it when it cannot be found.
fn absolute(p: &Path, what: &str) -> Outcome<PathBuf> {
    p.canonicalize()
        .map_err(|e| Failure::new(format!("cannot find {what} '{}': {e}", p.display())))
}

/// The folder holding `script`.
fn parent(script: &Path) -> PathBuf {
    script
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("/"))
}

/// `path` as text; a job file is text, so a path that is not UTF-8 cannot be written into one
/// exactly (and is refused rather than written as something else).
fn text(path: PathBuf, what: &str) -> Outcome<String> {
    path.into_os_string().into_string().map_err(|raw| {
        Failure::new(format!(
            "{what} '{}' is not valid UTF-8, so a job file cannot name it exactly",
            raw.to_string_lossy()
        ))
        .with_help("rename the folder or file to a UTF-8 name")
    })
}

/// The refusal of `value` (which is `what`) by a format, for `reason`.
pub fn refusal(what: &str, value: &str, reason: &str) -> Failure {
    Failure::new(format!("{what} {value:?} {reason}"))
}

/// The image path of every `render` call in `program`: `Some` for a string literal, `None`
/// for a path computed at run time.
pub fn render_targets(program: &Program, found: &mut Vec<Option<String>>) {
    for item in &program.items {
        match item {
            Item::Func(f) => block_targets(&f.body, found),
            Item::Stmt(s) => stmt_targets(s, found),
            Item::Import(_) => {}
        }
    }
}

fn block_targets(block: &Block, found: &mut Vec<Option<String>>) {
    for s in &block.stmts {
        stmt_targets(s, found);
    }
}

fn stmt_targets(stmt: &Stmt, found: &mut Vec<Option<String>>) {
    match &stmt.kind {
        StmtKind::Decl { init, .. } => match init {
            DeclInit::Expr(e) => expr_targets(e, found),
            DeclInit::Ctor(args) => args_targets(args, found),
            DeclInit::Default => {}
        },
        StmtKind::Expr(e) | StmtKind::Return(Some(e)) => expr_targets(e, found),
        StmtKind::Assign { target, value, .. } => {
            expr_targets(target, found);
            expr_targets(value, found);
        }
        StmtKind::IncDec { target, .. } => expr_targets(target, found),
        StmtKind::If {
            branches,
            else_branch,
        } => {
            for (cond, body) in branches {
                expr_targets(cond, found);
                block_targets(body, found);
            }
            if let Some(b) = else_branch {
                block_targets(b, found);
            }
        }
        StmtKind::For {
            init,
            cond,
            step,
            body,
        } => {
            for s in init.iter().chain(step.iter()) {
                stmt_targets(s, found);
            }
            if let Some(c) = cond {
                expr_targets(c, found);
            }
            block_targets(body, found);
        }
        StmtKind::While { cond, body } => {
            expr_targets(cond, found);
            block_targets(body, found);
        }
        StmtKind::Block(b) => block_targets(b, found),
        StmtKind::Break | StmtKind::Continue | StmtKind::Return(None) => {}
    }
}

fn args_targets(args: &[Arg], found: &mut Vec<Option<String>>) {
    for a in args {
        expr_targets(&a.value, found);
    }
}

fn expr_targets(expr: &Expr, found: &mut Vec<Option<String>>) {
    match &expr.kind {
        ExprKind::Call { callee, args } => {
            if callee.name == "render" {
                let path = args
                    .iter()
                    .find(|a| a.name.as_ref().is_some_and(|n| n.name == "path"))
                    .or_else(|| args.iter().find(|a| a.name.is_none()));
                found.push(match path.map(|a| &a.value.kind) {
                    Some(ExprKind::Str(s)) => Some(s.clone()),
                    _ => None,
                });
            }
            args_targets(args, found);
        }
        ExprKind::Tuple(items) | ExprKind::Array(items) => {
            for e in items {
                expr_targets(e, found);
            }
        }
        ExprKind::Unary(_, e) | ExprKind::Member(e, _) => expr_targets(e, found),
        ExprKind::Binary(first, rest) => {
            expr_targets(first, found);
            for op in rest {
                expr_targets(&op.operand, found);
            }
        }
        ExprKind::Index(a, b) => {
            expr_targets(a, found);
            expr_targets(b, found);
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn render_targets_are_found_wherever_render_is_called() {
        let text = r#"
            param int frame = 1;
            func void shot(string p) { render(p, density = 1.0); }
            if (frame > 0) { render("a.####.exr", density = 1.0); }
            for (int i = 0; i < 1; i++) { render(path = "b.png", density = 1.0); }
        "#;
        let program = crate::syntax::parse(crate::syntax::span::FileId(0), text).unwrap();
        let mut found = Vec::new();
        render_targets(&program, &mut found);
        assert_eq!(
            found,
            vec![
                None,
                Some("a.####.exr".to_string()),
                Some("b.png".to_string())
            ]
        );
    }
}
