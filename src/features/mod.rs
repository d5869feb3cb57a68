//! Rotation-invariant keypoints (paper section 2.2–2.3): steerable filter bank, multiscale
//! Harris on every steered image, two-stage merge, 5-entropy colour descriptor.

pub(crate) mod config;
pub(crate) mod convolve;
pub(crate) mod descriptor;
pub(crate) mod detector;
pub(crate) mod filter_bank;
pub(crate) mod harris;
pub mod matching;
pub(crate) mod merge;
pub(crate) mod neighbours;
pub(crate) mod pyramid;
pub(crate) mod steerable;
pub(crate) mod steered;

use serde::{Deserialize, Serialize};

pub use config::{BasisOrder, DescriptorKind, DetectorConfig, MergeMode, Spread};
pub use detector::{Backend, Detection, Detector, HarrisRun};

crate::gpu::layout::gpu_struct! {
    /// One detection of the Harris stage: a local maximum of R at one scale and one
    /// orientation. The layout is shared with `shaders/harris_nms.wgsl` (16 bytes).
    #[derive(PartialEq)]
    pub struct Candidate as "Candidate" {
        /// Sub-pixel column.
        pub x: f32,
        /// Sub-pixel row.
        pub y: f32,
        /// Scale-normalised Harris response (eq 8).
        pub response: f32,
        /// Scale index in the high 16 bits, the sub-scale offset (a signed byte, in 1/254 of a
        /// scale step) in bits 8–15, orientation index in the low 8 bits.
        pub packed: u32,
    }
}

/// Quantisation of a candidate's sub-scale offset: ±0.5 scale steps map to ±127.
const SCALE_OFFSET_UNITS: f32 = 254.0;

impl Candidate {
    /// Packs a scale and an orientation index (no sub-scale offset).
    pub fn pack(scale: usize, orientation: usize) -> u32 {
        Self::pack_with_offset(scale, orientation, 0.0)
    }
    /// Packs a scale index, an orientation index (below 256) and the sub-scale offset of the
    /// peak across scales, in scale steps within ±0.5 (quantised to 1/254).
    pub fn pack_with_offset(scale: usize, orientation: usize, offset: f32) -> u32 {
        // Halves round up, as `shaders/harris_nms.wgsl` rounds them.
        let q = (offset.clamp(-0.5, 0.5) * SCALE_OFFSET_UNITS + 0.5).floor() as i32 as i8 as u8;
        ((scale as u32) << 16) | ((q as u32) << 8) | (orientation as u32 & 0xff)
    }
    /// Index of the detection scale.
    pub fn scale_index(&self) -> usize {
        (self.packed >> 16) as usize
    }
    /// Index of the steered orientation.
    pub fn orientation_index(&self) -> usize {
        (self.packed & 0xff) as usize
    }
    /// Offset of the response's peak across scales from this scale, in scale steps within
    /// ±0.5 (the vertex of the parabola through the responses at the adjacent scales).
    pub fn scale_offset(&self) -> f32 {
        ((self.packed >> 8) & 0xff) as u8 as i8 as f32 / SCALE_OFFSET_UNITS
    }
}

/// Orders candidates strongest first, ties broken by position, scale and orientation, so the
/// merge sees the same sequence whatever order the GPU's atomic compaction produced.
pub fn sort_candidates(c: &mut [Candidate]) {
    c.sort_unstable_by(|a, b| {
        b.response
            .total_cmp(&a.response)
            .then(a.y.total_cmp(&b.y))
            .then(a.x.total_cmp(&b.x))
            .then(a.packed.cmp(&b.packed))
    });
}

/// The next threshold when more candidates survive than the list can hold.
pub fn raised_threshold(t: f32) -> f32 {
    (t * 4.0).max(1e-12)
}

/// A final keypoint, serialised with exactly the field names of the keypoint JSON.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Keypoint {
    /// Sub-pixel column (pixel centres at integers).
    pub x: f32,
    /// Sub-pixel row.
    pub y: f32,
    /// Characteristic scale, in pixels: the total blur √(σ_D² + b²) at the keypoint's σ_D and
    /// the image's own blur b ([`crate::low_level::harris::plan::IMAGE_BLUR`], 0.7 px), which
    /// is what follows a zoom between views. Its σ_D is that of the scale dominating the cluster, moved by its
    /// members' sub-scale offset (the peak of the response across the adjacent scales), so it
    /// lies within half a scale step of a sampled σ_D.
    pub scale: f32,
    /// Dominant steered orientation of the cluster's members, radians in [0, π).
    pub angle: f32,
    /// Strongest Harris response among the members.
    pub response: f32,
    /// The descriptor named by [`Detection::descriptor`]: 128 steered responses (unit length)
    /// or the entropies (bits) of the 20×20 patch quantised to 16 … 256 colours (eq 10).
    pub descriptor: Vec<f32>,
}
