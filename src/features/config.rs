//! Detector configuration: every knob of sections 2.2–2.3 with its documented default,
//! loadable from TOML (`[detector]` table) and validated before any work starts.

use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, Error, Result};

/// Order of the Gaussian-derivative basis that is steered (eq 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BasisOrder {
    /// First derivatives (Gx, Gy): F(θ) = cosθ·Ix + sinθ·Iy.
    First,
    /// Second derivatives (Gxx, Gxy, Gyy): F(θ) = cos²θ·Ixx + 2cosθ sinθ·Ixy + sin²θ·Iyy.
    Second,
}

named_variants!(BasisOrder { First => "first", Second => "second" });

impl BasisOrder {
    /// The derivative order n of the basis.
    pub fn order(self) -> usize {
        match self {
            BasisOrder::First => 1,
            BasisOrder::Second => 2,
        }
    }
}

/// How the detections of all orientations and scales are merged into keypoints (section 2.2.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MergeMode {
    /// Two-stage merge covariant with the image and its scale: k-means seeded from a radius
    /// suppression of the strongest candidates and confined to their neighbourhoods, then
    /// close means merged, both with radii proportional to σ_D and only between adjacent
    /// scales, so a fine and a coarse keypoint at the same place both survive.
    Covariant,
    /// The same two stages with the radius in pixels at every scale and across all scales
    /// (the merge before octaves): each place gives one keypoint. SLAM's tracking preset keeps
    /// it, as its landmarks start at the finest keypoints.
    Pixel,
    /// The literal reading of the paper: k-means++ with random (seeded) starts over all
    /// candidates, k = max_keypoints, then close means merged. Kept for comparison.
    KmeansPp,
}

named_variants!(MergeMode { Covariant => "covariant", Pixel => "pixel", KmeansPp => "kmeans-pp" });

/// How the `max_keypoints` kept are chosen among the merged clusters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Spread {
    /// The strongest (by rank).
    Strongest,
    /// Adaptive non-maximal suppression (Brown, Szeliski and Winder 2005), within an octave:
    /// each cluster's radius is its distance to the nearest cluster of a scale at most an
    /// octave away that is clearly stronger (by 1/0.9); the largest radii are kept, so the
    /// keypoints spread over the image while a coarse structure never suppresses the fine
    /// corners on it.
    Anms,
}

named_variants!(Spread { Strongest => "strongest", Anms => "anms" });

/// Which descriptor each keypoint carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DescriptorKind {
    /// 128 steered first-order responses in the keypoint's own frame, for matching
    /// ([`crate::low_level::steered`]).
    Steered,
    /// The steered descriptor read in two frames: the orientation histogram's highest peak and,
    /// where a second peak reaches 0.8 of it, that one too (a corner's other edge); 256 values,
    /// the second 128 a copy of the first when there is no second peak. Two such descriptors
    /// are as near as their nearest pair of frames
    /// ([`crate::low_level::steered::squared_distance`]), so a keypoint whose orientation
    /// flips between views still matches. Computed on the CPU on every backend.
    #[serde(rename = "steered-twin")]
    SteeredTwin,
    /// The paper's five colour entropies (section 2.3, eqs 9–10).
    Entropy,
    /// Keypoints only, for callers that describe (or track) them their own way, as SLAM does
    /// with its templates: the keypoints cannot be matched.
    None,
}

named_variants!(DescriptorKind {
    Steered => "steered",
    SteeredTwin => "steered-twin",
    Entropy => "entropy",
    None => "none"
});

impl DescriptorKind {
    /// Frames each descriptor holds (2 for `steered-twin`, else 1): the `frames` of
    /// [`crate::low_level::steered::squared_distance`] and of the matcher's settings.
    pub fn frames(self) -> usize {
        match self {
            DescriptorKind::SteeredTwin => 2,
            _ => 1,
        }
    }

