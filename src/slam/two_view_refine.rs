//! The two-view motion refined on the Sampson distances of every correspondence, from several
//! starting directions. Not an equation of the paper (its filter starts at rest).
//!
//! The eight-point fit minimises an algebraic error whose noise pulls the translation towards
//! the optical axis. A hand-held camera that walks sideways while it turns is the worst case:
//! sideways translation and rotation about the vertical move the image alike (the bas-relief
//! ambiguity), and on the generated walks the eight-point direction came out 40–50° from the
//! truth, a forward motion plus extra rotation that the filter then kept for seconds. The
//! Sampson cost over the directions has a valley with more than one basin, and a refinement
//! started from the eight-point direction stays in its basin. So Levenberg–Marquardt starts
//! from that direction and from a spread of others on its hemisphere, on every correspondence
//! within [`GATE`] thresholds of the eight-point fit (its inliers were picked by the biased
//! fit; the gross outliers stay out): a wide Cauchy cost finds each start's basin,
//! the truncated quadratic of RANSAC's score (MSAC) settles in it, and the lowest score wins.
//! The lowest score is not always the true motion: on forward starts (KITTI clip_b) another
//! basin can score lower and be wrong (docs/SLAM.md, "Hand-held starts"). So the result is a
//! second hypothesis, which the start tracks beside the eight-point one before it chooses
//! (`tracker/trial.rs`).

use nalgebra::{DMatrix, DVector, Matrix3, Matrix5, Rotation3, SVector, Vector3};

use super::motion::{central_jacobian, levenberg_marquardt_step};
use super::rotation::skew;
use super::two_view::{sampson_residual, Correspondence};

/// Levenberg–Marquardt iterations from each start.
const ITERATIONS: usize = 12;
/// Polar angles, radians, of the starting directions around the eight-point one's
/// hemisphere axis (the optical axis), with [`AZIMUTHS`] directions on each ring.
const RINGS: [f64; 2] = [0.6, 1.2];
/// Starting directions per ring.
const AZIMUTHS: usize = 8;
/// Correspondences farther than this many RANSAC thresholds from the eight-point fit are
/// left out.
const GATE: f64 = 10.0;
/// The Cauchy scale that finds each start's basin, in RANSAC thresholds.
const BASIN_SCALE: f64 = 3.0;

/// Refines (R, t) on `points` (X₁ = R·X₀ + t, |t| = 1), `threshold` the RANSAC one in
/// normalised units. The returned translation may be the opposite of the true one: the
/// Sampson cost does not see the sign, and cheirality is the caller's.
pub(super) fn refine(
    points: &[Correspondence],
    rotation: Matrix3<f64>,
    translation: Vector3<f64>,
    threshold: f64,
) -> (Matrix3<f64>, Vector3<f64>) {
    if points.len() < 8 {
        return (rotation, translation);
    }
    let axis = Vector3::z() * translation.z.signum();
    let mut starts = vec![translation, axis];
    for polar in RINGS {
        for k in 0..AZIMUTHS {
            let azimuth = std::f64::consts::TAU * k as f64 / AZIMUTHS as f64;
            let (s, c) = polar.sin_cos();
            starts.push(Vector3::new(
                s * azimuth.cos(),
                s * azimuth.sin(),
                c * axis.z,
            ));
        }
    }
    // The eight-point fit's gross outliers stay out: even a Cauchy cost lets a fifth of the
    // points, pushed one way, bend the motion.
    let e = skew(&translation) * rotation;
    let gate = (GATE * threshold).powi(2);
    let near: Vec<Correspondence> = points
        .iter()
        .filter(|c| sampson_residual(&e, c).powi(2) < gate)
        .cloned()
        .collect();
    if near.len() < 8 {
        return (rotation, translation);
    }
    let problem = Problem { points: &near };
    starts
        .into_iter()
        .map(|t| {
            let (r, t, _) = problem.descend(rotation, t, Loss::Cauchy(BASIN_SCALE * threshold));
            problem.descend(r, t, Loss::Truncated(threshold))
        })
        .min_by(|a, b| a.2.total_cmp(&b.2))
        .map_or((rotation, translation), |(r, t, _)| (r, t))
}

/// The MSAC score of (R, t) on `points`: the squared Sampson residuals truncated at
/// `threshold` (normalised units), summed.
pub(super) fn msac_score(
    points: &[Correspondence],
    rotation: &Matrix3<f64>,
    translation: &Vector3<f64>,
    threshold: f64,
) -> f64 {
    let problem = Problem { points };
    Problem::robust(
        &problem.residuals(rotation, translation),
        Loss::Truncated(threshold),
    )
    .1
}

/// How the residuals are weighed: a Cauchy cost at a wide scale finds the basin (gross
/// outliers weigh next to nothing, and the points a little off it still pull); the truncated
/// quadratic (MSAC, RANSAC's own score) settles in it and ranks the starts.
#[derive(Clone, Copy)]
enum Loss {
    Cauchy(f64),
    Truncated(f64),
}

struct Problem<'a> {
    points: &'a [Correspondence],
}

