//! `Slam` and its typed `FrameReport`.

use std::sync::Arc;

use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use steernav_core::slam::camera::PinholeCamera;
use steernav_core::slam::config::SlamConfig;
use steernav_core::slam::{FrameReport as CoreFrameReport, Slam as CoreSlam};
use steernav_core::{Detector as CoreDetector, DetectorConfig};

use crate::convert::*;

/// Monocular EKF SLAM, one frame at a time.
#[pyclass(module = "steernav")]
pub(crate) struct Slam {
    inner: CoreSlam,
    detector: Arc<CoreDetector>,
    trajectory: Vec<[f64; 8]>,
}

#[pymethods]
impl Slam {
    /// Refused: a running filter (state, covariance, map, templates) is not a
    /// value to ship; each worker builds its own `Slam` from the camera and settings.
    fn __reduce__(&self) -> PyResult<()> {
        Err(crate::convert::unpicklable("Slam", "it holds a running filter (state, covariance, landmark map, templates) that only makes sense in the process feeding it frames; build one Slam per worker from the same camera and settings instead"))
    }

    /// `Slam(fx, fy, cx, cy, width, height, distortion=None, backend="auto", detector=None,
    /// **slam_settings)`; `distortion` is (k1, k2, p1, p2, k3) or shorter; `detector` a dict of
    /// `[detector]` keys applied over the tracking preset; the keyword arguments are the
    /// `[slam]` table's sub-tables (`filter={...}`, `search={...}`, `map={...}`, …).
    #[new]
    #[pyo3(signature = (fx, fy, cx, cy, width, height, distortion = None, backend = "auto", detector = None, **settings))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        width: i64,
        height: i64,
        distortion: Option<Vec<f64>>,
        backend: &str,
        detector: Option<&Bound<'_, PyDict>>,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let (width, height) = (
            crate::convert::image_side("width", width)?,
            crate::convert::image_side("height", height)?,
        );
        let mut camera = PinholeCamera::ideal(fx, fy, cx, cy, width, height);
        if let Some(d) = distortion {
            if d.len() > 5 {
                return Err(PyValueError::new_err(format!(
                    "distortion: at most 5 coefficients (k1, k2, p1, p2, k3), got {}",
                    d.len()
                )));
            }
            let mut k = [0.0; 5];
            k[..d.len()].copy_from_slice(&d);
            [camera.k1, camera.k2, camera.p1, camera.p2, camera.k3] = k;
        }
        camera.validate().map_err(py_err)?;
        let config: SlamConfig = config_from("Slam", settings)?;
        let detector_config = DetectorConfig::tracking()
            .overlaid(&kwargs_table(detector)?)
            .map_err(|e| PyValueError::new_err(format!("Slam detector: {e}")))?;
        let detector =
            CoreDetector::new(&detector_config, parse_backend(backend)?).map_err(py_err)?;
        Ok(Self {
            inner: CoreSlam::new(camera, config).map_err(py_err)?,
            detector: Arc::new(detector),
            trajectory: Vec::new(),
        })
    }

    /// Processes the frame taken at `t` seconds; returns its [`FrameReport`].
    fn process(&mut self, image: &Bound<'_, PyAny>, t: f64) -> PyResult<FrameReport> {
        let py = image.py();
        let frame = frame_of(image)?;
        if !t.is_finite() {
            return Err(PyValueError::new_err(format!("t = {t}: must be finite")));
        }
        let (slam, detector) = (&mut self.inner, Arc::clone(&self.detector));
        let report = py
            .detach(|| slam.process(&frame, t, None, &detector))
            .map_err(py_err)?;
        // The start may revise the frames of its wait and of its trial (`take_revised`): the
        // trajectory takes their new poses.
        for earlier in self.inner.take_revised() {
            if let Some(row) = self
                .trajectory
                .iter_mut()
                .find(|row| row[0] == earlier.timestamp)
            {
                *row = tum_row(&earlier);
            }
        }
        self.trajectory.push(tum_row(&report));
        let covariance = self.inner.filter().pose_covariance();
        Ok(FrameReport {
            covariance: std::array::from_fn(|a| std::array::from_fn(|b| covariance[(a, b)])),
            report,
        })
    }

    /// The trajectory so far as an (N, 8) TUM array: t, x, y, z, qx, qy, qz, qw. Frames the
    /// start revised after reporting them carry their revised poses.
    fn trajectory<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let flat: Vec<f64> = self.trajectory.iter().flatten().copied().collect();
        let array = Array2::from_shape_vec((self.trajectory.len(), 8), flat)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(array.into_pyarray(py))
    }
}

/// A frame's pose as a TUM row: t, x, y, z, qx, qy, qz, qw.
fn tum_row(report: &CoreFrameReport) -> [f64; 8] {
    let [qw, qx, qy, qz] = report.orientation;
    let [x, y, z] = report.position;
    [report.timestamp, x, y, z, qx, qy, qz, qw]
}

/// What one frame did: the pose after it, its covariance, and the counts and flags of the
/// library's frame report.
#[pyclass(module = "steernav", frozen)]
pub(crate) struct FrameReport {
    report: CoreFrameReport,
    /// Covariance of (position, rotation vector).
    covariance: [[f64; 6]; 6],
}

#[pymethods]
impl FrameReport {
    /// Seconds.
    #[getter]
    fn timestamp(&self) -> f64 {
        self.report.timestamp
    }

    /// (3,): the camera position after the update.
    #[getter]
    fn position<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from(self.report.position.to_vec()).into_pyarray(py)
    }

    /// (4,): the camera orientation as (x, y, z, w), camera → world.
    #[getter]
    fn quaternion<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let [w, x, y, z] = self.report.orientation;
        Array1::from(vec![x, y, z, w]).into_pyarray(py)
    }

    /// (6, 6): covariance of the position and the rotation vector.
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        Array2::from_shape_fn((6, 6), |(a, b)| self.covariance[a][b]).into_pyarray(py)
    }

    /// Landmarks predicted inside the image.
    #[getter]
    fn predicted(&self) -> usize {
        self.report.predicted
    }

    /// Matches found by the active search.
    #[getter]
    fn matched(&self) -> usize {
        self.report.matched
    }

    /// Low-innovation inliers of 1-point RANSAC.
    #[getter]
    fn inliers(&self) -> usize {
        self.report.inliers
    }

    /// High-innovation inliers rescued by the χ² gate.
    #[getter]
    fn rescued(&self) -> usize {
        self.report.rescued
    }

    /// Landmarks created.
    #[getter]
    fn created(&self) -> usize {
        self.report.created
    }

    /// Landmarks deleted.
    #[getter]
    fn deleted(&self) -> usize {
        self.report.deleted
    }

    /// Landmarks in the map after the frame.
    #[getter]
    fn landmarks(&self) -> usize {
        self.report.landmarks
    }

    /// Fewer than 3 landmarks supported the pose.
    #[getter]
    fn lost(&self) -> bool {
        self.report.lost
    }

    /// Tracking resumed against the map after being lost.
    #[getter]
    fn relocalised(&self) -> bool {
        self.report.relocalised
    }

    /// Waiting for the parallax to start (the pose is the start pose).
    #[getter]
    fn initialising(&self) -> bool {
        self.report.initialising
    }

    /// The filter refused an update this frame.
    #[getter]
    fn update_rejected(&self) -> bool {
        self.report.update_rejected
    }

    fn __repr__(&self) -> String {
        let r = &self.report;
        format!(
            "FrameReport(t={}, position={:?}, landmarks={}, inliers={}, lost={})",
            r.timestamp, r.position, r.landmarks, r.inliers, r.lost
        )
    }
}