    /// Number of values per keypoint.
    pub fn length(self) -> usize {
        match self {
            DescriptorKind::Steered => crate::features::steered::STEERED_LEN,
            DescriptorKind::SteeredTwin => 2 * crate::features::steered::STEERED_LEN,
            DescriptorKind::Entropy => 5,
            DescriptorKind::None => 0,
        }
    }
}

/// All parameters of the detector; `Default` gives the documented defaults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DetectorConfig {
    /// Number of steered orientations N, spread over [0, π) (eq 3). Default 12: 15° apart, so
    /// the 15° steps of a rotation sweep land on steered filters (8 measured 0.02–0.03 lower in mean
    /// rotation repeatability, for about 20% less time).
    pub orientations: usize,
    /// Basis of the steerable filter. Default first order: Harris on every steered first
    /// derivative. Its responses fall with blur as (σ_e/t)^8 (t the total blur), against
    /// (σ_e/t)^12 for the second order's third derivatives, so a blurred, compressed or
    /// resampled view keeps more of the same keypoints (docs/EVALUATION.md, "The first-order
    /// basis").
    pub basis: BasisOrder,
    /// Standard deviation of the Gaussian basis filters, in pixels. Default 0.8 (1.0 for the
    /// second order, which SLAM's tracking preset keeps).
    pub basis_sigma: f32,
    /// Number of detection scales S. Default 16: σ_D from 1 to 32 px, five octaves of three
    /// scales, whose coarse scales run on the image pyramid (see
    /// [`crate::features::harris::plan`]).
    pub scales: usize,
    /// Finest differentiation scale σ_D, in pixels. Default 1.0.
    pub sigma0: f32,
    /// Ratio between successive scales (σ_D = sigma0 · scale_step^s). Default 2^(1/3): three
    /// scales per octave, which find 1–8% more correct matches on the Oxford and generated
    /// sequences than two (√2, with `scales = 11`; a corner's response peak moves with scale,
    /// so a finer sampling keeps a zoomed or blurred view's keypoints closer), at 20–50% more
    /// time on the CPU (docs/EVALUATION.md, "Three scales per octave").
    pub scale_step: f32,
    /// Exponent p of the scale normalisation: every derivative plane D_k is multiplied by
    /// σ_e^p (σ_e the effective scale) before the structure tensor, so R scales with σ_e^(4p).
    /// Default 2.0, the order of the D_k (second derivatives for the first-order basis; 3 for
    /// the second order's third derivatives): the γ-normalisation under which R of a
    /// structure zoomed by s peaks at s times the scale, so the suppression across scales
    /// picks each corner's characteristic scale. One below the order, the responses fall as
    /// σ⁻⁴ and 99% of the keypoints come from the finest scale.
    pub scale_normalization: f32,
    /// Exponent p_r of the normalisation used to rank keypoints against each other across
    /// scales: a member's response R_s counts as R_s·(σ_e,s/σ_e,0)^(4(p_r − p)) when its
    /// cluster's strength is taken. Scale selection (suppression across scales) keeps p; a
    /// ranking with p_r < p favours the finest scales. Default 1.8 (p − 0.2): a slight lean to
    /// the fine scales, whose keypoints survive the blur of a resampled (rotated) view better;
    /// p_r = p gives more coarse keypoints and loses rotation repeatability (docs/EVALUATION.md).
    pub rank_normalization: f32,
    /// Integration-window ratio γ (σ_I = γ·σ_D, eq 7). Default 1.5.
    pub gamma: f32,
    /// Blur the input images carry already, in their pixels (optics, demosaicing, resizing).
    /// Default 0.7 ([`crate::low_level::harris::plan::IMAGE_BLUR`]). A keypoint's scale is
    /// the total blur √(σ_D² + b²), which follows zoom between views, and the steered
    /// descriptor smooths its patch from it: about 0.5 suits images shrunk with an area
    /// filter, 1 or more soft optics. Detection itself does not depend on it.
    pub image_blur: f32,
    /// Harris constant k of eq 8. Default 0.04.
    pub harris_k: f32,
    /// Absolute floor of the scale-normalised Harris response of a candidate. Default 1e-12,
    /// below the responses that 8-bit quantisation noise gives, so that the relative threshold
    /// decides on any textured image.
    pub threshold: f32,
    /// Relative threshold: a candidate's response must exceed this fraction of the frame's
    /// strongest response (taken in the response pass itself), so the detector keeps its
    /// keypoints on blurred, dim and low-contrast images, where responses fall with the fourth
    /// power of contrast. The threshold applied is max(threshold, relative_threshold ×
    /// strongest). 0 turns it off. Default 0.001 (the strongest response of a frame now often
    /// comes from a coarse scale, far above the fine corners).
    pub relative_threshold: f32,
    /// Kernels are truncated at this many standard deviations. Default 4.0: at 3σ the
    /// square support of the separable derivative kernels cut off enough tail to make their
    /// responses measurably less rotation-invariant.
    pub truncate: f32,
    /// Merge strategy. Default covariant.
    pub merge: MergeMode,
    /// Radius of the merge neighbourhoods, in pixels. Default 2.0.
    pub merge_radius: f32,
    /// Keep at most this many keypoints, the strongest. Default 500.
    pub max_keypoints: usize,
    /// How the kept keypoints are chosen. Default strongest.
    pub spread: Spread,
    /// Capacity of the candidate list read back from the GPU; when more candidates survive,
    /// both backends raise the threshold ×4 until they fit. Default 131072.
    pub candidate_capacity: usize,
    /// Seed of the random starts of `kmeans-pp`. Default 7.
    pub seed: u64,
    /// The descriptor each keypoint carries. Default steered (matchable under rotation and
    /// light changes); `entropy` is the paper's.
    pub descriptor: DescriptorKind,
    /// Side of the square tiles (core, pixels) the GPU backend cuts frames into; each tile
    /// carries a halo wide enough for the largest kernel, so the candidates are those of an
    /// untiled run. 0 (default): tiles only for frames past the device's buffer limits, as
    /// large as fit.
    pub gpu_tile_size: u32,
}

