//! Local bundle adjustment over the last keyframes, after the EKF update (issue 25): the
//! filter's estimate of section 2.6 is linearised once per frame, so the depths of young
//! landmarks and the poses that saw them keep the errors of the first linearisation; a short
//! window of keyframes, refined jointly with the points they see, lets the landmarks met in a
//! turn take the unit of those seen before it.
//!
//! Each keyframe keeps its pose and the pixels the update accepted (or where a landmark was
//! created). The oldest `fixed` keyframes of the window hold the gauge and the scale; the
//! others and every point seen from two keyframes with enough parallax are refined by
//! Levenberg–Marquardt on the reprojection error (eq 20 with the camera's distortion, Huber
//! weights), solved through the Schur complement of the points (Triggs et al., "Bundle
//! adjustment — a modern synthesis", 2000, §6.1). The filter then takes the refined current
//! pose as a measurement (eqs 22–24 with H the pose's rows), its covariance the window's,
//! inflated: the map follows through its correlations with the pose, and the filter's
//! covariance stays its own. Writing the refined means over the filter's, the first form,
//! made the suite worse (docs/SLAM.md).

use std::collections::{BTreeMap, HashMap, VecDeque};

use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, SMatrix, Vector2, Vector3};
use serde::{Deserialize, Serialize};

use super::camera::PinholeCamera;
use super::rotation::{self, Quat};

/// `[slam.refine]`: the local bundle adjustment over the last keyframes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RefineConfig {
    /// Keyframes in the window; 0 turns the refinement off. Default 8.
    pub keyframes: usize,
    /// Oldest keyframes of the window held fixed (at least 2: they fix the gauge and the scale).
    pub fixed: usize,
    /// A frame becomes a keyframe once the camera has turned this much since the last one,
    /// radians …
    pub rotation: f64,
    /// … or moved this fraction of the median depth of the landmarks it sees.
    pub translation: f64,
    /// Levenberg–Marquardt iterations per refinement.
    pub iterations: usize,
    /// A point is refined only when the rays of two keyframes that see it meet at this angle,
    /// radians; the others keep the filter's estimate.
    pub min_parallax: f64,
    /// Residual, pixels, beyond which an observation's weight falls as 1/residual (Huber).
    pub huber: f64,
    /// The window's covariance of the refined current pose is multiplied by this before the
    /// filter takes the pose as a measurement: the window re-uses pixels the filter has already
    /// taken, so its own covariance would count them twice, and more. Default 16 (4 to 256
    /// measured, docs/SLAM.md).
    pub measurement_inflation: f64,
}

impl Default for RefineConfig {
    fn default() -> Self {
        Self {
            keyframes: 8,
            fixed: 2,
            rotation: 0.05,
            translation: 0.05,
            iterations: 5,
            min_parallax: 0.017,
            huber: 2.0,
            measurement_inflation: 16.0,
        }
    }
}

/// One keyframe: the camera pose (camera → world) and the landmarks it measured.
#[derive(Clone, Debug)]
pub(in crate::slam) struct Keyframe {
    pub position: Vector3<f64>,
    pub orientation: Quat,
    /// (landmark id, measured pixel).
    pub observations: Vec<(u64, Vector2<f64>)>,
}

/// What one refinement did, for the log.
#[derive(Clone, Debug, PartialEq)]
pub(in crate::slam) struct Refined {
    /// Points refined (the others keep the filter's estimate).
    pub points: usize,
    /// Covariance of the newest keyframe's refined (position, rotation vector), from the
    /// window's measurements alone.
    pub newest_covariance: Option<Matrix6<f64>>,
    /// RMS reprojection error before and after, pixels.
    pub rms_before: f64,
    pub rms_after: f64,
}

/// The window of keyframes.
#[derive(Clone, Debug, Default)]
pub(in crate::slam) struct Window {
    frames: VecDeque<Keyframe>,
}

