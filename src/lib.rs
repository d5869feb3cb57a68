//! # steernav
//!
//! GPU-accelerated perception for mobile robots, after the paper in `shared/paper.txt`:
//! rotation-invariant keypoints from a steerable filter bank and a multiscale Harris detector
//! (sections 2.2–2.3), with a CPU reference for every GPU stage.
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

pub mod error;
pub mod features;
pub mod gpu;
pub mod image;

pub use error::{Error, Result};
pub use features::{Backend, Detection, Detector, DetectorConfig, Keypoint};
pub use image::Frame;
pub mod batch;
pub mod bench;
pub mod draw;
pub mod eval;
pub mod nav;
pub mod output;
pub mod plot;
pub mod slam;
pub mod synth;
