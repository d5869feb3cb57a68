//! Python bindings of steernav: numpy arrays in and out, the GIL released while the library
//! works, every library error raised as a Python exception with the library's message.
//!
//! Built on the library API only (no CLI code), so `Detector(backend="cpu").detect(image)`
//! gives exactly what `steernav detect --backend cpu` writes for the same pixels.

mod bag;
mod convert;
mod detect;
mod eval;
mod gist;
mod nav;
mod slam;

use numpy::IntoPyArray;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

use crate::detect::{Detector, Keypoints};
use crate::eval::{match_keypoints, recall, repeatability};
use crate::nav::Controller;
use crate::slam::Slam;

/// `textured_scene(width, height, seed=1)`: the seeded procedural scene the benchmarks and
/// tests use, as an (H, W, 3) uint8 array.
#[pyfunction]
#[pyo3(signature = (width, height, seed = 1))]
fn textured_scene(
    py: Python<'_>,
    width: u32,
    height: u32,
    seed: u64,
) -> PyResult<Bound<'_, PyAny>> {
    if width == 0 || height == 0 || width as u64 * height as u64 > 100_000_000 {
        return Err(PyValueError::new_err(format!(
            "{width}x{height}: width and height must be ≥ 1, at most 100 MP in all"
        )));
    }
    let frame = steernav_core::low_level::synth::textured_scene(width, height, seed);
    let array =
        numpy::ndarray::Array3::from_shape_vec((height as usize, width as usize, 3), frame.rgb)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(array.into_pyarray(py).into_any())
}

/// steernav: rotation-invariant keypoints, GIST, monocular EKF SLAM and a neural-field
/// navigation controller, with numpy arrays in and out.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Detector>()?;
    m.add_class::<bag::BagReader>()?;
    m.add_class::<Keypoints>()?;
    m.add_class::<Slam>()?;
    m.add_class::<Controller>()?;
    m.add_class::<crate::eval::Matches>()?;
    m.add_class::<crate::slam::FrameReport>()?;
    m.add_function(wrap_pyfunction!(gist::gist, m)?)?;
    m.add_function(wrap_pyfunction!(repeatability, m)?)?;
    m.add_function(wrap_pyfunction!(recall, m)?)?;
    m.add_function(wrap_pyfunction!(match_keypoints, m)?)?;
    m.add_function(wrap_pyfunction!(textured_scene, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
