//! Every parameter of the SLAM front end and filter, with documented units and defaults,
//! loadable from the `[slam]` table of a TOML file and its sub-tables: `[slam.filter]` (the
//! noise model and the landmark parametrisation, eqs 13–24), `[slam.search]` (the active search,
//! eqs 25–27), `[slam.ransac]` (1-point RANSAC and the rescue gate, eq 26), `[slam.map]`
//! (creation and deletion of landmarks), `[slam.start]` (the two-view start and the start at
//! rest), `[slam.klt]` (the frame-to-frame tracker), `[slam.motion]` (eqs 15–16) and
//! `[slam.refine]` (the local bundle adjustment over the last keyframes).
//!
//! Keys that used to sit flat in `[slam]` are refused with the place they moved to.

use serde::{Deserialize, Serialize};

use super::klt::KltParams;
use super::motion::MotionModel;
use super::refine::RefineConfig;
use crate::error::{Error, Result};
use crate::moved::{Moved, MovedKeys};

/// SLAM parameters.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(from = "SlamTable")]
pub struct SlamConfig {
    /// `[slam.motion]`: the motion model (constant velocity unless `--odometry` is given).
    pub motion: MotionModel,
    /// `[slam.filter]`: noise model and landmark parametrisation.
    pub filter: FilterConfig,
    /// `[slam.search]`: the active search of each landmark.
    pub search: SearchConfig,
    /// `[slam.ransac]`: 1-point RANSAC and the rescue of high-innovation inliers.
    pub ransac: RansacConfig,
    /// `[slam.map]`: creation and deletion of landmarks.
    pub map: MapConfig,
    /// `[slam.start]`: the start of a monocular session.
    pub start: StartConfig,
    /// `[slam.klt]`: the pyramidal Lucas–Kanade tracker that follows points between frames.
    pub klt: KltParams,
    /// `[slam.refine]`: the local bundle adjustment over the last keyframes.
    pub refine: RefineConfig,
}

/// `[slam.filter]`: the EKF's noise model and the landmark parametrisation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FilterConfig {
    /// Standard deviation of a measured pixel, pixels (R = σ² I).
    pub pixel_sigma: f64,
    /// Prior standard deviation of the initial linear velocity, m/s.
    pub velocity_sigma: f64,
    /// Prior standard deviation of the initial angular velocity, rad/s.
    pub angular_velocity_sigma: f64,
    /// Initial inverse depth ρ₀ of a new landmark, 1/m (eq 13).
    pub initial_inverse_depth: f64,
    /// Standard deviation of ρ₀, 1/m (large: the depth is unknown from one view).
    pub inverse_depth_sigma: f64,
    /// Linearity index (dimensionless) under which an inverse-depth landmark becomes
    /// Euclidean.
    pub linearity_threshold: f64,
}

impl Default for FilterConfig {
    fn default() -> Self {
        Self {
            pixel_sigma: 1.0,
            velocity_sigma: 0.05,
            angular_velocity_sigma: 0.05,
            initial_inverse_depth: 0.5,
            inverse_depth_sigma: 0.5,
            linearity_threshold: 0.1,
        }
    }
}

/// `[slam.search]`: how each landmark predicted in view is looked for.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SearchConfig {
    /// Half side of the matched template, pixels (side = 2·half + 1).
    pub template_half: usize,
    /// χ² gate of the search ellipse (eq 27, 2 degrees of freedom; 9.21 = 99%).
    pub gate: f64,
    /// Largest search half-extent along each axis, pixels, while tracking holds.
    pub max_extent: f64,
    /// While tracking is lost the cap grows by `max_extent` per lost frame, up to this many
    /// times (the covariance grows too; the cap keeps one search affordable).
    pub max_widening: usize,
    /// Half-extent, pixels, of the search around a pixel followed by KLT.
    pub tracked_extent: f64,
    /// Variance, pixels², of a pixel followed by KLT, for its search ellipse.
    pub tracked_variance: f64,
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
    /// Frames in a row without support after which a frame that finds the map again is a
    /// relocalisation (the camera is decorrelated from the map before its update).
    pub lost_after: usize,
}

impl Default for SearchConfig {
    fn default() -> Self {
        Self {
            template_half: 5,
            gate: 9.21,
            max_extent: 40.0,
            max_widening: 4,
            tracked_extent: 2.0,
            tracked_variance: 0.5,
            min_correlation: 0.8,
            min_tracked_correlation: 0.5,
            template_scales: vec![0.8, 0.9, 1.12, 1.25],
            template_refresh: 0.4,
            descriptor_tolerance: 1.0,
            lost_after: 5,
        }
    }
}

