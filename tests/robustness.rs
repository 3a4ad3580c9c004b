//! No input may panic or hang felt. Every example, test script and standard-library file is
//! mutated thousands of times (tokens deleted, duplicated or swapped, text truncated, random
//! bytes inserted) and each mutant is checked and, when it checks, run. The result must be a
//! clean success or a diagnostic: never a panic, and never a run that ignores the interrupt a
//! watchdog raises after a time budget.

mod common;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Deterministic pseudo-random numbers (xorshift*), so a failure reproduces.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
}

/// Splits text into rough tokens: runs of word characters, runs of spaces, single symbols.
fn tokens(text: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut start = 0;
    let chars: Vec<(usize, char)> = text.char_indices().collect();
    let class = |c: char| {
        if c.is_alphanumeric() || c == '_' || c == '.' {
            0
        } else if c.is_whitespace() {
            1
        } else {
            2
        }
    };
    for w in 1..=chars.len() {
        let boundary = w == chars.len()
            || class(chars[w].1) != class(chars[w - 1].1)
            || class(chars[w].1) == 2;
        if boundary {
            let end = if w == chars.len() {
                text.len()
            } else {
                chars[w].0
            };
            out.push(&text[start..end]);
            start = end;
        }
    }
    out
}

fn mutate(text: &str, rng: &mut Rng) -> String {
    let mut toks: Vec<String> = tokens(text).into_iter().map(String::from).collect();
    if toks.is_empty() {
        toks.push(String::new());
    }
    let edits = 1 + rng.below(3);
    for _ in 0..edits {
        let i = rng.below(toks.len());
        match rng.below(6) {
            0 => {
                toks.remove(i);
                if toks.is_empty() {
                    toks.push(String::new());
                }
            }
            1 => {
                let t = toks[i].clone();
                toks.insert(i, t);
            }
            2 => {
                let j = rng.below(toks.len());
                toks.swap(i, j);
            }
            3 => {
                let all: String = toks.concat();
                let cut = rng.below(all.len() + 1);
                let cut = (0..=cut)
                    .rev()
                    .find(|c| all.is_char_boundary(*c))
                    .unwrap_or(0);
                toks = vec![all[..cut].to_string()];
            }
            4 => {
                let noise: String = (0..1 + rng.below(4))
                    .map(|_| {
                        let b = rng.below(128) as u8;
                        if b.is_ascii_graphic() || b == b' ' || b == b'\n' {
                            b as char
                        } else {
                            '\u{7f}'
                        }
                    })
                    .collect();
                toks.insert(i, noise);
            }
            _ => {
                let pick = [
                    "(", ")", "{", "}", ";", "[", "]", ",", "=", "\"", "/*", "-", "^", "1e400",
                    "0", "func",
                ];
                toks.insert(i, pick[rng.below(pick.len())].to_string());
            }
        }
    }
    toks.concat()
}

fn corpus() -> Vec<PathBuf> {
    let mut files = Vec::new();
    for dir in [
        "examples",
        "stdlib",
        "tests/scripts/lang",
        "tests/scripts/lang/lib",
        "tests/scripts/errors",
        "tests/scripts/heavy",
    ] {
        if let Ok(entries) = std::fs::read_dir(dir) {
            for e in entries.flatten() {
                let p = e.path();
                if p.extension().is_some_and(|x| x == "felt") {
                    files.push(p);
                }
            }
        }
    }
    files.sort();
    files
}

