//! Blender's Filmic view, read from the studio's own OpenColorIO configuration.
//!
//! Filmic is defined by two tables, not by a formula: a 65³ cube that desaturates colours as
//! they near the top of Filmic's range (`filmic_desat65cube.spi3d`) and a 4096-entry contrast
//! curve from Filmic's log encoding to the sRGB display (`filmic_to_0-70_1-03.spi1d`, the
//! default "base contrast"). They ship with Blender and with every configuration derived from
//! Filmic Blender, under those configurations' own terms, so felt does not carry them: it reads
//! them from the configuration `$OCIO` names, as every OpenColorIO tool finds its
//! configuration, searching that configuration's `search_path` folders.
//!
//! The key decision is to apply the tables as OpenColorIO does for Blender's "Filmic sRGB"
//! colour space, so that a preview matches Blender's to the byte: each channel `c` goes to
//! `(log2 c + 12.473931188) / 25` (the `lg2` allocation from −12.47 to +12.53 EV), the triple
//! through the cube by tetrahedral interpolation (what OpenColorIO's "best" gives a 3D table),
//! divided by 0.66 (the `uniform` allocation of [0, 0.66]), through the curve by linear
//! interpolation, clamped to each table's domain. The curve's output is sRGB-encoded; felt's
//! PNG writer encodes display-linear values, so the result is decoded once here. Greys at or
//! above 16.3 (log position 0.66) show as white; a bright saturated colour is pushed towards
//! white by the cube before that, as Blender shows it.

use crate::base::failure::{Failure, Outcome};
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

/// The cube's file name in Blender's configuration.
const CUBE: &str = "filmic_desat65cube.spi3d";
/// The base-contrast curve's file name.
const CURVE: &str = "filmic_to_0-70_1-03.spi1d";
/// The log encoding's ends, in EV (`lg2` allocation of Blender's "Filmic Log").
const LOG_MIN: f64 = -12.473931188;
const LOG_MAX: f64 = 12.526068812;
/// The part of the encoding that the curve spans (`uniform` allocation of [0, 0.66]).
const CURVE_SPAN: f64 = 0.66;

/// The two tables, read once per process.
#[derive(Debug)]
pub struct FilmicTables {
    /// Points along each side of the cube.
    size: usize,
    /// The cube's entries, red slowest (index `(r·size + g)·size + b`).
    cube: Vec<[f64; 3]>,
    /// The curve's entries over [0, 1].
    curve: Vec<f64>,
}

/// The tables from the configuration `$OCIO` names, read on first use; the failure names what
/// was missing.
pub fn tables() -> Outcome<Arc<FilmicTables>> {
    static TABLES: OnceLock<Result<Arc<FilmicTables>, String>> = OnceLock::new();
    TABLES
        .get_or_init(|| {
            let config = std::env::var_os("OCIO").ok_or_else(|| {
                String::from(
                    "view \"filmic\" reads Blender's Filmic tables from the OpenColorIO \
                     configuration that $OCIO names, and OCIO is not set",
                )
            })?;
            FilmicTables::from_config(Path::new(&config)).map(Arc::new)
        })
        .clone()
        .map_err(|message| {
            Failure::new(message).with_help(
                "set OCIO to a configuration with Filmic's tables, such as Blender's \
                 datafiles/colormanagement/config.ocio, or use view = \"agx\"",
            )
        })
}

