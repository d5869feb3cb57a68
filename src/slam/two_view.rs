//! Two-view geometry for starting the filter on a moving camera: the essential matrix from
//! normalised correspondences (eight-point algorithm inside RANSAC, Sampson distance), its
//! decomposition into rotation and translation direction chosen by cheirality, and the
//! triangulated depths; and a second hypothesis, the motion refined on the Sampson distances
//! from several starting directions (`two_view_refine.rs`), which the start tries beside the
//! first (`tracker/trial.rs`). Not an equation of the paper: the paper starts the filter at
//! rest (v = 0, eq 15), which a car driving at 12 m/s from the first frame contradicts by tens
//! of standard deviations, and the first updates then explain forward motion with rotation.

use nalgebra::{Matrix3, SMatrix, SymmetricEigen, Vector3};

use super::rotation::skew;
use super::two_view_refine::refine;
use crate::rng::Rng;

/// The relative motion of the second camera: a point X₀ in the first camera's frame is at
/// X₁ = R·X₀ + t in the second's, with |t| = 1.
#[derive(Clone, Debug)]
pub struct RelativePose {
    /// Rotation from the first camera's frame to the second's.
    pub rotation: Matrix3<f64>,
    /// Unit translation (second camera's frame).
    pub translation: Vector3<f64>,
    /// Which correspondences agree with the motion and lie in front of both cameras.
    pub inliers: Vec<bool>,
    /// Depth of each inlier in the second camera for |t| = 1 (0 for outliers).
    pub depths: Vec<f64>,
    /// Parallax of each inlier, radians: the angle between its two rays once the rotation is
    /// removed (0 for outliers).
    pub parallax: Vec<f64>,
}

/// Normalised image points (x/z, y/z) of the two views.
pub type Correspondence = (Vector3<f64>, Vector3<f64>);

fn essential_from(
    points: &[Correspondence],
    pick: impl Iterator<Item = usize>,
) -> Option<Matrix3<f64>> {
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    let mut count = 0;
    for i in pick {
        let (a, b) = &points[i];
        let row = SMatrix::<f64, 9, 1>::from_column_slice(&[
            b.x * a.x,
            b.x * a.y,
            b.x,
            b.y * a.x,
            b.y * a.y,
            b.y,
            a.x,
            a.y,
            1.0,
        ]);
        ata += row * row.transpose();
        count += 1;
    }
    if count < 8 {
        return None;
    }
    let eigen = SymmetricEigen::new(ata);
    let smallest = eigen.eigenvalues.imin();
    let e = eigen.eigenvectors.column(smallest);
    let e = Matrix3::new(e[0], e[1], e[2], e[3], e[4], e[5], e[6], e[7], e[8]);
    // Project onto the essential manifold: singular values (1, 1, 0).
    let svd = e.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    Some(u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.0)) * v_t)
}

/// The squared Sampson distance of a correspondence to the essential matrix `e`.
fn sampson(e: &Matrix3<f64>, c: &Correspondence) -> f64 {
    sampson_residual(e, c).powi(2)
}

/// The signed Sampson residual: the epipolar error bᵀE·a over its first-order spread.
pub(super) fn sampson_residual(e: &Matrix3<f64>, (a, b): &Correspondence) -> f64 {
    let ea = e * a;
    let etb = e.transpose() * b;
    b.dot(&ea)
        / (ea.x * ea.x + ea.y * ea.y + etb.x * etb.x + etb.y * etb.y)
            .max(1e-30)
            .sqrt()
}

/// Depths (d₀, d₁) with d₁·b = R·(d₀·a) + t, by least squares; `None` when the rays are
/// parallel.
fn triangulate(
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
) -> Option<(f64, f64)> {
    let ra = r * a;
    // [ra, -b] [d0, d1]ᵀ = -t, normal equations.
    let (aa, ab, bb) = (ra.dot(&ra), -ra.dot(b), b.dot(b));
    let (ta, tb) = (-ra.dot(t), b.dot(t));
    let det = aa * bb - ab * ab;
    if det.abs() < 1e-12 * aa * bb {
        return None;
    }
    Some(((ta * bb - ab * tb) / det, (aa * tb - ab * ta) / det))
}

