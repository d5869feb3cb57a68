//! `Detector` and its `Keypoints`.

use std::sync::Arc;

use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use steernav_core::{Detection, Detector as CoreDetector, DetectorConfig, Frame};

use crate::convert::*;

/// Keypoints of one image as numpy arrays.
#[pyclass(module = "steernav", frozen)]
pub(crate) struct Keypoints {
    /// (K, 2) float32: x, y in pixels, pixel centres at integers.
    #[pyo3(get)]
    xy: Py<PyArray2<f32>>,
    /// (K,) float32: σ_D of the dominant scale.
    #[pyo3(get)]
    scale: Py<PyArray1<f32>>,
    /// (K,) float32: dominant steered orientation, radians in [0, π).
    #[pyo3(get)]
    angle: Py<PyArray1<f32>>,
    /// (K,) float32: strongest Harris response of the cluster.
    #[pyo3(get)]
    response: Py<PyArray1<f32>>,
    /// (K, L) float32: the descriptors (L = 128 for "steered", 5 for "entropy").
    #[pyo3(get)]
    descriptor: Py<PyArray2<f32>>,
    /// The descriptor's name: "steered" or "entropy".
    #[pyo3(get)]
    descriptor_kind: &'static str,
    /// "cpu" or "gpu": where the detection ran.
    #[pyo3(get)]
    backend: &'static str,
    len: usize,
}

impl Keypoints {
    fn new(py: Python<'_>, d: &Detection) -> Self {
        let k = d.keypoints.len();
        let xy = Array2::from_shape_fn((k, 2), |(i, c)| {
            if c == 0 {
                d.keypoints[i].x
            } else {
                d.keypoints[i].y
            }
        });
        let length = d.descriptor.length();
        let descriptor = Array2::from_shape_fn((k, length), |(i, c)| d.keypoints[i].descriptor[c]);
        let column = |f: fn(&steernav_core::Keypoint) -> f32| {
            Array1::from_iter(d.keypoints.iter().map(f))
                .into_pyarray(py)
                .unbind()
        };
        Self {
            xy: xy.into_pyarray(py).unbind(),
            scale: column(|k| k.scale),
            angle: column(|k| k.angle),
            response: column(|k| k.response),
            descriptor: descriptor.into_pyarray(py).unbind(),
            descriptor_kind: d.descriptor.as_str(),
            backend: d.backend.as_str(),
            len: k,
        }
    }
}

#[pymethods]
impl Keypoints {
    fn __len__(&self) -> usize {
        self.len
    }

    fn __repr__(&self) -> String {
        format!("<Keypoints: {} on {}>", self.len, self.backend)
    }

    /// The keypoints as OpenCV `cv2.KeyPoint`s: size is the diameter 2·3σ_D of the drawn
    /// circle, angle in degrees, response as is.
    fn to_cv<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let cv2 = py.import("cv2").map_err(|_| {
            PyRuntimeError::new_err("to_cv() needs OpenCV: pip install opencv-python-headless")
        })?;
        let xy = self.xy.bind(py).readonly();
        let xy = xy.as_array();
        let scale = self.scale.bind(py).readonly();
        let angle = self.angle.bind(py).readonly();
        let response = self.response.bind(py).readonly();
        let (scale, angle, response) = (scale.as_array(), angle.as_array(), response.as_array());
        let list = PyList::empty(py);
        for i in 0..self.len {
            let kp = cv2.getattr("KeyPoint")?.call1((
                xy[[i, 0]],
                xy[[i, 1]],
                6.0 * scale[i],
                angle[i].to_degrees(),
                response[i],
            ))?;
            list.append(kp)?;
        }
        Ok(list)
    }
}

/// The rotation-invariant keypoint detector.
#[pyclass(module = "steernav", frozen)]
pub(crate) struct Detector {
    inner: Arc<CoreDetector>,
    /// The last frame's buffers, refilled by the next call of the same size.
    scratch: std::sync::Mutex<Option<Frame>>,
}

#[pymethods]
impl Detector {
    /// `Detector(backend="auto", **detector_settings)`: the keys of the `[detector]` table.
    #[new]
    #[pyo3(signature = (backend = "auto", **settings))]
    fn new(backend: &str, settings: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let backend = parse_backend(backend)?;
        let config: DetectorConfig = config_from("Detector", settings)?;
        let inner = CoreDetector::new(&config, backend).map_err(py_err)?;
        Ok(Self {
            inner: Arc::new(inner),
            scratch: std::sync::Mutex::new(None),
        })
    }

    /// "cpu" or "gpu": where frames go.
    #[getter]
    fn backend(&self) -> &'static str {
        self.inner.backend().as_str()
    }

    /// Keypoints of one image: uint8 or float32 in [0, 1], (H, W) or (H, W, 3) RGB.
    fn detect(&self, py: Python<'_>, image: &Bound<'_, PyAny>) -> PyResult<Keypoints> {
        let cached = self
            .scratch
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .take();
        let mut frame = match cached {
            Some(frame) => frame,
            None => Frame::from_rgb(1, 1, vec![0; 3]).map_err(py_err)?,
        };
        fill_frame(&mut frame, image)?;
        let detector = Arc::clone(&self.inner);
        let (found, frame) = py.detach(move || (detector.detect(&frame), frame));
        *self.scratch.lock().unwrap_or_else(|e| e.into_inner()) = Some(frame);
        Ok(Keypoints::new(py, &found.map_err(py_err)?))
    }

    /// Keypoints of many images, one after another: each detection already runs on every CPU
    /// core (or on the GPU), and the detector's scratch planes are shared, so detecting
    /// several frames at once would only make them wait for each other.
    fn detect_batch(&self, py: Python<'_>, images: &Bound<'_, PyAny>) -> PyResult<Vec<Keypoints>> {
        let frames = images
            .try_iter()?
            .map(|image| frame_of(&image?))
            .collect::<PyResult<Vec<_>>>()?;
        let detector = Arc::clone(&self.inner);
        let found = py
            .detach(move || -> steernav_core::Result<Vec<Detection>> {
                frames.iter().map(|f| detector.detect(f)).collect()
            })
            .map_err(py_err)?;
        Ok(found.iter().map(|d| Keypoints::new(py, d)).collect())
    }
}