impl Window {
    /// Whether a frame at this pose, seeing its landmarks at `median_depth`, is a keyframe.
    pub fn wants(
        &self,
        position: &Vector3<f64>,
        orientation: &Quat,
        median_depth: f64,
        config: &RefineConfig,
    ) -> bool {
        let Some(last) = self.frames.back() else {
            return true;
        };
        let relative = rotation::multiply(&rotation::conjugate(&last.orientation), orientation);
        rotation::to_rotation_vector(&relative).norm() > config.rotation
            || (position - last.position).norm() > config.translation * median_depth
    }

    /// Adds a keyframe, dropping the oldest beyond the window.
    pub fn push(&mut self, keyframe: Keyframe, config: &RefineConfig) {
        self.frames.push_back(keyframe);
        while self.frames.len() > config.keyframes {
            self.frames.pop_front();
        }
    }

    /// The newest keyframe's pose.
    pub fn newest(&self) -> Option<(Vector3<f64>, Quat)> {
        self.frames.back().map(|k| (k.position, k.orientation))
    }

    /// Refines the free keyframes and the points of `points` (world positions by landmark id,
    /// the filter's estimates) seen from two keyframes with enough parallax. Refined points are
    /// written back into `points`; the others are removed from it. None when the window is
    /// not yet longer than its fixed part or no point can be refined.
    pub fn adjust(
        &mut self,
        camera: &PinholeCamera,
        points: &mut HashMap<u64, Vector3<f64>>,
        config: &RefineConfig,
    ) -> Option<Refined> {
        let fixed = config.fixed.min(self.frames.len());
        if self.frames.len() <= fixed {
            return None;
        }
        let problem = Problem::gather(&self.frames, points, config.min_parallax)?;
        let mut poses: Vec<(Vector3<f64>, Quat)> = self
            .frames
            .iter()
            .map(|k| (k.position, k.orientation))
            .collect();
        let mut xyz: Vec<Vector3<f64>> = problem.ids.iter().map(|id| points[id]).collect();
        let before = problem.cost(camera, &poses, &xyz, config.huber);
        let mut cost = before;
        let mut lambda = 1e-3;
        for _ in 0..config.iterations {
            let Some(Step {
                poses: dp,
                points: dl,
                ..
            }) = problem.step(camera, &poses, &xyz, fixed, config.huber, lambda)
            else {
                break;
            };
            let trial_poses: Vec<(Vector3<f64>, Quat)> = poses
                .iter()
                .enumerate()
                .map(|(k, &(r, q))| {
                    if k < fixed {
                        return (r, q);
                    }
                    let d = dp.fixed_rows::<6>(6 * (k - fixed));
                    let dtheta = Vector3::new(d[3], d[4], d[5]);
                    let q = rotation::multiply(&q, &rotation::from_rotation_vector(&dtheta));
                    (r + Vector3::new(d[0], d[1], d[2]), q.normalize())
                })
                .collect();
            let trial_xyz: Vec<Vector3<f64>> = xyz.iter().zip(&dl).map(|(p, d)| p + d).collect();
            let trial = problem.cost(camera, &trial_poses, &trial_xyz, config.huber);
            if trial.total < cost.total {
                poses = trial_poses;
                xyz = trial_xyz;
                let converged = cost.total - trial.total < 1e-6 * cost.total;
                cost = trial;
                lambda = (lambda * 0.1).max(1e-7);
                if converged {
                    break;
                }
            } else {
                lambda *= 10.0;
            }
        }
        let newest_covariance = problem
            .step(camera, &poses, &xyz, fixed, config.huber, 0.0)
            .map(|step| step.newest);
        for (frame, (r, q)) in self.frames.iter_mut().zip(&poses) {
            frame.position = *r;
            frame.orientation = *q;
        }
        points.clear();
        for ((id, p), &free) in problem.ids.iter().zip(&xyz).zip(&problem.free) {
            if free {
                points.insert(*id, *p);
            }
        }
        Some(Refined {
            newest_covariance,
            points: problem.free.iter().filter(|&&f| f).count(),
            rms_before: before.rms(),
            rms_after: cost.rms(),
        })
    }
}

/// Robust cost and the count of observations it sums.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cost {
    total: f64,
    squared: f64,
    count: usize,
}

impl Cost {
    fn rms(&self) -> f64 {
        (self.squared / self.count.max(1) as f64).sqrt()
    }
}