impl Problem<'_> {
    /// The signed Sampson residuals of every correspondence.
    fn residuals(&self, r: &Matrix3<f64>, t: &Vector3<f64>) -> DVector<f64> {
        let e = skew(t) * r;
        DVector::from_iterator(
            self.points.len(),
            self.points.iter().map(|c| sampson_residual(&e, c)),
        )
    }

    /// Weights and cost of `residuals` under `loss`.
    fn robust(residuals: &DVector<f64>, loss: Loss) -> (DVector<f64>, f64) {
        let mut cost = 0.0;
        let weights = residuals.map(|x| match loss {
            Loss::Cauchy(scale) => {
                let u = x * x / (scale * scale);
                cost += scale * scale * u.ln_1p();
                1.0 / (1.0 + u)
            }
            Loss::Truncated(k) => {
                cost += (x * x).min(k * k);
                if x.abs() < k {
                    1.0
                } else {
                    0.0
                }
            }
        });
        (weights, cost)
    }

    /// Levenberg–Marquardt from (r, t): the rotation moves by a rotation vector, the unit
    /// translation on its tangent plane; the Jacobian by `central_jacobian`. Returns the
    /// pose and its cost.
    fn descend(
        &self,
        r: Matrix3<f64>,
        t: Vector3<f64>,
        loss: Loss,
    ) -> (Matrix3<f64>, Vector3<f64>, f64) {
        let (mut r, mut t) = (r, t);
        let mut residuals = self.residuals(&r, &t);
        let (mut weights, mut cost) = Self::robust(&residuals, loss);
        let mut lambda = 1e-3;
        for _ in 0..ITERATIONS {
            let jacobian = central_jacobian(&DVector::zeros(5), |d| {
                let (rd, td) = moved(&r, &t, &SVector::<f64, 5>::from_column_slice(d.as_slice()));
                self.residuals(&rd, &td)
            });
            let weighted =
                DMatrix::from_fn(self.points.len(), 5, |i, k| weights[i] * jacobian[(i, k)]);
            let normal: Matrix5<f64> = (weighted.transpose() * &jacobian)
                .fixed_view::<5, 5>(0, 0)
                .into();
            let gradient: SVector<f64, 5> = (weighted.transpose() * &residuals)
                .fixed_view::<5, 1>(0, 0)
                .into();
            let improved = levenberg_marquardt_step(&normal, &gradient, &mut lambda, |step| {
                let (rn, tn) = moved(&r, &t, step);
                let residuals_n = self.residuals(&rn, &tn);
                let (weights_n, cost_n) = Self::robust(&residuals_n, loss);
                let better = cost_n < cost;
                if better {
                    (r, t, residuals, weights, cost) = (rn, tn, residuals_n, weights_n, cost_n);
                }
                better
            });
            if !improved {
                break;
            }
        }
        (r, t, cost)
    }
}

/// (r, t) moved by a rotation vector d[0..3] and a tangent step d[3..5] of the unit t.
fn moved(r: &Matrix3<f64>, t: &Vector3<f64>, d: &SVector<f64, 5>) -> (Matrix3<f64>, Vector3<f64>) {
    let turn = Rotation3::new(Vector3::new(d[0], d[1], d[2])).into_inner();
    let helper = if t.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = t.cross(&helper).normalize();
    let v = t.cross(&u);
    (turn * r, (t + u * d[3] + v * d[4]).normalize())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;
    use crate::slam::rotation;

    /// A camera that walks sideways while it turns towards its motion, over a shallow scene
    /// seen through a 70° field of view, with 1.5-pixel noise at f = 171 (a 240-pixel-wide
    /// image): the refinement finds the sideways direction from a forward start.
    #[test]
    fn finds_a_sideways_motion_from_a_forward_start() {
        let mut rng = Rng(11);
        let rot = rotation::matrix(&rotation::from_rotation_vector(&Vector3::new(
            0.0, 0.3, 0.0,
        )));
        let t = Vector3::new(0.9, 0.1, 0.4).normalize();
        let noise = 1.5 / 171.0;
        let mut gauss = || (rng.unit_f64() + rng.unit_f64() + rng.unit_f64() - 1.5) * 2.0;
        let mut points = Vec::new();
        while points.len() < 150 {
            let x0 = Vector3::new(gauss() * 2.0, gauss() * 1.5, 6.0 + gauss() * 2.0);
            let x1 = rot * x0 + t;
            if x0.z < 1.0 || x1.z < 1.0 {
                continue;
            }
            let a = x0 / x0.z + Vector3::new(gauss() * noise, gauss() * noise, 0.0);
            let b = x1 / x1.z + Vector3::new(gauss() * noise, gauss() * noise, 0.0);
            points.push((a, b));
        }
        let forward = Vector3::new(0.2, 0.0, 1.0).normalize();
        let wrong_turn = rotation::matrix(&rotation::from_rotation_vector(&Vector3::new(
            0.0, 0.2, 0.0,
        )));
        let (r, found) = refine(&points, wrong_turn, forward, 1.0 / 171.0);
        let angle = found.dot(&t).abs().min(1.0).acos().to_degrees();
        assert!(angle < 10.0, "direction {found} is {angle:.1}° from {t}");
        assert!((r - rot).amax() < 0.02, "{r}");
    }
}