/// `[slam.ransac]`: 1-point RANSAC and the rescue of high-innovation inliers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RansacConfig {
    /// Distance, pixels, under which a match supports a hypothesis (also the two-view
    /// start's threshold, on the image plane).
    pub threshold: f64,
    /// Confidence of 1-point RANSAC, in [0, 1).
    pub confidence: f64,
    /// Upper bound on hypotheses per frame.
    pub max_hypotheses: usize,
    /// χ² gate (eq 26, 2 degrees of freedom) for rescuing high-innovation inliers.
    pub rescue_gate: f64,
}

impl Default for RansacConfig {
    fn default() -> Self {
        Self {
            threshold: 2.0,
            confidence: 0.99,
            max_hypotheses: 500,
            rescue_gate: 5.99,
        }
    }
}

/// `[slam.map]`: when landmarks are created and deleted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapConfig {
    /// Landmarks the front end tries to keep in view; new ones are added below this.
    pub target_visible: usize,
    /// Most landmarks created in one frame.
    pub max_new_per_frame: usize,
    /// Start a new landmark at the depth where its ray meets the ray of its KLT track in the
    /// previous frame, when that is more certain than the prior ρ₀ ± σ (large steps between
    /// frames); otherwise, and when false, at the prior.
    pub two_frame_depth: bool,
    /// Smallest σ_ρ/ρ given to a two-frame depth (dimensionless): the motion between the
    /// frames is itself an estimate, however large the parallax.
    pub two_frame_depth_floor: f64,
    /// Cells of the grid (columns × rows) that spreads new landmarks over the image.
    pub grid: [usize; 2],
    /// After a detection that created no landmark, frames to wait before detecting again
    /// (not while fewer than half of `target_visible` landmarks are in view).
    pub redetect_interval: usize,
    /// A landmark predicted in view this many frames …
    pub min_predicted_for_deletion: usize,
    /// … and matched in less than this fraction of them is deleted.
    pub min_match_ratio: f64,
    /// Most landmarks kept in the state; those unseen longest go first.
    pub max_landmarks: usize,
}

impl Default for MapConfig {
    fn default() -> Self {
        Self {
            target_visible: 32,
            max_new_per_frame: 8,
            two_frame_depth: true,
            two_frame_depth_floor: 0.25,
            grid: [8, 6],
            redetect_interval: 10,
            min_predicted_for_deletion: 10,
            min_match_ratio: 0.5,
            max_landmarks: 120,
        }
    }
}

/// `[slam.start]`: the start of a monocular session (constant velocity) — points followed from
/// a reference frame until two views fix the motion, or the start at rest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StartConfig {
    /// Seconds without enough parallax after which the camera is taken to be at rest and the
    /// filter starts there, as in the paper.
    pub stationary_after: f64,
    /// Median step of the start-up points between two frames, pixels, under which a camera
    /// that started at rest is taken to be still at rest.
    pub rest_step: f64,
    /// Fewest points (followed, then inliers) for a two-view estimate.
    pub min_points: usize,
    /// Parallax, radians, that a quarter of the inliers must reach for the two views to fix
    /// the depths (0.017 ≈ 1°).
    pub min_parallax: f64,
    /// Cells (columns × rows) of the grid the start-up corners are spread over.
    pub corner_grid: [usize; 2],
    /// Start-up corners per cell.
    pub corners_per_cell: usize,
    /// RANSAC hypotheses of the two-view (essential matrix) estimate.
    pub two_view_iterations: usize,
    /// Standard deviation of the seated position per metre of the two-view baseline.
    pub position_sigma_per_baseline: f64,
    /// Variance of each quaternion entry of the seated orientation.
    pub orientation_variance: f64,
    /// Standard deviation of the seated velocity as a fraction of its norm (added to
    /// `velocity_sigma`).
    pub velocity_sigma_fraction: f64,
    /// Smallest σ_ρ/ρ given to a triangulated start-up landmark.
    pub depth_floor: f64,
    /// Also refine the two-view motion on the Sampson distances from 18 starting directions
    /// (`two_view_refine.rs`): the eight-point direction is biased towards the optical axis,
    /// 40–50° off on hand-held starts that walk sideways while turning. When the search
    /// lands elsewhere, both motions are seated and tracked side by side for `trial_frames`
    /// frames, and the searched one replaces the eight-point one only when its normalised
    /// innovations total clearly less (`tracker/trial.rs`); the trial's frames are then
    /// revised (`Slam::take_revised`). On by default: nine 240×180 walks 3.22 → 1.37% mean
    /// ATE, the suite and the KITTI clips unchanged (docs/SLAM.md, "Hand-held starts").
    pub two_view_search: bool,
    /// Frames over which the two start hypotheses are tracked side by side (1–100); each
    /// costs two frames' work.
    pub trial_frames: usize,
    /// Seat the filter at the velocity the camera has at the end of the wait instead of the
    /// wait's mean, when the wait's placed frames accelerate (a quadratic in time explains
    /// them better than a line, F > 10): a camera that starts from rest (a slider, a robot
    /// that drives off) is twice as fast at the seat as over the wait. Off by default: the
    /// generated sliders go 1.99 / 4.78 / 1.20 / 1.06 / 1.64% → 1.85 / 3.60 / 1.12 / 1.06 /
    /// 1.37% and the suite's mean 0.96 → 0.91%, but rover-7 loses 8 frames late in its run
    /// (docs/SLAM.md, "The seat's velocity when the wait accelerates").
    pub accelerated_seat: bool,
}

