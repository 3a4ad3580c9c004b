//! USD layers for volumes: the `.usda` text of a `Volume` prim whose `field:NAME`
//! relationships point at `OpenVDBAsset` prims, each naming its VDB files frame by frame, so a
//! cached simulation drops into a USD scene as one reference.
//!
//! The one key decision: the layer is written as plain `.usda` text by felt itself, no USD
//! library involved, so every value that comes from a script is escaped here for the grammar of
//! Pixar's text format: strings and tokens are double-quoted with `\"`, `\\` and `\n` escapes,
//! an asset path is `@path@`, or `@@@path@@@` when it holds an `@` (with `\@@@` for a `@@@`
//! inside), and prim names are identifiers made from the grid names (other characters become
//! `_`). A path no asset syntax can hold (a newline) is refused rather than written otherwise.

use glam::DVec3;
use std::fmt::Write;

/// What a grid's voxels hold, as `fieldDataType` names it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DataType {
    Float,
    Vector3f,
}

/// One grid of the volume: its name in the VDB files and the file of each frame.
#[derive(Clone, Debug)]
pub struct Grid {
    pub name: String,
    pub data: DataType,
    /// One file for every frame (`frame` is `None`), or one file per frame.
    pub files: Vec<(Option<i64>, String)>,
}

/// The layer: its volume's prim name, grids, frame span, rate, up axis and extent.
#[derive(Clone, Debug)]
pub struct Layer {
    pub prim: String,
    pub grids: Vec<Grid>,
    /// The first and last frame, as `startTimeCode` and `endTimeCode`.
    pub frames: Option<(i64, i64)>,
    pub frames_per_second: f64,
    /// `"Y"` or `"Z"`.
    pub up: &'static str,
    /// How many metres one unit of the scene is.
    pub meters_per_unit: f64,
    /// The world box the volume fills: its min and max corners.
    pub extent: (DVec3, DVec3),
}

/// The `.usda` text of `layer`, or why a path in it cannot be written as a USD asset path.
pub fn text(layer: &Layer) -> Result<String, String> {
    let prim = identifier(&layer.prim);
    let mut names: Vec<String> = Vec::new();
    for grid in &layer.grids {
        let name = identifier(&grid.name);
        if names.contains(&name) {
            return Err(format!(
                "two grids are named `{name}` once made USD names (letters, digits and `_`)"
            ));
        }
        names.push(name);
    }
    let mut out = String::from("#usda 1.0\n(\n");
    let _ = writeln!(out, "    defaultPrim = {}", string(&prim));
    if let Some((start, end)) = layer.frames {
        let _ = writeln!(out, "    endTimeCode = {end}");
        let _ = writeln!(out, "    startTimeCode = {start}");
    }
    let _ = writeln!(out, "    framesPerSecond = {}", layer.frames_per_second);
    let _ = writeln!(out, "    timeCodesPerSecond = {}", layer.frames_per_second);
    let _ = writeln!(out, "    metersPerUnit = {}", layer.meters_per_unit);
    let _ = writeln!(out, "    upAxis = {}", string(layer.up));
    out.push_str(")\n\n");
    let _ = writeln!(out, "def Volume {}\n{{", string(&prim));
    let (min, max) = layer.extent;
    let _ = writeln!(
        out,
        "    float3[] extent = [{}, {}]",
        triple(min),
        triple(max)
    );
    for name in &names {
        let _ = writeln!(out, "    rel field:{name} = </{prim}/{name}>");
    }
    for (grid, name) in layer.grids.iter().zip(&names) {
        let _ = writeln!(out, "\n    def OpenVDBAsset {}\n    {{", string(name));
        match grid.files.as_slice() {
            [(None, file)] => {
                let _ = writeln!(out, "        asset filePath = {}", asset(file)?);
            }
            files => {
                out.push_str("        asset filePath.timeSamples = {\n");
                for (frame, file) in files {
                    let _ = writeln!(out, "            {}: {},", frame.unwrap_or(0), asset(file)?);
                }
                out.push_str("        }\n");
            }
        }
        let _ = writeln!(out, "        token fieldName = {}", string(&grid.name));
        let (data, class) = match grid.data {
            DataType::Float => ("float", Some("fogVolume")),
            DataType::Vector3f => ("vector3f", None),
        };
        let _ = writeln!(out, "        token fieldDataType = {}", string(data));
        if let Some(class) = class {
            let _ = writeln!(out, "        token fieldClass = {}", string(class));
        }
        out.push_str("    }\n");
    }
    out.push_str("}\n");
    Ok(out)
}

/// `text` as a double-quoted USD string (or token) value.
pub fn string(text: &str) -> String {
    let mut out = String::from("\"");
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if (c as u32) < 0x20 || c == '\x7f' => {
                let _ = write!(out, "\\x{:02x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// `path` as a USD asset path: `@path@`, or `@@@path@@@` when it holds an `@`. Neither form
/// can hold a newline, and the single form takes every other character as it is.
pub fn asset(path: &str) -> Result<String, String> {
    if path.contains('\n') || path.contains('\r') {
        return Err(format!(
            "the path {path:?} has a line break, which a USD asset path cannot hold"
        ));
    }
    if !path.contains('@') {
        return Ok(format!("@{path}@"));
    }
    // In the triple form `\@@@` stands for `@@@`, and the path must not end in `@`, which
    // would join the closing delimiter.
    if path.ends_with('@') {
        return Err(format!(
            "the path {path:?} ends with '@', which a USD asset path cannot hold"
        ));
    }
    Ok(format!("@@@{}@@@", path.replace("@@@", "\\@@@")))
}

/// `name` as a USD identifier: letters, digits and `_`, not starting with a digit.
pub fn identifier(name: &str) -> String {
    let mut out: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, '_');
    }
    out
}

fn triple(v: DVec3) -> String {
    format!("({}, {}, {})", v.x as f32, v.y as f32, v.z as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_paths_are_escaped_for_the_usda_grammar() {
        assert_eq!(string(r#"a "b" \c"#), r#""a \"b\" \\c""#);
        assert_eq!(string("two\nlines"), r#""two\nlines""#);
        assert_eq!(asset("/a/b.vdb").unwrap(), "@/a/b.vdb@");
        assert_eq!(asset(r#"/a "q"\b.vdb"#).unwrap(), r#"@/a "q"\b.vdb@"#);
        assert_eq!(asset("/a@b@@@c.vdb").unwrap(), r"@@@/a@b\@@@c.vdb@@@");
        assert!(asset("/a\nb.vdb").is_err());
        assert!(asset("/a/b@").is_err());
        assert_eq!(identifier("density"), "density");
        assert_eq!(identifier("3 temp-K"), "_3_temp_K");
        assert_eq!(identifier(""), "_");
    }
}
