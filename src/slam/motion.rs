//! Motion models for the prediction step (eqs 15–16): the constant-velocity model of a
//! hand-held camera, the same model for a camera on a wheeled vehicle with the vehicle's
//! non-holonomic constraint, and the wheel-odometry model of a robot, where u_k is the
//! measured relative motion between two frames.
//!
//! Each returns the predicted camera state, its Jacobian F w.r.t. the previous camera state,
//! and the process noise Q, all restricted to the camera block (landmarks are static, so the
//! full F is the identity outside it). The wheeled model adds [`constraint`]: pseudo-
//! measurements of the camera block that the filter takes after every prediction.

use nalgebra::{DMatrix, DVector, Matrix3, SMatrix, SVector, Vector3};
use serde::{Deserialize, Serialize};

use super::rotation::{self, Quat};

/// Which motion model drives the prediction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields)]
pub enum MotionModel {
    /// Camera state (r, q, v, ω), 13 entries; unknown accelerations as white noise. A key
    /// left out of `[slam.motion.constant-velocity]` keeps its default.
    ConstantVelocity {
        /// Standard deviation of the linear acceleration, map units/s² (default 1).
        #[serde(default = "default_linear_acceleration")]
        linear_acceleration: f64,
        /// Standard deviation of the angular acceleration, rad/s² (default 6).
        #[serde(default = "default_angular_acceleration")]
        angular_acceleration: f64,
    },
    /// A camera on a wheeled robot or a car, looking forward with its axes along the
    /// vehicle's (x right, y down, z forward): the constant-velocity state plus the camera's
    /// arm d ahead of the vertical axis the vehicle turns about (14 entries), and the
    /// vehicle's motion as pseudo-measurements after every prediction (see
    /// [`WheeledMotion`]). An in-place turn then moves the camera sideways by d·ω, tied to the
    /// turn instead of free, and d, once seen in a turn, carries the map's unit to the next.
    Wheeled(WheeledMotion),
    /// Camera state (r, q), 7 entries; motion measured by wheel odometry (u_k of eq 15). A
    /// key left out of `[slam.motion.odometry]` keeps its default.
    Odometry {
        /// Translation noise as a fraction of the distance travelled (default 0.05).
        #[serde(default = "default_odometry_fraction")]
        translation_fraction: f64,
        /// Rotation noise as a fraction of the angle turned (default 0.05).
        #[serde(default = "default_odometry_fraction")]
        rotation_fraction: f64,
        /// Floor on the translation noise per step, metres (default 0.002).
        #[serde(default = "default_odometry_floor")]
        translation_floor: f64,
        /// Floor on the rotation noise per step, radians (default 0.002).
        #[serde(default = "default_odometry_floor")]
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
            linear_acceleration: default_linear_acceleration(),
            angular_acceleration: default_angular_acceleration(),
        }
    }
}

/// The hand-held model's linear acceleration, map units/s² ([`MotionModel::hand_held`]).
/// Measured on the suite's walks and rooms: walk-3 rendered with four rays a pixel 2.00% →
/// 0.63% (scale drift 1.332 → 1.069); 4 gives 0.73%.
pub const HAND_HELD_LINEAR_ACCELERATION: f64 = 2.0;

fn default_linear_acceleration() -> f64 {
    1.0
}

fn default_angular_acceleration() -> f64 {
    6.0
}

fn default_odometry_fraction() -> f64 {
    0.05
}

fn default_odometry_floor() -> f64 {
    0.002
}

