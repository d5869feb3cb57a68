//! The extended Kalman filter of section 2.6: state x = [camera, y₁ … yₙ] (eq 14), prediction
//! (eqs 15–16) and update (eqs 17–24) exploiting the sparsity of H. The bookkeeping that keeps
//! the state small (landmarks added from one observation, converted from inverse depth to
//! Euclidean, deleted) is in `super::landmarks`.
//!
//! The update never forms the dense H. Each observation's rows touch only the camera pose (7
//! columns) and its landmark (6 or 3), so P Hᵀ costs O(n·m), S = H P Hᵀ + R costs O(m²), and
//! the covariance update P ← P − W Wᵀ with W = P Hᵀ L⁻ᵀ (S = L Lᵀ, Cholesky) is the only
//! O(n²·m) term. Computing it as one product W Wᵀ keeps P exactly symmetric (each entry and its
//! mirror are the same sum of the same products), and the Cholesky factor makes it the
//! numerically stable form of eq 24's (I − K H) P.

use nalgebra::{DMatrix, DVector, Matrix2, Matrix6, SMatrix, Vector2, Vector3};

use super::camera::PinholeCamera;
use super::inverse_depth::{self, Parametrisation, Prediction};
use super::motion::{self, MotionModel, OdometryStep};
use super::rotation::{self, Quat};
use super::wheeled;

/// Where a landmark lives in the state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slot {
    /// Stable identifier of the landmark.
    pub id: u64,
    /// Parametrisation.
    pub kind: Parametrisation,
    /// Index of its first entry in x.
    pub offset: usize,
}

/// One matched observation ready for the update.
#[derive(Clone, Debug)]
pub struct Observation {
    /// Index into [`Filter::slots`].
    pub slot: usize,
    /// Measured pixel z.
    pub pixel: Vector2<f64>,
    /// Prediction h(x) with its Jacobians, at the current state.
    pub prediction: Prediction,
}

/// Why an update was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UpdateError {
    /// The innovation covariance is not positive definite (the state is inconsistent).
    #[error("innovation covariance is not positive definite")]
    NotPositiveDefinite,
}

/// The filter: state, covariance and landmark slots. Outside `slam` they are read only, through
/// the accessors; the tracker changes them through the filter's own operations.
#[derive(Clone, Debug)]
pub struct Filter {
    pub(in crate::slam) camera: PinholeCamera,
    pub(in crate::slam) motion: MotionModel,
    pub(in crate::slam) x: DVector<f64>,
    pub(in crate::slam) p: DMatrix<f64>,
    pub(in crate::slam) slots: Vec<Slot>,
    /// Pixel noise standard deviation (R = σ² I per observation).
    pub(in crate::slam) pixel_sigma: f64,
    pub(in crate::slam) next_id: u64,
    /// The wheeled model's open step: where the copy of the previous frame's pose sits
    /// (the last `motion::STEP_COPY` entries of x) and the step's duration, until it is closed
    /// (`slam::wheeled`).
    pub(in crate::slam) step: Option<(usize, f64)>,
}

/// Where the two-view start puts the camera, with the variances it gives each part: the
/// filter is seated there and the camera's old correlations are dropped.
#[derive(Clone, Debug)]
pub(in crate::slam) struct Seat {
    pub position: Vector3<f64>,
    pub orientation: Quat,
    /// Variance of each position coordinate, m².
    pub position_variance: f64,
    /// Variance of each quaternion entry.
    pub orientation_variance: f64,
    /// Linear velocity, m/s, and the variance of each coordinate (constant velocity only).
    pub velocity: Vector3<f64>,
    pub velocity_variance: f64,
    /// Angular velocity, rad/s, and the variance of each coordinate (constant velocity only).
    pub angular_velocity: Vector3<f64>,
    pub angular_velocity_variance: f64,
}

/// The pose entries (r, q) are the first 7 of the camera state in every motion model.
pub const POSE: usize = 7;

