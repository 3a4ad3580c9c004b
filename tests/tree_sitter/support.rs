//! What the editor-grammar tests read: the repository's scripts, the tree-sitter corpus, and
//! the trees `tree-sitter parse` prints.

use std::path::{Path, PathBuf};

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

pub fn grammar_dir() -> PathBuf {
    root().join("editors/tree-sitter-felt")
}

/// Every `.felt` file of the repository, build outputs and hidden folders aside, in path
/// order.
pub fn felt_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().into_owned();
            if path.is_dir() {
                if !name.starts_with('.') && name != "target" && name != "node_modules" {
                    walk(&path, out);
                }
            } else if name.ends_with(".felt") {
                out.push(path);
            }
        }
    }
    let mut files = Vec::new();
    walk(&root(), &mut files);
    files.sort();
    files
}

/// One test of `test/corpus/*.txt`: its input, and whether it is marked `:error`.
pub struct CorpusEntry {
    pub file: String,
    pub name: String,
    pub error: bool,
    pub input: String,
}

fn is_rule(line: &str, c: char) -> bool {
    line.len() >= 3 && line.chars().all(|x| x == c)
}

/// The tests of the tree-sitter corpus, in the layout `tree-sitter test` reads: a header
/// between two lines of `=` (the name, then attributes such as `:error`), the input, a line
/// of `-`, the expected tree.
pub fn corpus() -> Vec<CorpusEntry> {
    let dir = grammar_dir().join("test/corpus");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "txt"))
        .collect();
    paths.sort();
    let mut entries = Vec::new();
    for path in paths {
        let file = path
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        let text = std::fs::read_to_string(&path).expect("corpus file");
        let mut lines = text.lines().peekable();
        while let Some(line) = lines.next() {
            if !is_rule(line, '=') {
                continue;
            }
            let mut name = String::new();
            let mut error = false;
            for header in lines.by_ref() {
                if is_rule(header, '=') {
                    break;
                }
                match header.trim() {
                    ":error" => error = true,
                    h if h.starts_with(':') || h.is_empty() => {}
                    h => name = h.to_string(),
                }
            }
            let mut input = Vec::new();
            for body in lines.by_ref() {
                if is_rule(body, '-') {
                    break;
                }
                input.push(body);
            }
            while lines.peek().is_some_and(|l| !is_rule(l, '=')) {
                lines.next();
            }
            entries.push(CorpusEntry {
                file: file.clone(),
                name,
                error,
                input: input.join("\n").trim().to_string(),
            });
        }
    }
    entries
}

/// Copies the grammar's sources (not its compiled parsers) into `to`.
pub fn copy_grammar(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("copy of the grammar");
    for entry in std::fs::read_dir(from).expect("grammar folder").flatten() {
        let target = to.join(entry.file_name());
        if entry.path().is_dir() {
            copy_grammar(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).expect("copy of a grammar file");
        }
    }
}

/// Whether a tree printed by `tree-sitter parse` holds an ERROR node or a MISSING token.
pub fn tree_has_error(tree: &str) -> bool {
    tree.contains("(ERROR") || tree.contains("(MISSING")
}
