//! Paths in scripts: how the file name a builtin is given becomes a place on disk.
//!
//! Every builtin that reads or writes a file (`cacheload`, `cachesave`, `render`, `loadshape`,
//! `saveshape`, ...) asks `ScriptFiles` for its path, and nothing else joins or expands paths.
//! The one key decision: a relative path resolves against the folder of the script `felt run`
//! was given, as `import` does, not against the directory felt happens to run in, so a farm
//! node can start a script from anywhere and find its inputs beside it. `--output-dir` still
//! sends relative *outputs* under its folder (and reads of a file this run wrote there come
//! back from it). At the REPL there is no script, and relative paths are relative to the
//! current directory. Environment variables are expanded first: `$SHOT/cache/density.vdb`,
//! `${SHOT}_v2.exr`; `$$` is a literal `$`; an unset variable is an error that names it.
//! Frame patterns (`$F4`, `####`, `%04d`) are filled before variables are expanded, so `$F`
//! and `$F4` are always frame numbers, never variables.

use crate::base::failure::{Failure, Outcome};
use std::collections::HashSet;
use std::path::{Path, PathBuf};

/// Where a run's relative paths start, and which files it has written.
#[derive(Clone, Debug, Default)]
pub struct ScriptFiles {
    /// The script `felt run` was given, canonical; `None` at the REPL.
    pub script: Option<PathBuf>,
    /// VDB files this run has written (where they landed): a later `cachesave` to one of
    /// them adds its grid instead of replacing the file.
    pub vdbs_written: HashSet<PathBuf>,
}

impl ScriptFiles {
    /// The folder relative paths start from: the script's, or the current directory's
    /// (`None`) at the REPL.
    pub fn base(&self) -> Option<&Path> {
        self.script.as_deref().and_then(Path::parent)
    }

    /// Where a file a script reads, named `text`, is found.
    pub fn reading(&self, text: &str) -> Outcome<PathBuf> {
        let path = PathBuf::from(expand(&crate::engine::output::framed(text))?);
        if path.is_absolute() {
            return Ok(path);
        }
        if let Some(written) = crate::engine::output::directory().map(|d| d.join(&path))
            && written.exists()
        {
            return Ok(written);
        }
        Ok(self.beside_script(&path))
    }

    /// Where a file a script writes, named `text`, lands.
    pub fn writing(&self, text: &str) -> Outcome<PathBuf> {
        crate::engine::output::check_frame(text)
            .map_err(|e| Failure::new(format!("cannot write '{text}': {e}")))?;
        let path = PathBuf::from(expand(&crate::engine::output::framed(text))?);
        if path.is_absolute() {
            return Ok(path);
        }
        Ok(match crate::engine::output::directory() {
            Some(directory) => directory.join(&path),
            None => self.beside_script(&path),
        })
    }

    fn beside_script(&self, relative: &Path) -> PathBuf {
        match self.base() {
            Some(base) => base.join(relative),
            None => relative.to_path_buf(),
        }
    }
}

/// `text` with its environment variables replaced by their values.
pub fn expand(text: &str) -> Outcome<String> {
    expand_with(text, |name| std::env::var_os(name))
}