impl Filter {
    /// A filter at the origin, looking along +z, with a small velocity prior.
    pub fn new(
        camera: PinholeCamera,
        motion: MotionModel,
        pixel_sigma: f64,
        velocity_sigma: f64,
        angular_velocity_sigma: f64,
    ) -> Self {
        let n = motion.camera_dim();
        let mut x = DVector::zeros(n);
        x.fixed_rows_mut::<4>(3).copy_from(&rotation::identity());
        let mut p = DMatrix::zeros(n, n);
        // The first pose defines the world frame; a tiny variance keeps P well conditioned.
        for i in 0..POSE {
            p[(i, i)] = 1e-12;
        }
        if motion.has_velocity() {
            for i in 7..10 {
                p[(i, i)] = velocity_sigma * velocity_sigma;
                p[(i + 3, i + 3)] = angular_velocity_sigma * angular_velocity_sigma;
            }
        }
        if let Some(variance) = wheeled::arm_variance(&motion) {
            p[(motion::ARM, motion::ARM)] = variance;
        }
        Self {
            camera,
            motion,
            x,
            p,
            slots: Vec::new(),
            pixel_sigma,
            next_id: 0,
            step: None,
        }
    }

    /// State dimension.
    pub fn dim(&self) -> usize {
        self.x.len()
    }

    /// The state vector x (eq 14): camera, then the landmarks in slot order.
    pub fn state(&self) -> &DVector<f64> {
        &self.x
    }

    /// The covariance P of the state.
    pub fn covariance(&self) -> &DMatrix<f64> {
        &self.p
    }

    /// The landmarks, in state order.
    pub fn slots(&self) -> &[Slot] {
        &self.slots
    }

    /// The camera model.
    pub fn camera(&self) -> &PinholeCamera {
        &self.camera
    }

    /// The motion model.
    pub fn motion(&self) -> &MotionModel {
        &self.motion
    }

    /// Puts the camera at `seat`: its entries of x are replaced, its rows and columns of P
    /// are cleared (the old map's correlations with the camera no longer hold) and given the
    /// seat's variances.
    pub(in crate::slam) fn seat(&mut self, seat: &Seat) {
        self.close_step();
        let c = self.motion.camera_dim();
        let n = self.dim();
        self.x.as_mut_slice()[0..3].copy_from_slice(seat.position.as_slice());
        self.x.as_mut_slice()[3..7].copy_from_slice(seat.orientation.as_slice());
        self.p.view_mut((0, 0), (c, n)).fill(0.0);
        self.p.view_mut((0, 0), (n, c)).fill(0.0);
        for i in 0..3 {
            self.p[(i, i)] = seat.position_variance;
        }
        for i in 3..POSE {
            self.p[(i, i)] = seat.orientation_variance;
        }
        if let Some(variance) = wheeled::arm_variance(&self.motion) {
            // The arm keeps its estimate; the start fixes the map's unit, so its prior
            // (in map units) starts afresh.
            self.p[(motion::ARM, motion::ARM)] = variance;
        }
        if self.motion.has_velocity() {
            self.x.as_mut_slice()[7..10].copy_from_slice(seat.velocity.as_slice());
            self.x.as_mut_slice()[10..13].copy_from_slice(seat.angular_velocity.as_slice());
            for i in 7..10 {
                self.p[(i, i)] = seat.velocity_variance;
                self.p[(i + 3, i + 3)] = seat.angular_velocity_variance;
            }
        }
    }

    /// Updates the state with a measurement of the camera's pose: `position` and
    /// `orientation` with the covariance `covariance` of (position, rotation vector δθ, where
    /// q = q̂ ⊗ q(δθ)). The map follows the pose through its correlations with it.
    pub(in crate::slam) fn update_pose(
        &mut self,
        position: &Vector3<f64>,
        orientation: &Quat,
        covariance: &Matrix6<f64>,
    ) -> Result<(), UpdateError> {
        let q = self.orientation();
        let measured = if orientation.dot(&q) < 0.0 {
            -orientation
        } else {
            *orientation
        };
        // ∂q/∂δθ at δθ = 0: half the vector columns of q ⊗ (1, δθ/2).
        let mut j = SMatrix::<f64, POSE, 6>::zeros();
        for i in 0..3 {
            j[(i, i)] = 1.0;
        }
        let right = rotation::d_multiply_d_right(&measured);
        j.fixed_view_mut::<4, 3>(3, 3)
            .copy_from(&(right.fixed_view::<4, 3>(0, 1) * 0.5));
        // The norm direction of q is not measured: a small variance keeps S definite.
        let r = j * covariance * j.transpose() + SMatrix::<f64, POSE, POSE>::identity() * 1e-10;
        let mut nu = DVector::<f64>::zeros(POSE);
        nu.fixed_rows_mut::<3>(0)
            .copy_from(&(position - self.position()));
        nu.fixed_rows_mut::<4>(3).copy_from(&(measured - q));
        let pose: Vec<usize> = (0..POSE).collect();
        self.update_columns(
            &nu,
            &pose,
            &DMatrix::identity(POSE, POSE),
            &DMatrix::from_iterator(POSE, POSE, r.iter().copied()),
        )
    }

