//! `felt merge` and `felt farm`: assembling bands into images, and writing the job files a
//! render farm runs (Open Job Description templates, Slurm array scripts).

use crate::cli::FarmEngine;
use crate::frame_param;
use crate::report;
use felt::session::Session;
use felt::syntax::diagnostic::{Diagnostic, Stage};
use std::path::PathBuf;
use std::process::ExitCode;

pub fn print_failure(failure: &felt::base::failure::Failure) {
    eprintln!("felt: {}", failure.message);
    if let Some(help) = &failure.help {
        eprintln!("  help: {help}");
    }
}

/// `felt merge`: every image of every frame; a failure is reported and the rest go on.
pub fn merge(
    images: &[String],
    frames: Option<&felt::io::frames::FrameRange>,
    tiles: Option<usize>,
    output_dir: Option<&std::path::Path>,
) -> ExitCode {
    if let Some(dir) = output_dir
        && let Err(e) = felt::engine::output::set_directory(dir)
    {
        eprintln!("felt: --output-dir: {e}");
        return ExitCode::from(2);
    }
    let mut paths = Vec::new();
    for image in images {
        match frames {
            None => paths.push(image.clone()),
            Some(range) => {
                if !felt::io::frames::has_pattern(image) {
                    eprintln!("felt: merge: '{image}' names no frame, but --frames was given");
                    eprintln!("  help: write the frame as the script does: name.####.exr");
                    return ExitCode::from(2);
                }
                paths.extend(
                    range
                        .frames
                        .iter()
                        .filter_map(|&f| felt::io::frames::fill(image, f)),
                );
            }
        }
    }
    let mut failed = 0;
    for path in &paths {
        if let Err(failure) = felt::app::farm::merge::merge(std::path::Path::new(path), tiles) {
            print_failure(&failure);
            failed += 1;
        }
    }
    if failed > 0 {
        eprintln!("felt: {failed} of {} images not assembled", paths.len());
    }
    ExitCode::from(u8::from(failed > 0))
}

