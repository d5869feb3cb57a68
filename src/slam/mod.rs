//! Monocular EKF SLAM with inverse-depth landmarks (paper sections 2.1 and 2.6, eqs 1–2 and
//! 13–27), fed by steernav keypoints.
//!
//! - [`rotation`]: quaternion algebra and derivatives.
//! - [`camera`]: pinhole + distortion (eq 20), the stereo pair (eqs 1–2), calibration files.
//! - [`inverse_depth`]: landmarks (eq 13), the measurement model (eqs 17–21), conversion.
//! - [`motion`]: constant-velocity and odometry motion models (eqs 15–16).
//! - [`ekf`]: the filter's state, prediction and sparse update (eqs 22–24).
//! - [`tracker`]: the per-frame loop (eqs 25–27, map management), in rooms.
//! - [`config`]: every setting, in the `[slam.*]` sub-tables.
//! - [`data`]: what is around the filter — sequences on disk (TUM, EuRoC, KITTI, plain
//!   folders), trajectories and their evaluation, the generated sequences, the figure.

pub mod association;
pub mod camera;
pub mod config;
pub mod data;
pub mod ekf;
pub mod inverse_depth;
pub mod klt;
pub mod motion;
pub mod rotation;
pub mod tracker;
pub mod two_view;