impl Default for StartConfig {
    fn default() -> Self {
        Self {
            stationary_after: 1.0,
            rest_step: 0.5,
            min_points: 20,
            min_parallax: 0.017,
            corner_grid: [16, 12],
            corners_per_cell: 2,
            two_view_iterations: 2000,
            position_sigma_per_baseline: 0.05,
            orientation_variance: 1e-6,
            velocity_sigma_fraction: 0.1,
            depth_floor: 0.1,
            two_view_search: true,
            trial_frames: 30,
            accelerated_seat: false,
        }
    }
}

/// Where each key that used to sit flat in `[slam]` lives now.
pub const MOVED_KEYS: &[(&str, &str)] = &[
    ("pixel_sigma", "slam.filter.pixel_sigma"),
    ("velocity_sigma", "slam.filter.velocity_sigma"),
    (
        "angular_velocity_sigma",
        "slam.filter.angular_velocity_sigma",
    ),
    ("initial_inverse_depth", "slam.filter.initial_inverse_depth"),
    ("inverse_depth_sigma", "slam.filter.inverse_depth_sigma"),
    ("linearity_threshold", "slam.filter.linearity_threshold"),
    ("template_half", "slam.search.template_half"),
    ("search_gate", "slam.search.gate"),
    ("max_search_extent", "slam.search.max_extent"),
    ("min_correlation", "slam.search.min_correlation"),
    (
        "min_tracked_correlation",
        "slam.search.min_tracked_correlation",
    ),
    ("template_scales", "slam.search.template_scales"),
    ("template_refresh", "slam.search.template_refresh"),
    ("descriptor_tolerance", "slam.search.descriptor_tolerance"),
    ("lost_after", "slam.search.lost_after"),
    ("ransac_threshold", "slam.ransac.threshold"),
    ("ransac_confidence", "slam.ransac.confidence"),
    ("max_hypotheses", "slam.ransac.max_hypotheses"),
    ("rescue_gate", "slam.ransac.rescue_gate"),
    ("target_visible", "slam.map.target_visible"),
    ("max_new_per_frame", "slam.map.max_new_per_frame"),
    ("two_frame_depth", "slam.map.two_frame_depth"),
    ("two_frame_depth_floor", "slam.map.two_frame_depth_floor"),
    ("grid", "slam.map.grid"),
    ("redetect_interval", "slam.map.redetect_interval"),
    (
        "min_predicted_for_deletion",
        "slam.map.min_predicted_for_deletion",
    ),
    ("min_match_ratio", "slam.map.min_match_ratio"),
    ("max_landmarks", "slam.map.max_landmarks"),
];

/// The keys of the old flat `[slam]` table.
struct FlatSlam;

impl MovedKeys for FlatSlam {
    const TABLE: &'static str = "slam";
    const KEYS: &'static [(&'static str, &'static str)] = MOVED_KEYS;
    const WHY: &'static str = "the [slam] table is split into [slam.filter], [slam.search], \
                               [slam.ransac], [slam.map], [slam.start], [slam.klt]";
}