    /// Eqs 22–24 for a measurement that touches the entries `columns` of x alone: innovation
    /// `nu`, Jacobian `h` over those entries, noise covariance `r`. The rest of the state
    /// follows through its correlations with them.
    pub(in crate::slam) fn update_columns(
        &mut self,
        nu: &DVector<f64>,
        columns: &[usize],
        h: &DMatrix<f64>,
        r: &DMatrix<f64>,
    ) -> Result<(), UpdateError> {
        let m = h.nrows();
        let n = self.dim();
        let mut pht = DMatrix::<f64>::zeros(n, m);
        for (k, &col) in columns.iter().enumerate() {
            pht.ger(1.0, &self.p.column(col), &h.column(k), 1.0);
        }
        let mut s = r.clone();
        for (k, &col) in columns.iter().enumerate() {
            s.ger(1.0, &h.column(k), &pht.row(col).transpose(), 1.0);
        }
        let chol =
            nalgebra::Cholesky::new(symmetric(&s)).ok_or(UpdateError::NotPositiveDefinite)?;
        let l_inv = chol
            .l()
            .solve_lower_triangular(&DMatrix::identity(m, m))
            .ok_or(UpdateError::NotPositiveDefinite)?;
        let w = &pht * l_inv.transpose();
        let white = &l_inv * nu;
        self.x.gemv(1.0, &w, &white, 1.0);
        let wt = w.transpose();
        subtract_symmetric_product(&mut self.p, &w, &wt);
        self.normalize_quaternion();
        Ok(())
    }

    /// Drops the correlations between the camera and the map, keeping both marginals: the
    /// pose is about to be measured afresh against the map (relocalisation).
    pub(in crate::slam) fn decorrelate_camera(&mut self) {
        self.discard_step();
        let c = self.motion.camera_dim();
        let n = self.dim();
        if n > c {
            self.p.view_mut((0, c), (c, n - c)).fill(0.0);
            self.p.view_mut((c, 0), (n - c, c)).fill(0.0);
        }
    }

    /// Covariance of the pose as (position, rotation vector), 6×6: J P Jᵀ over the (r, q)
    /// block, with δθ = 2 Im(q* ⊗ δq).
    pub fn pose_covariance(&self) -> Matrix6<f64> {
        let (w, v) = (self.x[3], Vector3::new(self.x[4], self.x[5], self.x[6]));
        let mut j = SMatrix::<f64, 6, POSE>::zeros();
        for i in 0..3 {
            j[(i, i)] = 1.0;
        }
        // Rows 3..6: 2·[−v | w·I − [v]×].
        let skew = v.cross_matrix();
        for r in 0..3 {
            j[(3 + r, 3)] = -2.0 * v[r];
            for c in 0..3 {
                let identity = if r == c { w } else { 0.0 };
                j[(3 + r, 4 + c)] = 2.0 * (identity - skew[(r, c)]);
            }
        }
        let block = self.p.fixed_view::<POSE, POSE>(0, 0);
        j * block * j.transpose()
    }

    /// Camera position r.
    pub fn position(&self) -> Vector3<f64> {
        Vector3::new(self.x[0], self.x[1], self.x[2])
    }

    /// Camera orientation q (camera → world).
    pub fn orientation(&self) -> Quat {
        Quat::new(self.x[3], self.x[4], self.x[5], self.x[6])
    }

