//! Every parameter of the SLAM front end and filter, with documented defaults; loadable from
//! the `[slam]` table of a TOML file.

use serde::{Deserialize, Serialize};

use super::motion::MotionModel;
use crate::error::{Error, Result};

/// SLAM parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SlamConfig {
    /// Motion model (constant velocity unless `--odometry` is given).
    pub motion: MotionModel,
    /// Standard deviation of a measured pixel (R = σ² I).
    pub pixel_sigma: f64,
    /// Prior standard deviation of the initial linear velocity, m/s.
    pub velocity_sigma: f64,
    /// Prior standard deviation of the initial angular velocity, rad/s.
    pub angular_velocity_sigma: f64,
    /// Initial inverse depth ρ₀ of a new landmark, 1/m.
    pub initial_inverse_depth: f64,
    /// Standard deviation of ρ₀ (large: the depth is unknown from one view).
    pub inverse_depth_sigma: f64,
    /// Half side of the matched template, pixels (side = 2·half + 1).
    pub template_half: usize,
    /// χ² gate of the active search ellipse (2 degrees of freedom; 9.21 = 99%).
    pub search_gate: f64,
    /// Largest search half-extent along each axis, pixels.
    pub max_search_extent: f64,
    /// Smallest normalised cross-correlation accepted as a match.
    pub min_correlation: f32,
    /// Smallest correlation for a pixel followed by KLT from the previous frame (its
    /// forward–backward check already vouches for it; the warped template only guards
    /// against drift, and its warp is least reliable while the depth is uncertain).
    pub min_tracked_correlation: f32,
    /// Scales, relative to the predicted warp, at which a template that correlates below the
    /// threshold is scored again around its best position. The warp's scale comes from the
    /// landmark's depth estimate, which is poor while the landmark is young; under forward
    /// motion a wrong scale costs a correct match most of its correlation.
    pub template_scales: Vec<f64>,
    /// A matched landmark's template is cut again from the current frame once the camera
    /// has moved this fraction of the landmark's depth since it was cut.
    pub template_refresh: f64,
    /// Largest difference of any entropy of the descriptor (eq 10) accepted, bits.
    pub descriptor_tolerance: f32,
    /// Pixel distance under which a match supports a 1-point RANSAC hypothesis.
    pub ransac_threshold: f64,
    /// Confidence of 1-point RANSAC.
    pub ransac_confidence: f64,
    /// Upper bound on RANSAC hypotheses per frame.
    pub max_hypotheses: usize,
    /// χ² gate (eq 26, 2 degrees of freedom) for rescuing high-innovation inliers.
    pub rescue_gate: f64,
    /// Landmarks the front end tries to keep visible; new ones are added below this.
    pub target_visible: usize,
    /// Most landmarks created in one frame.
    pub max_new_per_frame: usize,
    /// Start a new landmark at the depth where its ray meets the ray of its KLT track in the
    /// previous frame, when that is more certain than the prior ρ₀ ± σ (large steps between
    /// frames); otherwise, and when false, at the prior.
    pub two_frame_depth: bool,
    /// Smallest σ_ρ/ρ given to a two-frame depth: the motion between the frames is itself an
    /// estimate, however large the parallax.
    pub two_frame_depth_floor: f64,
    /// Cells of the grid (columns × rows) that spreads new landmarks over the image.
    pub grid: [usize; 2],
    /// After a detection that created no landmark, frames to wait before detecting again
    /// (not while fewer than half of `target_visible` landmarks are in view).
    pub redetect_interval: usize,
    /// Linearity index under which an inverse-depth landmark becomes Euclidean.
    pub linearity_threshold: f64,
    /// A landmark predicted visible this many times …
    pub min_predicted_for_deletion: usize,
    /// … and matched in less than this fraction of them is deleted.
    pub min_match_ratio: f64,
    /// Most landmarks kept in the state; those unseen longest go first.
    pub max_landmarks: usize,
    /// Frames in a row without support after which a frame that finds the map again is
    /// reported as a relocalisation.
    pub lost_after: usize,
}

