//! `Controller`: the neural-field controller, laser or fusion.

use numpy::ndarray::Array1;
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use steernav_core::nav::gist::Gist;
use steernav_core::nav::{Controller as CoreController, ControllerConfig, LaserScan, Mode};

use crate::convert::*;

/// The neural-field navigation controller of one robot.
#[pyclass(module = "steernav")]
pub(crate) struct Controller {
    inner: CoreController,
    /// The camera's GIST engine, in fusion mode.
    gist: Option<Gist>,
}

#[pymethods]
impl Controller {
    /// Refused: the field's activation is live state tied to the scans so far;
    /// each worker builds its own `Controller`.
    fn __reduce__(&self) -> PyResult<()> {
        Err(crate::convert::unpicklable("Controller", "its neural field holds activation from the scans fed so far (and, in fusion mode, a GIST engine); build one Controller per worker from the same mode and settings instead"))
    }

    /// `Controller(mode="laser", backend="auto", **controller_settings)`: the keys of the
    /// `[nav.controller]` table (field, stimulus, camera, visual, turn_gain…); in fusion mode
    /// the camera's GIST runs on `backend`.
    #[new]
    #[pyo3(signature = (mode = "laser", backend = "auto", **settings))]
    fn new(mode: &str, backend: &str, settings: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let config: ControllerConfig = config_from("Controller", settings)?;
        let mode: Mode = mode.parse().map_err(|_| {
            PyValueError::new_err(format!(
                "mode = {mode:?}: expected one of {}",
                Mode::NAMES.join(", ")
            ))
        })?;
        let gist = match mode {
            Mode::Fusion => Some(
                Gist::new(config.visual.gist.clone(), parse_backend(backend)?).map_err(py_err)?,
            ),
            Mode::Laser => None,
        };
        Ok(Self {
            inner: CoreController::new(config, mode, Default::default()).map_err(py_err)?,
            gist,
        })
    }

    /// The mode, "laser" or "fusion".
    #[getter]
    fn mode(&self) -> &'static str {
        self.inner.mode().as_str()
    }

    /// One control cycle: ranges (metres) with the first beam's angle and the spacing
    /// (radians, ROS convention), the pose (x, y, θ), the goal (x, y) and, in fusion mode, the
    /// camera image. Returns (v, ω, heading).
    #[pyo3(signature = (ranges, angle_min, angle_increment, pose, goal, range_max = f32::INFINITY, image = None))]
    #[allow(clippy::too_many_arguments)]
    fn step(
        &mut self,
        ranges: PyReadonlyArray1<'_, f32>,
        angle_min: f32,
        angle_increment: f32,
        pose: (f32, f32, f32),
        goal: (f32, f32),
        range_max: f32,
        image: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<(f32, f32, f32)> {
        let scan = LaserScan::new(
            ranges.as_array().to_vec(),
            angle_min,
            angle_increment,
            range_max,
        );
        let frame = image.map(frame_of).transpose()?;
        if frame.is_some() && self.gist.is_none() {
            return Err(PyValueError::new_err(
                "image: a laser-mode controller uses no camera (Controller(mode=\"fusion\"))",
            ));
        }
        let camera = frame.as_ref().zip(self.gist.as_ref());
        let c = self
            .inner
            .step(&scan, [pose.0, pose.1, pose.2], [goal.0, goal.1], camera)
            .map_err(py_err)?;
        Ok((c.v, c.omega, c.heading))
    }

    /// The field's activations after the last step, (N,) over world headings 2πi/N.
    #[getter]
    fn field<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        Array1::from(self.inner.field().to_vec()).into_pyarray(py)
    }
}