/// `felt farm openjd|slurm`: checks the script, then writes the job files.
pub fn farm(engine: FarmEngine, color: bool) -> ExitCode {
    let (openjd, args) = match engine {
        FarmEngine::Openjd(args) => (true, args),
        FarmEngine::Slurm(args) => (false, args),
    };
    // Both scripts are checked before any job file is written.
    let (session, units) = match checked(&args.file, &args.set, color) {
        Ok(checked) => checked,
        Err(code) => return code,
    };
    if let Some(sim) = &args.sim
        && let Err(code) = checked(sim, &args.sim_set, color)
    {
        return code;
    }
    let felt_binary = match std::env::current_exe() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("felt: cannot find the felt binary the tasks should run: {e}");
            return ExitCode::from(2);
        }
    };
    let programs: Vec<&felt::syntax::ast::Program> = units.iter().map(|u| &u.program).collect();
    let refused = |failure: felt::base::failure::Failure| {
        let diagnostic =
            Diagnostic::bare(Stage::Usage, failure.message).with_help_opt(failure.help);
        report(&session.sources.borrow(), &[diagnostic], color, 2)
    };
    let job = match felt::app::farm::Job::new(
        &felt_binary,
        &args.file,
        &programs,
        args.frames,
        args.tiles.map(usize::from),
        args.set,
        args.images,
    )
    .and_then(|job| match &args.sim {
        Some(sim) => job.with_sim(sim, args.sim_set),
        None => Ok(job),
    }) {
        Ok(job) => job,
        Err(failure) => return refused(failure),
    };
    let stem = args
        .file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| String::from("felt"));
    // The job files are made whole before any is written, so a refused job writes nothing.
    let written = if openjd {
        let template = match felt::app::farm::openjd::template(&job) {
            Ok(template) => template,
            Err(failure) => return refused(failure),
        };
        let out = args
            .out
            .unwrap_or_else(|| PathBuf::from(format!("{stem}.openjd.yaml")));
        write_job_file(&out, &template, false).map(|()| vec![out])
    } else {
        let scripts = match felt::app::farm::slurm::scripts(&job) {
            Ok(scripts) => scripts,
            Err(failure) => return refused(failure),
        };
        let out = args
            .out
            .unwrap_or_else(|| PathBuf::from(format!("{stem}.slurm.sh")));
        write_slurm(&out, &scripts)
    };
    match written {
        Ok(files) => {
            for file in files {
                println!("wrote {}", file.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("felt: {e}");
            ExitCode::from(1)
        }
    }
}

/// `file` loaded and checked, with its `--frames` param and the `set` values it is given.
fn checked(
    file: &std::path::Path,
    set: &[(String, String)],
    color: bool,
) -> Result<(Session, Vec<felt::session::Unit>), ExitCode> {
    frame_param(file, set)?;
    let mut session = match Session::new(Box::new(std::io::sink())) {
        Ok(s) => s,
        Err(failure) => return Err(report(&failure.sources, &failure.diagnostics, color, 1)),
    };
    let units = match session.load(file) {
        Ok(units) => units,
        Err(diags) => return Err(report(&session.sources.borrow(), &diags, color, 2)),
    };
    let diags = session.check(&units);
    if diags.iter().any(|d| d.is_error()) {
        return Err(report(&session.sources.borrow(), &diags, color, 1));
    }
    session.interp.overrides = set.iter().cloned().collect();
    if let Err(d) = session.check_overrides(&units) {
        return Err(report(&session.sources.borrow(), &[d], color, 2));
    }
    Ok((session, units))
}

/// The Slurm scripts: OUT (the render array), with bands OUT's `.merge.sh`, with a simulation
/// its `.sim.sh`, and the `.submit.sh` sibling, written in every case.
fn write_slurm(
    out: &std::path::Path,
    scripts: &felt::app::farm::slurm::Scripts,
) -> Result<Vec<PathBuf>, String> {
    let name = out.to_string_lossy();
    let stem = name.strip_suffix(".sh").unwrap_or(&name);
    // The submit script names the others exactly, so their paths must be text.
    let absolute = |p: &std::path::Path| {
        std::path::absolute(p)
            .map_err(|e| format!("cannot resolve '{}': {e}", p.display()))?
            .into_os_string()
            .into_string()
            .map_err(|p| {
                let p = p.to_string_lossy();
                format!("'{p}' is not valid UTF-8, so the submit script cannot name it")
            })
    };
    let mut files = Vec::new();
    let sim = match &scripts.sim {
        Some(text) => {
            let path = PathBuf::from(format!("{stem}.sim.sh"));
            write_job_file(&path, text, true)?;
            files.push(path.clone());
            Some(absolute(&path)?)
        }
        None => None,
    };
    files.push(out.to_path_buf());
    write_job_file(out, &scripts.render, true)?;
    let merge = match &scripts.merge {
        Some(text) => {
            let path = PathBuf::from(format!("{stem}.merge.sh"));
            write_job_file(&path, text, true)?;
            files.push(path.clone());
            Some(absolute(&path)?)
        }
        None => None,
    };
    let submit = PathBuf::from(format!("{stem}.submit.sh"));
    let text = felt::app::farm::slurm::submit(sim.as_deref(), &absolute(out)?, merge.as_deref());
    write_job_file(&submit, &text, true)?;
    files.push(submit);
    Ok(files)
}

fn write_job_file(path: &std::path::Path, text: &str, executable: bool) -> Result<(), String> {
    use std::io::Write;
    felt::io::output::write_atomically(path, |file| {
        file.write_all(text.as_bytes()).map_err(|e| e.to_string())?;
        #[cfg(unix)]
        if executable {
            use std::os::unix::fs::PermissionsExt;
            let mode = file
                .metadata()
                .map_err(|e| e.to_string())?
                .permissions()
                .mode();
            file.set_permissions(std::fs::Permissions::from_mode(mode | (mode & 0o444) >> 2))
                .map_err(|e| e.to_string())?;
        }
        Ok(())
    })
    .map_err(|e| format!("cannot write '{}': {e}", path.display()))
}
