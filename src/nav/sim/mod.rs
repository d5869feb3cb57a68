//! The 2D navigation simulator (paper section 4.2): worlds, sensors, and episodes in which
//! the robot's [`crate::nav::controller::Controller`] drives the dynamic neural field.

pub mod episode;
pub mod evaluate;
#[cfg(feature = "plot")]
pub mod figure;
pub mod sensors;
pub mod sweep;
pub mod world;
