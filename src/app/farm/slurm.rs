//! Slurm job arrays: a render script whose array tasks are the frames (or frames × bands), a
//! merge script with one task per frame, with a simulation a single-task script that runs
//! before the render array, and a submit script that chains them.
//!
//! The one key decision: array indices run from 0 and the script maps them to frames through a
//! list it carries (`FRAMES=(1 3 5 ...)`), so any range felt accepts, steps and comma lists
//! included, becomes one array; with `N` bands task `i` renders frame `FRAMES[i / N]`, band
//! `i % N`. The merge array waits for the whole render array (`--dependency=afterok:JOB`), so
//! `sbatch` alone never merges too early: submit with the submit script. Likewise the render
//! array waits for the simulation job (`afterok`), so no frame is rendered before its cache. Slurm's `MaxArraySize`
//! (1001 by default) bounds frames × bands per job.
//!
//! Quoting: every path and value in a shell line is one `shell::word`. The `#SBATCH` lines are
//! read by sbatch, not by a shell, with rules of their own (blanks split, `"` and `'` group,
//! `\` escapes, an unquoted `#` ends the line, and `hetjob` or `packjob` anywhere in the line,
//! in any case, starts another component of a heterogeneous job). There the folder is written
//! in double quotes with `\` before `"` and `\`; a folder with a newline (which would end the
//! line and run the rest as a command) or either of those two words is refused. The job name is
//! only a label, so it is made fit instead.

use super::{Job, Word, refusal, shell};
use crate::base::failure::Outcome;

/// The scripts for `job`: the render array, with bands the merge array, and with a
/// simulation its single job.
pub struct Scripts {
    pub sim: Option<String>,
    pub render: String,
    pub merge: Option<String>,
}

/// The scripts for `job`, or why Slurm cannot run it as it stands.
pub fn scripts(job: &Job) -> Outcome<Scripts> {
    let folder = directive_value(&job.folder).map_err(|reason| {
        refusal("the script's folder", &job.folder, reason)
            .with_help("move the script to a folder whose path sbatch can read")
    })?;
    let bands = job.tiles.unwrap_or(1);
    let frames = &job.frames.frames;
    let render = array_script(
        job,
        &folder,
        "render",
        frames.len() * bands,
        &format!(
            "frame=${{FRAMES[SLURM_ARRAY_TASK_ID / {bands}]}}\ntile=$((SLURM_ARRAY_TASK_ID % {bands}))\n"
        ),
        &job.run_args(),
    );
    let merge = job.tiles.map(|_| {
        array_script(
            job,
            &folder,
            "merge",
            frames.len(),
            "frame=${FRAMES[SLURM_ARRAY_TASK_ID]}\n",
            &job.merge_args(),
        )
    });
    let sim = match (&job.sim, job.sim_args()) {
        (Some(sim), Some(args)) => {
            let folder = directive_value(&sim.folder).map_err(|reason| {
                refusal("the simulation script's folder", &sim.folder, reason)
                    .with_help("move the simulation script to a folder whose path sbatch can read")
            })?;
            Some(sim_script(job, &sim.folder, &folder, &args))
        }
        _ => None,
    };
    Ok(Scripts { sim, render, merge })
}

/// The submit script: `sbatch` the simulation, then the render array after it, then the merge
/// array after that.
pub fn submit(sim: Option<&str>, render: &str, merge: Option<&str>) -> String {
    let mut text = String::from("#!/bin/sh\n# Submits the felt job; prints the job ids.\nset -e\n");
    let mut after = String::new();
    if let Some(sim) = sim {
        text.push_str(&format!(
            "sim=$(sbatch --parsable \"$@\" {})\necho \"simulation job $sim\"\n",
            shell::word(sim)
        ));
        after = "--dependency=afterok:\"${sim%%;*}\" ".to_string();
    }
    text.push_str(&format!(
        "render=$(sbatch --parsable {after}\"$@\" {})\necho \"render job $render\"\n",
        shell::word(render)
    ));
    if let Some(merge) = merge {
        text.push_str(&format!(
            "merge=$(sbatch --parsable --dependency=afterok:\"${{render%%;*}}\" \"$@\" {})\n\
             echo \"merge job $merge\"\n",
            shell::word(merge)
        ));
    }
    text
}