/// `[slam.motion.wheeled]`: a vehicle's constant velocity, held in its own frame so that it
/// turns with the vehicle ([`predict`]), with the vehicle's constraints.
/// The camera's velocity u = R(q)ᵀ v and angular velocity ω in its own frame obey, within the
/// standard deviations below (map units as the velocities'):
/// u_x = d·ω_y (no side slip: the only sideways motion is the arm's swing in a turn),
/// u_y = 0 (no vertical motion), ω_x = ω_z = 0 (no pitch or roll rate).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WheeledMotion {
    /// Standard deviation of the linear acceleration, map units/s² (as the constant-velocity
    /// model's).
    pub linear_acceleration: f64,
    /// Standard deviation of the angular acceleration, rad/s².
    pub angular_acceleration: f64,
    /// Standard deviation of the sideways velocity the arm does not explain (slip, a camera
    /// yawed on its mount), map units/s. Default 0.01: at 0.05 the rover's turns lose the
    /// unit again (docs/SLAM.md).
    pub slip: f64,
    /// Standard deviation of the vertical velocity, map units/s. Default 0.1: a camera
    /// pitched by 1–2° on a car at speed moves this much along its own y axis (at 0.01 the
    /// KITTI clips lost accuracy).
    pub vertical: f64,
    /// Standard deviation of the pitch and roll rates, rad/s. Default 0.5, a weak bound: a
    /// vehicle's vibration turns the camera by a few milliradians at 5–15 Hz (0.2–0.4 rad/s);
    /// at 0.02 the rover's tracking broke.
    pub tilt_rate: f64,
    /// Prior standard deviation of the arm d, map units (its prior mean is 0: the camera on
    /// the turning axis). A map's unit is about half the median depth of the first view.
    pub arm_sigma: f64,
    /// The camera rides at a fixed height over flat ground it can see: that height is learnt
    /// in the map's unit and holds the ground's landmarks to it, which keeps the map's unit
    /// (`ground.rs`), and landmarks met below the horizon while the vehicle turns in place
    /// start where their ray meets the ground (docs/SLAM.md); `false` when the camera cannot
    /// see the ground it drives on, or the ground is not flat. Default true.
    pub ground_prior: bool,
}

impl Default for WheeledMotion {
    fn default() -> Self {
        Self {
            linear_acceleration: 1.0,
            angular_acceleration: 6.0,
            slip: 0.01,
            vertical: 0.1,
            tilt_rate: 0.5,
            arm_sigma: 0.5,
            ground_prior: true,
        }
    }
}

impl MotionModel {
    /// The default wheeled-vehicle model.
    pub fn wheeled() -> Self {
        MotionModel::Wheeled(WheeledMotion::default())
    }

    /// The constant-velocity model for a camera carried by hand (`steernav slam --hand-held`):
    /// a linear acceleration of [`HAND_HELD_LINEAR_ACCELERATION`] map units/s² instead of 1,
    /// so that the speed follows a walker who speeds up through a turn, while the landmarks
    /// in view are renewed, instead of the map's unit shrinking to the lagging speed
    /// (docs/SLAM.md, "What walk-3's turns lose"). On a car it follows the road's jolts into
    /// the unit, which is why it is not the default.
    pub fn hand_held() -> Self {
        MotionModel::ConstantVelocity {
            linear_acceleration: HAND_HELD_LINEAR_ACCELERATION,
            angular_acceleration: default_angular_acceleration(),
        }
    }

    /// The default odometry model.
    pub fn odometry() -> Self {
        MotionModel::Odometry {
            translation_fraction: default_odometry_fraction(),
            rotation_fraction: default_odometry_fraction(),
            translation_floor: default_odometry_floor(),
            rotation_floor: default_odometry_floor(),
        }
    }

    /// Number of camera-state entries: 13, 15 or 7.
    pub fn camera_dim(&self) -> usize {
        match self {
            MotionModel::ConstantVelocity { .. } => 13,
            MotionModel::Wheeled(_) => 15,
            MotionModel::Odometry { .. } => 7,
        }
    }

    /// Whether the state carries the velocities (r, q, v, ω, …): the model learns the motion
    /// from the images rather than from odometry.
    pub fn has_velocity(&self) -> bool {
        self.camera_dim() >= 13
    }
}

/// Index of the wheeled model's arm d in the camera state.
pub const ARM: usize = 13;

/// Index of the wheeled model's camera height over the ground, H, in the camera state
/// (`super::ground`); held by the prediction.
pub const GROUND: usize = 14;

