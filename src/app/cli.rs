//! The `felt` command line: every subcommand and option as clap reads them, with the long
//! help texts of the commands whose use needs an example.

use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// Most worker threads `--threads` accepts: far more than any machine felt runs on has cores,
/// and few enough that asking for them cannot exhaust the process's thread limit by itself.
pub const MAX_THREADS: u16 = 1024;

#[derive(Parser)]
#[command(
    name = "felt",
    version,
    about = "A field expression language for volumetric effects"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(clap::Args)]
pub struct FarmArgs {
    /// The script each task runs.
    pub file: PathBuf,
    /// The frames, one task each: `1-240`, `1-240:2`, `12` or a comma list.
    #[arg(long, value_name = "RANGE")]
    pub frames: felt::io::frames::FrameRange,
    /// Split each frame into N bands, one task each, merged by a dependent step.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=4096))]
    pub tiles: Option<u16>,
    /// Override a `param` declaration in every task: `--set name=value` (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_assignment)]
    pub set: Vec<(String, String)>,
    /// An image the merge step assembles, as the script names it (repeatable; default: the
    /// paths of the script's render calls).
    #[arg(long = "image", value_name = "PATH")]
    pub images: Vec<String>,
    /// A simulation script run once, over every frame from the range's first to its last in
    /// order, before any render task; the render tasks read the caches it writes.
    #[arg(long, value_name = "SCRIPT")]
    pub sim: Option<PathBuf>,
    /// Override a `param` of the simulation script: `--sim-set name=value` (repeatable).
    #[arg(long = "sim-set", value_name = "NAME=VALUE", value_parser = parse_assignment, requires = "sim")]
    pub sim_set: Vec<(String, String)>,
    /// The file to write (default: SCRIPT.openjd.yaml or SCRIPT.slurm.sh in the current
    /// folder).
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

#[derive(Subcommand)]
pub enum FarmEngine {
    /// An Open Job Description template (jobtemplate-2023-09): one task per frame, or per
    /// frame and band with a dependent merge step. Check it with `openjd check FILE`.
    Openjd(FarmArgs),
    /// A Slurm array script (one task per frame, or per frame and band), and with bands a
    /// merge array and a submit script that runs it after the render (afterok).
    Slurm(FarmArgs),
}

pub const MERGE_ABOUT: &str = "\
Assemble the bands `felt run --tile I/N` wrote into whole images.

Band I of N of the image NAME.exr is NAME.tile-I-of-N.exr (of NAME.png, NAME.png.tile-I-of-N.exr). \
merge reads all N, checks that each is present once, that they are of one image size and \
hold the rows their index says, and writes NAME.exr (or the NAME.png preview) with the same \
channels, samples and header as a render on one machine: bit for bit the same pixels. The \
band files are left in place.

Exit status: 0 when every image was assembled, 1 when a band is missing, duplicated or does \
not fit (the others are still assembled), 2 for bad usage.

Example:
  felt merge renders/cloud.####.exr --frames 1-240 --tiles 4";

#[derive(Subcommand)]
pub enum Command {
    /// Run a script.
    Run {
        /// The script to run.
        file: PathBuf,
        /// Override a `param` declaration: `--set name=value` (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_assignment)]
        set: Vec<(String, String)>,
        /// Worker threads for field evaluation and rendering (default: all cores).
        #[arg(
            long,
            value_name = "N",
            value_parser = clap::value_parser!(u16).range(1..=MAX_THREADS as i64)
        )]
        threads: Option<u16>,
        /// After the run, print each grid that was computed and the grids never needed.
        #[arg(long)]
        profile: bool,
        /// The run's memory budget in megabytes: caches, FFT buffers, images and large
        /// strings and arrays all count (default: half of the memory felt may use).
        #[arg(long, value_name = "MB", value_parser = clap::value_parser!(u64).range(1..))]
        memory_limit: Option<u64>,
        /// Write outputs named by relative paths under DIR (created if missing) instead of
        /// the script's folder; inputs are still read from the script's folder.
        #[arg(long, value_name = "DIR")]
        output_dir: Option<PathBuf>,
        /// Run the script once per frame with its `param int frame` set: `12`, `1-240`,
        /// `1-240:2` (every second frame) or a comma list of those. Output paths must name
        /// their frame (`out.####.exr`, `out.%04d.exr`, `out.$F4.exr`). Each frame of a
        /// range runs in its own process; a failed frame is reported and the rest still run.
        #[arg(long, value_name = "RANGE")]
        frames: Option<felt::io::frames::FrameRange>,
        /// Render only band I of N (from 0, counted from the top) of every image, into
        /// NAME.tile-I-of-N.exr, for `felt merge` to assemble.
        #[arg(long, value_name = "I/N")]
        tile: Option<felt::engine::band::Band>,
    },
    /// Assemble the bands `felt run --tile I/N` wrote into whole images.
    #[command(long_about = MERGE_ABOUT)]
    Merge {
        /// The images to assemble, as the script names them (a frame pattern with --frames).
        #[arg(required = true)]
        images: Vec<String>,
        /// The frames to assemble, as for `felt run --frames`.
        #[arg(long, value_name = "RANGE")]
        frames: Option<felt::io::frames::FrameRange>,
        /// How many bands each image was split into (default: the split found on disk).
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=4096))]
        tiles: Option<u16>,
        /// Where the bands and images are, for images named by relative paths (as `felt run
        /// --output-dir`).
        #[arg(long, value_name = "DIR")]
        output_dir: Option<PathBuf>,
    },
    /// Write a job for a render farm: an Open Job Description template or Slurm array scripts.
    Farm {
        #[command(subcommand)]
        engine: FarmEngine,
    },
    /// Measure what accuracy costs: run a script once per setting of its swept params and
    /// compare each run's outputs with a reference setting's.
    #[command(long_about = STUDY_ABOUT)]
    Study {
        /// The script to study.
        file: PathBuf,
        /// A param and the values to try: `--sweep NAME=v1,v2,...` (repeatable; the study
        /// runs every combination).
        #[arg(long = "sweep", value_name = "NAME=V1,V2,...", value_parser = parse_assignment, required = true)]
        sweeps: Vec<(String, String)>,
        /// The value a param takes in the reference: `--reference NAME=VALUE` (repeatable).
        /// Each setting is compared with itself with these values applied.
        #[arg(long = "reference", value_name = "NAME=VALUE", value_parser = parse_assignment, required = true)]
        reference: Vec<(String, String)>,
        /// Fix a param for every run, reference included: `--set name=value` (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_assignment)]
        set: Vec<(String, String)>,
        /// Run each setting N times and report the medians of its wall and CPU times (one
        /// run's time is noise: a cold file cache or another job can double it).
        #[arg(long, value_name = "N", default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=1000))]
        repeat: u32,
        /// The swept param the Pareto fronts trade (default: the last swept param whose
        /// values are numbers, else the last swept param); one front is drawn per setting of
        /// the other swept params.
        #[arg(long, value_name = "NAME")]
        trade: Option<String>,
        /// The study's folder: runs, the cached references, study.csv and the plots
        /// (default: SCRIPT-study in the current folder).
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Worker threads for each run (default: all cores).
        #[arg(
            long,
            value_name = "N",
            value_parser = clap::value_parser!(u16).range(1..=MAX_THREADS as i64)
        )]
        threads: Option<u16>,
        /// The memory budget of each run, in megabytes, as for `felt run`.
        #[arg(long, value_name = "MB", value_parser = clap::value_parser!(u64).range(1..))]
        memory_limit: Option<u64>,
    },
    /// Check a script for errors without running it.
    Check {
        /// The script to check.
        file: PathBuf,
        /// Check a `param` override as `felt run --set name=value` would take it (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_assignment)]
        set: Vec<(String, String)>,
    },
    /// Start an interactive session.
    Repl {
        /// Worker threads for field evaluation and rendering (default: all cores).
        #[arg(
            long,
            value_name = "N",
            value_parser = clap::value_parser!(u16).range(1..=MAX_THREADS as i64)
        )]
        threads: Option<u16>,
    },
    /// Serve an editor: a Language Server Protocol server on stdin and stdout, giving the
    /// errors `felt check` finds as you type, hover, completion, signature help, go to
    /// definition and document symbols.
    Lsp,
    /// List the builtins and library functions, or describe one.
    Doc {
        /// A builtin or library function.
        name: Option<String>,
    },
}

