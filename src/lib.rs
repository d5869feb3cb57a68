//! # steernav
//!
//! GPU-accelerated perception and navigation for mobile robots, after the paper *Accurate
//! Robot Navigation Using Visual Invariant Features and Dynamic Neural Fields*:
//! rotation- and scale-invariant keypoints ([`features`], eqs 3–10), monocular EKF SLAM
//! ([`slam`], eqs 13–27), a dynamic neural field driven by a LIDAR and the camera's GIST
//! ([`nav`], eqs 28–45), and their evaluation ([`eval`], eqs 11–12). Every GPU stage has a
//! CPU twin that gives the same results within a stated tolerance.
//!
//! ## Where to start
//!
//! What a robot program needs is at the crate root:
//!
//! | to… | use |
//! |---|---|
//! | find keypoints in a [`Frame`] | [`Detector`] with a [`DetectorConfig`], on a [`Backend`]; each [`Keypoint`] carries its descriptor |
//! | run monocular SLAM | [`Slam`] with a [`PinholeCamera`] and a [`SlamConfig`]; each frame gives a [`FrameReport`] |
//! | steer with the neural field | [`Controller`] with a [`ControllerConfig`]; a [`LaserScan`] in, a [`Command`] out |
//! | share your own wgpu device | [`GpuContext::from_device`], then `Detector::with_context` |
//! | read every table of one TOML file | [`Settings`] |
//! | handle failures | [`Error`] (typed, sources kept) |
//!
//! The modules hold the rest: the evaluation ([`eval`]), the datasets and trajectories of
//! SLAM ([`slam::data`]), the simulator ([`nav::sim`]), the GIST of an image ([`nav::gist`]),
//! ROS 2 bags ([`bag`]). The stages' own drivers, for those who test, benchmark or extend
//! them, are under [`low_level`].
//!
//! The library never prints: warnings and fallbacks go through `log`, errors are [`Error`].
//! With `default-features = false` it builds without the CLI's crates.
//!
//! ```no_run
//! use steernav::{Backend, Detector, DetectorConfig, Frame};
//! let detector = Detector::new(&DetectorConfig::default(), Backend::Auto)?;
//! let frame = Frame::load(std::path::Path::new("assets/sample.png"))?;
//! let found = detector.detect(&frame)?;
//! println!("{} keypoints on {}", found.keypoints.len(), found.backend);
//! # Ok::<(), steernav::Error>(())
//! ```
#![warn(missing_docs)]
// The library reports through `log` and return values; only the CLI prints.
#![deny(clippy::print_stdout, clippy::print_stderr)]

/// Gives a fieldless enum the names it has in TOML, JSON and on the command line: a `NAMES`
/// list, `as_str`, `Display` and `FromStr`, so that front ends (the CLI, the Python bindings)
/// parse the same words without depending on the library's types deriving their traits.
macro_rules! named_variants {
    ($ty:ident { $($variant:ident => $name:literal),+ $(,)? }) => {
        impl $ty {
            /// Every name, in declaration order.
            pub const NAMES: &'static [&'static str] = &[$($name),+];
            /// The name of this value.
            pub fn as_str(self) -> &'static str {
                match self { $($ty::$variant => $name),+ }
            }
        }
        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.as_str())
            }
        }
        impl std::str::FromStr for $ty {
            type Err = crate::error::Error;
            fn from_str(s: &str) -> crate::error::Result<Self> {
                match s {
                    $($name => Ok($ty::$variant),)+
                    other => Err(crate::error::Error::config(
                        stringify!($ty),
                        other,
                        format!("expected one of {}", Self::NAMES.join(", ")),
                    )),
                }
            }
        }
    };
}

pub mod bag;
pub mod error;
pub mod features;
mod gpu;
pub mod image;
pub mod low_level;
mod moved;
mod rng;
pub mod settings;
mod shard;
pub(crate) mod simd;

pub use error::{Error, Result};
pub use features::{Backend, Detection, Detector, DetectorConfig, Keypoint};
pub use gpu::GpuContext;
pub use image::Frame;
pub use nav::{Command, Controller, ControllerConfig, LaserScan};
pub use settings::Settings;
pub use slam::camera::PinholeCamera;
pub use slam::{FrameReport, Slam, SlamConfig};
pub mod eval;
pub mod nav;
pub mod output;
#[cfg(feature = "plot")]
pub(crate) mod plot;
pub mod slam;
mod synth;
