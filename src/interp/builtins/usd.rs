//! `usdvolume` (docs/language.md, "USD volumes"): a USD layer naming the VDB files a script
//! caches, frame by frame, as one `Volume` prim a scene can reference.
//!
//! The layer describes the whole sequence, not one frame: its name takes no frame pattern, and
//! every frame of a `--frames` run writes the same text (atomically), so it does not matter
//! which frame writes it last. The VDB paths are resolved as `cachesave` resolves them, then
//! written relative to the layer's folder (`./...`, which USD anchors to the layer) when they
//! lie under it, so the layer and its caches move together; otherwise absolute. USD reads a
//! `\` in the layer's own folder as a `/` when it anchors a relative path (it does not in the
//! path itself), so under such a folder every path is written absolute.

use crate::base::failure::{Failure, Outcome};
use crate::interp::Interpreter;
use crate::interp::registry::{Args, Registry};
use crate::interp::value::Value;
use crate::io::frames::FrameRange;
use crate::io::usd::{self, DataType, Grid, Layer};
use std::path::{Path, PathBuf};

pub fn register(r: &mut Registry) {
    r.add(
        "caches",
        &["usdvolume(string path, string[] grids, domain bounds, string frames?, float fps?, string up?, string[] vectors?, float meters_per_unit?) -> void"],
        "writes a USD layer (.usda) with a Volume prim over bounds whose fields are the VDB \
         grids named \"NAME=FILE\" in grids (FILE with a frame pattern: one file per frame of \
         frames, \"1-48\"); vectors lists the grids that are vector grids (the others are float \
         fog volumes); fps sets timeCodesPerSecond (default 24), up the up axis \"Y\" (default) \
         or \"Z\", meters_per_unit the metres in a unit of the scene (default 1)",
        usdvolume,
    );
    r.choices("usdvolume", "up", "up axis", &["Y", "Z"]);
}

fn usdvolume(interp: &mut Interpreter, a: Args) -> Outcome<Value> {
    let layer_path = layer_path(interp, a.string("path")?)?;
    let Value::Domain(bounds) = a.get("bounds")? else {
        return Err(Failure::new("usdvolume needs a domain for its bounds"));
    };
    let frames = match a.opt("frames") {
        Some(v) => Some(
            v.as_str()?
                .parse::<FrameRange>()
                .map_err(|e| Failure::new(format!("usdvolume frames: {e}")))?,
        ),
        None => None,
    };
    let fps = a.opt_positive_float("fps")?.unwrap_or(24.0);
    let meters_per_unit = a.opt_positive_float("meters_per_unit")?.unwrap_or(1.0);
    let up = match a.opt("up") {
        None => "Y",
        Some(v) => match v.as_str()? {
            "Y" => "Y",
            "Z" => "Z",
            other => {
                return Err(Failure::new(format!(
                    "usdvolume up must be \"Y\" or \"Z\", found \"{other}\""
                )));
            }
        },
    };
    let vectors: Vec<String> = match a.opt("vectors") {
        Some(v) => v
            .as_array()?
            .iter()
            .map(|s| s.as_str().map(str::to_string))
            .collect::<Result<_, _>>()?,
        None => Vec::new(),
    };
    let folder = layer_path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let mut grids = Vec::new();
    for entry in a.get("grids")?.as_array()?.iter() {
        let entry = entry.as_str()?;
        let Some((name, file)) = entry
            .split_once('=')
            .filter(|(n, f)| !n.is_empty() && !f.is_empty())
        else {
            return Err(
                Failure::new(format!("usdvolume grid \"{entry}\" is not NAME=FILE"))
                    .with_help("name each grid and its VDB files: \"density=smoke.####.vdb\""),
            );
        };
        let files = match (crate::io::frames::has_pattern(file), &frames) {
            (false, _) => vec![(None, asset_text(interp, file, &folder)?)],
            (true, None) => {
                return Err(Failure::new(format!(
                    "usdvolume grid \"{entry}\" has a frame pattern but no frames were given"
                ))
                .with_help("give the frames the files cover: frames = \"1-48\""));
            }
            (true, Some(range)) => {
                let mut files = Vec::with_capacity(range.frames.len());
                for &frame in &range.frames {
                    let filled =
                        crate::io::frames::fill(file, frame).unwrap_or_else(|| file.to_string());
                    files.push((Some(frame), asset_text(interp, &filled, &folder)?));
                }
                files
            }
        };
        grids.push(Grid {
            name: name.to_string(),
            data: if vectors.iter().any(|v| v == name) {
                DataType::Vector3f
            } else {
                DataType::Float
            },
            files,
        });
    }
    if grids.is_empty() {
        return Err(Failure::new("usdvolume needs at least one grid"));
    }
    if let Some(unknown) = vectors
        .iter()
        .find(|v| !grids.iter().any(|g| &g.name == *v))
    {
        return Err(Failure::new(format!(
            "usdvolume vectors names \"{unknown}\", which is not one of its grids"
        )));
    }
    let aabb = bounds.bounds();
    let prim = layer_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "volume".to_string());
    let layer = Layer {
        prim,
        grids,
        frames: frames
            .as_ref()
            .and_then(|r| Some((*r.frames.iter().min()?, *r.frames.iter().max()?))),
        frames_per_second: fps,
        up,
        meters_per_unit,
        extent: (aabb.min, aabb.max),
    };
    let text = usd::text(&layer).map_err(Failure::new)?;
    crate::io::output::write_atomically(&layer_path, |file| {
        use std::io::Write;
        file.write_all(text.as_bytes()).map_err(|e| e.to_string())
    })
    .map_err(|e| {
        Failure::new(format!(
            "cannot write USD layer '{}': {e}",
            layer_path.display()
        ))
    })?;
    Ok(Value::Void)
}

/// Where the layer lands: as any output, but one file for the whole sequence.
fn layer_path(interp: &Interpreter, text: &str) -> Outcome<PathBuf> {
    if crate::io::frames::has_pattern(text) {
        return Err(Failure::new(format!(
            "the USD layer '{text}' has a frame pattern, but one layer holds every frame"
        ))
        .with_help("name it without a frame: \"smoke.usda\"; the frames go in its grids"));
    }
    resolve(interp, text)
}

/// A relative path as `cachesave` lands it: under `--output-dir`, else beside the script.
fn resolve(interp: &Interpreter, text: &str) -> Outcome<PathBuf> {
    let path = PathBuf::from(crate::interp::paths::expand(text)?);
    if path.is_absolute() {
        return Ok(path);
    }
    Ok(
        match (crate::engine::output::directory(), interp.files.base()) {
            (Some(directory), _) => directory.join(&path),
            (None, Some(base)) => base.join(&path),
            (None, None) => path,
        },
    )
}

/// The VDB file `text` as the layer in `folder` names it: `./` and the path below the folder,
/// or the whole path.
fn asset_text(interp: &Interpreter, text: &str, folder: &Path) -> Outcome<String> {
    let path = resolve(interp, text)?;
    let anchorable = !folder.as_os_str().is_empty() && !folder.to_string_lossy().contains('\\');
    let shown = match path.strip_prefix(folder) {
        Ok(below) if anchorable => Path::new(".").join(below),
        _ => path.clone(),
    };
    shown.into_os_string().into_string().map_err(|raw| {
        Failure::new(format!(
            "the VDB path '{}' is not valid UTF-8, so a USD layer cannot name it",
            raw.to_string_lossy()
        ))
    })
}