impl FilmicTables {
    /// Reads the tables from the folders the configuration file `config` searches.
    pub fn from_config(config: &Path) -> Result<FilmicTables, String> {
        let text = std::fs::read_to_string(config).map_err(|e| {
            format!(
                "cannot read the OpenColorIO configuration '{}': {e}",
                config.display()
            )
        })?;
        let base = config.parent().unwrap_or(Path::new("."));
        let folders = search_path(&text)
            .into_iter()
            .map(|folder| base.join(folder))
            .chain([base.to_path_buf()])
            .collect::<Vec<PathBuf>>();
        let find = |name: &str| {
            folders
                .iter()
                .map(|folder| folder.join(name))
                .find(|path| path.is_file())
                .ok_or_else(|| {
                    format!(
                        "the OpenColorIO configuration '{}' has no {name} in its search path \
                         (it is not Blender's Filmic configuration)",
                        config.display()
                    )
                })
        };
        let (cube, curve) = (find(CUBE)?, find(CURVE)?);
        let read = |path: &Path| {
            std::fs::read_to_string(path)
                .map_err(|e| format!("cannot read '{}': {e}", path.display()))
        };
        let (size, cube) = parse_spi3d(&read(&cube)?)
            .map_err(|e| format!("'{}' is not a 3D table: {e}", cube.display()))?;
        let curve = parse_spi1d(&read(&curve)?)
            .map_err(|e| format!("'{}' is not a 1D table: {e}", curve.display()))?;
        Ok(FilmicTables { size, cube, curve })
    }

    /// The display-encoded (sRGB) Filmic colour of one scene-linear Rec.709 colour.
    pub fn encode(&self, rgb: [f64; 3]) -> [f64; 3] {
        let log = rgb.map(|c| {
            let c = if c > 0.0 { c } else { f64::MIN_POSITIVE };
            (c.log2() - LOG_MIN) / (LOG_MAX - LOG_MIN)
        });
        self.cube_at(log).map(|t| self.curve_at(t / CURVE_SPAN))
    }

    fn entry(&self, r: usize, g: usize, b: usize) -> [f64; 3] {
        self.cube[(r * self.size + g) * self.size + b]
    }

    /// Tetrahedral interpolation in the cube: the unit cell is cut into six tetrahedra along
    /// its main diagonal, chosen by the order of the three fractions.
    fn cube_at(&self, at: [f64; 3]) -> [f64; 3] {
        let last = (self.size - 1) as f64;
        let mut cell = [0usize; 3];
        let mut frac = [0.0; 3];
        for axis in 0..3 {
            let x = at[axis].clamp(0.0, 1.0) * last;
            let i = (x.floor() as usize).min(self.size - 2);
            cell[axis] = i;
            frac[axis] = x - i as f64;
        }
        let [r, g, b] = cell;
        let [fr, fg, fb] = frac;
        // The two corners after the origin on the way to the far corner, and the weights of
        // the four vertices, for each ordering of the fractions.
        let (first, second, weights) = if fr >= fg && fg >= fb {
            ([1, 0, 0], [1, 1, 0], [1.0 - fr, fr - fg, fg - fb, fb])
        } else if fr >= fb && fb >= fg {
            ([1, 0, 0], [1, 0, 1], [1.0 - fr, fr - fb, fb - fg, fg])
        } else if fb >= fr && fr >= fg {
            ([0, 0, 1], [1, 0, 1], [1.0 - fb, fb - fr, fr - fg, fg])
        } else if fg >= fr && fr >= fb {
            ([0, 1, 0], [1, 1, 0], [1.0 - fg, fg - fr, fr - fb, fb])
        } else if fg >= fb && fb >= fr {
            ([0, 1, 0], [0, 1, 1], [1.0 - fg, fg - fb, fb - fr, fr])
        } else {
            ([0, 0, 1], [0, 1, 1], [1.0 - fb, fb - fg, fg - fr, fr])
        };
        let corners = [
            self.entry(r, g, b),
            self.entry(r + first[0], g + first[1], b + first[2]),
            self.entry(r + second[0], g + second[1], b + second[2]),
            self.entry(r + 1, g + 1, b + 1),
        ];
        std::array::from_fn(|c| (0..4).map(|v| weights[v] * corners[v][c]).sum())
    }

    /// Linear interpolation in the curve over [0, 1].
    fn curve_at(&self, t: f64) -> f64 {
        let x = t.clamp(0.0, 1.0) * (self.curve.len() - 1) as f64;
        let i = (x.floor() as usize).min(self.curve.len() - 2);
        let f = x - i as f64;
        self.curve[i] * (1.0 - f) + self.curve[i + 1] * f
    }
}