/// `expand` with `lookup` in place of the process's environment.
fn expand_with(text: &str, lookup: impl Fn(&str) -> Option<std::ffi::OsString>) -> Outcome<String> {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find('$') {
        out.push_str(&rest[..at]);
        let after = &rest[at + 1..];
        let (name, tail) = if let Some(braced) = after.strip_prefix('{') {
            let Some(end) = braced.find('}') else {
                return Err(Failure::new(format!(
                    "the path \"{text}\" opens '${{' without a closing '}}'"
                ))
                .with_help("write ${NAME} for a variable, or $$ for a literal $"));
            };
            let name = &braced[..end];
            if !is_name(name) {
                return Err(Failure::new(format!(
                    "the path \"{text}\" has '${{{name}}}', which is not an environment \
                     variable's name"
                ))
                .with_help("names are letters, digits and _, not starting with a digit"));
            }
            (name, &braced[end + 1..])
        } else if let Some(tail) = after.strip_prefix('$') {
            out.push('$');
            rest = tail;
            continue;
        } else {
            let end = after
                .char_indices()
                .find(|&(i, c)| {
                    !(c == '_' || c.is_ascii_alphabetic() || i > 0 && c.is_ascii_digit())
                })
                .map_or(after.len(), |(i, _)| i);
            if end == 0 {
                // A '$' that starts no name is just a character of the file name.
                out.push('$');
                rest = after;
                continue;
            }
            (&after[..end], &after[end..])
        };
        let value = lookup(name).ok_or_else(|| {
            Failure::new(format!(
                "the environment variable {name} in the path \"{text}\" is not set"
            ))
            .with_help(format!(
                "set it before running felt (export {name}=...), or write the path without it"
            ))
        })?;
        let value = value.into_string().map_err(|_| {
            Failure::new(format!(
                "the environment variable {name} in the path \"{text}\" is not valid UTF-8"
            ))
        })?;
        out.push_str(&value);
        rest = tail;
    }
    out.push_str(rest);
    Ok(out)
}

fn is_name(name: &str) -> bool {
    let mut chars = name.chars();
    matches!(chars.next(), Some(c) if c == '_' || c.is_ascii_alphabetic())
        && chars.all(|c| c == '_' || c.is_ascii_alphanumeric())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ffi::OsString;

    fn shot(name: &str) -> Option<OsString> {
        match name {
            "SHOT" => Some("/show/sq010/sh020".into()),
            "V" => Some("3".into()),
            "EMPTY" => Some(OsString::new()),
            _ => None,
        }
    }

    #[test]
    fn variables_expand_in_both_spellings() {
        let cases = [
            (
                "$SHOT/cache/density.vdb",
                "/show/sq010/sh020/cache/density.vdb",
            ),
            ("${SHOT}/v${V}.exr", "/show/sq010/sh020/v3.exr"),
            ("out_$V.exr", "out_3.exr"),
            ("$V$V", "33"),
            ("a$EMPTY.b", "a.b"),
            ("cost$$.exr", "cost$.exr"),
            ("price$.exr", "price$.exr"),
            ("$1.exr", "$1.exr"),
            ("plain/path.vdb#density", "plain/path.vdb#density"),
        ];
        for (text, expected) in cases {
            assert_eq!(expand_with(text, shot).unwrap(), expected, "{text}");
        }
    }

    #[test]
    fn an_unset_or_malformed_variable_is_named() {
        let unset = expand_with("$SHOT/$TAKE/a.exr", shot).unwrap_err();
        assert_eq!(
            unset.message,
            "the environment variable TAKE in the path \"$SHOT/$TAKE/a.exr\" is not set"
        );
        assert!(unset.help.unwrap().contains("export TAKE="));
        let open = expand_with("${SHOT/a.exr", shot).unwrap_err();
        assert!(
            open.message.contains("without a closing"),
            "{}",
            open.message
        );
        let empty = expand_with("${}/a.exr", shot).unwrap_err();
        assert!(
            empty.message.contains("not an environment"),
            "{}",
            empty.message
        );
    }

    #[test]
    fn relative_paths_start_at_the_script_folder_or_the_current_one() {
        let files = ScriptFiles {
            script: Some(PathBuf::from("/show/scenes/cloud.felt")),
            ..ScriptFiles::default()
        };
        assert_eq!(
            files.reading("cache/a.vdb").unwrap(),
            Path::new("/show/scenes/cache/a.vdb")
        );
        assert_eq!(
            files.reading("/abs/a.vdb").unwrap(),
            Path::new("/abs/a.vdb")
        );
        let at_prompt = ScriptFiles::default();
        assert_eq!(at_prompt.reading("a.vdb").unwrap(), Path::new("a.vdb"));
        assert_eq!(at_prompt.writing("a.exr").unwrap(), Path::new("a.exr"));
    }
}
