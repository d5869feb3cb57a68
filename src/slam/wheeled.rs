//! The wheeled motion model's side of the filter (`MotionModel::Wheeled`, eqs 15–16 with the
//! vehicle's non-holonomic constraints as pseudo-measurements, taken by eqs 22–24): the
//! constraints on the predicted velocity, and the constraints on each step's displacement by
//! stochastic cloning, where the previous pose is copied into the state before the
//! prediction and leaves it once the frame's measurements are in. The constraints themselves
//! and their Jacobians are in [`super::motion`].

use nalgebra::{DMatrix, DVector};

use super::ekf::Filter;
use super::motion::{self, MotionModel};

/// How many standard deviations from zero the yaw rate must be for a step to teach the
/// wheeled model its arm.
const ARM_EVIDENCE: f64 = 3.0;

/// The prior variance of the wheeled model's arm; `None` for the other models.
pub(super) fn arm_variance(motion: &MotionModel) -> Option<f64> {
    match motion {
        MotionModel::Wheeled(w) => Some(w.arm_sigma * w.arm_sigma),
        _ => None,
    }
}

impl Filter {
    /// The wheeled model's estimate of the camera's arm ahead of the turning axis and its
    /// standard deviation, in map units (× the map's scale gives metres, a check against the
    /// vehicle's geometry); `None` for the other models.
    pub fn arm(&self) -> Option<(f64, f64)> {
        matches!(self.motion, MotionModel::Wheeled(_)).then(|| {
            (
                self.x[motion::ARM],
                self.p[(motion::ARM, motion::ARM)].sqrt(),
            )
        })
    }

    /// The motion model's pseudo-measurements (the wheeled model's constraints), taken as an
    /// update of the camera block. A refused update leaves the state as predicted.
    pub(super) fn constrain_motion(&mut self) {
        let c = self.motion.camera_dim();
        let camera = self.x.rows(0, c).into_owned();
        let Some((value, h, sigma)) = motion::constraint(&self.motion, &camera) else {
            return;
        };
        self.take_constraint(&value, &(0..c).collect::<Vec<_>>(), &h, &sigma);
    }

    /// Takes pseudo-measurements c(x) = 0 ± `sigma` with Jacobian `h` over `columns`.
    pub(super) fn take_constraint(
        &mut self,
        value: &DVector<f64>,
        columns: &[usize],
        h: &DMatrix<f64>,
        sigma: &DVector<f64>,
    ) {
        let nu = DVector::from_iterator(value.len(), value.iter().map(|v| -v));
        let r = DMatrix::from_diagonal(&DVector::from_iterator(
            sigma.len(),
            sigma.iter().map(|s| s * s),
        ));
        if self.update_columns(&nu, columns, h, &r).is_err() {
            log::debug!("wheeled motion constraint refused: innovation covariance not definite");
        }
    }

    /// Opens a step of the wheeled model before a prediction: the current pose (position and
    /// orientation) is copied to the end of the state (x and P), so that the step's
    /// displacement can be constrained once the frame's measurements have moved the pose
    /// (stochastic cloning).
    pub(super) fn open_step(&mut self, dt: f64) {
        self.close_step();
        if !matches!(self.motion, MotionModel::Wheeled(_)) {
            return;
        }
        let (n, k) = (self.dim(), motion::STEP_COPY);
        let mut x = DVector::zeros(n + k);
        x.rows_mut(0, n).copy_from(&self.x);
        x.rows_mut(n, k).copy_from(&self.x.rows(0, k));
        let mut p = DMatrix::zeros(n + k, n + k);
        p.view_mut((0, 0), (n, n)).copy_from(&self.p);
        p.view_mut((n, 0), (k, n)).copy_from(&self.p.rows(0, k));
        p.view_mut((0, n), (n, k)).copy_from(&self.p.columns(0, k));
        p.view_mut((n, n), (k, k))
            .copy_from(&self.p.view((0, 0), (k, k)));
        self.x = x;
        self.p = p;
        self.step = Some((n, dt));
    }

    /// Closes the wheeled model's open step: its displacement, in the frame midway through
    /// the step, is the arm's swing (`motion::step_constraint`), then the copy of the
    /// previous pose leaves the state. The velocity
    /// constraints tie the prediction; this ties what the measurements did to the pose.
    /// Called once the frame's updates are in; a no-op when no step is open.
    pub(in crate::slam) fn close_step(&mut self) {
        let Some((origin, dt)) = self.step.take() else {
            return;
        };
        if let MotionModel::Wheeled(w) = &self.motion {
            // The arm is learnt only in a clear turn (see `motion::step_constraint`).
            let learn_arm = self.x[11].abs() > ARM_EVIDENCE * self.p[(11, 11)].sqrt();
            let (value, columns, h) = motion::step_constraint(&self.x, origin, learn_arm);
            let sigma = DVector::from_vec(vec![w.slip * dt, w.vertical * dt]);
            self.take_constraint(&value, &columns, &h, &sigma);
        }
        self.drop_step_copy(origin);
    }

    /// Drops the open step without its constraint: relocalisation re-measures the pose, to
    /// which the copy of the previous pose is as unrelated as the map.
    pub(super) fn discard_step(&mut self) {
        if let Some((origin, _)) = self.step.take() {
            self.drop_step_copy(origin);
        }
    }

    /// Removes the copy of the previous pose (the last `motion::STEP_COPY` entries) from x
    /// and P.
    fn drop_step_copy(&mut self, origin: usize) {
        self.x = self.x.rows(0, origin).into_owned();
        self.p = self.p.view((0, 0), (origin, origin)).into_owned();
    }
}