/// The folders of a configuration's `search_path` line (`search_path: "luts:filmic"`).
fn search_path(config: &str) -> Vec<String> {
    config
        .lines()
        .find_map(|line| line.trim().strip_prefix("search_path:"))
        .map(|value| {
            value
                .trim()
                .trim_matches(|c| c == '"' || c == '\'')
                .split(':')
                .filter(|folder| !folder.is_empty())
                .map(String::from)
                .collect()
        })
        .unwrap_or_default()
}

/// A Sony Imageworks 1D table over [0, 1] with one component: `Version`, `From 0 1`,
/// `Length N`, `Components 1`, then N values between braces.
fn parse_spi1d(text: &str) -> Result<Vec<f64>, String> {
    let mut length = None;
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match (words.next(), words.next(), words.next()) {
            (Some("From"), Some(lo), Some(hi)) => {
                let (lo, hi): (f64, f64) = (
                    lo.parse().map_err(|_| "a bad From line")?,
                    hi.parse().map_err(|_| "a bad From line")?,
                );
                if (lo, hi) != (0.0, 1.0) {
                    return Err(format!("its domain is [{lo}, {hi}], not [0, 1]"));
                }
            }
            (Some("Length"), Some(n), None) => length = n.parse::<usize>().ok(),
            (Some("Components"), Some(n), None) if n != "1" => {
                return Err(format!("it has {n} components, not 1"));
            }
            _ => {}
        }
    }
    let body = text
        .split_once('{')
        .and_then(|(_, rest)| rest.split_once('}'))
        .map(|(body, _)| body)
        .ok_or("no values between braces")?;
    let values = body
        .split_whitespace()
        .map(|v| {
            v.parse::<f64>()
                .map_err(|_| format!("'{v}' is not a number"))
        })
        .collect::<Result<Vec<f64>, String>>()?;
    match length {
        Some(n) if n == values.len() && n >= 2 => Ok(values),
        _ => Err(format!(
            "its Length does not match its {} values",
            values.len()
        )),
    }
}

