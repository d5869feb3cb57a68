//! `Detector` and its `Keypoints`.

use std::sync::Arc;

use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList, PyTuple};
use steernav_core::{Backend, Detection, Detector as CoreDetector, DetectorConfig, Frame};

use crate::convert::*;

/// Keypoints of one image as numpy arrays.
#[pyclass(module = "steernav", frozen)]
pub(crate) struct Keypoints {
    /// (K, 2) float32: x, y in pixels, pixel centres at integers.
    #[pyo3(get)]
    xy: Py<PyArray2<f32>>,
    /// (K,) float32: the characteristic scale, √(σ_D² + 0.7²) (`Keypoint::scale`).
    #[pyo3(get)]
    scale: Py<PyArray1<f32>>,
    /// (K,) float32: dominant steered orientation, radians in [0, π).
    #[pyo3(get)]
    angle: Py<PyArray1<f32>>,
    /// (K,) float32: strongest Harris response of the cluster.
    #[pyo3(get)]
    response: Py<PyArray1<f32>>,
    /// (K, L) float32: the descriptors (L = 128 for "steered", 256 for "steered-twin", 5 for
    /// "entropy").
    #[pyo3(get)]
    descriptor: Py<PyArray2<f32>>,
    /// The descriptor's name: "steered", "steered-twin" or "entropy".
    #[pyo3(get)]
    descriptor_kind: &'static str,
    /// "cpu" or "gpu": where the detection ran.
    #[pyo3(get)]
    backend: &'static str,
    len: usize,
}

