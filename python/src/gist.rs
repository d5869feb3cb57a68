//! `gist()`: GIST descriptors on either backend.

use numpy::ndarray::{Array1, Array2};
use numpy::IntoPyArray;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use steernav_core::nav::gist::{Gist, GistConfig};

use crate::convert::*;

/// `gist(image_or_list, backend="auto", **gist_settings)`: (512,) for one image, (N, 512) for
/// a list.
#[pyfunction]
#[pyo3(signature = (images, backend = "auto", **settings))]
pub(crate) fn gist<'py>(
    py: Python<'py>,
    images: &Bound<'py, PyAny>,
    backend: &str,
    settings: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let backend = parse_backend(backend)?;
    let config: GistConfig = config_from("gist", settings)?;
    let config_len = config.len();
    let single = images.hasattr("shape")?;
    let frames = if single {
        vec![frame_of(images)?]
    } else {
        images
            .try_iter()?
            .map(|image| frame_of(&image?))
            .collect::<PyResult<Vec<_>>>()?
    };
    let context = backend.resolve().map_err(py_err)?;
    let rows = py
        .detach(move || -> steernav_core::Result<Vec<Vec<f32>>> {
            Gist::with_context(context, config)?.describe_batch(&frames)
        })
        .map_err(py_err)?;
    if single {
        return Ok(Array1::from(rows.into_iter().next().unwrap_or_default())
            .into_pyarray(py)
            .into_any());
    }
    // An empty list still has the descriptor's width: (0, 512), not (0, 0).
    let width = rows.first().map_or(config_len, |r| r.len());
    let flat: Vec<f32> = rows.concat();
    let array = Array2::from_shape_vec((flat.len() / width.max(1), width), flat)
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(array.into_pyarray(py).into_any())
}
