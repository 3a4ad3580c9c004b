//! Open Job Description templates (`specificationVersion: jobtemplate-2023-09`), the format
//! AWS Deadline Cloud and OpenCue's tools read and `openjd-cli` checks and runs locally.
//!
//! The one key decision: the frame range is handed to the engine as it was written, as the
//! `Frame` task parameter's range expression (felt's range syntax is OpenJD's), so the engine,
//! not felt, expands it into tasks; with bands a `Tile` parameter is crossed with it and a
//! `merge` step depending on the render step has one task per frame. Each task runs through
//! `/bin/sh -c 'cd FOLDER && exec felt ...'` so it starts in the script's folder. The template
//! is YAML whose every string is double-quoted with JSON escapes (so it is JSON-safe text too).

use super::{Job, shell_quote};

/// The template for `job`.
pub fn template(job: &Job) -> String {
    let mut yaml = String::new();
    yaml.push_str("specificationVersion: \"jobtemplate-2023-09\"\n");
    yaml.push_str(&format!(
        "name: {}\n",
        quoted(&format!("felt {}", job.name()))
    ));
    yaml.push_str("steps:\n");
    let frame = "{{Task.Param.Frame}}";
    let tile = job.tiles.map(|_| "{{Task.Param.Tile}}");
    step(
        &mut yaml,
        "render",
        None,
        &job.frames.text,
        job.tiles,
        &command_line(job, &job.run_args(frame, tile)),
    );
    if job.tiles.is_some() {
        step(
            &mut yaml,
            "merge",
            Some("render"),
            &job.frames.text,
            None,
            &command_line(job, &job.merge_args(frame)),
        );
    }
    yaml
}

/// `cd FOLDER && exec ARGS...`, with the engine's `{{...}}` placeholders left for it to fill.
fn command_line(job: &Job, args: &[String]) -> String {
    let words: Vec<String> = args
        .iter()
        .map(|a| {
            if a.contains("{{") {
                a.clone()
            } else {
                shell_quote(a)
            }
        })
        .collect();
    format!(
        "cd {} && exec {}",
        shell_quote(&job.folder.display().to_string()),
        words.join(" ")
    )
}

fn step(
    yaml: &mut String,
    name: &str,
    after: Option<&str>,
    frames: &str,
    tiles: Option<usize>,
    command: &str,
) {
    yaml.push_str(&format!("  - name: {}\n", quoted(name)));
    if let Some(after) = after {
        yaml.push_str("    dependencies:\n");
        yaml.push_str(&format!("      - dependsOn: {}\n", quoted(after)));
    }
    yaml.push_str("    parameterSpace:\n      taskParameterDefinitions:\n");
    parameter(yaml, "Frame", frames);
    if let Some(count) = tiles {
        parameter(yaml, "Tile", &format!("0-{}", count - 1));
        yaml.push_str("      combination: \"Frame * Tile\"\n");
    }
    yaml.push_str("    script:\n      actions:\n        onRun:\n");
    yaml.push_str("          command: \"/bin/sh\"\n");
    yaml.push_str(&format!("          args: [\"-c\", {}]\n", quoted(command)));
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
    use std::path::PathBuf;

    fn job(tiles: Option<usize>) -> Job {
        Job {
            felt: PathBuf::from("/opt/felt/bin/felt"),
            script: PathBuf::from("/shows/a b/scene.felt"),
            folder: PathBuf::from("/shows/a b"),
            frames: "1-240:2".parse().unwrap(),
            tiles,
            set: vec![("res".into(), "64".into())],
            images: vec!["out/cloud.####.exr".into()],
        }
    }

    #[test]
    fn one_task_per_frame_in_the_scripts_folder() {
        let yaml = template(&job(None));
        assert!(yaml.contains("range: \"1-240:2\""), "{yaml}");
        assert!(!yaml.contains("Tile") && !yaml.contains("merge"), "{yaml}");
        assert!(
            yaml.contains(
                r#"args: ["-c", "cd '/shows/a b' && exec /opt/felt/bin/felt run '/shows/a b/scene.felt' --frames {{Task.Param.Frame}} --set res=64"]"#
            ),
            "{yaml}"
        );
    }

    #[test]
    fn bands_cross_frames_with_tiles_and_merge_after() {
        let yaml = template(&job(Some(4)));
        assert!(yaml.contains("range: \"0-3\"") && yaml.contains("\"Frame * Tile\""));
        assert!(yaml.contains("--tile {{Task.Param.Tile}}/4"), "{yaml}");
        assert!(yaml.contains("dependsOn: \"render\""), "{yaml}");
        assert!(
            yaml.contains("merge --frames {{Task.Param.Frame}} --tiles 4 'out/cloud.####.exr'"),
            "{yaml}"
        );
    }
}
