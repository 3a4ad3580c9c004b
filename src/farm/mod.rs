//! `felt farm`: job descriptions for render farms that already exist (Open Job Description,
//! Slurm), never a scheduler of felt's own.
//!
//! A job is a script, a frame range, optionally a split of each frame into bands, and the
//! `--set` values. Every task is one `felt run --frames F [--tile I/N]` process, idempotent and
//! atomic as any felt run is; with bands, a dependent step runs `felt merge` per frame. The one
//! key decision: a farm node shares the file system but not the working directory, so every
//! command names the felt binary and the script by absolute path and first changes into the
//! script's folder; relative paths in the script (outputs, caches, imports) then resolve there,
//! as they do for `felt run` started in that folder.

pub mod merge;
pub mod openjd;
pub mod slurm;

use crate::failure::{Failure, Outcome};
use crate::frames::FrameRange;
use crate::syntax::ast::{Arg, Block, DeclInit, Expr, ExprKind, Item, Program, Stmt, StmtKind};
use std::path::{Path, PathBuf};

/// What every task of a job runs.
#[derive(Clone, Debug)]
pub struct Job {
    /// The felt binary, absolute.
    pub felt: PathBuf,
    /// The script, absolute.
    pub script: PathBuf,
    /// Where every task runs: the script's folder.
    pub folder: PathBuf,
    pub frames: FrameRange,
    /// Bands per frame, when frames are split.
    pub tiles: Option<usize>,
    pub set: Vec<(String, String)>,
    /// The images `felt merge` assembles, as the script names them (relative to `folder`).
    pub images: Vec<String>,
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
        let absolute = |p: &Path, what: &str| {
            p.canonicalize()
                .map_err(|e| Failure::new(format!("cannot find {what} '{}': {e}", p.display())))
        };
        let script = absolute(script, "the script")?;
        let folder = script
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("/"));
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
            felt: absolute(felt, "the felt binary")?,
            script,
            folder,
            frames,
            tiles,
            set,
            images,
        })
    }

    /// The arguments of one render task's `felt run`, `frame` and `tile` being how the engine
    /// spells the task's frame and band index.
    pub fn run_args(&self, frame: &str, tile: Option<&str>) -> Vec<String> {
        let mut args = vec![
            self.felt.display().to_string(),
            "run".to_string(),
            self.script.display().to_string(),
            "--frames".to_string(),
            frame.to_string(),
        ];
        if let (Some(tile), Some(count)) = (tile, self.tiles) {
            args.extend(["--tile".to_string(), format!("{tile}/{count}")]);
        }
        for (name, value) in &self.set {
            args.extend(["--set".to_string(), format!("{name}={value}")]);
        }
        args
    }

    /// The arguments of one frame's `felt merge`.
    pub fn merge_args(&self, frame: &str) -> Vec<String> {
        let mut args = vec![
            self.felt.display().to_string(),
            "merge".to_string(),
            "--frames".to_string(),
            frame.to_string(),
            "--tiles".to_string(),
            self.tiles.unwrap_or(1).to_string(),
        ];
        args.extend(self.images.iter().cloned());
        args
    }

    /// A name for the job: the script's file name.
    pub fn name(&self) -> String {
        self.script
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| String::from("felt"))
    }
}

/// `text` quoted for a POSIX shell, where it needs quoting. Engine placeholders (`{{...}}`,
/// `$VAR`) must be passed unquoted by the caller.
pub fn shell_quote(text: &str) -> String {
    let plain = !text.is_empty()
        && text
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c));
    if plain {
        text.to_string()
    } else {
        format!("'{}'", text.replace('\'', r"'\''"))
    }
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
    fn shell_quoting_survives_spaces_and_quotes() {
        assert_eq!(shell_quote("/opt/felt/bin/felt"), "/opt/felt/bin/felt");
        assert_eq!(shell_quote("my scene.felt"), "'my scene.felt'");
        assert_eq!(shell_quote("it's"), r"'it'\''s'");
        assert_eq!(shell_quote(""), "''");
    }

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
