//! Motion models for the prediction step (eqs 15–16): the constant-velocity model of a
//! hand-held camera and the wheel-odometry model of a robot, where u_k is the measured
//! relative motion between two frames.
//!
//! Both return the predicted camera state, its Jacobian F w.r.t. the previous camera state,
//! and the process noise Q, all restricted to the camera block (landmarks are static, so the
//! full F is the identity outside it).

use nalgebra::{DMatrix, DVector, Matrix3, SMatrix, Vector3};
use serde::{Deserialize, Serialize};

use super::rotation::{self, Quat};

/// Which motion model drives the prediction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields)]
pub enum MotionModel {
    /// Camera state (r, q, v, ω), 13 entries; unknown accelerations as white noise.
    ConstantVelocity {
        /// Standard deviation of the linear acceleration, m/s².
        linear_acceleration: f64,
        /// Standard deviation of the angular acceleration, rad/s².
        angular_acceleration: f64,
    },
    /// Camera state (r, q), 7 entries; motion measured by wheel odometry (u_k of eq 15).
    Odometry {
        /// Translation noise as a fraction of the distance travelled.
        translation_fraction: f64,
        /// Rotation noise as a fraction of the angle turned.
        rotation_fraction: f64,
        /// Floor on the translation noise per step, metres.
        translation_floor: f64,
        /// Floor on the rotation noise per step, radians.
        rotation_floor: f64,
    },
}

impl Default for MotionModel {
    fn default() -> Self {
        // In map units: a monocular map's scale follows the inverse-depth prior (median depth
        // 1/ρ₀ = 2 units), so a car at 12 m/s among 15 m depths moves 1.6 units/s and a
        // hand-held camera in a room about 0.3. 1 unit/s² covers both; 4 let the predictions
        // of a car wander by tens of pixels (CHANGELOG, issue 10).
        MotionModel::ConstantVelocity {
            linear_acceleration: 1.0,
            angular_acceleration: 6.0,
        }
    }
}

impl MotionModel {
    /// The default odometry model.
    pub fn odometry() -> Self {
        MotionModel::Odometry {
            translation_fraction: 0.05,
            rotation_fraction: 0.05,
            translation_floor: 0.002,
            rotation_floor: 0.002,
        }
    }

    /// Number of camera-state entries: 13 or 7.
    pub fn camera_dim(&self) -> usize {
        match self {
            MotionModel::ConstantVelocity { .. } => 13,
            MotionModel::Odometry { .. } => 7,
        }
    }
}

/// One relative motion measured by odometry, in the previous camera frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometryStep {
    /// Translation, metres, in the previous camera frame.
    pub translation: Vector3<f64>,
    /// Rotation vector, radians, in the previous camera frame.
    pub rotation: Vector3<f64>,
}