/// Estimates the relative pose from normalised correspondences. `threshold` is the largest
/// Sampson distance of an inlier in normalised units (pixels / focal length).
pub fn relative_pose(
    points: &[Correspondence],
    threshold: f64,
    iterations: usize,
    rng: &mut Rng,
) -> Option<RelativePose> {
    let n = points.len();
    if n < 8 {
        return None;
    }
    let t2 = threshold * threshold;
    let inliers_of =
        |e: &Matrix3<f64>| -> Vec<bool> { points.iter().map(|c| sampson(e, c) < t2).collect() };
    let mut best: Option<(usize, Vec<bool>)> = None;
    let mut needed = iterations;
    let mut done = 0;
    while done < needed {
        done += 1;
        let mut sample = [0usize; 8];
        let mut k = 0;
        while k < 8 {
            let i = (rng.next_u64() % n as u64) as usize;
            if !sample[..k].contains(&i) {
                sample[k] = i;
                k += 1;
            }
        }
        let Some(e) = essential_from(points, sample.iter().copied()) else {
            continue;
        };
        let inliers = inliers_of(&e);
        let count = inliers.iter().filter(|&&b| b).count();
        if best.as_ref().is_none_or(|(c, _)| count > *c) {
            // Adaptive count for 99% confidence of one all-inlier sample of eight.
            let w = (count as f64 / n as f64).powi(8);
            if w > 0.0 {
                let adaptive = ((0.01f64).ln() / (1.0 - w).ln().min(-1e-12)).ceil();
                needed = needed.min(adaptive.max(1.0) as usize);
            }
            best = Some((count, inliers));
        }
    }
    let (_, mut inliers) = best?;
    // Refit on every inlier, twice.
    let mut e = Matrix3::zeros();
    for _ in 0..2 {
        e = essential_from(points, (0..n).filter(|&i| inliers[i]))?;
        inliers = inliers_of(&e);
    }
    let svd = e.svd(true, true);
    let (mut u, mut v_t) = (svd.u?, svd.v_t?);
    if u.determinant() < 0.0 {
        u = -u;
    }
    if v_t.determinant() < 0.0 {
        v_t = -v_t;
    }
    let w = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
    let t_dir: Vector3<f64> = u.column(2).into_owned();
    let mut chosen: Option<(usize, Matrix3<f64>, Vector3<f64>)> = None;
    for r in [u * w * v_t, u * w.transpose() * v_t] {
        for t in [t_dir, -t_dir] {
            let front = (0..n)
                .filter(|&i| inliers[i])
                .filter(|&i| {
                    triangulate(&r, &t, &points[i].0, &points[i].1)
                        .is_some_and(|(d0, d1)| d0 > 0.0 && d1 > 0.0)
                })
                .count();
            if chosen.as_ref().is_none_or(|(c, _, _)| front > *c) {
                chosen = Some((front, r, t));
            }
        }
    }
    let (_, rotation, translation) = chosen?;
    Some(with_motion(points, rotation, translation, &inliers))
}

/// The motion refined from several starting directions (`two_view_refine.rs`), when it lands
/// more than [`DISTINCT_DIRECTION`] from `pose`'s direction: a second hypothesis for the
/// start to try beside the eight-point one. `None` when the search agrees with it.
pub fn searched_alternative(
    points: &[Correspondence],
    pose: &RelativePose,
    threshold: f64,
) -> Option<RelativePose> {
    let (r, t) = refine(points, pose.rotation, pose.translation, threshold);
    let e = skew(&t) * r;
    let t2 = threshold * threshold;
    let inliers: Vec<bool> = points.iter().map(|c| sampson(&e, c) < t2).collect();
    // The Sampson cost does not see the translation's sign: cheirality chooses it.
    let front = |t: &Vector3<f64>| {
        (0..points.len())
            .filter(|&i| inliers[i])
            .filter(|&i| {
                triangulate(&r, t, &points[i].0, &points[i].1)
                    .is_some_and(|(d0, d1)| d0 > 0.0 && d1 > 0.0)
            })
            .count()
    };
    let t = if front(&-t) > front(&t) { -t } else { t };
    let apart = t.dot(&pose.translation).clamp(-1.0, 1.0).acos();
    (apart > DISTINCT_DIRECTION).then(|| with_motion(points, r, t, &inliers))
}

/// Directions closer than this (radians) are one hypothesis, not two.
const DISTINCT_DIRECTION: f64 = 0.087;

