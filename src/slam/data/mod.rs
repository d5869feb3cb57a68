//! What SLAM reads and writes around the filter: image sequences on disk and their ground
//! truth ([`sequence`], [`kitti`]), depth images and the map's depths against them
//! ([`depth`]), trajectories in TUM and KITTI form with their evaluation
//! (ATE after Sim(3) alignment, RPE: [`trajectory`]), generated sequences with exact ground
//! truth ([`synthetic`]), wheel odometry as the motion model's input ([`odometry`]) and the
//! trajectory-and-map figure (Fig. 4c–f, `figure`).

pub mod depth;
#[cfg(feature = "plot")]
pub mod figure;
pub mod kitti;
pub mod odometry;
pub mod sequence;
pub mod synthetic;
pub mod trajectory;
