//! Slurm job arrays: a render script whose array tasks are the frames (or frames × bands), a
//! merge script with one task per frame, and a submit script that chains them.
//!
//! The one key decision: array indices run from 0 and the script maps them to frames through a
//! list it carries (`FRAMES=(1 3 5 ...)`), so any range felt accepts, steps and comma lists
//! included, becomes one array; with `N` bands task `i` renders frame `FRAMES[i / N]`, band
//! `i % N`. The merge array waits for the whole render array (`--dependency=afterok:JOB`), so
//! `sbatch` alone never merges too early: submit with the submit script. Slurm's `MaxArraySize`
//! (1001 by default) bounds frames × bands per job.

use super::{Job, shell_quote};

/// The scripts for `job`: the render array, and with bands the merge array.
pub struct Scripts {
    pub render: String,
    pub merge: Option<String>,
}

/// The scripts for `job`.
pub fn scripts(job: &Job) -> Scripts {
    let bands = job.tiles.unwrap_or(1);
    let frames = &job.frames.frames;
    let tile = job.tiles.map(|_| "$tile");
    let render = array_script(
        job,
        "render",
        frames.len() * bands,
        &format!(
            "frame=${{FRAMES[SLURM_ARRAY_TASK_ID / {bands}]}}\ntile=$((SLURM_ARRAY_TASK_ID % {bands}))\n"
        ),
        &job.run_args("$frame", tile),
    );
    let merge = job.tiles.map(|_| {
        array_script(
            job,
            "merge",
            frames.len(),
            "frame=${FRAMES[SLURM_ARRAY_TASK_ID]}\n",
            &job.merge_args("$frame"),
        )
    });
    Scripts { render, merge }
}

/// The submit script: `sbatch` the render array, then the merge array after it.
pub fn submit(render: &str, merge: Option<&str>) -> String {
    let mut text = String::from("#!/bin/sh\n# Submits the felt job; prints the job ids.\nset -e\n");
    text.push_str(&format!(
        "render=$(sbatch --parsable \"$@\" {})\necho \"render job $render\"\n",
        shell_quote(render)
    ));
    if let Some(merge) = merge {
        text.push_str(&format!(
            "merge=$(sbatch --parsable --dependency=afterok:\"${{render%%;*}}\" \"$@\" {})\n\
             echo \"merge job $merge\"\n",
            shell_quote(merge)
        ));
    }
    text
}

fn array_script(job: &Job, what: &str, tasks: usize, mapping: &str, args: &[String]) -> String {
    let frames: Vec<String> = job.frames.frames.iter().map(|f| f.to_string()).collect();
    let words: Vec<String> = args
        .iter()
        .map(|a| {
            if a.starts_with('$') {
                format!("\"{a}\"")
            } else if a.contains('$') {
                // `--tile $tile/N`: the variable expands, the rest is plain.
                format!("\"{}\"", a.replace('"', "\\\""))
            } else {
                shell_quote(a)
            }
        })
        .collect();
    let folder = shell_quote(&job.folder.display().to_string());
    format!(
        "#!/bin/bash\n\
         #SBATCH --job-name={name}-{what}\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --chdir={folder}\n\
         # felt {what}: {tasks} tasks over frames {range}{bands}.\n\
         set -euo pipefail\n\
         FRAMES=({list})\n\
         {mapping}\
         cd {folder}\n\
         exec {command}\n",
        name = job.name(),
        last = tasks - 1,
        range = job.frames.text,
        bands = job
            .tiles
            .map_or(String::new(), |n| format!(", {n} bands each")),
        list = frames.join(" "),
        command = words.join(" "),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn job(tiles: Option<usize>) -> Job {
        Job {
            felt: PathBuf::from("/opt/felt/bin/felt"),
            script: PathBuf::from("/shows/scene.felt"),
            folder: PathBuf::from("/shows"),
            frames: "1-5:2,10".parse().unwrap(),
            tiles,
            set: Vec::new(),
            images: vec!["out/c.####.exr".into()],
        }
    }

    #[test]
    fn the_array_maps_task_ids_to_frames_and_bands() {
        let s = scripts(&job(Some(2)));
        assert!(s.render.contains("#SBATCH --array=0-7\n"), "{}", s.render);
        assert!(s.render.contains("FRAMES=(1 3 5 10)\n"));
        assert!(
            s.render
                .contains("frame=${FRAMES[SLURM_ARRAY_TASK_ID / 2]}\n")
        );
        assert!(s.render.contains("tile=$((SLURM_ARRAY_TASK_ID % 2))\n"));
        assert!(
            s.render.contains(
                "exec /opt/felt/bin/felt run /shows/scene.felt --frames \"$frame\" --tile \"$tile/2\"\n"
            ),
            "{}",
            s.render
        );
        let merge = s.merge.unwrap();
        assert!(merge.contains("#SBATCH --array=0-3\n"), "{merge}");
        assert!(merge.contains("merge --frames \"$frame\" --tiles 2 'out/c.####.exr'"));
        let submit = submit("r.sh", Some("m.sh"));
        assert!(submit.contains("--dependency=afterok:"), "{submit}");
    }

    #[test]
    fn without_bands_there_is_one_task_per_frame_and_no_merge() {
        let s = scripts(&job(None));
        assert!(s.render.contains("#SBATCH --array=0-3\n"));
        assert!(s.merge.is_none());
        assert!(!s.render.contains("--tile"));
    }
}