    /// Parameters of landmark `slot`.
    pub fn landmark(&self, slot: usize) -> &[f64] {
        let s = self.slots[slot];
        &self.x.as_slice()[s.offset..s.offset + s.kind.dim()]
    }

    /// Euclidean position of landmark `slot` (None for an inverse-depth point at or past infinity).
    pub fn landmark_point(&self, slot: usize) -> Option<Vector3<f64>> {
        let y = self.landmark(slot);
        match self.slots[slot].kind {
            Parametrisation::Euclidean => Some(Vector3::new(y[0], y[1], y[2])),
            Parametrisation::InverseDepth if y[5] > 1e-9 => Some(inverse_depth::to_euclidean(y).0),
            Parametrisation::InverseDepth => None,
        }
    }

    /// 3×3 covariance of landmark `slot`'s Euclidean position (first order for inverse depth).
    pub fn landmark_covariance(&self, slot: usize) -> Option<nalgebra::Matrix3<f64>> {
        let s = self.slots[slot];
        match s.kind {
            Parametrisation::Euclidean => {
                Some(self.p.fixed_view::<3, 3>(s.offset, s.offset).into_owned())
            }
            Parametrisation::InverseDepth => {
                let y = self.landmark(slot);
                if y[5] <= 1e-9 {
                    return None;
                }
                let (_, j) = inverse_depth::to_euclidean(y);
                let block = self.p.fixed_view::<6, 6>(s.offset, s.offset);
                Some(j * block * j.transpose())
            }
        }
    }

    /// Eqs 15–16: propagates the camera block through the motion model.
    pub fn predict(&mut self, dt: f64, odometry: Option<&OdometryStep>) {
        self.open_step(dt);
        let c = self.motion.camera_dim();
        let n = self.dim();
        let camera = self.x.rows(0, c).into_owned();
        let (next, f, q) = motion::predict(&self.motion, &camera, dt, odometry);
        self.x.rows_mut(0, c).copy_from(&next);
        let pcc = &f * self.p.view((0, 0), (c, c)) * f.transpose() + q;
        self.p.view_mut((0, 0), (c, c)).copy_from(&symmetric(&pcc));
        if n > c {
            let pcy = &f * self.p.view((0, c), (c, n - c));
            self.p.view_mut((0, c), (c, n - c)).copy_from(&pcy);
            self.p
                .view_mut((c, 0), (n - c, c))
                .copy_from(&pcy.transpose());
        }
        self.constrain_motion();
    }

    /// Eqs 17–21 for landmark `slot` at the current state.
    pub fn predict_observation(&self, slot: usize) -> Option<Prediction> {
        let s = self.slots[slot];
        inverse_depth::predict(
            &self.camera,
            s.kind,
            self.landmark(slot),
            &self.position(),
            &self.orientation(),
        )
    }

    /// P Hᵀ for one observation (n×2), from the pose columns and the landmark's columns only.
    fn p_ht(
        &self,
        slot: usize,
        prediction: &Prediction,
    ) -> nalgebra::OMatrix<f64, nalgebra::Dyn, nalgebra::U2> {
        let s = self.slots[slot];
        let d = s.kind.dim();
        let hp = prediction.d_pose;
        let hl = prediction.d_landmark.columns(0, d).into_owned();
        self.p.columns(0, POSE) * hp.transpose() + self.p.columns(s.offset, d) * hl.transpose()
    }

    /// Eq 27: S = H P Hᵀ + R for one landmark.
    pub fn innovation_covariance(&self, slot: usize, prediction: &Prediction) -> Matrix2<f64> {
        let s = self.slots[slot];
        let d = s.kind.dim();
        let hp = prediction.d_pose;
        let hl = prediction.d_landmark.columns(0, d).into_owned();
        let ppp = self.p.fixed_view::<7, 7>(0, 0);
        let ppl = self.p.view((0, s.offset), (POSE, d));
        let pll = self.p.view((s.offset, s.offset), (d, d));
        let cross = hp * ppl * hl.transpose();
        let s2 = hp * ppp * hp.transpose() + cross + cross.transpose() + &hl * pll * hl.transpose();
        Matrix2::new(s2[(0, 0)], s2[(0, 1)], s2[(1, 0)], s2[(1, 1)])
            + Matrix2::identity() * self.pixel_sigma * self.pixel_sigma
    }