pub const STUDY_ABOUT: &str = "\
Measure what accuracy costs: run a script once per setting of its swept params and compare \
each run's outputs with a reference setting's.

Every combination of the --sweep values is one setting. Each setting runs as its own \
`felt run` process, with the values passed as --set does and its relative outputs written \
to a folder of its own, and is measured for wall time, CPU time and peak memory. Its \
reference is the same setting with the --reference values applied (a --reference may name a \
param that is not swept, such as a finer resolution for the reference alone). What each run \
wrote and printed is compared with what its reference wrote and printed:

  images (.exr, .png)   RMSE, PSNR and relative MSE of RGBA, and SSIM of the displayed colour
  VDB files (.vdb)      RMSE and largest error over the union of active voxels, per grid; a
                        grid on other voxels (another resolution) is resampled onto the
                        reference's voxels, trilinear in world space, and marked † in the table
  printed numbers       each number's value, absolute and relative error; a line's label is
                        its text without the numbers (print(\"area error\", e) is \"area error\")

A printed line whose label contains \"error\" or \"seconds\" (or \"time\") is a quantity the \
script measured itself, against an exact answer or with clock(): it is shown as it is, not \
compared with the reference's.

Each setting runs --repeat times (3 by default); the table and study.csv give the medians \
of its wall time (seconds) and CPU time (user plus system, all threads), and the count of \
runs.

The study prints a table and writes, into --out: study.csv (one row per setting), \
pareto-MEASURE.svg (each error against seconds on log-log axes, the Pareto front marked: \
one front per setting of the swept params other than the traded one, see --trade), \
MEASURE-vs-PARAM.svg (each error against each swept param) and seconds-vs-PARAM.svg and \
peak-mib-vs-PARAM.svg (the costs). Errors plotted are the RMSEs and largest errors, relative \
errors of printed numbers, and the errors the script printed itself (by their size). A \
setting whose error is exactly 0 is drawn on the floor of the log axis with its own marker \
(\"exact: error 0\" in the legend). Each setting of the other params keeps one colour in \
every plot of a study.

Reference runs are cached in --out/reference, keyed by the text of the script and every file \
it imports, felt's version and the reference's params: running the study again with more \
settings reuses them. A setting whose run fails is reported and the study goes on.

Exit status: 0 when every setting ran and was compared; 1 when the script has errors or a \
run (or the reference) failed; 2 for bad usage: unknown params, values of the wrong type, \
empty sweeps, or settings some of whose outputs cannot be compared with their reference's \
(files only one of them wrote, images of other sizes); the rest of such a setting's outputs \
are still compared and reported.

Example:
  felt study examples/studies/raymarch_step.felt --sweep step=0.04,0.02,0.01 \\
      --reference step=0.0025 --set scene=cloud --out step-study";

pub fn parse_assignment(text: &str) -> Result<(String, String), String> {
    match text.split_once('=') {
        Some((name, value)) if !name.trim().is_empty() => {
            Ok((name.trim().to_string(), value.to_string()))
        }
        _ => Err(format!("expected NAME=VALUE, found `{text}`")),
    }
}