/// One argument of the task's command as the script's shell reads it.
fn shell_word(word: &Word) -> String {
    match word {
        Word::Text(text) => shell::word(text),
        Word::Frame => shell::variable("frame"),
        Word::Band { count } => {
            format!(
                "{}{}",
                shell::variable("tile"),
                shell::word(&format!("/{count}"))
            )
        }
    }
}

/// `text` as one value of an `#SBATCH` option, or why it cannot be one.
fn directive_value(text: &str) -> Result<String, &'static str> {
    if text.contains('\n') {
        return Err("has a newline, which an #SBATCH line cannot hold");
    }
    if heterogeneous_word(text).is_some() {
        return Err(
            "names `hetjob` or `packjob`, which sbatch reads as the start of another job \
             component wherever it stands in an #SBATCH line",
        );
    }
    Ok(quoted_directive(text))
}

/// Where `text` names `hetjob` or `packjob` in any case: the byte offset and the word.
fn heterogeneous_word(text: &str) -> Option<(usize, &'static str)> {
    let lower = text.to_ascii_lowercase();
    ["hetjob", "packjob"]
        .into_iter()
        .find_map(|word| lower.find(word).map(|at| (at, word)))
}

/// `text` in double quotes as sbatch reads an `#SBATCH` line, `"` and `\` escaped.
fn quoted_directive(text: &str) -> String {
    format!("\"{}\"", text.replace('\\', "\\\\").replace('"', "\\\""))
}

/// The job's name as a label every `#SBATCH` line can hold: the script's name with control
/// characters as `?` and `hetjob`/`packjob` broken as `het_job`/`pack_job`.
fn label(name: &str) -> String {
    let mut label: String = name
        .chars()
        .map(|c| if c.is_control() { '?' } else { c })
        .collect();
    while let Some((at, word)) = heterogeneous_word(&label) {
        label.insert(at + word.len() - 3, '_');
    }
    label
}

/// The simulation's job: one task, no array, in the simulation script's folder.
fn sim_script(job: &Job, cd: &str, folder: &str, args: &[Word]) -> String {
    let command: Vec<String> = args.iter().map(shell_word).collect();
    format!(
        "#!/bin/bash\n\
         #SBATCH --job-name={name}\n\
         #SBATCH --chdir={folder}\n\
         # felt simulate: frames {frames} in order, in one task.\n\
         set -euo pipefail\n\
         cd {cd}\n\
         exec {command}\n",
        name = quoted_directive(&label(&format!("{}-simulate", job.name()))),
        frames = job.sim_frames(),
        cd = shell::word(cd),
        command = command.join(" "),
    )
}

