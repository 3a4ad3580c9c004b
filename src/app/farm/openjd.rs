//! Open Job Description templates (`specificationVersion: jobtemplate-2023-09`), the format
//! AWS Deadline Cloud and OpenCue's tools read and `openjd-cli` checks and runs locally.
//!
//! The one key decision: the frame range is handed to the engine as it was written, as the
//! `Frame` task parameter's range expression (felt's range syntax is OpenJD's), so the engine,
//! not felt, expands it into tasks; with bands a `Tile` parameter is crossed with it and a
//! `merge` step depending on the render step has one task per frame. With a simulation, a
//! `simulate` step of one task (no parameter space) runs first and the render step depends on
//! it. The template is YAML whose
//! every string is double-quoted with JSON escapes (so it is JSON-safe text too).
//!
//! Quoting: each task runs `/bin/sh -c 'cd "$1" && shift && exec "$@"' felt-task FOLDER FELT
//! ARGS...`, so the folder, the paths and the values reach the task as whole arguments and no
//! shell ever parses them. OpenJD itself expands `{{...}}` in every argument and in the job name
//! and has no escape for a literal brace, so a `{` or `}` of a path or value is written as
//! `{{Param.FeltLeftBrace}}` or `{{Param.FeltRightBrace}}`, two hidden job parameters whose only
//! allowed values are the braces themselves (expansion is one pass, so the brace they give is
//! never read again): every name works. An argument cannot hold control characters other than
//! the newline, so a path or value with one (a tab, a carriage return) is refused; the job name
//! is only a label, so its control characters become `?`.

use super::{Job, Word, refusal};
use crate::base::failure::Outcome;

/// The shell line of every task: into the folder, then the command, both given as arguments.
const TASK_SHELL: &str = "cd \"$1\" && shift && exec \"$@\"";

/// The job parameters that stand for a literal brace.
const LEFT_BRACE: &str = "{{Param.FeltLeftBrace}}";
const RIGHT_BRACE: &str = "{{Param.FeltRightBrace}}";

/// OpenJD's longest job name, in characters after expansion.
const MAX_NAME: usize = 128;

/// The template for `job`, or why OpenJD cannot carry it.
pub fn template(job: &Job) -> Outcome<String> {
    for (what, text) in job.texts() {
        if let Some(c) = text.chars().find(|&c| c.is_control() && c != '\n') {
            return Err(refusal(
                &what,
                text,
                &format!(
                    "has the control character {c:?}, which an Open Job Description \
                     argument cannot hold"
                ),
            )
            .with_help("rename it without tabs, carriage returns or other control characters"));
        }
    }
    let mut text = Literal::default();
    let name: String = format!("felt {}", job.name())
        .chars()
        .map(|c| if c.is_control() { '?' } else { c })
        .take(MAX_NAME)
        .collect();
    let name = text.format(&name);
    let mut steps = String::new();
    let mut render_after = None;
    if let (Some(sim), Some(args)) = (&job.sim, job.sim_args()) {
        let simulate = command(&mut text, &sim.folder, &args);
        step(&mut steps, "simulate", None, None, &simulate);
        render_after = Some("simulate");
    }
    let render = command(&mut text, &job.folder, &job.run_args());
    let space = Space {
        frames: job.frames_text(),
        tiles: job.tiles,
    };
    step(&mut steps, "render", render_after, Some(&space), &render);
    if job.tiles.is_some() {
        let merge = command(&mut text, &job.folder, &job.merge_args());
        let space = Space {
            frames: job.frames_text(),
            tiles: None,
        };
        step(&mut steps, "merge", Some("render"), Some(&space), &merge);
    }
    let mut yaml = String::new();
    yaml.push_str("specificationVersion: \"jobtemplate-2023-09\"\n");
    yaml.push_str(&format!("name: {}\n", quoted(&name)));
    if text.braces {
        yaml.push_str("parameterDefinitions:\n");
        for (param, brace, side) in [
            ("FeltLeftBrace", "{", "left"),
            ("FeltRightBrace", "}", "right"),
        ] {
            yaml.push_str(&format!(
                "  - name: {}\n    type: \"STRING\"\n    description: {}\n    default: {}\n    \
                 allowedValues: [{}]\n    userInterface:\n      control: \"HIDDEN\"\n",
                quoted(param),
                quoted(&format!(
                    "Stands for a {side} brace in a path or value; leave as is."
                )),
                quoted(brace),
                quoted(brace),
            ));
        }
    }
    yaml.push_str("steps:\n");
    yaml.push_str(&steps);
    Ok(yaml)
}

/// Text written into format strings, remembering whether a brace had to be given by the
/// brace parameters.
#[derive(Default)]
struct Literal {
    braces: bool,
}

impl Literal {
    /// `text` as a format string that OpenJD expands back to `text`.
    fn format(&mut self, text: &str) -> String {
        let mut out = String::with_capacity(text.len());
        for c in text.chars() {
            match c {
                '{' => out.push_str(LEFT_BRACE),
                '}' => out.push_str(RIGHT_BRACE),
                c => out.push(c),
            }
        }
        self.braces |= out.len() != text.len();
        out
    }
}

/// The arguments of `/bin/sh` for a task running `args` in `folder`.
fn command(text: &mut Literal, folder: &str, args: &[Word]) -> Vec<String> {
    let mut argv = vec![
        "-c".to_string(),
        TASK_SHELL.to_string(),
        "felt-task".to_string(),
        text.format(folder),
    ];
    argv.extend(args.iter().map(|word| match word {
        Word::Text(t) => text.format(t),
        Word::Frame => "{{Task.Param.Frame}}".to_string(),
        Word::Band { count } => format!("{{{{Task.Param.Tile}}}}/{count}"),
    }));
    argv
}