/// The wheeled model's pseudo-measurements of a camera state: the constraint values c(x)
/// (zero when the motion obeys them), ∂c/∂x over the camera block, and the standard deviation
/// of each. `None` for the other models.
pub fn constraint(
    model: &MotionModel,
    camera: &DVector<f64>,
) -> Option<(DVector<f64>, DMatrix<f64>, DVector<f64>)> {
    let MotionModel::Wheeled(w) = model else {
        return None;
    };
    let n = model.camera_dim();
    let q = Quat::new(camera[3], camera[4], camera[5], camera[6]);
    let v = Vector3::new(camera[7], camera[8], camera[9]);
    let omega = Vector3::new(camera[10], camera[11], camera[12]);
    let arm = camera[ARM];
    let rt = rotation::matrix(&q).transpose();
    let u = rt * v;
    let du_dq = rotation::d_rotate_transpose_dq(&q, &v);
    let value = DVector::from_vec(vec![u.x - arm * omega.y, u.y, omega.x, omega.z]);
    let mut h = DMatrix::<f64>::zeros(4, n);
    for row in 0..2 {
        for k in 0..4 {
            h[(row, 3 + k)] = du_dq[(row, k)];
        }
        for k in 0..3 {
            h[(row, 7 + k)] = rt[(row, k)];
        }
    }
    // The arm is held here: it is learnt from the steps' displacements (`step_constraint`).
    h[(0, 11)] = -arm;
    h[(2, 10)] = 1.0;
    h[(3, 12)] = 1.0;
    let sigma = DVector::from_vec(vec![w.slip, w.vertical, w.tilt_rate, w.tilt_rate]);
    Some((value, h, sigma))
}

/// Entries of the state that the wheeled model's open step copies: the previous frame's
/// position r₀ and orientation q₀ (stochastic cloning).
pub const STEP_COPY: usize = 7;

/// The step's residuals of [`step_constraint`], in the frame midway between the step's two
/// orientations: the sideways displacement less the arm's swing, and the vertical one.
fn step_residual(r: &Vector3<f64>, q: &Quat, r0: &Vector3<f64>, q0: &Quat, arm: f64) -> [f64; 2] {
    let (q, q0) = (q.normalize(), q0.normalize());
    let q = if q.dot(&q0) < 0.0 { -q } else { q };
    // The slerp midpoint of q₀ and q.
    let mid = rotation::matrix(&(q0 + q).normalize()).transpose();
    let delta = mid * (r - r0);
    let swing = mid * ((rotation::matrix(&q) - rotation::matrix(&q0)) * Vector3::z());
    [delta.x - arm * swing.x, delta.y]
}

