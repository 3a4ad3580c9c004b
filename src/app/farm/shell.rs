//! Shell words for the job files `felt farm` writes: the one place a path or value an artist
//! typed (a folder, a script name, a `--set` value, an `--image` path) becomes shell text.
//!
//! The one key decision: every such text is one POSIX single-quoted word (`'...'`, a `'`
//! written `'\''`), the only quoting under which a POSIX shell expands nothing at all: `$(...)`,
//! backticks, `$VAR`, `\`, `*`, `~`, `#`, `;`, `|`, `&&` and newlines are all plain characters
//! there. Text made only of characters no shell treats specially is written bare, so the usual
//! path reads as typed (the rule of Python's `shlex.quote`). A value the task itself computes
//! (its frame, its band) is a shell variable, written double-quoted so it stays one word.

/// `text` as one word a POSIX shell reads back exactly.
pub fn word(text: &str) -> String {
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

/// The value of the script's own variable `name` (a frame, a band), as one word.
pub fn variable(name: &str) -> String {
    debug_assert!(
        name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'),
        "`{name}` is not a shell variable name"
    );
    format!("\"${name}\"")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_text_stays_bare_and_the_rest_is_single_quoted() {
        assert_eq!(word("/opt/felt/bin/felt"), "/opt/felt/bin/felt");
        assert_eq!(word("res=64"), "res=64");
        assert_eq!(word("my scene.felt"), "'my scene.felt'");
        assert_eq!(word("it's"), r"'it'\''s'");
        assert_eq!(word("$(touch x)"), "'$(touch x)'");
        assert_eq!(word("a\nb"), "'a\nb'");
        assert_eq!(word("~"), "'~'");
        assert_eq!(word(""), "''");
        assert_eq!(variable("frame"), "\"$frame\"");
    }
}