impl Default for SlamConfig {
    fn default() -> Self {
        Self {
            motion: MotionModel::default(),
            pixel_sigma: 1.0,
            velocity_sigma: 0.05,
            angular_velocity_sigma: 0.05,
            initial_inverse_depth: 0.5,
            inverse_depth_sigma: 0.5,
            template_half: 5,
            search_gate: 9.21,
            max_search_extent: 40.0,
            min_correlation: 0.8,
            min_tracked_correlation: 0.5,
            template_scales: vec![0.8, 0.9, 1.12, 1.25],
            template_refresh: 0.4,
            descriptor_tolerance: 1.0,
            ransac_threshold: 2.0,
            ransac_confidence: 0.99,
            max_hypotheses: 500,
            rescue_gate: 5.99,
            target_visible: 32,
            max_new_per_frame: 8,
            two_frame_depth: true,
            two_frame_depth_floor: 0.25,
            grid: [8, 6],
            redetect_interval: 10,
            linearity_threshold: 0.1,
            min_predicted_for_deletion: 10,
            min_match_ratio: 0.5,
            max_landmarks: 120,
            lost_after: 5,
        }
    }
}

impl SlamConfig {
    /// Checks every value, naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        let positive = [
            ("slam.pixel_sigma", self.pixel_sigma),
            ("slam.velocity_sigma", self.velocity_sigma),
            ("slam.angular_velocity_sigma", self.angular_velocity_sigma),
            ("slam.inverse_depth_sigma", self.inverse_depth_sigma),
            ("slam.search_gate", self.search_gate),
            ("slam.max_search_extent", self.max_search_extent),
            ("slam.ransac_threshold", self.ransac_threshold),
            ("slam.rescue_gate", self.rescue_gate),
            ("slam.linearity_threshold", self.linearity_threshold),
            ("slam.template_refresh", self.template_refresh),
            ("slam.two_frame_depth_floor", self.two_frame_depth_floor),
        ];
        for (field, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::config(field, v, "must be finite and > 0"));
            }
        }
        if !(self.initial_inverse_depth.is_finite() && self.initial_inverse_depth >= 0.0) {
            return Err(Error::config(
                "slam.initial_inverse_depth",
                self.initial_inverse_depth,
                "must be finite and >= 0",
            ));
        }
        if !(0.0..1.0).contains(&self.ransac_confidence) {
            return Err(Error::config(
                "slam.ransac_confidence",
                self.ransac_confidence,
                "must be in [0, 1)",
            ));
        }
        if !(-1.0..=1.0).contains(&self.min_correlation) {
            return Err(Error::config(
                "slam.min_correlation",
                self.min_correlation,
                "must be in [-1, 1]",
            ));
        }
        if !(-1.0..=1.0).contains(&self.min_tracked_correlation) {
            return Err(Error::config(
                "slam.min_tracked_correlation",
                self.min_tracked_correlation,
                "must be in [-1, 1]",
            ));
        }
        if !(self.descriptor_tolerance.is_finite() && self.descriptor_tolerance > 0.0) {
            return Err(Error::config(
                "slam.descriptor_tolerance",
                self.descriptor_tolerance,
                "must be finite and > 0",
            ));
        }
        if let Some(&bad) = self
            .template_scales
            .iter()
            .find(|s| !(s.is_finite() && (0.25..=4.0).contains(*s)))
        {
            return Err(Error::config(
                "slam.template_scales",
                bad,
                "every scale must be in [0.25, 4]",
            ));
        }
        if self.template_half == 0 || self.template_half > 32 {
            return Err(Error::config(
                "slam.template_half",
                self.template_half,
                "must be in 1..=32",
            ));
        }
        if self.grid[0] == 0 || self.grid[1] == 0 {
            return Err(Error::config(
                "slam.grid",
                format!("{:?}", self.grid),
                "needs at least one cell each way",
            ));
        }
        if self.target_visible == 0 || self.max_landmarks < self.target_visible {
            return Err(Error::config(
                "slam.max_landmarks",
                self.max_landmarks,
                "must be >= target_visible >= 1",
            ));
        }
        if self.max_hypotheses == 0 {
            return Err(Error::config("slam.max_hypotheses", 0, "must be >= 1"));
        }
        if !(0.0..=1.0).contains(&self.min_match_ratio) {
            return Err(Error::config(
                "slam.min_match_ratio",
                self.min_match_ratio,
                "must be in [0, 1]",
            ));
        }
        if let MotionModel::ConstantVelocity {
            linear_acceleration,
            angular_acceleration,
        } = self.motion
        {
            for (field, v) in [
                (
                    "slam.motion.constant-velocity.linear_acceleration",
                    linear_acceleration,
                ),
                (
                    "slam.motion.constant-velocity.angular_acceleration",
                    angular_acceleration,
                ),
            ] {
                if !(v.is_finite() && v > 0.0) {
                    return Err(Error::config(field, v, "must be finite and > 0"));
                }
            }
        }
        Ok(())
    }
}