impl Default for DetectorConfig {
    fn default() -> Self {
        Self {
            orientations: 12,
            basis: BasisOrder::First,
            basis_sigma: 0.8,
            scales: 16,
            sigma0: 1.0,
            scale_step: THREE_PER_OCTAVE,
            scale_normalization: 2.0,
            rank_normalization: 1.8,
            gamma: 1.5,
            image_blur: crate::features::harris::plan::IMAGE_BLUR,
            harris_k: 0.04,
            threshold: 1e-12,
            relative_threshold: 0.001,
            truncate: 4.0,
            merge: MergeMode::Covariant,
            merge_radius: 2.0,
            max_keypoints: 500,
            spread: Spread::Strongest,
            candidate_capacity: 1 << 17,
            seed: 7,
            descriptor: DescriptorKind::Steered,
            gpu_tile_size: 0,
        }
    }
}

/// 2^(1/3), the default ratio between successive scales: three per octave.
pub const THREE_PER_OCTAVE: f32 = 1.259_921;

/// Upper bound on orientations: the GPU's non-maximum suppression visits 27 neighbours per
/// orientation in one invocation and lavapipe stops loops past 65,535 iterations.
pub const MAX_ORIENTATIONS: usize = 180;
/// Upper bound on scales: the coarse ones run on the pyramid, so their kernels stay small;
/// 32 allow six per octave over the default five octaves.
pub const MAX_SCALES: usize = 32;