/// The points the window sees and their observations: (keyframe, point index, pixel).
/// Points without enough parallax are held at the filter's estimate: they still constrain
/// the poses (mostly their rotation).
struct Problem {
    ids: Vec<u64>,
    free: Vec<bool>,
    observations: Vec<(usize, usize, Vector2<f64>)>,
}

impl Problem {
    /// Every point the window sees; those seen from two keyframes whose rays meet at
    /// `min_parallax` at least are free.
    fn gather(
        frames: &VecDeque<Keyframe>,
        points: &HashMap<u64, Vector3<f64>>,
        min_parallax: f64,
    ) -> Option<Self> {
        let mut seen: HashMap<u64, Vec<(usize, Vector2<f64>)>> = HashMap::new();
        for (k, frame) in frames.iter().enumerate() {
            for &(id, z) in &frame.observations {
                if points.contains_key(&id) {
                    seen.entry(id).or_default().push((k, z));
                }
            }
        }
        let mut ids: Vec<u64> = seen.keys().copied().collect();
        ids.sort_unstable();
        let free: Vec<bool> = ids
            .iter()
            .map(|id| {
                let p = points[id];
                let rays: Vec<Vector3<f64>> = seen[id]
                    .iter()
                    .map(|&(k, _)| (p - frames[k].position).normalize())
                    .collect();
                rays.iter()
                    .skip(1)
                    .any(|ray| ray.dot(&rays[0]).clamp(-1.0, 1.0).acos() >= min_parallax)
            })
            .collect();
        if !free.contains(&true) {
            return None;
        }
        let mut observations = Vec::new();
        for (j, id) in ids.iter().enumerate() {
            for &(k, z) in &seen[id] {
                observations.push((k, j, z));
            }
        }
        Some(Self {
            ids,
            free,
            observations,
        })
    }

    fn cost(
        &self,
        camera: &PinholeCamera,
        poses: &[(Vector3<f64>, Quat)],
        xyz: &[Vector3<f64>],
        huber: f64,
    ) -> Cost {
        let rotations: Vec<Matrix3<f64>> = poses.iter().map(|(_, q)| rotation::matrix(q)).collect();
        let mut cost = Cost {
            total: 0.0,
            squared: 0.0,
            count: 0,
        };
        for &(k, j, z) in &self.observations {
            let h = rotations[k].transpose() * (xyz[j] - poses[k].0);
            // A point behind a camera that saw it is a failed step, never a better one.
            let e = camera.project(&h).map_or(1e6, |pixel| (z - pixel).norm());
            cost.total += huber_cost(e, huber);
            cost.squared += e * e;
            cost.count += 1;
        }
        cost
    }