/// Eq 15–16 for the camera block: the new camera state, F and Q.
pub fn predict(
    model: &MotionModel,
    camera: &DVector<f64>,
    dt: f64,
    odometry: Option<&OdometryStep>,
) -> (DVector<f64>, DMatrix<f64>, DMatrix<f64>) {
    let n = model.camera_dim();
    let r = Vector3::new(camera[0], camera[1], camera[2]);
    let q = Quat::new(camera[3], camera[4], camera[5], camera[6]);
    let mut next = camera.clone();
    let mut f = DMatrix::<f64>::identity(n, n);
    match *model {
        MotionModel::ConstantVelocity {
            linear_acceleration,
            angular_acceleration,
        } => {
            let v = Vector3::new(camera[7], camera[8], camera[9]);
            let w = Vector3::new(camera[10], camera[11], camera[12]);
            let dq = rotation::from_rotation_vector(&(w * dt));
            let q_next = rotation::multiply(&q, &dq);
            next.fixed_rows_mut::<3>(0).copy_from(&(r + v * dt));
            next.fixed_rows_mut::<4>(3).copy_from(&q_next);
            // ∂r'/∂v, ∂q'/∂q, ∂q'/∂ω.
            f.view_mut((0, 7), (3, 3))
                .copy_from(&(Matrix3::identity() * dt));
            f.view_mut((3, 3), (4, 4))
                .copy_from(&rotation::d_multiply_d_left(&dq));
            let dq_dw: SMatrix<f64, 4, 3> =
                rotation::d_multiply_d_right(&q) * rotation::d_from_rotation_vector(&(w * dt)) * dt;
            f.view_mut((3, 10), (4, 3)).copy_from(&dq_dw);
            // Impulses V = a·dt, Ω = α·dt enter like v and ω: G = ∂f/∂(V, Ω) = F[:, v, ω].
            let mut g = DMatrix::<f64>::zeros(13, 6);
            g.view_mut((0, 0), (3, 3))
                .copy_from(&(Matrix3::identity() * dt));
            g.view_mut((3, 3), (4, 3)).copy_from(&dq_dw);
            g.view_mut((7, 0), (6, 6))
                .copy_from(&DMatrix::<f64>::identity(6, 6));
            let mut noise = DMatrix::<f64>::zeros(6, 6);
            for i in 0..3 {
                noise[(i, i)] = (linear_acceleration * dt).powi(2);
                noise[(i + 3, i + 3)] = (angular_acceleration * dt).powi(2);
            }
            let qn = &g * noise * g.transpose();
            (next, f, qn)
        }
        MotionModel::Odometry {
            translation_fraction,
            rotation_fraction,
            translation_floor,
            rotation_floor,
        } => {
            let step = odometry.copied().unwrap_or(OdometryStep {
                translation: Vector3::zeros(),
                rotation: Vector3::zeros(),
            });
            let rot = rotation::matrix(&q);
            let dq = rotation::from_rotation_vector(&step.rotation);
            next.fixed_rows_mut::<3>(0)
                .copy_from(&(r + rot * step.translation));
            next.fixed_rows_mut::<4>(3)
                .copy_from(&rotation::multiply(&q, &dq));
            f.view_mut((0, 3), (3, 4))
                .copy_from(&rotation::d_rotate_dq(&q, &step.translation));
            f.view_mut((3, 3), (4, 4))
                .copy_from(&rotation::d_multiply_d_left(&dq));
            let mut g = DMatrix::<f64>::zeros(7, 6);
            g.view_mut((0, 0), (3, 3)).copy_from(&rot);
            g.view_mut((3, 3), (4, 3)).copy_from(
                &(rotation::d_multiply_d_right(&q)
                    * rotation::d_from_rotation_vector(&step.rotation)),
            );
            let st = translation_fraction * step.translation.norm() + translation_floor;
            let sr = rotation_fraction * step.rotation.norm() + rotation_floor;
            let mut noise = DMatrix::<f64>::zeros(6, 6);
            for i in 0..3 {
                noise[(i, i)] = st * st;
                noise[(i + 3, i + 3)] = sr * sr;
            }
            let qn = &g * noise * g.transpose();
            (next, f, qn)
        }
    }
}

/// The odometry step between two absolute poses (r, q) of the odometry's own frame.
pub fn relative_motion(r0: &Vector3<f64>, q0: &Quat, r1: &Vector3<f64>, q1: &Quat) -> OdometryStep {
    OdometryStep {
        translation: rotation::matrix(q0).transpose() * (r1 - r0),
        rotation: rotation::to_rotation_vector(&rotation::multiply(&rotation::conjugate(q0), q1)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn jacobian_check(model: &MotionModel, odometry: Option<&OdometryStep>) {
        let n = model.camera_dim();
        let q = rotation::from_rotation_vector(&Vector3::new(0.2, -0.1, 0.3));
        let mut x = DVector::zeros(n);
        x.fixed_rows_mut::<3>(0)
            .copy_from(&Vector3::new(0.5, -0.2, 1.0));
        x.fixed_rows_mut::<4>(3).copy_from(&q);
        if n == 13 {
            x.fixed_rows_mut::<6>(7)
                .copy_from_slice(&[0.3, -0.1, 0.2, 0.4, -0.3, 0.1]);
        }
        let (_, f, qn) = predict(model, &x, 0.05, odometry);
        for c in 0..n {
            let (mut a, mut b) = (x.clone(), x.clone());
            a[c] += 1e-6;
            b[c] -= 1e-6;
            let fd = (predict(model, &a, 0.05, odometry).0 - predict(model, &b, 0.05, odometry).0)
                / 2e-6;
            assert!((fd - f.column(c)).amax() < 1e-6, "column {c}");
        }
        assert!((&qn - qn.transpose()).amax() < 1e-15);
        assert!(qn.diagonal().iter().all(|&d| d >= 0.0));
    }

    #[test]
    fn constant_velocity_jacobian_matches_finite_differences() {
        jacobian_check(&MotionModel::default(), None);
    }

    #[test]
    fn odometry_jacobian_matches_and_relative_motion_round_trips() {
        let step = OdometryStep {
            translation: Vector3::new(0.1, 0.0, 0.3),
            rotation: Vector3::new(0.0, 0.2, 0.01),
        };
        jacobian_check(&MotionModel::odometry(), Some(&step));
        let r0 = Vector3::new(1.0, 2.0, 3.0);
        let q0 = rotation::from_rotation_vector(&Vector3::new(0.3, 0.2, -0.1));
        let r1 = r0 + rotation::matrix(&q0) * step.translation;
        let q1 = rotation::multiply(&q0, &rotation::from_rotation_vector(&step.rotation));
        let back = relative_motion(&r0, &q0, &r1, &q1);
        assert!((back.translation - step.translation).amax() < 1e-12);
        assert!((back.rotation - step.rotation).amax() < 1e-12);
    }
}