impl DetectorConfig {
    /// The configuration SLAM detects new landmarks with: 6 orientations and 3 fine scales
    /// (σ_D 1–2, ranked towards the finest) instead of 12 and 16. Landmarks start at the
    /// finest keypoints, where the corner is, and are then followed by KLT and templates, so
    /// the extra orientations and coarse scales buy nothing there; the detection costs much
    /// less and the accuracy of the SLAM runs held or improved (CHANGELOG, issues 10 and 20).
    /// `steernav slam` starts from it; its flags still override.
    pub fn tracking() -> Self {
        Self {
            orientations: 6,
            // Measured with the second-order basis, which it keeps: its landmarks' templates
            // and the SLAM suite's figures were set on it.
            basis: BasisOrder::Second,
            basis_sigma: 1.0,
            scales: 3,
            scale_step: 1.4,
            scale_normalization: 2.0,
            rank_normalization: 0.5,
            merge: MergeMode::Pixel,
            relative_threshold: 0.001,
            // The tracker cuts its own templates and entropies where a landmark starts.
            descriptor: DescriptorKind::None,
            ..Self::default()
        }
    }

    /// The configuration for matching two views (`steernav match`): the defaults with 1000
    /// keypoints, the count the homography evaluation compares every detector at, instead of
    /// 500. Under a large change of scale only the keypoints coarse enough to exist in both
    /// views can pair, and 500 leave too few of them: bark img1–img4 (a zoom of 2.5 and a
    /// rotation) gives 65 inliers at 500 and 145 at 1000, at 0.21 s against 0.15 s per pair on
    /// two cores (docs/EVALUATION.md).
    pub fn matching() -> Self {
        Self {
            max_keypoints: 1000,
            ..Self::default()
        }
    }

    /// These settings with `keys` (a `[detector]` table's) in place of their own, checked: how
    /// a command with its own preset takes a user's settings without losing the rest of it.
    pub fn overlaid(&self, keys: &toml::Table) -> Result<Self> {
        let invalid = |reason: String| Error::config("detector", "(the [detector] keys)", reason);
        let mut merged = toml::Table::try_from(self).map_err(|e| invalid(e.to_string()))?;
        for (key, value) in keys {
            merged.insert(key.clone(), value.clone());
        }
        let config: Self = toml::Value::Table(merged)
            .try_into()
            .map_err(|e: toml::de::Error| invalid(e.to_string().trim_end().to_string()))?;
        config.validate()?;
        Ok(config)
    }

    /// Checks every value; the error names the field and its valid range.
    pub fn validate(&self) -> Result<()> {
        fn bad(field: &'static str, value: impl ToString, reason: &str) -> Result<()> {
            Err(Error::Config {
                field,
                value: value.to_string(),
                reason: reason.to_string(),
            })
        }
        // Each bound caps the work the value causes: kernel radii, window sizes, merge area.
        let bounded = [
            ("basis_sigma", self.basis_sigma, 32.0),
            ("sigma0", self.sigma0, 32.0),
            ("gamma", self.gamma, 8.0),
            ("truncate", self.truncate, 8.0),
            ("merge_radius", self.merge_radius, 64.0),
        ];
        for (field, v, max) in bounded {
            if !v.is_finite() || v <= 0.0 || v > max {
                return bad(field, v, &format!("must be a finite number in (0, {max}]"));
            }
        }
        if !self.scale_normalization.is_finite() || !(0.0..=4.0).contains(&self.scale_normalization)
        {
            return bad(
                "scale_normalization",
                self.scale_normalization,
                "must be finite, in [0, 4]",
            );
        }
        if !self.rank_normalization.is_finite() || !(0.0..=4.0).contains(&self.rank_normalization) {
            return bad(
                "rank_normalization",
                self.rank_normalization,
                "must be finite, in [0, 4]",
            );
        }
        if !self.scale_step.is_finite() || self.scale_step <= 1.0 || self.scale_step > 4.0 {
            return bad(
                "scale_step",
                self.scale_step,
                "must be a finite number in (1, 4]",
            );
        }
        if !self.harris_k.is_finite() || !(0.0..0.25).contains(&self.harris_k) {
            return bad("harris_k", self.harris_k, "must be finite, in [0, 0.25)");
        }
        if !self.threshold.is_finite() || self.threshold < 0.0 {
            return bad("threshold", self.threshold, "must be a finite number >= 0");
        }
        if !self.image_blur.is_finite() || !(0.0..=3.0).contains(&self.image_blur) {
            return bad(
                "image_blur",
                self.image_blur,
                "must be finite, in [0, 3] px",
            );
        }
        if !self.relative_threshold.is_finite() || !(0.0..=1.0).contains(&self.relative_threshold) {
            return bad(
                "relative_threshold",
                self.relative_threshold,
                "must be finite, in [0, 1]",
            );
        }
        if !(1..=MAX_ORIENTATIONS).contains(&self.orientations) {
            return bad(
                "orientations",
                self.orientations,
                &format!("must be in 1..={MAX_ORIENTATIONS}"),
            );
        }
        if !(1..=MAX_SCALES).contains(&self.scales) {
            return bad(
                "scales",
                self.scales,
                &format!("must be in 1..={MAX_SCALES}"),
            );
        }
        let largest = (self.sigma0 * self.scale_step.powi(self.scales as i32 - 1) * self.gamma)
            .max(self.basis_sigma);
        if !largest.is_finite() || largest * self.truncate > 256.0 {
            return bad(
                "scales",
                self.scales,
                "the largest integration window would exceed a 256-pixel radius",
            );
        }
        if self.gpu_tile_size != 0 && !(64..=1 << 16).contains(&self.gpu_tile_size) {
            return bad(
                "gpu_tile_size",
                self.gpu_tile_size,
                "must be 0 (automatic) or in 64..=65536",
            );
        }
        if self.max_keypoints == 0 {
            return bad("max_keypoints", 0, "must be at least 1");
        }
        if !(1..=(1 << 22)).contains(&self.candidate_capacity) {
            return bad(
                "candidate_capacity",
                self.candidate_capacity,
                "must be in 1..=4194304",
            );
        }
        Ok(())
    }