    /// One damped Gauss–Newton step (pose increments of the free keyframes, stacked as
    /// (δr, δθ) with q ← q ⊗ q(δθ), and point increments), by the Schur complement.
    fn step(
        &self,
        camera: &PinholeCamera,
        poses: &[(Vector3<f64>, Quat)],
        xyz: &[Vector3<f64>],
        fixed: usize,
        huber: f64,
        lambda: f64,
    ) -> Option<Step> {
        let free = poses.len() - fixed;
        let np = 6 * free;
        let rotations: Vec<Matrix3<f64>> = poses.iter().map(|(_, q)| rotation::matrix(q)).collect();
        let mut hpp = DMatrix::<f64>::zeros(np, np);
        let mut bp = DVector::<f64>::zeros(np);
        let mut hll = vec![Matrix3::<f64>::zeros(); xyz.len()];
        let mut bl = vec![Vector3::<f64>::zeros(); xyz.len()];
        // Pose–point blocks, keyed by (free keyframe, point); ordered, so that the sums of the
        // Schur complement, and so the trajectory, are the same on every run.
        let mut hpl: BTreeMap<(usize, usize), SMatrix<f64, 6, 3>> = BTreeMap::new();
        for &(k, j, z) in &self.observations {
            let rt = rotations[k].transpose();
            let h = rt * (xyz[j] - poses[k].0);
            let Some((pixel, jp)) = camera.project_with_jacobian(&h) else {
                continue;
            };
            let e = z - pixel;
            let w = huber_weight(e.norm(), huber);
            let j_point = jp * rt;
            if self.free[j] {
                hll[j] += j_point.transpose() * j_point * w;
                bl[j] += j_point.transpose() * e * w;
            }
            if k < fixed {
                continue;
            }
            let mut j_pose = SMatrix::<f64, 2, 6>::zeros();
            j_pose.fixed_view_mut::<2, 3>(0, 0).copy_from(&(-j_point));
            j_pose
                .fixed_view_mut::<2, 3>(0, 3)
                .copy_from(&(jp * h.cross_matrix()));
            let o = 6 * (k - fixed);
            let block = j_pose.transpose() * j_pose * w;
            let mut view = hpp.fixed_view_mut::<6, 6>(o, o);
            view += block;
            let mut rhs = bp.fixed_rows_mut::<6>(o);
            rhs += j_pose.transpose() * e * w;
            if self.free[j] {
                *hpl.entry((k - fixed, j)).or_insert_with(SMatrix::zeros) +=
                    j_pose.transpose() * j_point * w;
            }
        }
        for i in 0..np {
            hpp[(i, i)] *= 1.0 + lambda;
        }
        let hll_inv: Vec<Option<Matrix3<f64>>> = hll
            .iter()
            .zip(&self.free)
            .map(|(h, &free)| {
                if !free {
                    return None;
                }
                let mut d = *h;
                for i in 0..3 {
                    d[(i, i)] *= 1.0 + lambda;
                }
                d.try_inverse()
            })
            .collect();
        // Per point, the free keyframes that see it.
        let mut by_point: Vec<Vec<(usize, SMatrix<f64, 6, 3>)>> = vec![Vec::new(); xyz.len()];
        for (&(f, j), block) in &hpl {
            by_point[j].push((f, *block));
        }
        let mut s = hpp;
        let mut rhs = bp;
        for (j, blocks) in by_point.iter().enumerate() {
            let Some(inv) = hll_inv[j] else { continue };
            for &(a, wa) in blocks {
                let wa_inv = wa * inv;
                let mut r = rhs.fixed_rows_mut::<6>(6 * a);
                r -= wa_inv * bl[j];
                for &(b, wb) in blocks {
                    let mut view = s.fixed_view_mut::<6, 6>(6 * a, 6 * b);
                    view -= wa_inv * wb.transpose();
                }
            }
        }
        let chol = s.cholesky()?;
        let dp = chol.solve(&rhs);
        let newest = chol
            .inverse()
            .fixed_view::<6, 6>(np - 6, np - 6)
            .into_owned();
        let dl = (0..xyz.len())
            .map(|j| {
                let Some(inv) = hll_inv[j] else {
                    return Vector3::zeros();
                };
                let mut b = bl[j];
                for &(a, wa) in &by_point[j] {
                    b -= wa.transpose() * dp.fixed_rows::<6>(6 * a);
                }
                inv * b
            })
            .collect();
        Some(Step {
            poses: dp,
            points: dl,
            newest,
        })
    }
}

/// One damped Gauss–Newton step and the covariance it gives the newest keyframe's pose.
struct Step {
    /// (δr, δθ) of each free keyframe.
    poses: DVector<f64>,
    points: Vec<Vector3<f64>>,
    /// Covariance of the newest keyframe's (δr, δθ), from the reduced camera system.
    newest: Matrix6<f64>,
}

fn huber_weight(e: f64, delta: f64) -> f64 {
    if e <= delta {
        1.0
    } else {
        delta / e
    }
}