/// The `[slam]` table as read: the sub-tables, and the old flat keys, which only refuse.
#[derive(Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct SlamTable {
    motion: MotionModel,
    filter: FilterConfig,
    search: SearchConfig,
    ransac: RansacConfig,
    map: MapConfig,
    start: StartConfig,
    klt: KltParams,
    refine: RefineConfig,
    #[serde(rename = "pixel_sigma")]
    _0: Moved<FlatSlam, 0>,
    #[serde(rename = "velocity_sigma")]
    _1: Moved<FlatSlam, 1>,
    #[serde(rename = "angular_velocity_sigma")]
    _2: Moved<FlatSlam, 2>,
    #[serde(rename = "initial_inverse_depth")]
    _3: Moved<FlatSlam, 3>,
    #[serde(rename = "inverse_depth_sigma")]
    _4: Moved<FlatSlam, 4>,
    #[serde(rename = "linearity_threshold")]
    _5: Moved<FlatSlam, 5>,
    #[serde(rename = "template_half")]
    _6: Moved<FlatSlam, 6>,
    #[serde(rename = "search_gate")]
    _7: Moved<FlatSlam, 7>,
    #[serde(rename = "max_search_extent")]
    _8: Moved<FlatSlam, 8>,
    #[serde(rename = "min_correlation")]
    _9: Moved<FlatSlam, 9>,
    #[serde(rename = "min_tracked_correlation")]
    _10: Moved<FlatSlam, 10>,
    #[serde(rename = "template_scales")]
    _11: Moved<FlatSlam, 11>,
    #[serde(rename = "template_refresh")]
    _12: Moved<FlatSlam, 12>,
    #[serde(rename = "descriptor_tolerance")]
    _13: Moved<FlatSlam, 13>,
    #[serde(rename = "lost_after")]
    _14: Moved<FlatSlam, 14>,
    #[serde(rename = "ransac_threshold")]
    _15: Moved<FlatSlam, 15>,
    #[serde(rename = "ransac_confidence")]
    _16: Moved<FlatSlam, 16>,
    #[serde(rename = "max_hypotheses")]
    _17: Moved<FlatSlam, 17>,
    #[serde(rename = "rescue_gate")]
    _18: Moved<FlatSlam, 18>,
    #[serde(rename = "target_visible")]
    _19: Moved<FlatSlam, 19>,
    #[serde(rename = "max_new_per_frame")]
    _20: Moved<FlatSlam, 20>,
    #[serde(rename = "two_frame_depth")]
    _21: Moved<FlatSlam, 21>,
    #[serde(rename = "two_frame_depth_floor")]
    _22: Moved<FlatSlam, 22>,
    #[serde(rename = "grid")]
    _23: Moved<FlatSlam, 23>,
    #[serde(rename = "redetect_interval")]
    _24: Moved<FlatSlam, 24>,
    #[serde(rename = "min_predicted_for_deletion")]
    _25: Moved<FlatSlam, 25>,
    #[serde(rename = "min_match_ratio")]
    _26: Moved<FlatSlam, 26>,
    #[serde(rename = "max_landmarks")]
    _27: Moved<FlatSlam, 27>,
}

impl From<SlamTable> for SlamConfig {
    fn from(t: SlamTable) -> Self {
        Self {
            motion: t.motion,
            filter: t.filter,
            search: t.search,
            ransac: t.ransac,
            map: t.map,
            start: t.start,
            klt: t.klt,
            refine: t.refine,
        }
    }
}

/// Checks that each value is finite and > 0.
fn positive(values: &[(&'static str, f64)]) -> Result<()> {
    for &(field, v) in values {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::config(field, v, "must be finite and > 0"));
        }
    }
    Ok(())
}

/// Checks that a value lies in an inclusive range.
fn within<T: PartialOrd + std::fmt::Display + Copy>(
    field: &'static str,
    v: T,
    range: std::ops::RangeInclusive<T>,
) -> Result<()> {
    if range.contains(&v) {
        Ok(())
    } else {
        Err(Error::config(
            field,
            v,
            format!("must be in [{}, {}]", range.start(), range.end()),
        ))
    }
}