    /// Parses a TOML document (the `[detector]` table or a bare table) and validates it.
    ///
    /// Errors name the real culprit with its line: a misspelled key or a wrong type inside
    /// `[detector]`, a stray table beside it, or a top-level key next to it.
    pub fn from_toml_str(text: &str) -> Result<Self, ConfigError> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct InTable {
            detector: DetectorConfig,
        }
        let parse_error = |e| ConfigError::from_toml(text, e);
        let table: toml::Table = toml::from_str(text).map_err(parse_error)?;
        let cfg = if table.contains_key("detector") {
            toml::from_str::<InTable>(text)
                .map_err(parse_error)?
                .detector
        } else {
            toml::from_str::<DetectorConfig>(text).map_err(parse_error)?
        };
        cfg.validate()
            .map_err(|e| ConfigError::invalid("detector", e))?;
        Ok(cfg)
    }

    /// The threshold applied to a frame whose strongest response is `strongest` (before any
    /// raise for an overflowing candidate list). Both backends compute it this way, in f32.
    pub fn effective_threshold(&self, strongest: f32) -> f32 {
        self.threshold.max(self.relative_threshold * strongest)
    }

    /// Differentiation scale σ_D of detection scale `s`.
    pub fn sigma_d(&self, s: usize) -> f32 {
        self.sigma0 * self.scale_step.powi(s as i32)
    }

    /// Integration scale σ_I = γ·σ_D of detection scale `s`.
    pub fn sigma_i(&self, s: usize) -> f32 {
        self.gamma * self.sigma_d(s)
    }

    /// Effective scale σ_e = √(σ_D² + σ_b²) of the derivative filters of scale `s`.
    pub fn sigma_e(&self, s: usize) -> f32 {
        self.sigma_d(s).hypot(self.basis_sigma)
    }

    /// Candidates closer than this to the border are dropped at scale `s`: the radius of the
    /// derivative filters (truncate·σ_e, at least 2 px), so that no candidate rests on the
    /// structure that clamped borders invent (an oblique edge bends where the border clamps).
    pub fn margin(&self, s: usize) -> u32 {
        (self.truncate * self.sigma_e(s)).ceil().max(2.0) as u32
    }
}