/// The wheeled model's constraints on one step's displacement, for a state x whose entries
/// from `origin` hold the previous frame's position r₀ and orientation q₀ ([`STEP_COPY`]).
/// The vehicle's turning axis moves only along its heading, and over a step of constant turn
/// rate its chord lies along the heading midway through the step; the camera rides on the arm
/// d ahead of the axis. So in the midway frame R_m (the slerp midpoint of q₀ and q) the step's
/// sideways displacement is the arm's swing, R_mᵀ(r − r₀)·e_x = d·R_mᵀ(R(q) − R(q₀))·e_z·e_x,
/// and its vertical displacement none. This holds on a car's bend as in an in-place turn (the
/// end frame sees a car's chord turned by half the step's rotation), and takes the step's
/// rotation from the orientations the measurements fixed, not from the angular velocity the
/// motion model holds. Returns the values, the entries of x they depend on (r, q, d, r₀, q₀)
/// and the Jacobian over those entries (by central differences). With `learn_arm` false the arm
/// is held (its column is zero): outside a clear turn the swing says nothing of d, but its
/// linearisation about a noisy turn would let the filter believe it learns d on every
/// straight step.
pub fn step_constraint(
    x: &DVector<f64>,
    origin: usize,
    learn_arm: bool,
) -> (DVector<f64>, Vec<usize>, DMatrix<f64>) {
    let columns: Vec<usize> = (0..7)
        .chain([ARM])
        .chain(origin..origin + STEP_COPY)
        .collect();
    // The entries in `columns`' order: r, q, d, r₀, q₀.
    let residual = |e: &DVector<f64>| {
        let [sideways, vertical] = step_residual(
            &Vector3::new(e[0], e[1], e[2]),
            &Quat::new(e[3], e[4], e[5], e[6]),
            &Vector3::new(e[8], e[9], e[10]),
            &Quat::new(e[11], e[12], e[13], e[14]),
            e[7],
        );
        DVector::from_vec(vec![sideways, vertical])
    };
    let entries = DVector::from_iterator(columns.len(), columns.iter().map(|&c| x[c]));
    let mut h = central_jacobian(&entries, residual);
    if !learn_arm {
        h.column_mut(7).fill(0.0);
    }
    (residual(&entries), columns, h)
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
        MotionModel::Wheeled(WheeledMotion {
            linear_acceleration,
            angular_acceleration,
            ..
        }) => {
            let next = wheeled_step(camera, dt);
            let f = central_jacobian(camera, |c| wheeled_step(c, dt));
            let qn = impulse_covariance(&f, linear_acceleration, angular_acceleration, dt);
            (next, f, qn)
        }
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
            let qn = impulse_covariance(&f, linear_acceleration, angular_acceleration, dt);
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

/// The process noise of the velocity models: unknown accelerations as impulses V = a·dt and
/// Ω = α·dt, which enter the state like v and ω, so G = ∂f/∂(V, Ω) = F[:, v, ω] and
/// Q = G·diag((a·dt)², (α·dt)²)·Gᵀ (zero on the wheeled model's arm, a constant).
fn impulse_covariance(f: &DMatrix<f64>, linear: f64, angular: f64, dt: f64) -> DMatrix<f64> {
    let g = f.columns(7, 6);
    let mut noise = DMatrix::<f64>::zeros(6, 6);
    for i in 0..3 {
        noise[(i, i)] = (linear * dt).powi(2);
        noise[(i + 3, i + 3)] = (angular * dt).powi(2);
    }
    g * noise * g.transpose()
}

/// The wheeled model's prediction: a vehicle keeps its velocity in its own frame, u = R(q)ᵀv,
/// and turns at a constant ω, so its velocity turns with it and a step's chord runs along
/// the heading midway through the step (the world-frame constant velocity of a hand-held
/// camera would send it along the heading it started the step with, sideways to the arc a
/// vehicle drives). The arm is a constant.
fn wheeled_step(camera: &DVector<f64>, dt: f64) -> DVector<f64> {
    let r = Vector3::new(camera[0], camera[1], camera[2]);
    let q = Quat::new(camera[3], camera[4], camera[5], camera[6]);
    let v = Vector3::new(camera[7], camera[8], camera[9]);
    let w = Vector3::new(camera[10], camera[11], camera[12]);
    let u = rotation::matrix(&q).transpose() * v;
    let midway = rotation::multiply(&q, &rotation::from_rotation_vector(&(w * (0.5 * dt))));
    let q_next = rotation::multiply(&q, &rotation::from_rotation_vector(&(w * dt)));
    let mut next = camera.clone();
    next.fixed_rows_mut::<3>(0)
        .copy_from(&(r + rotation::matrix(&midway) * u * dt));
    next.fixed_rows_mut::<4>(3).copy_from(&q_next);
    next.fixed_rows_mut::<3>(7)
        .copy_from(&(rotation::matrix(&q_next) * u));
    next
}

/// One Levenberg–Marquardt step: the normal equations damped by `lambda` (on their
/// diagonal, Marquardt's scaling) are solved and the step offered to `accept`, which keeps it
/// when it lowers the cost. λ shrinks tenfold after a kept step and grows tenfold after each
/// refused one; `false` when none was kept before λ reached 1e8.
pub(super) fn levenberg_marquardt_step<const N: usize>(
    normal: &SMatrix<f64, N, N>,
    gradient: &SVector<f64, N>,
    lambda: &mut f64,
    mut accept: impl FnMut(&SVector<f64, N>) -> bool,
) -> bool {
    while *lambda < 1e8 {
        let mut damped = *normal;
        for k in 0..N {
            damped[(k, k)] += *lambda * normal[(k, k)].max(1e-12);
        }
        if let Some(step) = damped.cholesky().map(|c| c.solve(&(-gradient))) {
            if accept(&step) {
                *lambda = (*lambda * 0.1).max(1e-9);
                return true;
            }
        }
        *lambda *= 10.0;
    }
    false
}

/// The Jacobian of `f` at `x` by central differences (steps of 10⁻⁶ relative to each entry,
/// at least 10⁻⁶): for the smooth, cheap functions of a few entries the wheeled model adds,
/// and the two-view refinement's five.
pub(super) fn central_jacobian(
    x: &DVector<f64>,
    f: impl Fn(&DVector<f64>) -> DVector<f64>,
) -> DMatrix<f64> {
    let rows = f(x).len();
    let mut j = DMatrix::<f64>::zeros(rows, x.len());
    let mut probe = x.clone();
    for c in 0..x.len() {
        let e = 1e-6 * x[c].abs().max(1.0);
        probe[c] = x[c] + e;
        let up = f(&probe);
        probe[c] = x[c] - e;
        let down = f(&probe);
        probe[c] = x[c];
        j.set_column(c, &((up - down) / (2.0 * e)));
    }
    j
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
        if model.has_velocity() {
            x.fixed_rows_mut::<6>(7)
                .copy_from_slice(&[0.3, -0.1, 0.2, 0.4, -0.3, 0.1]);
        }
        if n > ARM {
            x[ARM] = 0.15;
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
    fn wheeled_jacobian_and_constraint_jacobian_match_finite_differences() {
        let model = MotionModel::wheeled();
        jacobian_check(&model, None);
        let mut x = DVector::zeros(14);
        x.fixed_rows_mut::<4>(3)
            .copy_from(&rotation::from_rotation_vector(&Vector3::new(
                0.2, -0.1, 0.3,
            )));
        x.fixed_rows_mut::<7>(7)
            .copy_from_slice(&[0.3, -0.1, 0.2, 0.4, -0.3, 0.1, 0.15]);
        let (_, h, sigma) = constraint(&model, &x).unwrap();
        assert!(sigma.iter().all(|&s| s > 0.0));
        let central = |f: &dyn Fn(&DVector<f64>) -> DVector<f64>, c: usize| {
            let (mut a, mut b) = (x.clone(), x.clone());
            a[c] += 1e-6;
            b[c] -= 1e-6;
            (f(&a) - f(&b)) / 2e-6
        };
        // The velocity constraint holds the arm (its column is zero); every other column is
        // the derivative.
        for c in (0..14).filter(|&c| c != ARM) {
            let fd = central(&|y| constraint(&model, y).unwrap().0, c);
            assert!((fd - h.column(c)).amax() < 1e-6, "column {c}");
        }
        assert_eq!(h.column(ARM).amax(), 0.0);
        // The step constraint, with the previous pose appended at 14..21.
        let mut x = x.clone().resize_vertically(21, 0.0);
        x.fixed_rows_mut::<3>(14)
            .copy_from_slice(&[-0.05, 0.02, -0.1]);
        x.fixed_rows_mut::<4>(17)
            .copy_from(&rotation::from_rotation_vector(&Vector3::new(
                0.18, -0.15, 0.31,
            )));
        let (_, columns, h) = step_constraint(&x, 14, true);
        for (k, &c) in columns.iter().enumerate() {
            let (mut a, mut b) = (x.clone(), x.clone());
            a[c] += 1e-5;
            b[c] -= 1e-5;
            let fd = (step_constraint(&a, 14, true).0 - step_constraint(&b, 14, true).0) / 2e-5;
            assert!((fd - h.column(k)).amax() < 1e-6, "column {c}");
        }
        let (_, _, held) = step_constraint(&x, 14, false);
        assert_eq!(held.column(7).amax(), 0.0, "the arm is held outside a turn");
        let x = x.rows(0, 14).into_owned();
        assert!(constraint(&MotionModel::default(), &x.rows(0, 13).into_owned()).is_none());
    }

    #[test]
    fn a_camera_ahead_of_the_turning_axis_obeys_the_wheeled_constraint() {
        // A vehicle turning left in place about the world's vertical (−y) axis, the camera
        // 0.3 units ahead of the axis: its world velocity is the arm's swing.
        let (arm, rate) = (0.3, 0.8);
        let heading = 0.4;
        let q = rotation::from_rotation_vector(&Vector3::new(0.0, -heading, 0.0));
        let forward = rotation::matrix(&q) * Vector3::z();
        let up = -Vector3::y();
        let v = up.cross(&forward) * (rate * arm);
        // Yawing left about −y is a rotation of −rate about the camera's own y axis.
        let mut x = DVector::zeros(14);
        x.fixed_rows_mut::<4>(3).copy_from(&q);
        x.fixed_rows_mut::<3>(7).copy_from(&v);
        x[11] = -rate;
        x[ARM] = arm;
        let (value, _, _) = constraint(&MotionModel::wheeled(), &x).unwrap();
        assert!(value.amax() < 1e-12, "{value}");
        x[ARM] = 0.0;
        let (value, _, _) = constraint(&MotionModel::wheeled(), &x).unwrap();
        assert!((value[0].abs() - rate * arm).abs() < 1e-12, "{value}");
    }

    #[test]
    fn a_camera_on_a_turning_vehicle_obeys_the_step_constraint_on_a_bend_and_in_place() {
        // The vehicle's axis drives along a circle (or turns in place, speed 0) about the
        // world's vertical, the camera 0.3 units ahead of it; a step of 0.1 s at 0.8 rad/s.
        let (arm, rate, dt) = (0.3, 0.8, 0.1);
        for speed in [0.0, 2.0] {
            let pose = |t: f64| {
                let heading = 0.4 + rate * t;
                // Yawing about −y; the axis moves along the heading, on a circle of
                // radius speed / rate.
                let q = rotation::from_rotation_vector(&Vector3::new(0.0, -heading, 0.0));
                let radius = speed / rate;
                let centre = Vector3::new(1.0, 0.5, -2.0);
                let axis = centre + radius * Vector3::new(heading.cos(), 0.0, heading.sin())
                    - radius * Vector3::new(0.4f64.cos(), 0.0, 0.4f64.sin());
                (axis + rotation::matrix(&q) * Vector3::new(0.0, 0.0, arm), q)
            };
            let ((r0, q0), (r1, q1)) = (pose(0.0), pose(dt));
            let mut x = DVector::zeros(21);
            x.fixed_rows_mut::<3>(0).copy_from(&r1);
            x.fixed_rows_mut::<4>(3).copy_from(&q1);
            x[ARM] = arm;
            x.fixed_rows_mut::<3>(14).copy_from(&r0);
            x.fixed_rows_mut::<4>(17).copy_from(&q0);
            let (value, _, _) = step_constraint(&x, 14, true);
            assert!(value.amax() < 1e-12, "speed {speed}: {value}");
            // Seen from the step's end, a car's chord is turned by half the step's rotation:
            // there it is not the arm's swing, −d·sin(ω·dt) (ω about the camera's y is −rate),
            // but off by the speed's 0.2 units times half the 0.08 rad turned.
            let end = rotation::matrix(&q1).transpose() * (r1 - r0);
            let off = end.x + arm * (rate * dt).sin();
            assert!(speed == 0.0 || (off - 0.2 * 0.04).abs() < 1e-3, "{end}");
        }
    }

    #[test]
    fn the_wheeled_prediction_follows_a_vehicle_around_its_bend() {
        // A car at 2 units/s on a bend of 0.8 rad/s, the camera on its turning axis, from a
        // state whose velocity and turn rate are the true ones: the wheeled prediction lands
        // on the arc; the hand-held model's goes on along the first heading.
        let (speed, rate, dt) = (2.0, 0.8, 0.1);
        let radius = speed / rate;
        let pose = |t: f64| {
            let heading = rate * t;
            let r = radius * Vector3::new(heading.cos() - 1.0, 0.0, heading.sin());
            (
                r,
                rotation::from_rotation_vector(&Vector3::new(0.0, -heading, 0.0)),
            )
        };
        let ((r0, q0), (r1, q1)) = (pose(0.0), pose(dt));
        let mut x = DVector::zeros(14);
        x.fixed_rows_mut::<3>(0).copy_from(&r0);
        x.fixed_rows_mut::<4>(3).copy_from(&q0);
        x.fixed_rows_mut::<3>(7)
            .copy_from(&(rotation::matrix(&q0) * Vector3::z() * speed));
        x[11] = -rate;
        let (next, _, _) = predict(&MotionModel::wheeled(), &x, dt, None);
        let miss = (next.fixed_rows::<3>(0) - r1).norm();
        assert!(miss < 1e-4, "{miss}");
        assert!((next.fixed_rows::<4>(3) - q1).amax() < 1e-12);
        let (straight, _, _) = predict(
            &MotionModel::default(),
            &x.rows(0, 13).into_owned(),
            dt,
            None,
        );
        assert!((straight.fixed_rows::<3>(0) - r1).norm() > 0.25 * speed * dt * rate * dt);
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
