//! The pose of one camera from known points and their normalised image coordinates
//! (resection, perspective-n-point), refined by Levenberg–Marquardt on the reprojection error
//! with a Huber cost. Not an equation of the paper: the start uses it to place the frames it
//! reported while it waited for two views (`tracker/start.rs`), once those views have fixed
//! the points.

use nalgebra::{DVector, Matrix3, Vector3};

use super::motion::{central_jacobian, levenberg_marquardt_step};
use super::rotation::{self, Quat};

/// Levenberg–Marquardt iterations.
const ITERATIONS: usize = 15;
/// Fewest points to resect from.
const MIN_POINTS: usize = 6;

/// The camera pose (centre, camera → world orientation) that brings `points` (world) onto
/// `rays` (normalised image coordinates x/z, y/z), from `position` and `orientation`;
/// `focal` (pixels) turns the residuals into pixels, `huber` their threshold. `None` with
/// fewer than six points, or when the residuals' root mean square after the refinement
/// exceeds `max_rms` pixels.
pub(crate) fn resect(
    points: &[Vector3<f64>],
    rays: &[(f64, f64)],
    position: Vector3<f64>,
    orientation: Quat,
    focal: f64,
    huber: f64,
    max_rms: f64,
) -> Option<(Vector3<f64>, Quat)> {
    if points.len() < MIN_POINTS || points.len() != rays.len() {
        return None;
    }
    let residuals = |r: &Matrix3<f64>, c: &Vector3<f64>| -> DVector<f64> {
        let mut out = DVector::zeros(2 * points.len());
        for (i, (x, (u, v))) in points.iter().zip(rays).enumerate() {
            let p = r.transpose() * (x - c);
            // Behind the camera: a large, smooth residual instead of a division by ~0.
            let z = p.z.max(1e-3);
            out[2 * i] = focal * (p.x / z - u);
            out[2 * i + 1] = focal * (p.y / z - v);
        }
        out
    };
    let moved = |r: &Matrix3<f64>, c: &Vector3<f64>, d: &DVector<f64>| {
        let turn = rotation::matrix(&rotation::from_rotation_vector(&Vector3::new(
            d[0], d[1], d[2],
        )));
        (turn * r, c + Vector3::new(d[3], d[4], d[5]))
    };
    let cost_of = |res: &DVector<f64>| -> (DVector<f64>, f64) {
        let mut cost = 0.0;
        let weights = DVector::from_iterator(
            res.len() / 2,
            (0..res.len() / 2).map(|i| {
                let e = res[2 * i].hypot(res[2 * i + 1]);
                if e <= huber {
                    cost += e * e;
                    1.0
                } else {
                    cost += huber * (2.0 * e - huber);
                    huber / e
                }
            }),
        );
        (weights, cost)
    };
    let (mut r, mut c) = (rotation::matrix(&orientation), position);
    let mut res = residuals(&r, &c);
    let (mut weights, mut cost) = cost_of(&res);
    let mut lambda = 1e-3;
    for _ in 0..ITERATIONS {
        let j = central_jacobian(&DVector::zeros(6), |d| {
            let (rd, cd) = moved(&r, &c, d);
            residuals(&rd, &cd)
        });
        let mut normal = nalgebra::Matrix6::<f64>::zeros();
        let mut gradient = nalgebra::Vector6::<f64>::zeros();
        for row in 0..res.len() {
            let w = weights[row / 2];
            let jr = j.row(row).transpose();
            let jr = nalgebra::Vector6::from_iterator(jr.iter().copied());
            normal += w * jr * jr.transpose();
            gradient += w * res[row] * jr;
        }
        let improved = levenberg_marquardt_step(&normal, &gradient, &mut lambda, |step| {
            let step = DVector::from_iterator(6, step.iter().copied());
            let (rn, cn) = moved(&r, &c, &step);
            let res_n = residuals(&rn, &cn);
            let (weights_n, cost_n) = cost_of(&res_n);
            let better = cost_n < cost;
            if better {
                (r, c, res, weights, cost) = (rn, cn, res_n, weights_n, cost_n);
            }
            better
        });
        if !improved {
            break;
        }
    }
    let rms = (res.norm_squared() / points.len() as f64).sqrt();
    (rms <= max_rms).then(|| (c, rotation::from_matrix(&r)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// Points 2–8 m in front of a camera that moved and turned: the resection from the
    /// starting pose finds the true one, and refuses a set of points that fits no pose.
    #[test]
    fn resects_a_moved_camera_and_refuses_nonsense() {
        let mut rng = Rng(5);
        let orientation = rotation::from_rotation_vector(&Vector3::new(0.05, 0.3, -0.02));
        let centre = Vector3::new(0.4, -0.1, 0.3);
        let r = rotation::matrix(&orientation);
        let mut points = Vec::new();
        let mut rays = Vec::new();
        while points.len() < 40 {
            let p = Vector3::new(
                rng.unit_f64() * 4.0 - 2.0,
                rng.unit_f64() * 3.0 - 1.5,
                2.0 + rng.unit_f64() * 6.0,
            );
            let x = r * p + centre;
            points.push(x);
            rays.push((p.x / p.z, p.y / p.z));
        }
        let start = rotation::from_rotation_vector(&Vector3::zeros());
        let (c, q) =
            resect(&points, &rays, Vector3::zeros(), start, 300.0, 2.0, 1.0).expect("a pose");
        assert!((c - centre).norm() < 1e-4, "{c}");
        assert!((rotation::matrix(&q) - r).amax() < 1e-5);
        let scrambled: Vec<(f64, f64)> = rays.iter().rev().copied().collect();
        assert!(resect(
            &points,
            &scrambled,
            Vector3::zeros(),
            start,
            300.0,
            2.0,
            1.0
        )
        .is_none());
    }
}
