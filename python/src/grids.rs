//! Grids between felt and NumPy. A felt cache stores 8³-cell bricks, filled on first read, so
//! no NumPy array can view it in place: reading one copies it once, in parallel, into a
//! `float32` buffer that NumPy then owns without a second copy. The array is indexed
//! `[i, j, k]` (`[i, j, k, c]` for vector and matrix caches) — x, y, z cell indices, as
//! pyopenvdb's `copyToArray` orders them — and laid out x fastest (Fortran order), felt's own
//! dense order: a brick's rows along x are then contiguous on both sides and each is one block
//! copy, where a C-ordered array scatters every cell (0.71 against 0.97 GB/s for 256³, measured
//! by `bench/bench.py` on one debug build).
//! `numpy.ascontiguousarray` gives C order where a consumer needs it. Arrays coming in are
//! copied once into a cache's bricks; values that are not finite are refused, so NaN never
//! enters a cache.

use felt::grid::cache::{BRICK, BRICK_CELLS, Cache};
use felt::space::domain::Domain;
use numpy::npyffi::NPY_ORDER;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use rayon::prelude::*;

/// A grid read from felt: `values` (a NumPy array indexed `[i, j, k]` or `[i, j, k, c]`) and
/// where its cells lie: cell `(i, j, k)` is centred at `origin + (i + 0.5, j + 0.5, k + 0.5)
/// * cell` along the domain's axes (rotated by `orientation`, a rotation vector).
#[pyclass(module = "felt", frozen, get_all)]
pub struct Grid {
    values: Py<PyAny>,
    origin: (f64, f64, f64),
    cell: (f64, f64, f64),
    lengths: (f64, f64, f64),
    orientation: (f64, f64, f64),
}

#[pymethods]
impl Grid {
    /// The values as a NumPy array, so `numpy.asarray(grid)` works.
    #[pyo3(signature = (dtype=None, copy=None))]
    fn __array__(
        &self,
        py: Python<'_>,
        dtype: Option<Py<PyAny>>,
        copy: Option<bool>,
    ) -> PyResult<Py<PyAny>> {
        let values = self.values.bind(py);
        let values = match dtype {
            Some(dtype) => values.call_method1("astype", (dtype,))?,
            None => values.clone(),
        };
        Ok(match copy {
            Some(true) => values.call_method0("copy")?.unbind(),
            _ => values.unbind(),
        })
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let shape = self.values.bind(py).getattr("shape")?.repr()?.to_string();
        Ok(format!(
            "<felt.Grid shape={shape} origin={:?} cell={:?}>",
            self.origin, self.cell
        ))
    }
}

fn tuple(v: glam::DVec3) -> (f64, f64, f64) {
    (v.x, v.y, v.z)
}

/// Every cell of a cache with x fastest: component `c` of cell `(i, j, k)` at
/// `c + width (i + nx (j + ny k))`, felt's own dense order; fills bricks not yet filled (call
/// with the session's engine entered, the GIL released).
pub fn cache_values(cache: &Cache) -> Vec<f32> {
    let [nx, ny, nz] = cache.resolution();
    let width = cache.width();
    let [bricks_x, bricks_y, _] = cache.brick_counts();
    let mut out = vec![0f32; nx * ny * nz * width];
    // A layer of bricks along z is one contiguous slab of the output, and a brick's rows along
    // x are contiguous in both, so each row is one block copy.
    let slab = BRICK * nx * ny * width;
    out.par_chunks_mut(slab.max(1))
        .enumerate()
        .for_each(|(bz, chunk)| {
            let z0 = bz * BRICK;
            for by in 0..bricks_y {
                for bx in 0..bricks_x {
                    let Some(values) = cache.brick_values_at([bx, by, bz]) else {
                        continue;
                    };
                    debug_assert!(values.len() >= BRICK_CELLS * width);
                    let (x0, y0) = (bx * BRICK, by * BRICK);
                    let row = BRICK.min(nx - x0) * width;
                    for lz in 0..BRICK.min(nz - z0) {
                        for ly in 0..BRICK.min(ny - y0) {
                            let from = BRICK * (ly + BRICK * lz) * width;
                            let to = (x0 + nx * (y0 + ly + ny * lz)) * width;
                            chunk[to..to + row].copy_from_slice(&values[from..from + row]);
                        }
                    }
                }
            }
        });
    out
}

/// A `Grid` of the values read from `domain`'s cells (`cache_values`' order), viewed by NumPy
/// as `[i, j, k]` or `[i, j, k, c]` without a copy.
pub fn grid(py: Python<'_>, values: Vec<f32>, width: usize, domain: &Domain) -> PyResult<Grid> {
    let [nx, ny, nz] = domain.resolution.unwrap_or([0, 0, 0]);
    let flat = PyArray1::from_vec(py, values);
    let array = if width == 1 {
        flat.reshape_with_order([nx, ny, nz], NPY_ORDER::NPY_FORTRANORDER)?
            .into_any()
    } else {
        // Components fastest: Fortran order over (c, i, j, k), then c moved last (a view).
        flat.reshape_with_order([width, nx, ny, nz], NPY_ORDER::NPY_FORTRANORDER)?
            .into_any()
            .call_method1("transpose", ((1, 2, 3, 0),))?
    };
    Ok(Grid {
        values: array.unbind(),
        origin: tuple(domain.origin),
        cell: tuple(domain.cell),
        lengths: tuple(domain.lengths),
        orientation: tuple(domain.orientation),
    })
}

/// The components of a C-ordered `[i, j, k, c]` array as `Cache::from_dense` wants them:
/// `data[c][i + nx (j + ny k)]`.
pub fn dense_components(values: &[f32], cells: [usize; 3], width: usize) -> Vec<Vec<f32>> {
    let [nx, ny, nz] = cells;
    let mut data = vec![vec![0f32; nx * ny * nz]; width];
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                let from = ((i * ny + j) * nz + k) * width;
                let to = i + nx * (j + ny * k);
                for (c, component) in data.iter_mut().enumerate() {
                    component[to] = values[from + c];
                }
            }
        }
    }
    data
}