/// The descriptor kinds and backends a `Keypoints` can name, as the static strings it holds.
fn known_name(what: &str, name: &str, known: &[&'static str]) -> PyResult<&'static str> {
    known.iter().copied().find(|k| *k == name).ok_or_else(|| {
        PyValueError::new_err(format!("{what} = {name:?}: expected one of {known:?}"))
    })
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
    /// `Keypoints(xy, scale, angle, response, descriptor, descriptor_kind="steered",
    /// backend="cpu")`: keypoints from their arrays (as read back from a Parquet file, or
    /// unpickled), checked to pair up; the arrays are copied.
    #[new]
    #[pyo3(signature = (xy, scale, angle, response, descriptor, descriptor_kind = "steered", backend = "cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn from_arrays(
        py: Python<'_>,
        xy: numpy::PyReadonlyArray2<'_, f32>,
        scale: numpy::PyReadonlyArray1<'_, f32>,
        angle: numpy::PyReadonlyArray1<'_, f32>,
        response: numpy::PyReadonlyArray1<'_, f32>,
        descriptor: numpy::PyReadonlyArray2<'_, f32>,
        descriptor_kind: &str,
        backend: &str,
    ) -> PyResult<Self> {
        let k = xy.shape()[0];
        if xy.shape()[1] != 2 {
            return Err(PyValueError::new_err(format!(
                "xy: expected shape (K, 2), got {:?}",
                xy.shape()
            )));
        }
        for (name, len) in [
            ("scale", scale.len()),
            ("angle", angle.len()),
            ("response", response.len()),
            ("descriptor", descriptor.shape()[0]),
        ] {
            if len != k {
                return Err(PyValueError::new_err(format!(
                    "{name}: {len} rows for {k} keypoints in xy"
                )));
            }
        }
        let copy1 =
            |a: numpy::PyReadonlyArray1<'_, f32>| a.as_array().to_owned().into_pyarray(py).unbind();
        let copy2 =
            |a: numpy::PyReadonlyArray2<'_, f32>| a.as_array().to_owned().into_pyarray(py).unbind();
        Ok(Self {
            xy: copy2(xy),
            scale: copy1(scale),
            angle: copy1(angle),
            response: copy1(response),
            descriptor: copy2(descriptor),
            descriptor_kind: known_name(
                "descriptor_kind",
                descriptor_kind,
                &["steered", "steered-twin", "entropy"],
            )?,
            backend: known_name("backend", backend, &["cpu", "gpu"])?,
            len: k,
        })
    }

    /// Pickled as its arrays, so keypoints travel between processes (Ray, multiprocessing).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        let py = slf.py();
        let k = slf.get();
        let args = (
            k.xy.clone_ref(py),
            k.scale.clone_ref(py),
            k.angle.clone_ref(py),
            k.response.clone_ref(py),
            k.descriptor.clone_ref(py),
            k.descriptor_kind,
            k.backend,
        );
        (slf.get_type(), args).into_pyobject(py)
    }

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
    /// The backend asked for ("auto" stays "auto"), so an unpickled copy resolves its own.
    requested: Backend,
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
            requested: backend,
            scratch: std::sync::Mutex::new(None),
        })
    }

    /// Every setting of the detector, defaults included, as the keyword arguments that
    /// build the same detector again: `Detector(d.backend, **d.settings)`.
    #[getter]
    fn settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let table = toml::Table::try_from(self.inner.config())
            .map_err(|e| PyRuntimeError::new_err(format!("settings: {e}")))?;
        table_dict(py, &table)
    }

    /// Pickled as the backend asked for and the settings; the copy builds its own GPU
    /// context (or CPU planes) where it is unpickled and gives the same keypoints.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let rebuild = py.import("steernav")?.getattr("_rebuild_detector")?;
        let requested = match self.requested {
            Backend::Auto => "auto",
            Backend::Cpu => "cpu",
            Backend::Gpu => "gpu",
        };
        (rebuild, (requested, self.settings(py)?)).into_pyobject(py)
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

    /// Keypoints of many images, in order, through the library's stream: two frames in
    /// flight on the GPU, as many frames at once as there are cores on the CPU. An item is an
    /// image array or the bytes of an encoded file (PNG, JPEG, ...), decoded by the library
    /// as the CLI decodes it, on every core. With `return_exceptions=True` an image that
    /// fails (undecodable, too small, too large) gives its exception in its place and the
    /// others go on; otherwise the first failure is raised. Errors name the item by its entry
    /// in `names` (file paths, say), or as "image i".
    #[pyo3(signature = (images, return_exceptions = false, names = None))]
    fn detect_batch<'py>(
        &self,
        py: Python<'py>,
        images: &Bound<'py, PyAny>,
        return_exceptions: bool,
        names: Option<Vec<String>>,
    ) -> PyResult<Vec<Bound<'py, PyAny>>> {
        /// An image as given: pixels, or the bytes of an encoded file.
        enum Source {
            Pixels(Frame),
            Encoded(Vec<u8>),
        }
        // An array that is no image waits in its slot, so it comes back in order.
        let mut refused: Vec<Option<PyErr>> = Vec::new();
        let mut sources: Vec<Option<Source>> = Vec::new();
        for image in images.try_iter()? {
            let image = image?;
            let source = match image.cast::<PyBytes>() {
                Ok(bytes) => Ok(Source::Encoded(bytes.as_bytes().to_vec())),
                Err(_) => frame_of(&image).map(Source::Pixels),
            };
            refused.push(source.as_ref().err().map(|e| e.clone_ref(py)));
            sources.push(source.ok());
        }
        let names: Vec<String> = match names {
            Some(names) if names.len() != sources.len() => {
                return Err(PyValueError::new_err(format!(
                    "names: {} names for {} images",
                    names.len(),
                    sources.len()
                )))
            }
            Some(names) => names,
            None => (0..sources.len()).map(|i| format!("image {i}")).collect(),
        };
        // In chunks, with Ctrl-C checked between them: a long batch stays interruptible, and
        // a chunk is long enough to keep the stream's frames in flight.
        const CHUNK: usize = 16;
        let mut found = Vec::with_capacity(sources.len());
        let mut sources = sources.into_iter();
        loop {
            let chunk: Vec<Option<Source>> = sources.by_ref().take(CHUNK).collect();
            if chunk.is_empty() {
                break;
            }
            let names = &names[found.len()..found.len() + chunk.len()];
            let detector = Arc::clone(&self.inner);
            let part = py.detach(move || {
                use rayon::prelude::*;
                let frames: Vec<(usize, steernav_core::Result<Frame>)> = chunk
                    .into_par_iter()
                    .zip(names)
                    .enumerate()
                    .map(|(i, (source, name))| {
                        let frame = match source {
                            Some(Source::Pixels(frame)) => Ok(frame),
                            Some(Source::Encoded(bytes)) => {
                                Frame::decode(std::path::Path::new(name), &bytes)
                            }
                            // Its error is in `refused`; a pixel stands in for it.
                            None => Frame::from_rgb(1, 1, vec![0; 3]),
                        };
                        (i, frame)
                    })
                    .collect();
                let mut part = Vec::with_capacity(frames.len());
                detector.detect_stream(frames, |_, result| {
                    part.push(result.map(|(_, detection)| detection))
                });
                part
            });
            found.extend(part);
            py.check_signals()?;
        }
        found
            .into_iter()
            .zip(refused)
            .zip(&names)
            .map(|((result, refused), name)| {
                let err = match (result, refused) {
                    (Ok(d), None) => return Ok(Bound::new(py, Keypoints::new(py, &d))?.into_any()),
                    (_, Some(refused)) => refused,
                    (Err(e), None) => py_err(e),
                };
                if return_exceptions {
                    return Ok(err.into_value(py).into_bound(py).into_any());
                }
                // The same exception type, its message naming the item.
                let named = format!("{name}: ");
                let mut message = err.value(py).to_string();
                if !message.starts_with(&named) {
                    message.insert_str(0, &named);
                }
                Err(PyErr::from_value(err.get_type(py).call1((message,))?))
            })
            .collect()
    }
}