/// A Sony Imageworks 3D table: `SPILUT 1.0`, `3 3`, `N N N`, then lines `r g b R G B` (indices
/// and the entry), every entry of the cube given once.
fn parse_spi3d(text: &str) -> Result<(usize, Vec<[f64; 3]>), String> {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    // The format line (`SPILUT 1.0`) and the dimensions line (`3 3`) say nothing needed here.
    lines.next();
    lines.next();
    let sizes: Vec<usize> = lines
        .next()
        .ok_or("no sizes")?
        .split_whitespace()
        .map(|n| n.parse().map_err(|_| format!("'{n}' is not a size")))
        .collect::<Result<_, String>>()?;
    let size = match sizes[..] {
        [a, b, c] if a == b && b == c && (2..=129).contains(&a) => a,
        _ => {
            return Err(format!(
                "its sizes {sizes:?} are not one side from 2 to 129"
            ));
        }
    };
    let mut cube = vec![[f64::NAN; 3]; size * size * size];
    for line in lines {
        let numbers: Vec<&str> = line.split_whitespace().collect();
        let [r, g, b, x, y, z] = numbers[..] else {
            return Err(format!(
                "the line '{line}' is not three indices and three values"
            ));
        };
        let index = |s: &str| s.parse::<usize>().ok().filter(|&i| i < size);
        let value = |s: &str| s.parse::<f64>().ok().filter(|v| v.is_finite());
        let (Some(r), Some(g), Some(b), Some(x), Some(y), Some(z)) =
            (index(r), index(g), index(b), value(x), value(y), value(z))
        else {
            return Err(format!("the line '{line}' is out of range"));
        };
        cube[(r * size + g) * size + b] = [x, y, z];
    }
    if cube.iter().any(|e| e[0].is_nan()) {
        return Err(String::from("some of its entries are missing"));
    }
    Ok((size, cube))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cube that is the identity and a curve that is the identity: Filmic then reduces to its
    /// log encoding and the span's rescale, in closed form.
    fn identity_tables(size: usize) -> FilmicTables {
        let last = (size - 1) as f64;
        let mut cube = Vec::new();
        for r in 0..size {
            for g in 0..size {
                for b in 0..size {
                    cube.push([r as f64 / last, g as f64 / last, b as f64 / last]);
                }
            }
        }
        FilmicTables {
            size,
            cube,
            curve: (0..1001).map(|i| i as f64 / 1000.0).collect(),
        }
    }

    #[test]
    fn identity_tables_give_the_log_encoding_in_closed_form() {
        let tables = identity_tables(5);
        for c in [1e-4, 0.01, 0.18, 1.0, 7.5] {
            let expected = ((f64::log2(c) - LOG_MIN) / 25.0 / CURVE_SPAN).clamp(0.0, 1.0);
            let rgb = [c, 0.5 * c, 2.0 * c];
            let got = tables.encode(rgb);
            let want = rgb.map(|v| ((v.log2() - LOG_MIN) / 25.0 / CURVE_SPAN).clamp(0.0, 1.0));
            for k in 0..3 {
                assert!(
                    (got[k] - want[k]).abs() < 1e-12,
                    "{c}: {got:?} against {want:?}"
                );
            }
            assert!((got[0] - expected).abs() < 1e-12);
        }
    }

    /// Tetrahedral interpolation is exact for any affine cube, whichever tetrahedron a point
    /// falls in.
    #[test]
    fn the_cube_reproduces_an_affine_map_in_every_tetrahedron() {
        let size = 4;
        let last = (size - 1) as f64;
        let affine = |p: [f64; 3]| {
            [
                0.2 + 0.5 * p[0] - 0.1 * p[1] + 0.3 * p[2],
                0.7 * p[1] + 0.2 * p[2],
                0.1 - 0.3 * p[0] + 0.9 * p[2],
            ]
        };
        let mut cube = Vec::new();
        for r in 0..size {
            for g in 0..size {
                for b in 0..size {
                    cube.push(affine([r as f64 / last, g as f64 / last, b as f64 / last]));
                }
            }
        }
        let tables = FilmicTables {
            size,
            cube,
            curve: vec![0.0, 1.0],
        };
        let mut random = crate::base::test_random::SplitMix(0xf11);
        for _ in 0..500 {
            let p = [random.unit(), random.unit(), random.unit()];
            let (got, want) = (tables.cube_at(p), affine(p));
            for k in 0..3 {
                assert!(
                    (got[k] - want[k]).abs() < 1e-12,
                    "{p:?}: {got:?} against {want:?}"
                );
            }
        }
    }

    #[test]
    fn tables_are_parsed_and_bad_ones_refused() {
        let curve = "Version 1\nFrom 0.0 1.0\nLength 3\nComponents 1\n{\n 0.0\n 0.25\n 1.0\n}\n";
        assert_eq!(parse_spi1d(curve).unwrap(), vec![0.0, 0.25, 1.0]);
        assert!(parse_spi1d(&curve.replace("Length 3", "Length 4")).is_err());
        assert!(parse_spi1d(&curve.replace("From 0.0 1.0", "From -1 2")).is_err());
        let mut cube = String::from("SPILUT 1.0\n3 3\n2 2 2\n");
        for i in 0..8 {
            let (r, g, b) = (i >> 2, (i >> 1) & 1, i & 1);
            cube += &format!("{r} {g} {b} {r} {g} {b}\n");
        }
        let (size, entries) = parse_spi3d(&cube).unwrap();
        assert_eq!((size, entries[5]), (2, [1.0, 0.0, 1.0]));
        let missing: String = cube.lines().take(9).map(|l| format!("{l}\n")).collect();
        assert!(parse_spi3d(&missing).unwrap_err().contains("missing"));
        assert!(parse_spi3d(&cube.replace("1 1 1 1 1 1", "1 1 9 1 1 1")).is_err());
        assert_eq!(
            search_path("search_path: \"luts:filmic\"\n"),
            ["luts", "filmic"]
        );
    }
}