    /// The state after updating with one observation alone, covariance untouched — the
    /// hypothesis of 1-point RANSAC.
    pub fn single_observation_state(&self, obs: &Observation) -> Option<DVector<f64>> {
        let pht = self.p_ht(obs.slot, &obs.prediction);
        let s = self.innovation_covariance(obs.slot, &obs.prediction);
        let s_inv = s.try_inverse()?;
        let nu = obs.pixel - obs.prediction.pixel;
        Some(&self.x + pht * (s_inv * nu))
    }

    /// Eqs 22–24 with all `observations` stacked; the quaternion is renormalised afterwards.
    pub fn update(&mut self, observations: &[Observation]) -> Result<(), UpdateError> {
        if observations.is_empty() {
            return Ok(());
        }
        let m2 = 2 * observations.len();
        // P Hᵀ: the pose columns of every observation in one product, then each landmark's own.
        let mut hp_t = DMatrix::<f64>::zeros(POSE, m2);
        for (i, obs) in observations.iter().enumerate() {
            hp_t.columns_mut(2 * i, 2)
                .copy_from(&obs.prediction.d_pose.transpose());
        }
        let mut pht = self.p.columns(0, POSE) * hp_t;
        for (i, obs) in observations.iter().enumerate() {
            let slot = self.slots[obs.slot];
            let d = slot.kind.dim();
            let hl_t = obs.prediction.d_landmark.columns(0, d).transpose();
            pht.columns_mut(2 * i, 2)
                .gemm(1.0, &self.p.columns(slot.offset, d), &hl_t, 1.0);
        }
        let mut s = DMatrix::<f64>::zeros(m2, m2);
        let mut nu = DVector::<f64>::zeros(m2);
        for (i, obs) in observations.iter().enumerate() {
            let slot = self.slots[obs.slot];
            let d = slot.kind.dim();
            let hp = obs.prediction.d_pose;
            let hl = obs.prediction.d_landmark.columns(0, d).into_owned();
            let rows = hp * pht.rows(0, POSE) + hl * pht.rows(slot.offset, d);
            s.rows_mut(2 * i, 2).copy_from(&rows);
            nu.rows_mut(2 * i, 2)
                .copy_from(&(obs.pixel - obs.prediction.pixel));
        }
        // Symmetrise S (rounding) and add R.
        let s = (&s + s.transpose()) * 0.5
            + DMatrix::<f64>::identity(m2, m2) * (self.pixel_sigma * self.pixel_sigma);
        let chol = s.cholesky().ok_or(UpdateError::NotPositiveDefinite)?;
        // L⁻¹ is only 2m×2m: inverting it once and multiplying is far faster than
        // triangular solves with n right-hand sides.
        let l_inv = chol
            .l()
            .solve_lower_triangular(&DMatrix::identity(m2, m2))
            .ok_or(UpdateError::NotPositiveDefinite)?;
        let w = pht * l_inv.transpose();
        let white = &l_inv * &nu;
        self.x.gemv(1.0, &w, &white, 1.0);
        let wt = w.transpose();
        subtract_symmetric_product(&mut self.p, &w, &wt);
        self.normalize_quaternion();
        Ok(())
    }

    fn normalize_quaternion(&mut self) {
        let q = self.orientation();
        let j = rotation::d_normalize(&q);
        self.x.fixed_rows_mut::<4>(3).copy_from(&q.normalize());
        let rows = j * self.p.fixed_rows::<4>(3);
        self.p.fixed_rows_mut::<4>(3).copy_from(&rows);
        let cols = self.p.fixed_columns::<4>(3) * j.transpose();
        self.p.fixed_columns_mut::<4>(3).copy_from(&cols);
        // The 4×4 block went through J twice in two products; make it exactly symmetric.
        let qq = self.p.view((3, 3), (4, 4)).into_owned();
        self.p.view_mut((3, 3), (4, 4)).copy_from(&symmetric(&qq));
        let n = self.dim();
        let cross = self.p.view((3, 0), (4, n)).into_owned();
        for k in (0..3).chain(7..n) {
            for a in 0..4 {
                self.p[(k, 3 + a)] = cross[(a, k)];
            }
        }
    }