impl SlamConfig {
    /// Checks every value, naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        let (f, s, r, m, st) = (
            &self.filter,
            &self.search,
            &self.ransac,
            &self.map,
            &self.start,
        );
        positive(&[
            ("slam.filter.pixel_sigma", f.pixel_sigma),
            ("slam.filter.velocity_sigma", f.velocity_sigma),
            (
                "slam.filter.angular_velocity_sigma",
                f.angular_velocity_sigma,
            ),
            ("slam.filter.inverse_depth_sigma", f.inverse_depth_sigma),
            ("slam.filter.linearity_threshold", f.linearity_threshold),
            ("slam.search.gate", s.gate),
            ("slam.search.max_extent", s.max_extent),
            ("slam.search.tracked_extent", s.tracked_extent),
            ("slam.search.tracked_variance", s.tracked_variance),
            ("slam.search.template_refresh", s.template_refresh),
            ("slam.ransac.threshold", r.threshold),
            ("slam.ransac.rescue_gate", r.rescue_gate),
            ("slam.map.two_frame_depth_floor", m.two_frame_depth_floor),
            ("slam.start.stationary_after", st.stationary_after),
            ("slam.start.rest_step", st.rest_step),
            ("slam.start.min_parallax", st.min_parallax),
            (
                "slam.start.position_sigma_per_baseline",
                st.position_sigma_per_baseline,
            ),
            ("slam.start.orientation_variance", st.orientation_variance),
            ("slam.start.depth_floor", st.depth_floor),
            ("slam.klt.max_round_trip", self.klt.max_round_trip),
        ])?;
        if !(f.initial_inverse_depth.is_finite() && f.initial_inverse_depth >= 0.0) {
            return Err(Error::config(
                "slam.filter.initial_inverse_depth",
                f.initial_inverse_depth,
                "must be finite and >= 0",
            ));
        }
        if !(st.velocity_sigma_fraction.is_finite() && st.velocity_sigma_fraction >= 0.0) {
            return Err(Error::config(
                "slam.start.velocity_sigma_fraction",
                st.velocity_sigma_fraction,
                "must be finite and >= 0",
            ));
        }
        if !(0.0..1.0).contains(&r.confidence) {
            return Err(Error::config(
                "slam.ransac.confidence",
                r.confidence,
                "must be in [0, 1)",
            ));
        }
        within("slam.search.min_correlation", s.min_correlation, -1.0..=1.0)?;
        within(
            "slam.search.min_tracked_correlation",
            s.min_tracked_correlation,
            -1.0..=1.0,
        )?;
        if !(s.descriptor_tolerance.is_finite() && s.descriptor_tolerance > 0.0) {
            return Err(Error::config(
                "slam.search.descriptor_tolerance",
                s.descriptor_tolerance,
                "must be finite and > 0",
            ));
        }
        if let Some(&bad) = s
            .template_scales
            .iter()
            .find(|v| !(v.is_finite() && (0.25..=4.0).contains(*v)))
        {
            return Err(Error::config(
                "slam.search.template_scales",
                bad,
                "every scale must be in [0.25, 4]",
            ));
        }
        within("slam.search.template_half", s.template_half, 1..=32)?;
        within("slam.search.max_widening", s.max_widening, 0..=64)?;
        for (field, grid) in [
            ("slam.map.grid", m.grid),
            ("slam.start.corner_grid", st.corner_grid),
        ] {
            if grid[0] == 0 || grid[1] == 0 || grid[0] * grid[1] > 1 << 16 {
                return Err(Error::config(
                    field,
                    format!("{grid:?}"),
                    "needs 1 to 65536 cells, at least one each way",
                ));
            }
        }
        if m.target_visible == 0 || m.max_landmarks < m.target_visible {
            return Err(Error::config(
                "slam.map.max_landmarks",
                m.max_landmarks,
                "must be >= target_visible >= 1",
            ));
        }
        if r.max_hypotheses == 0 {
            return Err(Error::config(
                "slam.ransac.max_hypotheses",
                0,
                "must be >= 1",
            ));
        }
        within("slam.map.min_match_ratio", m.min_match_ratio, 0.0..=1.0)?;
        within("slam.start.min_points", st.min_points, 8..=100_000)?;
        within("slam.start.corners_per_cell", st.corners_per_cell, 1..=64)?;
        within(
            "slam.start.two_view_iterations",
            st.two_view_iterations,
            1..=1_000_000,
        )?;
        within("slam.start.trial_frames", st.trial_frames, 1..=100)?;
        self.klt.validate()?;
        let rf = &self.refine;
        if rf.keyframes > 0 {
            // 0 is off; a window needs a free keyframe beside the fixed ones.
            within("slam.refine.keyframes", rf.keyframes, 3..=64)?;
            within("slam.refine.fixed", rf.fixed, 2..=rf.keyframes - 1)?;
        }
        within("slam.refine.iterations", rf.iterations, 1..=100)?;
        positive(&[
            ("slam.refine.rotation", rf.rotation),
            ("slam.refine.translation", rf.translation),
            ("slam.refine.huber", rf.huber),
            (
                "slam.refine.measurement_inflation",
                rf.measurement_inflation,
            ),
        ])?;
        within("slam.refine.min_parallax", rf.min_parallax, 0.0..=1.0)?;
        if let MotionModel::ConstantVelocity {
            linear_acceleration,
            angular_acceleration,
        } = self.motion
        {
            positive(&[
                (
                    "slam.motion.constant-velocity.linear_acceleration",
                    linear_acceleration,
                ),
                (
                    "slam.motion.constant-velocity.angular_acceleration",
                    angular_acceleration,
                ),
            ])?;
        }
        if let MotionModel::Wheeled(w) = &self.motion {
            positive(&[
                (
                    "slam.motion.wheeled.linear_acceleration",
                    w.linear_acceleration,
                ),
                (
                    "slam.motion.wheeled.angular_acceleration",
                    w.angular_acceleration,
                ),
                ("slam.motion.wheeled.slip", w.slip),
                ("slam.motion.wheeled.vertical", w.vertical),
                ("slam.motion.wheeled.tilt_rate", w.tilt_rate),
                ("slam.motion.wheeled.arm_sigma", w.arm_sigma),
            ])?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sub_tables_parse_and_moved_keys_name_their_new_place() {
        let c: SlamConfig = toml::from_str(
            "[filter]\npixel_sigma = 2.0\n[ransac]\nthreshold = 3\n[klt]\nlevels = 3\n",
        )
        .unwrap();
        assert_eq!(c.filter.pixel_sigma, 2.0);
        assert_eq!(c.ransac.threshold, 3.0);
        assert_eq!(c.klt.levels, 3);
        assert_eq!(c.map, MapConfig::default());
        for (old, new) in MOVED_KEYS {
            let e = toml::from_str::<SlamConfig>(&format!("{old} = 1\n"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(new), "{old}: {e}");
        }
        let e = toml::from_str::<SlamConfig>("[search]\ngatez = 1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown field `gatez`"), "{e}");
    }

    #[test]
    fn defaults_are_valid_and_bad_values_are_named() {
        SlamConfig::default().validate().unwrap();
        let mut c = SlamConfig::default();
        c.start.corner_grid = [0, 4];
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("slam.start.corner_grid"), "{e}");
        let mut c = SlamConfig::default();
        c.klt.levels = 0;
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("slam.klt.levels"), "{e}");
    }

    #[test]
    fn the_wheeled_model_takes_its_defaults_and_names_a_bad_key() {
        let c: SlamConfig = toml::from_str("[motion.wheeled]\n").unwrap();
        assert_eq!(c.motion, MotionModel::wheeled());
        c.validate().unwrap();
        let c: SlamConfig = toml::from_str("[motion.wheeled]\nslip = -1\n").unwrap();
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("slam.motion.wheeled.slip"), "{e}");
        let e = toml::from_str::<SlamConfig>("[motion.wheeled]\narm = 0.1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown field `arm`"), "{e}");
    }

    #[test]
    fn a_motion_key_left_out_keeps_its_default() {
        let c: SlamConfig =
            toml::from_str("[motion.constant-velocity]\nlinear_acceleration = 2\n").unwrap();
        assert_eq!(
            c.motion,
            MotionModel::ConstantVelocity {
                linear_acceleration: 2.0,
                angular_acceleration: 6.0,
            }
        );
        let c: SlamConfig = toml::from_str("[motion.constant-velocity]\n").unwrap();
        assert_eq!(c.motion, MotionModel::default());
        let c: SlamConfig = toml::from_str("[motion.odometry]\nrotation_floor = 0.01\n").unwrap();
        let MotionModel::Odometry {
            translation_fraction,
            rotation_floor,
            ..
        } = c.motion
        else {
            panic!("not odometry: {:?}", c.motion);
        };
        assert_eq!((translation_fraction, rotation_floor), (0.05, 0.01));
    }

    #[test]
    fn the_serialised_config_reads_back() {
        let mut c = SlamConfig::default();
        c.map.grid = [4, 3];
        c.search.template_scales = vec![0.9];
        let text = toml::to_string(&c).unwrap();
        let back: SlamConfig = toml::from_str(&text).unwrap();
        assert_eq!(back, c);
    }
}
