//! Frame ranges and frame patterns: what `felt run --frames 1-240:2` means and how an output
//! path names its frame.
//!
//! A range is written as Open Job Description and Houdini write them: `12`, `1-240`,
//! `1-240:2` (every second frame), or a comma list of those (`1-10,20,30-40:5`). A path names
//! its frame with a pattern that TDs already write: `####` (a run of `#`, zero-padded to that
//! many digits), `%04d` / `%d` (printf) or `$F4` / `$F` (Houdini). The one key decision: the
//! pattern is filled from the `frame` param's value at the time a file is opened, so a path
//! means the same under `--frames 12`, `--set frame=12` or the param's default.

use std::fmt::Write as _;

/// Most frames one range may name: a day of film at 24 frames a second is under 2.1 M.
pub const MAX_FRAMES: usize = 10_000_000;

/// An ordered list of frames, as a range names them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FrameRange {
    /// The range as written (also a valid Open Job Description range expression).
    pub text: String,
    pub frames: Vec<i64>,
}

impl std::str::FromStr for FrameRange {
    type Err = String;

    fn from_str(text: &str) -> Result<FrameRange, String> {
        let mut frames = Vec::new();
        for part in text.split(',') {
            let part = part.trim();
            let (span, step) = match part.split_once(':') {
                Some((span, step)) => {
                    let step: i64 = step.trim().parse().map_err(|_| {
                        format!("`{part}`: the step `{step}` is not a whole number")
                    })?;
                    if step <= 0 {
                        return Err(format!("`{part}`: the step must be 1 or more"));
                    }
                    (span.trim(), step)
                }
                None => (part, 1),
            };
            let (first, last) = split_span(span).ok_or_else(|| {
                format!("`{part}` is not a frame range (write 12, 1-240 or 1-240:2)")
            })?;
            if last < first {
                return Err(format!("`{part}`: the range ends before it starts"));
            }
            let count = ((last - first) / step + 1) as u128;
            if frames.len() as u128 + count > MAX_FRAMES as u128 {
                return Err(format!("`{text}` names more than {MAX_FRAMES} frames"));
            }
            frames.extend((0..count as i64).map(|k| first + k * step));
        }
        let mut seen = std::collections::HashSet::new();
        if let Some(twice) = frames.iter().find(|f| !seen.insert(**f)) {
            return Err(format!("`{text}` names frame {twice} more than once"));
        }
        Ok(FrameRange {
            text: text.trim().to_string(),
            frames,
        })
    }
}

/// `12` → (12, 12); `1-240` → (1, 240); `-5--1` → (-5, -1).
fn split_span(span: &str) -> Option<(i64, i64)> {
    let number = |s: &str| {
        s.trim()
            .parse::<i64>()
            .ok()
            .filter(|n| n.unsigned_abs() < 1 << 53)
    };
    if let Some(n) = number(span) {
        return Some((n, n));
    }
    // The separating `-` is the first one after the first character (which may be a sign).
    let cut = span.char_indices().skip(1).find(|&(_, c)| c == '-')?.0;
    Some((number(&span[..cut])?, number(&span[cut + 1..])?))
}

/// `path` with every frame pattern replaced by `frame`, or `None` when it has no pattern.
pub fn fill(path: &str, frame: i64) -> Option<String> {
    let chars: Vec<char> = path.chars().collect();
    let mut out = String::with_capacity(path.len() + 8);
    let mut found = false;
    let mut i = 0;
    while i < chars.len() {
        let (width, len) = match pattern_at(&chars, i) {
            Some(p) => p,
            None => {
                out.push(chars[i]);
                i += 1;
                continue;
            }
        };
        found = true;
        let _ = write!(out, "{frame:0width$}");
        i += len;
    }
    found.then_some(out)
}

/// Whether `path` names its frame.
pub fn has_pattern(path: &str) -> bool {
    let chars: Vec<char> = path.chars().collect();
    (0..chars.len()).any(|i| pattern_at(&chars, i).is_some())
}

/// Whether `path` already holds `frame`'s number as a run of digits of its own (`0012` or `12`
/// for frame 12, with its sign for a negative frame): a path the script built from its frame.
/// A path that does not depend on the frame would name every frame of a range alike.
pub fn names_frame(path: &str, frame: i64) -> bool {
    let bytes = path.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        if !bytes[i].is_ascii_digit() {
            i += 1;
            continue;
        }
        let start = i;
        while i < bytes.len() && bytes[i].is_ascii_digit() {
            i += 1;
        }
        let negative = start > 0 && bytes[start - 1] == b'-';
        let value = path[start..i].parse::<i64>().ok();
        let signed = value.map(|v| if negative { -v } else { v });
        if signed == Some(frame) || (frame >= 0 && value == Some(frame)) {
            return true;
        }
    }
    false
}