/// A step's tasks: the frames, each crossed with the bands when there are some.
struct Space {
    frames: String,
    tiles: Option<usize>,
}

/// A step running `args`; without a parameter space it is a single task.
fn step(
    yaml: &mut String,
    name: &str,
    after: Option<&str>,
    space: Option<&Space>,
    args: &[String],
) {
    yaml.push_str(&format!("  - name: {}\n", quoted(name)));
    if let Some(after) = after {
        yaml.push_str("    dependencies:\n");
        yaml.push_str(&format!("      - dependsOn: {}\n", quoted(after)));
    }
    if let Some(space) = space {
        yaml.push_str("    parameterSpace:\n      taskParameterDefinitions:\n");
        parameter(yaml, "Frame", &space.frames);
        if let Some(count) = space.tiles {
            parameter(yaml, "Tile", &format!("0-{}", count - 1));
            yaml.push_str("      combination: \"Frame * Tile\"\n");
        }
    }
    yaml.push_str("    script:\n      actions:\n        onRun:\n");
    yaml.push_str("          command: \"/bin/sh\"\n");
    let args: Vec<String> = args.iter().map(|a| quoted(a)).collect();
    yaml.push_str(&format!("          args: [{}]\n", args.join(", ")));
}

fn parameter(yaml: &mut String, name: &str, range: &str) {
    yaml.push_str(&format!(
        "        - name: {}\n          type: \"INT\"\n          range: {}\n",
        quoted(name),
        quoted(range)
    ));
}

/// A double-quoted YAML (and JSON) string.
fn quoted(text: &str) -> String {
    let mut out = String::from("\"");
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(tiles: Option<usize>) -> Job {
        Job {
            felt: "/opt/felt/bin/felt".into(),
            script: "/shows/a b/scene.felt".into(),
            folder: "/shows/a b".into(),
            frames: "1-240:2".parse().unwrap(),
            tiles,
            set: vec![("res".into(), "64".into())],
            images: vec!["out/cloud.####.exr".into()],
            sim: None,
        }
    }

    #[test]
    fn one_task_per_frame_in_the_scripts_folder() {
        let yaml = template(&job(None)).unwrap();
        assert!(yaml.contains("range: \"1-240:2\""), "{yaml}");
        assert!(!yaml.contains("Tile") && !yaml.contains("merge"), "{yaml}");
        assert!(!yaml.contains("parameterDefinitions"), "{yaml}");
        assert!(
            yaml.contains(
                r#"args: ["-c", "cd \"$1\" && shift && exec \"$@\"", "felt-task", "/shows/a b", "/opt/felt/bin/felt", "run", "/shows/a b/scene.felt", "--frames", "{{Task.Param.Frame}}", "--set", "res=64"]"#
            ),
            "{yaml}"
        );
    }

    #[test]
    fn bands_cross_frames_with_tiles_and_merge_after() {
        let yaml = template(&job(Some(4))).unwrap();
        assert!(yaml.contains("range: \"0-3\"") && yaml.contains("\"Frame * Tile\""));
        assert!(
            yaml.contains("\"--tile\", \"{{Task.Param.Tile}}/4\""),
            "{yaml}"
        );
        assert!(yaml.contains("dependsOn: \"render\""), "{yaml}");
        assert!(
            yaml.contains(
                r#""merge", "--frames", "{{Task.Param.Frame}}", "--tiles", "4", "--", "out/cloud.####.exr"]"#
            ),
            "{yaml}"
        );
    }

    #[test]
    fn a_simulation_is_one_task_the_render_step_waits_for() {
        let mut simulated = job(Some(2));
        simulated.sim = Some(crate::app::farm::Simulation {
            script: "/shows/sim/smoke.felt".into(),
            folder: "/shows/sim".into(),
            set: vec![("res".into(), "96".into())],
        });
        let yaml = template(&simulated).unwrap();
        let (sim, rest) = yaml.split_once("  - name: \"render\"").unwrap();
        assert!(sim.contains("  - name: \"simulate\"\n"), "{yaml}");
        assert!(!sim.contains("parameterSpace"), "one task: {yaml}");
        assert!(
            sim.contains(
                r#"args: ["-c", "cd \"$1\" && shift && exec \"$@\"", "felt-task", "/shows/sim", "/opt/felt/bin/felt", "run", "/shows/sim/smoke.felt", "--frames", "1-239", "--set", "res=96"]"#
            ),
            "{yaml}"
        );
        assert!(
            rest.starts_with("\n    dependencies:\n      - dependsOn: \"simulate\"\n"),
            "{yaml}"
        );
        assert!(rest.contains("dependsOn: \"render\""), "{yaml}");
    }

    #[test]
    fn braces_come_from_the_brace_parameters_and_control_characters_are_refused() {
        let mut braced = job(None);
        braced.set = vec![("title".into(), "{{Task.Param.Frame}}}".into())];
        let yaml = template(&braced).unwrap();
        assert!(
            yaml.contains(
                "\"title={{Param.FeltLeftBrace}}{{Param.FeltLeftBrace}}Task.Param.Frame\
                 {{Param.FeltRightBrace}}{{Param.FeltRightBrace}}{{Param.FeltRightBrace}}\""
            ),
            "{yaml}"
        );
        assert!(yaml.contains("allowedValues: [\"{\"]"), "{yaml}");
        let mut tabbed = job(None);
        tabbed.images = vec!["a\tb.exr".into()];
        let refused = template(&tabbed).unwrap_err();
        assert!(refused.message.contains("--image"), "{}", refused.message);
    }
}
