//! Python bindings of steernav: numpy arrays in and out, the GIL released while the library
//! works, every library error raised as a Python exception with the library's message.
//!
//! Built on the library API only (no CLI code), so `Detector(backend="cpu").detect(image)`
//! gives exactly what `steernav detect --backend cpu` writes for the same pixels.

use std::sync::Arc;

use numpy::ndarray::{Array1, Array2};
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyReadonlyArrayDyn, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use steernav_core::eval::homography::Homography;
use steernav_core::eval::recall::{Descriptors, KeypointSet};
use steernav_core::nav::controller::{
    Controller as CoreController, ControllerConfig, LaserScan, Mode,
};
use steernav_core::nav::gist::{Gist, GistConfig};
use steernav_core::slam::camera::PinholeCamera;
use steernav_core::slam::config::SlamConfig;
use steernav_core::slam::tracker::Slam as CoreSlam;
use steernav_core::{Backend, Detection, Detector as CoreDetector, DetectorConfig, Frame};

/// A library error as the Python exception that fits it: bad values are `ValueError`, a
/// missing or failing GPU is `RuntimeError`.
fn py_err(e: steernav_core::Error) -> PyErr {
    use steernav_core::Error as E;
    match e {
        E::NoGpu { .. } | E::Gpu { .. } | E::GpuLimit(_) | E::Io { .. } => {
            PyRuntimeError::new_err(e.to_string())
        }
        other => PyValueError::new_err(other.to_string()),
    }
}

/// Python keyword arguments as a TOML table, so that a config type's own deserialisation
/// (unknown keys refused, types checked) names the bad key.
fn kwargs_table(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<toml::Table> {
    let mut table = toml::Table::new();
    if let Some(kwargs) = kwargs {
        for (key, value) in kwargs.iter() {
            let key: String = key.extract()?;
            table.insert(key.clone(), toml_value(&key, &value)?);
        }
    }
    Ok(table)
}

fn toml_value(key: &str, value: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    if let Ok(b) = value.extract::<bool>() {
        return Ok(toml::Value::Boolean(b));
    }
    if let Ok(i) = value.extract::<i64>() {
        return Ok(toml::Value::Integer(i));
    }
    if let Ok(f) = value.extract::<f64>() {
        return Ok(toml::Value::Float(f));
    }
    if let Ok(s) = value.extract::<String>() {
        return Ok(toml::Value::String(s));
    }
    if let Ok(list) = value.cast::<PyList>() {
        let items = list
            .iter()
            .map(|v| toml_value(key, &v))
            .collect::<PyResult<Vec<_>>>()?;
        return Ok(toml::Value::Array(items));
    }
    if let Ok(dict) = value.cast::<PyDict>() {
        return Ok(toml::Value::Table(kwargs_table(Some(dict))?));
    }
    Err(PyTypeError::new_err(format!(
        "{key}: {} is not a number, a string, a bool, a list or a dict",
        value.get_type().name()?
    )))
}

/// A config type from keyword arguments; errors name the key.
fn config_from<T: serde::de::DeserializeOwned>(
    what: &str,
    kwargs: Option<&Bound<'_, PyDict>>,
) -> PyResult<T> {
    kwargs_table(kwargs)?
        .try_into::<T>()
        .map_err(|e| PyValueError::new_err(format!("{what}: {}", e.to_string().trim_end())))
}

fn parse_backend(name: &str) -> PyResult<Backend> {
    name.parse::<Backend>().map_err(|_| {
        PyValueError::new_err(format!(
            "backend = {name:?}: expected one of auto, gpu, cpu"
        ))
    })
}

/// A numpy image as a frame: uint8 or float32 (values in [0, 1]), shape (H, W) or (H, W, 3)
/// in RGB order.
fn frame_of(image: &Bound<'_, PyAny>) -> PyResult<Frame> {
    let mut frame = Frame::from_rgb(1, 1, vec![0; 3]).map_err(py_err)?;
    fill_frame(&mut frame, image)?;
    Ok(frame)
}

/// [`frame_of`] into an existing frame, reusing its buffers when the image is RGB uint8.
fn fill_frame(frame: &mut Frame, image: &Bound<'_, PyAny>) -> PyResult<()> {
    let shape_err = |shape: &[usize]| {
        PyValueError::new_err(format!(
            "image: expected shape (H, W) or (H, W, 3), got {shape:?}"
        ))
    };
    let dims = |shape: &[usize]| -> PyResult<(u32, u32, bool)> {
        match *shape {
            [h, w] => Ok((w as u32, h as u32, false)),
            [h, w, 3] => Ok((w as u32, h as u32, true)),
            _ => Err(shape_err(shape)),
        }
    };
    if let Ok(a) = image.extract::<PyReadonlyArrayDyn<'_, u8>>() {
        let (w, h, colour) = dims(a.shape())?;
        // One copy of a contiguous RGB array; an element walk only for strided views or grey.
        return match (colour, a.as_slice()) {
            (true, Ok(slice)) => frame.set_rgb(w, h, slice),
            (true, Err(_)) => {
                let rgb: Vec<u8> = a.as_array().iter().copied().collect();
                frame.set_rgb(w, h, &rgb)
            }
            (false, _) => {
                let rgb: Vec<u8> = a.as_array().iter().flat_map(|&v| [v, v, v]).collect();
                frame.set_rgb(w, h, &rgb)
            }
        }
        .map_err(py_err);
    }
    if let Ok(a) = image.extract::<PyReadonlyArrayDyn<'_, f32>>() {
        let (w, h, colour) = dims(a.shape())?;
        let data: Vec<f32> = match a.as_slice() {
            Ok(slice) => slice.to_vec(),
            Err(_) => a.as_array().iter().copied().collect(),
        };
        *frame = if colour {
            Frame::from_rgb_f32(w, h, &data)
        } else {
            Frame::from_gray(w, h, data)
        }
        .map_err(py_err)?;
        return Ok(());
    }
    let dtype = image
        .getattr("dtype")
        .map(|d| d.to_string())
        .unwrap_or_else(|_| image.get_type().to_string());
    Err(PyTypeError::new_err(format!(
        "image: expected a numpy array of uint8 or float32, got {dtype}"
    )))
}