/// The frame pattern starting at `chars[i]`: `(digits, characters it spans)`.
fn pattern_at(chars: &[char], i: usize) -> Option<(usize, usize)> {
    let digits_from = |j: usize| chars[j..].iter().take_while(|c| c.is_ascii_digit()).count();
    let width = |from: usize, n: usize| -> usize {
        chars[from..from + n]
            .iter()
            .collect::<String>()
            .parse::<usize>()
            .unwrap_or(0)
            .min(18)
    };
    match chars[i] {
        '#' => {
            let n = chars[i..].iter().take_while(|&&c| c == '#').count();
            Some((n, n))
        }
        '%' => {
            let n = digits_from(i + 1);
            (chars.get(i + 1 + n) == Some(&'d')).then(|| (width(i + 1, n), n + 2))
        }
        '$' if chars.get(i + 1) == Some(&'F') => {
            let n = digits_from(i + 2);
            // `$FOO` is an environment variable, not a frame.
            let next = chars.get(i + 2 + n);
            if next.is_some_and(|c| c.is_ascii_alphanumeric() || *c == '_') {
                return None;
            }
            Some((width(i + 2, n), n + 2))
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frames(text: &str) -> Vec<i64> {
        text.parse::<FrameRange>().unwrap().frames
    }

    #[test]
    fn ranges_name_the_frames_openjd_would() {
        assert_eq!(frames("12"), vec![12]);
        assert_eq!(frames("1-5"), vec![1, 2, 3, 4, 5]);
        assert_eq!(frames("1-10:4"), vec![1, 5, 9]);
        assert_eq!(frames("1-3,10,20-30:5"), vec![1, 2, 3, 10, 20, 25, 30]);
        assert_eq!(frames("-2-1"), vec![-2, -1, 0, 1]);
        assert_eq!(frames("-5--4"), vec![-5, -4]);
    }

    #[test]
    fn bad_ranges_say_what_is_wrong() {
        for (text, says) in [
            ("5-1", "ends before it starts"),
            ("1-5:0", "step must be 1 or more"),
            ("1-5:x", "not a whole number"),
            ("a-b", "not a frame range"),
            ("", "not a frame range"),
            ("1-3,2", "frame 2 more than once"),
            ("0-99999999999", "more than"),
        ] {
            let error = text.parse::<FrameRange>().unwrap_err();
            assert!(error.contains(says), "{text}: {error}");
        }
    }

    #[test]
    fn a_path_names_its_frame_by_a_run_of_digits_of_that_value() {
        assert!(names_frame("frame.0012.exr", 12));
        assert!(names_frame("shots/12/beauty.exr", 12));
        assert!(names_frame("frame.-003.exr", -3));
        assert!(!names_frame("frame.0012.exr", 1));
        assert!(!names_frame("frame.0112.exr", 12));
        assert!(!names_frame("frame.exr", 0));
        assert!(!names_frame("frame.3.exr", -3));
    }

    #[test]
    fn every_pattern_spelling_fills_the_same_frame() {
        for pattern in ["out/a.####.exr", "out/a.%04d.exr", "out/a.$F4.exr"] {
            assert_eq!(fill(pattern, 12).as_deref(), Some("out/a.0012.exr"));
        }
        assert_eq!(fill("a.#.exr", 12).as_deref(), Some("a.12.exr"));
        assert_eq!(fill("a.%d.vdb", 7).as_deref(), Some("a.7.vdb"));
        assert_eq!(fill("a.$F.vdb", 7).as_deref(), Some("a.7.vdb"));
        assert_eq!(fill("a.###.exr", -5).as_deref(), Some("a.-05.exr"));
        assert_eq!(fill("f##/x.##.exr", 3).as_deref(), Some("f03/x.03.exr"));
        assert_eq!(fill("a.exr", 3), None);
        assert_eq!(
            fill("$FX/a.%s.exr", 3),
            None,
            "an env var and %s are not frames"
        );
        assert!(has_pattern("a.$F2.exr") && !has_pattern("$FOO/a.exr"));
    }
}
