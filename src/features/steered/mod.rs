//! A matchable rotation-invariant descriptor, steered by the keypoint's own orientation: the
//! first-order steerable basis (eq 3 with n = 1: F(θ) = cos θ·Ix + sin θ·Iy on the image
//! smoothed to the keypoint's scale, its total blur) read in the keypoint's frame. Beyond the
//! paper, whose 5-entropy descriptor (section 2.3, [`super::descriptor`]) recalls 0.29 under
//! rotation.
//!
//! 1. **Orientation** in [0, 2π). The keypoint's `angle` is the axis of its strongest steered
//!    second-order response, quantised to the N steered orientations and ambiguous by a half
//!    turn. The frame instead takes the direction θ* that maximises the first-order steered
//!    energy of the patch: a 36-bin histogram of argmax_θ F(θ) = atan2(Iy, Ix), weighted by
//!    |∇I| and a Gaussian window, smoothed, with a parabolic fit around its peak. The sign of
//!    the first-order response resolves the half turn, and the angle is continuous.
//! 2. **Descriptor**: the steered responses F(θ* + φ_b) of every pixel of a square window
//!    rotated by θ*, binned into 4×4 cells × 8 directions φ_b with trilinear weights and a
//!    Gaussian window (128 values). The vector is L2-normalised, clipped at 0.2 and
//!    normalised again, so that a few saturated gradients (light changes) cannot dominate.
//! 3. **Twin frames** (the `steered-twin` kind): where the smoothed histogram has a second
//!    local peak of at least 0.8 of the highest (a corner's other edge), the patch is
//!    also read in that peak's frame, and [`squared_distance`] takes the nearest pair of
//!    frames, so a keypoint whose peaks trade places between two views still matches.
//!
//! Each keypoint works on its own patch, smoothed on the spot, so memory does not grow with
//! the image. The detector reads a coarse keypoint on the pyramid level of its scale
//! ([`crate::features::harris::plan::descriptor_level`]), so its patch has the size of a fine
//! one's.
//!
//! Both the orientation and the descriptor are rotation invariant by construction: rotating
//! the image rotates the window, the gradients and θ* together.

pub mod cpu;
pub mod gpu;

pub use cpu::describe_steered;
pub use gpu::GpuSteered;

use crate::features::steerable::Kernel1d;

/// Length of the steered descriptor.
pub const STEERED_LEN: usize = CELLS * CELLS * DIRECTIONS;
/// Spatial cells per side.
pub(crate) const CELLS: usize = 4;
/// Direction bins per cell.
pub(crate) const DIRECTIONS: usize = 8;
/// Side of one cell, in units of the keypoint's scale (its total blur, `Keypoint::scale`). At
/// the finest scale (σ_D = 1, scale 1.22) the window spans 20 px, the entropy descriptor's
/// patch; measured against a side of 5 total σ (6.1 σ_D at the finest scale) on the Oxford
/// sequences: 4767 correct matches at 3 px against 4650 (docs/EVALUATION.md).
pub(crate) const CELL_SIGMAS: f32 = 4.1;
/// Standard deviation of the orientation window, in units of the keypoint's scale (4 σ_D at
/// the finest scale).
pub(crate) const ORIENTATION_SIGMAS: f32 = 3.3;
/// Bins of the orientation histogram.
pub(crate) const ORIENTATION_BINS: usize = 36;
/// Largest value of the normalised descriptor before the second normalisation.
pub(crate) const CLIP: f32 = 0.2;
/// A second orientation-histogram peak at least this share of the highest gets a frame of its
/// own in the `steered-twin` descriptor (SIFT's 0.8).
pub(crate) const TWIN_PEAK: f32 = 0.8;
/// Gaussian smoothing kernels are truncated at this many σ.
pub(crate) const SMOOTH_TRUNCATE: f32 = 3.0;