/// Keypoints of one image as numpy arrays.
#[pyclass(module = "steernav", frozen)]
struct Keypoints {
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
struct Detector {
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

/// `gist(image_or_list, backend="auto", **gist_settings)`: (512,) for one image, (N, 512) for
/// a list.
#[pyfunction]
#[pyo3(signature = (images, backend = "auto", **settings))]
fn gist<'py>(
    py: Python<'py>,
    images: &Bound<'py, PyAny>,
    backend: &str,
    settings: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let backend = parse_backend(backend)?;
    let config: GistConfig = config_from("gist", settings)?;
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
    let width = rows.first().map_or(0, |r| r.len());
    let flat: Vec<f32> = rows.concat();
    let array = Array2::from_shape_vec((flat.len() / width.max(1), width), flat)
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(array.into_pyarray(py).into_any())
}

/// Monocular EKF SLAM, one frame at a time.
#[pyclass(module = "steernav")]
struct Slam {
    inner: CoreSlam,
    detector: Arc<CoreDetector>,
    trajectory: Vec<[f64; 8]>,
}

#[pymethods]
impl Slam {
    /// `Slam(fx, fy, cx, cy, width, height, distortion=None, backend="auto", **slam_settings)`;
    /// `distortion` is (k1, k2, p1, p2, k3) or shorter.
    #[new]
    #[pyo3(signature = (fx, fy, cx, cy, width, height, distortion = None, backend = "auto", **settings))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        width: u32,
        height: u32,
        distortion: Option<Vec<f64>>,
        backend: &str,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
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
        let detector = CoreDetector::new(&DetectorConfig::tracking(), parse_backend(backend)?)
            .map_err(py_err)?;
        Ok(Self {
            inner: CoreSlam::new(camera, config).map_err(py_err)?,
            detector: Arc::new(detector),
            trajectory: Vec::new(),
        })
    }