    /// Variance of the inverse depth of landmark `slot` (0 for Euclidean landmarks).
    pub fn rho_variance(&self, slot: usize) -> f64 {
        let s = self.slots[slot];
        match s.kind {
            Parametrisation::InverseDepth => self.p[(s.offset + 5, s.offset + 5)],
            Parametrisation::Euclidean => 0.0,
        }
    }

    /// Marginal covariance of the camera position.
    pub fn position_covariance(&self) -> nalgebra::Matrix3<f64> {
        self.p.fixed_view::<3, 3>(0, 0).into_owned()
    }
}

/// P ← P − W Wᵀ, the only O(n²·m) term of the update, on the lower triangle only (column
/// panels of the lower part, one matrix product each), then mirrored: half the arithmetic of
/// the full product, and P exactly symmetric by construction.
fn subtract_symmetric_product(p: &mut DMatrix<f64>, w: &DMatrix<f64>, wt: &DMatrix<f64>) {
    const PANEL: usize = 64;
    const TILE: usize = 32;
    let n = p.nrows();
    for j0 in (0..n).step_by(PANEL) {
        let b = PANEL.min(n - j0);
        let mut panel = p.view_mut((j0, j0), (n - j0, b));
        panel.gemm(-1.0, &w.rows(j0, n - j0), &wt.columns(j0, b), 1.0);
    }
    // Upper triangle ← lower, tile by tile: each source tile is read column by column
    // (contiguous) into an L1 buffer, then written out transposed.
    let data = p.as_mut_slice();
    let mut buf = [0.0f64; TILE * TILE];
    for jt in (0..n).step_by(TILE) {
        let jw = TILE.min(n - jt);
        for it in (0..=jt).step_by(TILE) {
            let iw = TILE.min(n - it);
            // Source: rows jt..jt+jw of columns it..it+iw (below the diagonal).
            for (c, col) in buf.chunks_exact_mut(TILE).take(iw).enumerate() {
                let start = (it + c) * n + jt;
                col[..jw].copy_from_slice(&data[start..start + jw]);
            }
            for r in 0..jw {
                let j = jt + r;
                let rows = iw.min(j.saturating_sub(it));
                let dest = &mut data[j * n + it..j * n + it + rows];
                for (c, d) in dest.iter_mut().enumerate() {
                    *d = buf[c * TILE + r];
                }
            }
        }
    }
}

/// (A + Aᵀ)/2 for the small blocks computed as products J P Jᵀ, whose rounding differs
/// between an entry and its mirror.
pub(super) fn symmetric<R: nalgebra::Dim, S: nalgebra::storage::Storage<f64, R, R>>(
    a: &nalgebra::Matrix<f64, R, R, S>,
) -> DMatrix<f64> {
    let a = DMatrix::from_iterator(a.nrows(), a.ncols(), a.iter().copied());
    (&a + a.transpose()) * 0.5
}

#[cfg(test)]
mod tests {
    use super::*;

    fn filter_with_landmarks() -> Filter {
        let cam = PinholeCamera::ideal(300.0, 300.0, 160.0, 120.0, 320, 240);
        let mut f = Filter::new(cam, MotionModel::default(), 1.0, 0.1, 0.1);
        f.predict(0.05, None);
        f.add_landmarks(
            &[
                Vector2::new(50.0, 60.0),
                Vector2::new(200.0, 100.0),
                Vector2::new(120.0, 200.0),
            ],
            1.0,
            1.0,
        );
        f.predict(0.05, None);
        f
    }

