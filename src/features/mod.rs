//! Rotation-invariant keypoints (paper section 2.2–2.3): steerable filter bank, multiscale
//! Harris on every steered image, two-stage merge, 5-entropy colour descriptor.

pub mod config;
pub(crate) mod convolve;
pub mod descriptor;
pub mod detector;
pub mod filter_bank;
pub mod harris;
pub mod matching;
pub mod merge;
pub(crate) mod pyramid;
pub(crate) mod steerable;
pub mod steered;

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
        /// Scale index in the high 16 bits, orientation index in the low 16 bits.
        pub packed: u32,
    }
}

impl Candidate {
    /// Packs a scale and an orientation index.
    pub fn pack(scale: usize, orientation: usize) -> u32 {
        ((scale as u32) << 16) | orientation as u32
    }
    /// Index of the detection scale.
    pub fn scale_index(&self) -> usize {
        (self.packed >> 16) as usize
    }
    /// Index of the steered orientation.
    pub fn orientation_index(&self) -> usize {
        (self.packed & 0xffff) as usize
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
    /// Differentiation scale σ_D of the scale that dominates the cluster, in pixels.
    pub scale: f32,
    /// Dominant steered orientation of the cluster's members, radians in [0, π).
    pub angle: f32,
    /// Strongest Harris response among the members.
    pub response: f32,
    /// The descriptor named by [`Detection::descriptor`]: 128 steered responses (unit length)
    /// or the entropies (bits) of the 20×20 patch quantised to 16 … 256 colours (eq 10).
    pub descriptor: Vec<f32>,
}
