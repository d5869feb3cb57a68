//! `repeatability()`, `recall()` and `match_keypoints()` with its typed `Matches`.

use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use steernav_core::eval::recall::{Descriptors, KeypointSet};

use crate::convert::*;

/// Repeatability (eq 11) of two keypoint sets under the map `H` (3×3, view 1 → view 2).
/// `kp1`, `kp2`: (K, 2) arrays of x, y. `shape1`, `shape2`: the images' (H, W).
#[pyfunction]
#[pyo3(signature = (kp1, kp2, H, shape1, shape2, eps = 2.0, margin = 10.0))]
#[allow(non_snake_case)]
pub(crate) fn repeatability(
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

/// Recall (eq 12) of nearest-neighbour descriptor matching with Lowe's ratio test.
/// Descriptors are float arrays (K, D), compared by Euclidean distance.
#[pyfunction]
#[pyo3(signature = (kp1, desc1, kp2, desc2, H, shape1, shape2, eps = 2.0, ratio = 0.8, margin = 10.0))]
#[allow(non_snake_case, clippy::too_many_arguments)]
pub(crate) fn recall(
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
/// (`verify` = "homography", "fundamental" or "none"; `threshold` in pixels), then, with
/// `guided`, matched again among the candidates the model maps within `threshold` of each
/// other and verified again. `frames`: equal frames per descriptor row (2 for "steered-twin"
/// descriptors), two rows being as near as their nearest pair of frames. Returns a dict
/// with arrays `i`, `j` (indices into each set), `distance`, `inlier` (bool), and `model`, the
/// fitted 3×3 H or F (None when none was found).
#[pyfunction]
#[pyo3(signature = (kp1, desc1, kp2, desc2, ratio = 0.8, verify = "homography", threshold = 3.0, iterations = 10_000, seed = 1, guided = true, frames = 1))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn match_keypoints(
    py: Python<'_>,
    kp1: PyReadonlyArray2<'_, f32>,
    desc1: PyReadonlyArray2<'_, f32>,
    kp2: PyReadonlyArray2<'_, f32>,
    desc2: PyReadonlyArray2<'_, f32>,
    ratio: f32,
    verify: &str,
    threshold: f64,
    iterations: usize,
    seed: u64,
    guided: bool,
    frames: usize,
) -> PyResult<Matches> {
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
        guided,
        frames,
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
    Ok(Matches {
        matched: Matched { matches, verified },
    })
}

/// Correspondences between two keypoint sets and their verification.
#[pyclass(module = "steernav", frozen)]
pub(crate) struct Matches {
    matched: steernav_core::features::matching::Matched,
}

#[pymethods]
impl Matches {
    /// (M,): index of each match in the first set.
    #[getter]
    fn i<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<usize>> {
        Array1::from_iter(self.matched.matches.iter().map(|m| m.i)).into_pyarray(py)
    }

    /// (M,): index of each match in the second set.
    #[getter]
    fn j<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<usize>> {
        Array1::from_iter(self.matched.matches.iter().map(|m| m.j)).into_pyarray(py)
    }

    /// (M,): descriptor distance of each match, ascending.
    #[getter]
    fn distance<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        Array1::from_iter(self.matched.matches.iter().map(|m| m.distance)).into_pyarray(py)
    }

    /// (M,) bool: the match agrees with the fitted model.
    #[getter]
    fn inlier<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        Array1::from_vec(self.matched.verified.inliers.clone()).into_pyarray(py)
    }

    /// (3, 3): the fitted H or F, or None when none was found (or verify="none").
    #[getter]
    fn model<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.matched
            .verified
            .model
            .map(|m| Array2::from_shape_fn((3, 3), |(r, c)| m[3 * r + c]).into_pyarray(py))
    }

    fn __len__(&self) -> usize {
        self.matched.matches.len()
    }

    fn __repr__(&self) -> String {
        let inliers = self.matched.verified.inliers.iter().filter(|&&b| b).count();
        format!(
            "Matches({} matches, {inliers} inliers)",
            self.matched.matches.len()
        )
    }
}