/// The pose of a motion: its inliers in front of both cameras, their depths and parallax.
fn with_motion(
    points: &[Correspondence],
    rotation: Matrix3<f64>,
    translation: Vector3<f64>,
    agree: &[bool],
) -> RelativePose {
    let n = points.len();
    let mut inliers = agree.to_vec();
    let mut depths = vec![0.0; n];
    let mut parallax = vec![0.0; n];
    for i in 0..n {
        if !inliers[i] {
            continue;
        }
        let (a, b) = &points[i];
        match triangulate(&rotation, &translation, a, b) {
            Some((d0, d1)) if d0 > 0.0 && d1 > 0.0 => {
                depths[i] = d1 * b.z;
                let ra = (rotation * a).normalize();
                parallax[i] = ra.dot(&b.normalize()).clamp(-1.0, 1.0).acos();
            }
            _ => inliers[i] = false,
        }
    }
    RelativePose {
        rotation,
        translation,
        inliers,
        depths,
        parallax,
    }
}

/// Where two rays come closest: the distance along the first from its centre, and the angle
/// between the rays (the parallax). The directions must be unit vectors. `None` when the rays
/// are (nearly) parallel or the point lies behind either centre.
pub fn closest_approach(
    centre0: &Vector3<f64>,
    direction0: &Vector3<f64>,
    centre1: &Vector3<f64>,
    direction1: &Vector3<f64>,
) -> Option<(f64, f64)> {
    let cos = direction0.dot(direction1).clamp(-1.0, 1.0);
    let denominator = 1.0 - cos * cos;
    if denominator < 1e-12 {
        return None;
    }
    let w = centre0 - centre1;
    let (d, e) = (direction0.dot(&w), direction1.dot(&w));
    let along0 = (cos * e - d) / denominator;
    let along1 = (e - cos * d) / denominator;
    (along0 > 0.0 && along1 > 0.0).then(|| (along0, cos.acos()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::rotation;

    #[test]
    fn closest_approach_meets_at_the_point_and_refuses_parallel_or_backward_rays() {
        let point = Vector3::new(1.0, -0.5, 12.0);
        let (c0, c1) = (Vector3::new(0.0, 0.0, 2.0), Vector3::new(0.3, 0.1, 0.0));
        let (d0, d1) = ((point - c0).normalize(), (point - c1).normalize());
        let (distance, parallax) = closest_approach(&c0, &d0, &c1, &d1).expect("rays meet");
        assert!((distance - (point - c0).norm()).abs() < 1e-9, "{distance}");
        assert!((parallax - d0.dot(&d1).acos()).abs() < 1e-12);
        assert!(
            closest_approach(&c0, &d0, &c1, &d0).is_none(),
            "parallel rays"
        );
        assert!(
            closest_approach(&c0, &(-d0), &c1, &(-d1)).is_none(),
            "behind both"
        );
    }

    #[test]
    fn recovers_a_forward_motion_with_a_turn_despite_outliers() {
        let mut rng = Rng(7);
        let rot = rotation::matrix(&rotation::from_rotation_vector(&Vector3::new(
            0.01, 0.08, -0.02,
        )));
        let t = Vector3::new(0.1, -0.05, -1.0).normalize();
        let mut points = Vec::new();
        for i in 0..80 {
            let x0 = Vector3::new(
                rng.unit_f64() * 16.0 - 8.0,
                rng.unit_f64() * 4.0 - 2.0,
                4.0 + rng.unit_f64() * 40.0,
            );
            let x1 = rot * x0 + t;
            let mut b = x1 / x1.z;
            if i % 5 == 0 {
                b.x += 0.05 + rng.unit_f64() * 0.1;
            }
            points.push((x0 / x0.z, b));
        }
        let pose = relative_pose(&points, 1.0 / 700.0, 200, &mut rng).expect("pose");
        assert!((pose.rotation - rot).amax() < 1e-6, "{}", pose.rotation);
        assert!((pose.translation - t).norm() < 1e-6, "{}", pose.translation);
        for (i, &inlier) in pose.inliers.iter().enumerate() {
            assert_eq!(inlier, i % 5 != 0, "point {i}");
        }
        let x0 = points[1].0 * 1.0;
        assert!(pose.depths[1] > 0.0 && x0.z > 0.0);
        // The search from an exact fit stays in its basin: no second hypothesis.
        assert!(searched_alternative(&points, &pose, 1.0 / 700.0).is_none());
    }
}