fn array_script(
    job: &Job,
    folder: &str,
    what: &str,
    tasks: usize,
    mapping: &str,
    args: &[Word],
) -> String {
    let frames: Vec<String> = job.frames.frames.iter().map(|f| f.to_string()).collect();
    let command: Vec<String> = args.iter().map(shell_word).collect();
    format!(
        "#!/bin/bash\n\
         #SBATCH --job-name={name}\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --chdir={folder}\n\
         # felt {what}: {tasks} tasks over frames {range}{bands}.\n\
         set -euo pipefail\n\
         FRAMES=({list})\n\
         {mapping}\
         cd {cd}\n\
         exec {command}\n",
        name = quoted_directive(&label(&format!("{}-{what}", job.name()))),
        last = tasks - 1,
        range = job.frames_text(),
        bands = job
            .tiles
            .map_or(String::new(), |n| format!(", {n} bands each")),
        list = frames.join(" "),
        cd = shell::word(&job.folder),
        command = command.join(" "),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(tiles: Option<usize>) -> Job {
        Job {
            felt: "/opt/felt/bin/felt".into(),
            script: "/shows/scene.felt".into(),
            folder: "/shows".into(),
            frames: "1-5:2,10".parse().unwrap(),
            tiles,
            set: Vec::new(),
            images: vec!["out/c.####.exr".into()],
            sim: None,
        }
    }

    #[test]
    fn the_array_maps_task_ids_to_frames_and_bands() {
        let s = scripts(&job(Some(2))).unwrap();
        assert!(s.render.contains("#SBATCH --array=0-7\n"), "{}", s.render);
        assert!(
            s.render.contains("#SBATCH --chdir=\"/shows\"\n"),
            "{}",
            s.render
        );
        assert!(s.render.contains("FRAMES=(1 3 5 10)\n"));
        assert!(
            s.render
                .contains("frame=${FRAMES[SLURM_ARRAY_TASK_ID / 2]}\n")
        );
        assert!(s.render.contains("tile=$((SLURM_ARRAY_TASK_ID % 2))\n"));
        assert!(
            s.render.contains(
                "exec /opt/felt/bin/felt run /shows/scene.felt --frames \"$frame\" --tile \"$tile\"/2\n"
            ),
            "{}",
            s.render
        );
        let merge = s.merge.unwrap();
        assert!(merge.contains("#SBATCH --array=0-3\n"), "{merge}");
        assert!(merge.contains("merge --frames \"$frame\" --tiles 2 -- 'out/c.####.exr'"));
        let submit = submit(None, "r.sh", Some("m.sh"));
        assert!(submit.contains("--dependency=afterok:"), "{submit}");
        assert!(s.sim.is_none() && !submit.contains("sim="), "{submit}");
    }

    #[test]
    fn the_simulation_is_one_job_the_render_array_waits_for() {
        let mut simulated = job(Some(2));
        simulated.sim = Some(crate::app::farm::Simulation {
            script: "/shows/sim/it's.felt".into(),
            folder: "/shows/sim".into(),
            set: Vec::new(),
        });
        let sim = scripts(&simulated).unwrap().sim.unwrap();
        assert!(!sim.contains("--array"), "{sim}");
        assert!(sim.contains("#SBATCH --chdir=\"/shows/sim\"\n"), "{sim}");
        assert!(
            sim.contains(
                "cd /shows/sim\nexec /opt/felt/bin/felt run '/shows/sim/it'\\''s.felt' --frames 1-10\n"
            ),
            "{sim}"
        );
        let submit = submit(Some("s.sh"), "r.sh", Some("m.sh"));
        let sim_at = submit.find("sim=$(sbatch --parsable \"$@\" s.sh)").unwrap();
        let render_at = submit
            .find("render=$(sbatch --parsable --dependency=afterok:\"${sim%%;*}\" \"$@\" r.sh)")
            .unwrap_or_else(|| panic!("{submit}"));
        assert!(sim_at < render_at);
        let mut hostile = simulated.clone();
        if let Some(sim) = hostile.sim.as_mut() {
            sim.folder = "/shows/packjob".into();
        }
        assert!(scripts(&hostile).is_err());
    }

    #[test]
    fn without_bands_there_is_one_task_per_frame_and_no_merge() {
        let s = scripts(&job(None)).unwrap();
        assert!(s.render.contains("#SBATCH --array=0-3\n"));
        assert!(s.merge.is_none());
        assert!(!s.render.contains("--tile"));
    }

    #[test]
    fn sbatch_lines_hold_the_folder_exactly_or_refuse_it() {
        assert_eq!(
            directive_value(r#"/a "b" \c #d"#).unwrap(),
            r#""/a \"b\" \\c #d""#
        );
        assert!(directive_value("/a\nb").is_err());
        assert!(directive_value("/shows/HetJobs").is_err());
        assert!(directive_value("/shows/packjob").is_err());
        assert_eq!(label("a\tHetJob\npackjob"), "a?Het_Job?pack_job");
    }
}
