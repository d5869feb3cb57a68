//! Monocular EKF SLAM with inverse-depth landmarks (paper sections 2.1 and 2.6, eqs 1–2 and
//! 13–27), fed by steernav keypoints.
//!
//! - [`camera`]: pinhole + distortion (eq 20), the stereo pair (eqs 1–2), calibration files.
//! - [`crate::low_level::motion`]: constant-velocity, wheeled-vehicle and odometry motion
//!   models (eqs 15–16); `wheeled` holds the filter's side of the wheeled one.
//! - [`crate::low_level::ekf`]: the filter's state, prediction and sparse update (eqs 22–24).
//! - [`Slam`]: the per-frame loop (eqs 25–27, map management), in rooms.
//! - [`refine`]: the local bundle adjustment over the last keyframes.
//! - [`config`]: every setting, in the `[slam.*]` sub-tables.
//! - [`data`]: what is around the filter — sequences on disk (TUM, EuRoC, KITTI, plain
//!   folders), trajectories and their evaluation, the generated sequences, the figure.

pub(crate) mod association;
pub mod camera;
pub mod config;
pub mod data;
pub(crate) mod ekf;
mod ground;
pub(crate) mod inverse_depth;
pub(crate) mod klt;
mod landmarks;
pub(crate) mod motion;
pub mod refine;
pub(crate) mod resect;
pub(crate) mod rotation;
pub(crate) mod tracker;
pub(crate) mod two_view;
mod two_view_refine;
mod wheeled;

pub use config::SlamConfig;
pub use inverse_depth::Parametrisation;
pub use klt::KltParams;
pub use rotation::Quat;
pub use tracker::{FrameReport, MapPoint, Slam, SlamTimings};
