//! The 256³ density grid the VDB peer benchmarks share: felt's `cachesave` of the smoothed
//! five-octave pyroclastic sphere over [-1, 1]³ (voxel 2/256, zero voxels inactive).

use std::path::Path;

pub const CELLS: usize = 256;

/// The felt script that writes the grid, as grid "density", to `path`.
pub fn make_grid_script(path: &Path) -> String {
    format!(
        "domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 2.0 / {CELLS});
scalarfield noise = fbm(perlin(), 5, scalarfield(2.0), scalarfield(2.0), scalarfield(0.5));
scalarfield density = lsdensitysmooth(pyroclastic((0, 0, 0), 0.6, noise, 0.3), 0.05);
scalarcache c(d);
cachewrite(c, density);
cachesave(c, \"{}\");
",
        path.display()
    )
}
