//! The error type of the engine modules (fields, grids, rendering, geometry, file formats).
//! They know nothing of source text, so they report a `Failure`: a message in the script
//! author's terms and an optional hint. The interpreter attaches the span of the call that
//! failed and turns it into a diagnostic with the source line and the FELT call stack.
//!
//! A failure is the script's (a bad value, a missing file, a size over budget) unless it is
//! made with `Failure::internal`: an invariant of felt's own code that did not hold, which no
//! script should be able to cause. Those are a distinct kind, so the `felt` command exits 70
//! with a line asking for a report instead of blaming the script with exit 1.
//!
//! The words of a failure live here too: counts grouped in thousands and vectors as felt
//! prints them, so every layer that reports a failure writes numbers the same way.

use std::fmt;

#[derive(Clone, Debug, PartialEq)]
pub struct Failure {
    pub message: String,
    pub help: Option<String>,
    /// A bug in felt rather than a problem with the script (see the module doc).
    pub internal: bool,
}

impl Failure {
    pub fn new(message: impl Into<String>) -> Failure {
        Failure {
            message: message.into(),
            help: None,
            internal: false,
        }
    }

    /// An invariant of felt's own code that did not hold: `what` says which, after
    /// "internal error: ".
    pub fn internal(what: impl fmt::Display) -> Failure {
        Failure {
            message: format!("internal error: {what}"),
            help: Some(String::from(
                "this is a bug in felt, not in the script: please report it, with the script \
                 that caused it",
            )),
            internal: true,
        }
    }

    pub fn with_help(mut self, help: impl Into<String>) -> Failure {
        self.help = Some(help.into());
        self
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Failure {}

impl From<std::io::Error> for Failure {
    fn from(e: std::io::Error) -> Failure {
        Failure::new(e.to_string())
    }
}

/// Shorthand for engine results.
pub type Outcome<T> = Result<T, Failure>;

/// `return Err(Failure::new(format!(...)))` in one line.
#[macro_export]
macro_rules! fail {
    ($($arg:tt)*) => {
        return Err($crate::base::failure::Failure::new(format!($($arg)*)))
    };
}

/// `1234567` as `1,234,567`: counts in messages are written this way, so a large one reads
/// at a glance.
pub fn grouped(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// A vector in messages as felt prints one, `(0.5, 1e155, -3.0)`: each component in its
/// shortest round-trip form, so huge and tiny values stay short.
pub fn vector_text(v: glam::DVec3) -> String {
    format!("({:?}, {:?}, {:?})", v.x, v.y, v.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_internal_failures_are_internal() {
        let bug = Failure::internal("a crossing has no owner");
        assert!(bug.internal);
        assert_eq!(bug.message, "internal error: a crossing has no owner");
        assert!(!Failure::new("internal error: spelled by hand").internal);
        assert!(!Failure::from(std::io::Error::other("disk full")).internal);
    }

    /// Every "internal error" felt reports is made by `Failure::internal`, so it exits 70: no
    /// source file spells the words into an ordinary failure's message by hand.
    #[test]
    fn internal_errors_are_made_only_by_failure_internal() {
        fn sources(folder: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
            for entry in std::fs::read_dir(folder).unwrap() {
                let path = entry.unwrap().path();
                if path.is_dir() {
                    sources(&path, out);
                } else if path.extension().is_some_and(|e| e == "rs") {
                    out.push(path);
                }
            }
        }
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let mut files = Vec::new();
        sources(&root, &mut files);
        assert!(files.len() > 50, "found only {} source files", files.len());
        // This file builds the words for `Failure::internal`; main.rs prints them for a panic.
        let own = [root.join("base/failure.rs"), root.join("main.rs")];
        let words = ["\"internal", " error"].concat();
        let spelled: Vec<String> = files
            .iter()
            .filter(|f| !own.contains(f))
            .flat_map(|f| {
                let text = std::fs::read_to_string(f).unwrap();
                text.lines()
                    .enumerate()
                    .filter(|(_, line)| line.to_lowercase().contains(&words))
                    .map(|(n, line)| format!("{}:{}: {}", f.display(), n + 1, line.trim()))
                    .collect::<Vec<_>>()
            })
            .collect();
        assert!(
            spelled.is_empty(),
            "use Failure::internal:\n{}",
            spelled.join("\n")
        );
    }
}