fn huber_cost(e: f64, delta: f64) -> f64 {
    if e <= delta {
        e * e
    } else {
        2.0 * delta * e - delta * delta
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Keyframes on an arc around a cloud of points, each seeing every point exactly; the
    /// free ones and the points then disturbed.
    fn scene() -> (PinholeCamera, Vec<Keyframe>, HashMap<u64, Vector3<f64>>) {
        let camera = PinholeCamera::ideal(400.0, 400.0, 320.0, 240.0, 640, 480);
        let truth: Vec<Vector3<f64>> = (0..40)
            .map(|i| {
                let a = i as f64 * 0.7;
                Vector3::new(1.5 * a.sin(), 0.8 * (1.3 * a).cos(), 4.0 + (2.1 * a).sin())
            })
            .collect();
        let frames: Vec<Keyframe> = (0..6)
            .map(|k| {
                let position = Vector3::new(0.15 * k as f64, 0.02 * k as f64, 0.0);
                let orientation = rotation::from_rotation_vector(&Vector3::new(
                    0.0,
                    -0.02 * k as f64,
                    0.01 * k as f64,
                ));
                let rt = rotation::matrix(&orientation).transpose();
                let observations = truth
                    .iter()
                    .enumerate()
                    .filter_map(|(id, p)| {
                        Some((id as u64, camera.project(&(rt * (p - position)))?))
                    })
                    .collect();
                Keyframe {
                    position,
                    orientation,
                    observations,
                }
            })
            .collect();
        let points = truth
            .iter()
            .enumerate()
            .map(|(i, p)| (i as u64, *p))
            .collect();
        (camera, frames, points)
    }

    #[test]
    fn refinement_brings_disturbed_poses_and_points_back() {
        let (camera, frames, truth) = scene();
        let config = RefineConfig {
            keyframes: 6,
            iterations: 20,
            ..RefineConfig::default()
        };
        let mut window = Window::default();
        for (k, mut frame) in frames.clone().into_iter().enumerate() {
            if k >= 2 {
                frame.position += Vector3::new(0.02, -0.01, 0.015) * k as f64;
                frame.orientation = rotation::multiply(
                    &frame.orientation,
                    &rotation::from_rotation_vector(&Vector3::new(0.004, 0.003, -0.002)),
                );
            }
            window.push(frame, &config);
        }
        let mut points: HashMap<u64, Vector3<f64>> = truth
            .iter()
            .map(|(&id, p)| {
                (
                    id,
                    p + Vector3::new(0.05, -0.04, 0.1) * ((id % 3) as f64 - 1.0),
                )
            })
            .collect();
        let refined = window
            .adjust(&camera, &mut points, &config)
            .expect("refined");
        assert_eq!(refined.points, 40);
        assert!(refined.rms_before > 5.0, "{refined:?}");
        assert!(refined.rms_after < 0.01, "{refined:?}");
        for (frame, truth) in window.frames.iter().zip(&frames) {
            assert!((frame.position - truth.position).norm() < 1e-4);
        }
        for (id, p) in &points {
            assert!((p - truth[id]).norm() < 1e-3, "point {id}");
        }
    }

    #[test]
    fn an_outlier_observation_does_not_drag_the_rest() {
        let (camera, mut frames, truth) = scene();
        frames[4].observations[3].1 += Vector2::new(40.0, -30.0);
        let config = RefineConfig {
            keyframes: 6,
            iterations: 20,
            ..RefineConfig::default()
        };
        let mut window = Window::default();
        for frame in frames.clone() {
            window.push(frame, &config);
        }
        let mut points = truth.clone();
        window
            .adjust(&camera, &mut points, &config)
            .expect("refined");
        for (frame, truth) in window.frames.iter().zip(&frames) {
            assert!((frame.position - truth.position).norm() < 0.01);
        }
    }

    #[test]
    fn keyframes_follow_rotation_and_translation() {
        let config = RefineConfig {
            keyframes: 8,
            ..RefineConfig::default()
        };
        let mut window = Window::default();
        let q0 = rotation::identity();
        assert!(window.wants(&Vector3::zeros(), &q0, 2.0, &config));
        window.push(
            Keyframe {
                position: Vector3::zeros(),
                orientation: q0,
                observations: Vec::new(),
            },
            &config,
        );
        assert!(!window.wants(&Vector3::new(0.05, 0.0, 0.0), &q0, 2.0, &config));
        assert!(window.wants(&Vector3::new(0.11, 0.0, 0.0), &q0, 2.0, &config));
        let turned = rotation::from_rotation_vector(&Vector3::new(0.0, 0.06, 0.0));
        assert!(window.wants(&Vector3::zeros(), &turned, 2.0, &config));
    }
}
