//! The band of every image a run renders (`felt run --tile I/N`), held by the run's engine:
//! what `I/N` means, where a band's file goes, and the accessors renders read it through.
//! Which rows a band covers and how its file is cropped and merged are the renderer's
//! (`render::band`).

use std::path::{Path, PathBuf};

/// Band `index` of `count`, counted from the top.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Band {
    pub index: usize,
    pub count: usize,
}

/// Most bands an image may be split into.
pub const MAX_BANDS: usize = 4096;

impl std::str::FromStr for Band {
    type Err = String;

    /// `I/N`, with `0 <= I < N`.
    fn from_str(text: &str) -> Result<Band, String> {
        let (index, count) = text
            .split_once('/')
            .ok_or_else(|| format!("expected I/N (band I of N, from 0), found `{text}`"))?;
        let number = |s: &str| s.trim().parse::<usize>().ok();
        let (Some(index), Some(count)) = (number(index), number(count)) else {
            return Err(format!("expected I/N with whole numbers, found `{text}`"));
        };
        if count == 0 || count > MAX_BANDS {
            return Err(format!(
                "the band count must be 1 to {MAX_BANDS}, found {count}"
            ));
        }
        if index >= count {
            return Err(format!(
                "band {index} of {count} does not exist: bands are numbered 0 to {}",
                count - 1
            ));
        }
        Ok(Band { index, count })
    }
}

/// Makes every render of the current engine draw only `band`.
pub fn set(band: Band) {
    super::with(|e| {
        let _ = e.band.set(band);
    });
}

/// The band the current engine renders, if it renders one.
pub fn active() -> Option<Band> {
    super::with(|e| e.band.get().copied())
}

impl Band {
    /// Where this band of the image `target` is written.
    pub fn path(self, target: &Path) -> PathBuf {
        let name = target.to_string_lossy();
        let stem = match name.len().checked_sub(4) {
            Some(cut) if name.is_char_boundary(cut) && name[cut..].eq_ignore_ascii_case(".exr") => {
                &name[..cut]
            }
            _ => &name[..],
        };
        PathBuf::from(format!("{stem}.tile-{}-of-{}.exr", self.index, self.count))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn band_names_are_predictable() {
        let band = Band { index: 2, count: 4 };
        assert_eq!(
            band.path(Path::new("out/a.0012.exr")),
            Path::new("out/a.0012.tile-2-of-4.exr")
        );
        assert_eq!(
            band.path(Path::new("a.####.EXR")),
            Path::new("a.####.tile-2-of-4.exr")
        );
        assert_eq!(
            band.path(Path::new("a.png")),
            Path::new("a.png.tile-2-of-4.exr")
        );
    }

    #[test]
    fn band_arguments_are_checked() {
        assert_eq!("1/4".parse::<Band>(), Ok(Band { index: 1, count: 4 }));
        for (text, says) in [
            ("4/4", "numbered 0 to 3"),
            ("0/0", "1 to"),
            ("x/2", "whole numbers"),
            ("3", "expected I/N"),
        ] {
            let error = text.parse::<Band>().unwrap_err();
            assert!(error.contains(says), "{text}: {error}");
        }
    }
}