#[test]
fn mutated_scripts_give_diagnostics_not_panics() {
    let files = corpus();
    assert!(!files.is_empty());
    let texts: Vec<(PathBuf, String)> = files
        .iter()
        .map(|p| {
            (
                std::fs::canonicalize(p).unwrap(),
                std::fs::read_to_string(p).unwrap(),
            )
        })
        .collect();
    let total = 5_000;
    let scratch = tempfile::tempdir().unwrap();
    // Mutated scripts may write outputs (renders, caches): keep them out of the source tree,
    // and keep grids small so a mutated resolution cannot exhaust memory.
    std::env::set_current_dir(scratch.path()).unwrap();
    let engine = felt::engine::Engine::with_memory_limit(64 << 20);
    let stop = Arc::new(AtomicBool::new(false));
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut panics = Vec::new();
    let mut ran = 0;
    for n in 0..total {
        let (path, text) = &texts[n % texts.len()];
        let mutant = mutate(text, &mut rng);
        let target = scratch.path().join(path.file_name().unwrap());
        std::fs::write(&target, &mutant).unwrap();
        // Imports in the mutant resolve next to the original.
        let _ = copy_siblings(path, scratch.path());
        // A mutant still running after 400 polls 5 ms apart (about 2 s) is interrupted; one
        // that ignored the interrupt would never return, and the test would not finish.
        let watchdog = {
            let stop = stop.clone();
            let engine = engine.clone();
            std::thread::spawn(move || {
                for _ in 0..400 {
                    if stop.load(Ordering::Relaxed) {
                        return;
                    }
                    std::thread::sleep(Duration::from_millis(5));
                }
                engine.interrupt();
            })
        };
        // Example scenes declare their sizes as params: shrink them so a mutant that runs
        // renders a thumbnail over a coarse grid, simulating two frames.
        let small: Vec<(&str, &str)> = [
            ("width", "8"),
            ("height", "6"),
            ("res", "8"),
            ("frames", "2"),
        ]
        .into_iter()
        .filter(|(name, _)| mutant.contains(&format!("param int {name} ")))
        .collect();
        let result = catch_unwind(AssertUnwindSafe(|| {
            common::run_script_on(engine.clone(), &target, &small)
        }));
        stop.store(true, Ordering::Relaxed);
        watchdog.join().unwrap();
        stop.store(false, Ordering::Relaxed);
        engine.clear_interrupt();
        match result {
            Err(_) => panics.push(format!("mutant {n} of {}:\n{mutant}", path.display())),
            Ok(outcome) => {
                if outcome.ok {
                    ran += 1;
                } else {
                    assert!(
                        !outcome.rendered.is_empty(),
                        "a failure without a diagnostic: mutant {n}"
                    );
                }
            }
        }
    }
    assert!(
        panics.is_empty(),
        "{} panics; first:\n{}",
        panics.len(),
        panics[0]
    );
    eprintln!("{total} mutants, {ran} ran to completion");
}

fn copy_siblings(original: &Path, scratch: &Path) -> std::io::Result<()> {
    let dir = original.parent().unwrap();
    for e in std::fs::read_dir(dir)?.flatten() {
        let p = e.path();
        if p.is_dir() {
            let sub = scratch.join(e.file_name());
            std::fs::create_dir_all(&sub)?;
            for f in std::fs::read_dir(&p)?.flatten() {
                if !sub.join(f.file_name()).exists() {
                    std::fs::copy(f.path(), sub.join(f.file_name()))?;
                }
            }
        } else if p.extension().is_some_and(|x| x == "felt")
            && p != original
            && !scratch.join(e.file_name()).exists()
        {
            std::fs::copy(&p, scratch.join(e.file_name()))?;
        }
    }
    Ok(())
}

/// Each resource-heavy script in `tests/scripts/heavy` stops with a memory-budget diagnostic at
/// a line of its own (or of the library it calls), in its own process: an abort on a failed
/// allocation would show as a signal, not an exit status of 1.
#[test]
fn heavy_scripts_stop_at_the_memory_budget() {
    // Absolute: the mutation test beside this one changes the working directory.
    let heavy = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scripts/heavy");
    let mut scripts: Vec<PathBuf> = std::fs::read_dir(heavy)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "felt"))
        .collect();
    scripts.sort();
    assert!(scripts.len() >= 8);
    let scratch = tempfile::tempdir().unwrap();
    for script in &scripts {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_felt"))
            .current_dir(scratch.path())
            .arg("run")
            .arg(script)
            .args(["--memory-limit", "64"])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{}: {stderr}", script.display());
        // The renderer wraps long messages: compare the words.
        let words: Vec<&str> = stderr.split_whitespace().filter(|w| *w != "│").collect();
        let flat = words.join(" ");
        assert!(
            flat.contains("over the memory budget") && !flat.contains("panicked"),
            "{}: {stderr}",
            script.display()
        );
    }
}
