//! The 2D navigation simulator (paper section 4.2): worlds, sensors, the learned GIST
//! stimulus, and episodes driven by the dynamic neural field.

pub mod episode;
pub mod evaluate;
#[cfg(feature = "plot")]
pub mod figure;
pub mod sensors;
pub mod sweep;
pub mod visual;
pub mod world;
