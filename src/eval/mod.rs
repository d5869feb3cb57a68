//! Evaluation of keypoints (paper section 2.4): repeatability (eq 11) under a known map.

pub mod repeatability;

pub use repeatability::{repeatability, Repeatability};