/// The patch geometry both twins use for a keypoint of scale `sigma` (its total blur, in the
/// plane's pixels) on a plane that already carries a blur of `prior_blur` (pixels; a pyramid
/// level's, the image's own included): the half-side of the gradient window (pixels) and the
/// kernel that brings the blur up to `sigma`.
pub(crate) fn patch_geometry(sigma: f32, prior_blur: f32) -> (usize, Kernel1d) {
    let window = CELLS as f32 * CELL_SIGMAS * sigma;
    // The rotated window's corners reach half its diagonal; the orientation window 3σ.
    let reach = (0.5 * window * std::f32::consts::SQRT_2).max(3.0 * ORIENTATION_SIGMAS * sigma);
    let half = reach.ceil() as usize + 1;
    (
        half,
        Kernel1d::gaussian_derivative(
            (sigma * sigma - prior_blur * prior_blur).max(0.25).sqrt(),
            0,
            SMOOTH_TRUNCATE,
        ),
    )
}

/// The pixel nearest a sub-pixel coordinate (halves round up on both backends).
#[inline(always)]
pub(crate) fn nearest_pixel(v: f32) -> i64 {
    (v + 0.5).floor() as i64
}

/// atan2(y, x) in [−π, π] to within 1e-5 rad: a polynomial on [0, 1] and the octant's
/// symmetries. Four times cheaper than the library's on the CPU, and written out so that
/// `shaders/steered_descriptor.wgsl` computes it the same way. (0, 0) gives 0.
#[inline(always)]
pub(crate) fn fast_atan2(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let steep = ay > ax;
    let (num, den) = if steep { (ax, ay) } else { (ay, ax) };
    // Selects rather than an early return, so that loops over pixels vectorise; den = 0
    // means x = y = 0, whose z = 0 gives 0 below.
    let z = if den > 0.0 { num / den } else { 0.0 };
    let z2 = z * z;
    let a = z
        * (0.999_977_26
            + z2 * (-0.332_623_47
                + z2 * (0.193_543_46
                    + z2 * (-0.116_432_87 + z2 * (0.052_653_32 + z2 * -0.011_721_2)))));
    let a = if steep { FRAC_PI_2 - a } else { a };
    let a = if x < 0.0 { PI - a } else { a };
    if y < 0.0 {
        -a
    } else {
        a
    }
}

/// floor(t) for |t| < 2³¹, inline (the baseline x86-64 target calls the library for it).
#[inline(always)]
pub(crate) fn floor(t: f32) -> f32 {
    let f = t as i32 as f32;
    if f > t {
        f - 1.0
    } else {
        f
    }
}

/// Squared distance between two descriptors of `frames` equal frames each (1 for most kinds,
/// [`crate::features::DescriptorKind::frames`]): the squared Euclidean distance of the nearest
/// pair of frames, so two `steered-twin` descriptors are as near as their nearest frames.
/// With one frame, or lengths that do not split into `frames`, the plain squared distance.
pub fn squared_distance(a: &[f32], b: &[f32], frames: usize) -> f32 {
    let plain =
        |x: &[f32], y: &[f32]| -> f32 { x.iter().zip(y).map(|(p, q)| (p - q) * (p - q)).sum() };
    if frames <= 1 || a.len() != b.len() || !a.len().is_multiple_of(frames) {
        return plain(a, b);
    }
    let side = a.len() / frames;
    a.chunks_exact(side)
        .flat_map(|x| b.chunks_exact(side).map(move |y| plain(x, y)))
        .fold(f32::INFINITY, f32::min)
}

/// A descriptor and the orientation of its frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Steered {
    /// Direction θ* of the frame, radians in [0, 2π).
    pub orientation: f32,
    /// The 128 values, unit length (all zero on a flat patch).
    pub values: Vec<f32>,
}

#[cfg(test)]
mod tests {
    use super::fast_atan2;

    #[test]
    fn the_fast_arctangent_is_within_1e5_of_the_library() {
        let mut worst = 0.0f32;
        for i in 0..20_000 {
            let t = i as f32 / 20_000.0 * std::f32::consts::TAU;
            for r in [1e-6f32, 0.3, 1.0, 250.0] {
                let (y, x) = (r * t.sin(), r * t.cos());
                worst = worst.max((fast_atan2(y, x) - y.atan2(x)).abs());
            }
        }
        assert!(worst < 1.2e-5, "{worst}");
        assert_eq!(fast_atan2(0.0, 0.0), 0.0);
    }
}