    #[test]
    fn update_matches_the_dense_textbook_form() {
        let f0 = filter_with_landmarks();
        let mut f = f0.clone();
        let observations: Vec<Observation> = (0..3)
            .map(|slot| {
                let prediction = f.predict_observation(slot).unwrap();
                Observation {
                    slot,
                    pixel: prediction.pixel + Vector2::new(1.5, -0.7 * slot as f64),
                    prediction,
                }
            })
            .collect();
        f.update(&observations).unwrap();
        // Dense eqs 22–24.
        let n = f0.dim();
        let mut h = DMatrix::zeros(6, n);
        let mut nu = DVector::zeros(6);
        for (i, obs) in observations.iter().enumerate() {
            h.view_mut((2 * i, 0), (2, 7))
                .copy_from(&obs.prediction.d_pose);
            let off = f0.slots[obs.slot].offset;
            h.view_mut((2 * i, off), (2, 6))
                .copy_from(&obs.prediction.d_landmark);
            nu.rows_mut(2 * i, 2)
                .copy_from(&(obs.pixel - obs.prediction.pixel));
        }
        let s = &h * &f0.p * h.transpose() + DMatrix::identity(6, 6);
        let k = &f0.p * h.transpose() * s.try_inverse().unwrap();
        let mut x = &f0.x + &k * nu;
        let mut p = (DMatrix::identity(n, n) - &k * &h) * &f0.p;
        let q = Quat::new(x[3], x[4], x[5], x[6]);
        let jn = rotation::d_normalize(&q);
        x.fixed_rows_mut::<4>(3).copy_from(&q.normalize());
        let rows = jn * p.fixed_rows::<4>(3);
        p.fixed_rows_mut::<4>(3).copy_from(&rows);
        let cols = p.fixed_columns::<4>(3) * jn.transpose();
        p.fixed_columns_mut::<4>(3).copy_from(&cols);
        assert!((&f.x - &x).amax() < 1e-9);
        assert!((&f.p - &p).amax() < 1e-9);
        assert_eq!(
            f.p,
            f.p.transpose(),
            "covariance must stay exactly symmetric"
        );
    }

    #[test]
    fn conversion_and_removal_keep_the_rest_of_the_state() {
        let mut f = filter_with_landmarks();
        let before = f.clone();
        f.convert_to_euclidean(1);
        assert_eq!(f.dim(), before.dim() - 3);
        assert_eq!(f.slots[2].offset, before.slots[2].offset - 3);
        assert_eq!(f.landmark(2), before.landmark(2));
        let p_before = before.landmark_point(1).unwrap();
        assert!((f.landmark_point(1).unwrap() - p_before).amax() < 1e-12);
        assert!(
            (f.landmark_covariance(1).unwrap() - before.landmark_covariance(1).unwrap()).amax()
                < 1e-9
        );
        assert_eq!(f.p, f.p.transpose());
        f.remove_landmarks(&[0]);
        assert_eq!(f.slots.len(), 2);
        assert_eq!(f.landmark(1), before.landmark(2));
        let off = f.slots[1].offset;
        let old = before.slots[2].offset;
        assert_eq!(f.p[(off, off)], before.p[(old, old)]);
    }

    #[test]
    fn new_landmark_reprojects_where_it_was_seen() {
        let f = filter_with_landmarks();
        let pred = f.predict_observation(1).unwrap();
        // Seen at (200, 100) one prediction step ago with zero mean velocity.
        assert!((pred.pixel - Vector2::new(200.0, 100.0)).amax() < 1e-6);
        let s = f.innovation_covariance(1, &pred);
        assert!(s[(0, 0)] > 1.0 && s[(1, 1)] > 1.0);
    }

    #[test]
    fn a_pose_measurement_moves_the_camera_and_keeps_the_covariance_symmetric() {
        let mut f = filter_with_landmarks();
        let before = f.position();
        let target = before + Vector3::new(0.02, -0.01, 0.03);
        let turned = rotation::multiply(
            &f.orientation(),
            &rotation::from_rotation_vector(&Vector3::new(0.0, 0.01, 0.0)),
        );
        let covariance = Matrix6::identity() * 1e-8;
        f.update_pose(&target, &turned, &covariance).unwrap();
        // The measurement is far more certain than the prediction: the pose takes it.
        assert!((f.position() - target).norm() < 1e-3, "{:?}", f.position());
        let relative = rotation::multiply(&rotation::conjugate(&turned), &f.orientation());
        assert!(rotation::to_rotation_vector(&relative).norm() < 1e-3);
        assert!((f.orientation().norm() - 1.0).abs() < 1e-12);
        let p = f.covariance();
        assert!((p - p.transpose()).amax() < 1e-12);
        assert!((0..p.nrows()).all(|i| p[(i, i)] >= 0.0));
        assert!(p[(0, 0)] < 1e-6);
    }
}