    /// Processes the frame taken at `t` seconds. Returns a dict: position (3,), quaternion
    /// (4,) as (x, y, z, w), covariance (6, 6) of position and rotation vector, and the
    /// per-frame report's counts and flags.
    fn process<'py>(
        &mut self,
        py: Python<'py>,
        image: &Bound<'py, PyAny>,
        t: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let frame = frame_of(image)?;
        if !t.is_finite() {
            return Err(PyValueError::new_err(format!("t = {t}: must be finite")));
        }
        let (slam, detector) = (&mut self.inner, Arc::clone(&self.detector));
        let report = py
            .detach(|| slam.process(&frame, t, None, &detector))
            .map_err(py_err)?;
        let [qw, qx, qy, qz] = report.orientation;
        let [x, y, z] = report.position;
        self.trajectory.push([t, x, y, z, qx, qy, qz, qw]);
        let out = PyDict::new(py);
        out.set_item("position", Array1::from(vec![x, y, z]).into_pyarray(py))?;
        out.set_item(
            "quaternion",
            Array1::from(vec![qx, qy, qz, qw]).into_pyarray(py),
        )?;
        out.set_item("covariance", pose_covariance(&self.inner).into_pyarray(py))?;
        for (key, value) in [
            ("predicted", report.predicted),
            ("matched", report.matched),
            ("inliers", report.inliers),
            ("created", report.created),
            ("deleted", report.deleted),
            ("landmarks", report.landmarks),
        ] {
            out.set_item(key, value)?;
        }
        for (key, value) in [
            ("lost", report.lost),
            ("relocalised", report.relocalised),
            ("initialising", report.initialising),
        ] {
            out.set_item(key, value)?;
        }
        Ok(out)
    }

    /// The trajectory so far as an (N, 8) TUM array: t, x, y, z, qx, qy, qz, qw.
    fn trajectory<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let flat: Vec<f64> = self.trajectory.iter().flatten().copied().collect();
        let array = Array2::from_shape_vec((self.trajectory.len(), 8), flat)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(array.into_pyarray(py))
    }
}

/// Covariance of (position, rotation vector), 6×6.
fn pose_covariance(slam: &CoreSlam) -> Array2<f64> {
    let p = slam.filter().pose_covariance();
    Array2::from_shape_fn((6, 6), |(a, b)| p[(a, b)])
}

/// The neural-field navigation controller of one robot.
#[pyclass(module = "steernav")]
struct Controller {
    inner: CoreController,
    /// The camera's GIST engine, in fusion mode.
    gist: Option<Gist>,
}

