//! Evaluation of keypoints (paper section 2.4): repeatability (eq 11) and recall (eq 12) under
//! known maps, rotation sweeps, homography sequences (given or generated from photos), and the classic detectors as peers.

#[cfg(feature = "plot")]
pub mod figure;
pub mod generate;
pub mod homography;
pub mod matching;
pub mod overlap;
pub mod peers;
pub mod recall;
pub mod repeatability;
pub mod sweep;

pub use repeatability::{repeatability, Repeatability};
