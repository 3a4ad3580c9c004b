//! Rendered images into NumPy. `render` writes its image to a file (OpenEXR, or a PNG preview),
//! as it does from the command line; `felt.read_image(path)` reads such an EXR back as its
//! channels by name (`R`, `G`, `B`, `A`, and every AOV, e.g. `depth.Z`), each a `float32`
//! array indexed `[row, column]` with row 0 at the top, felt's pixel convention. Reading
//! copies once, from the file; the GIL is released while the file is decoded.

use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The channels of the flat OpenEXR image at `path`, by name.
#[pyfunction]
pub fn read_image<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let image = py
        .detach(|| exr::prelude::read_first_flat_layer_from_file(&path))
        .map_err(|e| {
            pyo3::exceptions::PyOSError::new_err(format!(
                "cannot read image '{}': {e}",
                path.display()
            ))
        })?;
    let layer = image.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    let channels = PyDict::new(py);
    for channel in layer.channel_data.list {
        let values: Vec<f32> = channel.sample_data.values_as_f32().collect();
        let array = PyArray1::from_vec(py, values).reshape([height, width])?;
        channels.set_item(channel.name.to_string(), array)?;
    }
    Ok(channels)
}