#[pymethods]
impl Controller {
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

fn points(xy: &PyReadonlyArray2<'_, f32>, what: &str) -> PyResult<Vec<(f64, f64)>> {
    let a = xy.as_array();
    if a.ncols() != 2 {
        return Err(PyValueError::new_err(format!(
            "{what}: expected shape (K, 2), got {:?}",
            a.shape()
        )));
    }
    Ok(a.rows()
        .into_iter()
        .map(|r| (r[0] as f64, r[1] as f64))
        .collect())
}

fn homography(h: &PyReadonlyArray2<'_, f64>) -> PyResult<Homography> {
    let a = h.as_array();
    if a.shape() != [3, 3] {
        return Err(PyValueError::new_err(format!(
            "H: expected shape (3, 3), got {:?}",
            a.shape()
        )));
    }
    let mut out = [0.0; 9];
    for (o, v) in out.iter_mut().zip(a.iter()) {
        *o = *v;
    }
    if out.iter().any(|v| !v.is_finite()) {
        return Err(PyValueError::new_err("H: every entry must be finite"));
    }
    Ok(out)
}

fn size_of(shape: (u32, u32)) -> (u32, u32) {
    // numpy shapes are (height, width); the library takes (width, height).
    (shape.1, shape.0)
}

/// Repeatability (eq 11) of two keypoint sets under the map `H` (3×3, view 1 → view 2).
/// `kp1`, `kp2`: (K, 2) arrays of x, y. `shape1`, `shape2`: the images' (H, W).
#[pyfunction]
#[pyo3(signature = (kp1, kp2, H, shape1, shape2, eps = 2.0, margin = 10.0))]
#[allow(non_snake_case)]
fn repeatability(
    kp1: PyReadonlyArray2<'_, f32>,
    kp2: PyReadonlyArray2<'_, f32>,
    H: PyReadonlyArray2<'_, f64>,
    shape1: (u32, u32),
    shape2: (u32, u32),
    eps: f64,
    margin: f64,
) -> PyResult<f64> {
    let (p1, p2) = (points(&kp1, "kp1")?, points(&kp2, "kp2")?);
    let h = homography(&H)?;
    Ok(steernav_core::eval::repeatability(
        &p1,
        size_of(shape1),
        &p2,
        size_of(shape2),
        &h,
        eps,
        margin,
    )
    .ratio)
}

/// Points (K, 2) and their descriptors (K, D) as rows, checked to pair up.
type Described = (Vec<(f64, f64)>, Vec<Vec<f32>>);
fn described(
    kp: &PyReadonlyArray2<'_, f32>,
    desc: &PyReadonlyArray2<'_, f32>,
    what: &str,
) -> PyResult<Described> {
    let points = points(kp, what)?;
    let rows: Vec<Vec<f32>> = desc
        .as_array()
        .rows()
        .into_iter()
        .map(|r| r.to_vec())
        .collect();
    if rows.len() != points.len() {
        return Err(PyValueError::new_err(format!(
            "{what}: {} points but {} descriptors",
            points.len(),
            rows.len()
        )));
    }
    Ok((points, rows))
}

/// Recall (eq 12) of nearest-neighbour descriptor matching with Lowe's ratio test.
/// Descriptors are float arrays (K, D), compared by Euclidean distance.
#[pyfunction]
#[pyo3(signature = (kp1, desc1, kp2, desc2, H, shape1, shape2, eps = 2.0, ratio = 0.8, margin = 10.0))]
#[allow(non_snake_case, clippy::too_many_arguments)]
fn recall(
    kp1: PyReadonlyArray2<'_, f32>,
    desc1: PyReadonlyArray2<'_, f32>,
    kp2: PyReadonlyArray2<'_, f32>,
    desc2: PyReadonlyArray2<'_, f32>,
    H: PyReadonlyArray2<'_, f64>,
    shape1: (u32, u32),
    shape2: (u32, u32),
    eps: f64,
    ratio: f64,
    margin: f64,
) -> PyResult<f64> {
    let set = |kp: &PyReadonlyArray2<'_, f32>,
               desc: &PyReadonlyArray2<'_, f32>,
               what: &str|
     -> PyResult<KeypointSet> {
        let (points, rows) = described(kp, desc, what)?;
        Ok(KeypointSet {
            points,
            descriptors: Descriptors::Float(rows),
            scales: Vec::new(),
        })
    };
    let (a, b) = (set(&kp1, &desc1, "kp1")?, set(&kp2, &desc2, "kp2")?);
    let h = homography(&H)?;
    Ok(steernav_core::eval::recall::recall(
        &a,
        size_of(shape1),
        &b,
        size_of(shape2),
        &h,
        eps,
        margin,
        ratio,
    )
    .recall)
}

/// Correspondences between two keypoint sets, as `steernav match` makes them: mutual nearest
/// neighbours of the descriptors passing the ratio test both ways, verified by RANSAC
/// (`verify` = "homography", "fundamental" or "none"; `threshold` in pixels). Returns a dict
/// with arrays `i`, `j` (indices into each set), `distance`, `inlier` (bool), and `model`, the
/// fitted 3×3 H or F (None when none was found).
#[pyfunction]
#[pyo3(signature = (kp1, desc1, kp2, desc2, ratio = 0.8, verify = "homography", threshold = 3.0, iterations = 10_000, seed = 1))]
#[allow(clippy::too_many_arguments)]
fn match_keypoints<'py>(
    py: Python<'py>,
    kp1: PyReadonlyArray2<'_, f32>,
    desc1: PyReadonlyArray2<'_, f32>,
    kp2: PyReadonlyArray2<'_, f32>,
    desc2: PyReadonlyArray2<'_, f32>,
    ratio: f32,
    verify: &str,
    threshold: f64,
    iterations: usize,
    seed: u64,
) -> PyResult<Bound<'py, PyDict>> {
    use steernav_core::features::matching::{MatchSettings, Matched, Verification};
    let verification: Verification = verify
        .parse()
        .map_err(|e: steernav_core::error::Error| PyValueError::new_err(format!("verify: {e}")))?;
    let settings = MatchSettings {
        ratio,
        verification,
        inlier_threshold: threshold,
        iterations,
        seed,
    };
    // The library names its field; Python calls the threshold `threshold`.
    settings.validate().map_err(|e| {
        PyValueError::new_err(e.to_string().replace("inlier_threshold", "threshold"))
    })?;
    let set = |kp: &PyReadonlyArray2<'_, f32>,
               desc: &PyReadonlyArray2<'_, f32>,
               what: &str|
     -> PyResult<Vec<steernav_core::Keypoint>> {
        let (points, rows) = described(kp, desc, what)?;
        Ok(points
            .into_iter()
            .zip(rows)
            .map(|((x, y), descriptor)| steernav_core::Keypoint {
                x: x as f32,
                y: y as f32,
                scale: 0.0,
                angle: 0.0,
                response: 0.0,
                descriptor,
            })
            .collect::<Vec<_>>())
    };
    let (a, b) = (set(&kp1, &desc1, "kp1")?, set(&kp2, &desc2, "kp2")?);
    let Matched { matches, verified } = py
        .detach(|| settings.run(&a, &b))
        .map_err(|e| PyValueError::new_err(format!("desc1, desc2: {e}")))?;
    let out = PyDict::new(py);
    let column = |f: fn(&steernav_core::features::matching::Match) -> usize| {
        Array1::from_iter(matches.iter().map(f)).into_pyarray(py)
    };
    out.set_item("i", column(|m| m.i))?;
    out.set_item("j", column(|m| m.j))?;
    out.set_item(
        "distance",
        Array1::from_iter(matches.iter().map(|m| m.distance)).into_pyarray(py),
    )?;
    out.set_item(
        "inlier",
        Array1::from_vec(verified.inliers.clone()).into_pyarray(py),
    )?;
    match verified.model {
        Some(m) => out.set_item(
            "model",
            Array2::from_shape_vec((3, 3), m.to_vec())
                .map_err(|e| PyRuntimeError::new_err(e.to_string()))?
                .into_pyarray(py),
        )?,
        None => out.set_item("model", py.None())?,
    }
    Ok(out)
}

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
    let frame = steernav_core::synth::textured_scene(width, height, seed);
    let array =
        numpy::ndarray::Array3::from_shape_vec((height as usize, width as usize, 3), frame.rgb)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(array.into_pyarray(py).into_any())
}

/// steernav: rotation-invariant keypoints, GIST, monocular EKF SLAM and a neural-field
/// navigation controller, with numpy arrays in and out.
#[pymodule]
fn steernav(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Detector>()?;
    m.add_class::<Keypoints>()?;
    m.add_class::<Slam>()?;
    m.add_class::<Controller>()?;
    m.add_function(wrap_pyfunction!(gist, m)?)?;
    m.add_function(wrap_pyfunction!(repeatability, m)?)?;
    m.add_function(wrap_pyfunction!(recall, m)?)?;
    m.add_function(wrap_pyfunction!(match_keypoints, m)?)?;
    m.add_function(wrap_pyfunction!(textured_scene, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
