//! CPU twin of the steered descriptor (see [`crate::low_level::steered`]); the GPU twin is
//! [`crate::low_level::steered::gpu`]
//! (`shaders/steered_descriptor.wgsl`), which follows this arithmetic step for step.

use std::f32::consts::TAU;

use super::{
    fast_atan2, floor, nearest_pixel, patch_geometry, wrap_angle, Steered, CELLS, CELL_SIGMAS,
    CLIP, DIRECTIONS, ORIENTATION_BINS, ORIENTATION_SIGMAS, STEERED_LEN,
};
use crate::features::harris::plan::IMAGE_BLUR;
use crate::features::steerable::Kernel1d;

/// The image around one keypoint, smoothed to its scale, as the magnitude and direction of its
/// gradient: the first-order steered response is largest, |∇I|, along atan2(Iy, Ix).
struct Patch {
    /// Column and row of the patch's first pixel in the image.
    x0: i64,
    y0: i64,
    side: usize,
    magnitude: Vec<f32>,
    direction: Vec<f32>,
}

impl Patch {
    /// The `side`×`side` window whose centre pixel is nearest (x, y), smoothed with `kernel`
    /// (borders clamped), and its central-difference gradient.
    #[inline(always)]
    fn around(
        gray: &[f32],
        width: usize,
        height: usize,
        (x, y): (f32, f32),
        half: usize,
        kernel: &Kernel1d,
    ) -> Self {
        let r = kernel.radius();
        let side = 2 * half + 1;
        let outer = side + 2 * (r + 1);
        let (cx, cy) = (nearest_pixel(x), nearest_pixel(y));
        let (ox, oy) = (cx - (half + r + 1) as i64, cy - (half + r + 1) as i64);
        // Rows first: `outer` rows of `side + 2` smoothed columns, each from the row's pixels
        // [ox, ox + inner + 2r) gathered once with the border clamped.
        let inner = side + 2;
        let mut rows = vec![0.0f32; outer * inner];
        let mut source = vec![0.0f32; inner + 2 * r];
        for j in 0..outer {
            let v = (oy + j as i64).clamp(0, height as i64 - 1) as usize;
            let line = &gray[v * width..(v + 1) * width];
            for (k, p) in source.iter_mut().enumerate() {
                *p = line[(ox + k as i64).clamp(0, width as i64 - 1) as usize];
            }
            // Tap by tap across the row: each output still sums its taps in order, and the
            // loop runs across outputs, which vectorises (a sum per output is a serial chain).
            let out = &mut rows[j * inner..(j + 1) * inner];
            for (t, &w) in kernel.taps.iter().enumerate() {
                for (o, &p) in out.iter_mut().zip(&source[t..]) {
                    *o += w * p;
                }
            }
        }
        let mut smooth = vec![0.0f32; inner * inner];
        for j in 0..inner {
            let out = &mut smooth[j * inner..(j + 1) * inner];
            for (t, &w) in kernel.taps.iter().enumerate() {
                for (o, &p) in out.iter_mut().zip(&rows[(j + t) * inner..]) {
                    *o += w * p;
                }
            }
        }
        let mut magnitude = vec![0.0; side * side];
        let mut direction = vec![0.0; side * side];
        // Row by row over slices, without closures or branches, so that the loops vectorise.
        for j in 0..side {
            let (up, mid, down) = (
                &smooth[j * inner + 1..j * inner + 1 + side],
                &smooth[(j + 1) * inner..(j + 2) * inner],
                &smooth[(j + 2) * inner + 1..(j + 2) * inner + 1 + side],
            );
            let (left, right) = (&mid[..side], &mid[2..side + 2]);
            let out_m = &mut magnitude[j * side..(j + 1) * side];
            let out_d = &mut direction[j * side..(j + 1) * side];
            for i in 0..side {
                let gx = 0.5 * (right[i] - left[i]);
                let gy = 0.5 * (down[i] - up[i]);
                out_m[i] = (gx * gx + gy * gy).sqrt();
                out_d[i] = fast_atan2(gy, gx);
            }
        }
        Self {
            x0: cx - half as i64,
            y0: cy - half as i64,
            side,
            magnitude,
            direction,
        }
    }

    /// Offsets from the sub-pixel centre c of the patch's columns (or rows) starting at `o`.
    #[inline(always)]
    fn offsets(&self, o: i64, c: f32) -> Vec<f32> {
        (0..self.side).map(|i| (o + i as i64) as f32 - c).collect()
    }
}

/// exp(−d²/(2σ²)) for each offset: the Gaussian window is separable, so a patch needs 2·side
/// exponentials instead of side². The GPU twin multiplies the same two factors.
#[inline(always)]
fn gaussian_factors(offsets: &[f32], sigma: f32) -> Vec<f32> {
    offsets
        .iter()
        .map(|d| (-(d * d) / (2.0 * sigma * sigma)).exp())
        .collect()
}

/// The steered descriptor of a keypoint at (x, y) of scale `sigma` (pixels, a
/// [`crate::Keypoint::scale`]: the total blur) on a luminance plane taken to carry the camera's
/// own blur ([`crate::low_level::harris::plan::IMAGE_BLUR`]).
pub fn describe_steered(
    gray: &[f32],
    width: usize,
    height: usize,
    x: f32,
    y: f32,
    sigma: f32,
) -> Steered {
    describe_steered_blurred(gray, width, height, (x, y, sigma), IMAGE_BLUR)
}

/// [`describe_steered`] on a plane that carries a Gaussian blur of `prior_blur` pixels (a
/// pyramid level's, the camera's own included): the patch is smoothed by what is missing to
/// reach `sigma`.
pub fn describe_steered_blurred(
    gray: &[f32],
    width: usize,
    height: usize,
    point: (f32, f32, f32),
    prior_blur: f32,
) -> Steered {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::has_avx2_fma() {
        // SAFETY: the CPU supports AVX2 (checked above).
        return unsafe { describe_avx2(gray, width, height, point, prior_blur) };
    }
    describe(gray, width, height, point, prior_blur)
}

/// [`describe`] compiled for AVX2: the smoothing, gradient and weighting loops run 8 lanes
/// wide instead of 4. Rust never contracts a multiply and an add into an FMA unless told to,
/// so the arithmetic, and every descriptor, is the baseline build's bit for bit.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn describe_avx2(
    gray: &[f32],
    width: usize,
    height: usize,
    point: (f32, f32, f32),
    prior_blur: f32,
) -> Steered {
    describe(gray, width, height, point, prior_blur)
}

#[inline(always)]
fn describe(
    gray: &[f32],
    width: usize,
    height: usize,
    (x, y, sigma): (f32, f32, f32),
    prior_blur: f32,
) -> Steered {
    let cell = CELL_SIGMAS * sigma;
    let window = CELLS as f32 * cell;
    let (half, kernel) = patch_geometry(sigma, prior_blur);
    let patch = Patch::around(gray, width, height, (x, y), half, &kernel);
    let (dxs, dys) = (patch.offsets(patch.x0, x), patch.offsets(patch.y0, y));
    let orientation = dominant_orientation(&patch, (&dxs, &dys), ORIENTATION_SIGMAS * sigma);
    let (sin, cos) = orientation.sin_cos();
    // Votes go to a histogram with a ring of spare cells around the 4×4, so that the
    // trilinear vote needs no bounds checks; the spare cells are dropped afterwards. Each
    // kept bin receives the same additions in the same order as a checked vote would.
    let mut padded = [0.0f32; PADDED_LEN];
    let weight_sigma = 0.5 * window;
    let to_bin = DIRECTIONS as f32 / TAU;
    let (gx, gy) = (
        gaussian_factors(&dxs, weight_sigma),
        gaussian_factors(&dys, weight_sigma),
    );
    // Row by row: first every pixel's place in the frame, weight and direction bin in loops
    // without branches (they vectorise), then the votes of the pixels inside the window.
    let side = patch.side;
    let mut votes = vec![Vote::default(); side];
    for (j, &dy) in dys.iter().enumerate() {
        let magnitude = &patch.magnitude[j * side..(j + 1) * side];
        let direction = &patch.direction[j * side..(j + 1) * side];
        for ((((vote, &dx), &m), &d), &wx) in votes
            .iter_mut()
            .zip(&dxs)
            .zip(magnitude)
            .zip(direction)
            .zip(&gx)
        {
            // The pixel in the keypoint's frame, in cells, with cell centres at integers.
            let u = (cos * dx + sin * dy) / cell + 0.5 * CELLS as f32 - 0.5;
            let v = (-sin * dx + cos * dy) / cell + 0.5 * CELLS as f32 - 0.5;
            vote.inside =
                !(u <= -1.0 || v <= -1.0 || u >= CELLS as f32 || v >= CELLS as f32) & (m != 0.0);
            vote.weight = m * (wx * gy[j]);
            // Direction of steepest steered response relative to the frame.
            vote.at = (u, v, wrap_angle(d - orientation) * to_bin);
        }
        for vote in votes.iter().filter(|v| v.inside) {
            trilinear(&mut padded, vote.at, vote.weight);
        }
    }
    let mut hist = vec![0.0f32; STEERED_LEN];
    for cv in 0..CELLS {
        for cu in 0..CELLS {
            let from = ((cv + 1) * PADDED_CELLS + cu + 1) * DIRECTIONS;
            let to = (cv * CELLS + cu) * DIRECTIONS;
            hist[to..to + DIRECTIONS].copy_from_slice(&padded[from..from + DIRECTIONS]);
        }
    }
    normalise(&mut hist);
    for v in &mut hist {
        *v = v.min(CLIP);
    }
    normalise(&mut hist);
    Steered {
        orientation,
        values: hist,
    }
}

/// One pixel's vote: its place in the frame (cells, cells, direction bins), its weight, and
/// whether it lies inside the window with a gradient.
#[derive(Clone, Copy, Default)]
struct Vote {
    at: (f32, f32, f32),
    weight: f32,
    inside: bool,
}

/// Cells per side of the histogram the votes go to: the 4×4 and a spare ring around it.
const PADDED_CELLS: usize = CELLS + 2;
/// Length of that histogram.
const PADDED_LEN: usize = PADDED_CELLS * PADDED_CELLS * DIRECTIONS;

/// Adds a pixel's weight `w` to the 2×2×2 bins around (u, v, φ) (cells, cells, direction
/// bins) with trilinear weights, in the padded histogram: u and v lie in (−1, CELLS), so the
/// cells reached are 0 … CELLS + 1 after the shift by one.
#[inline(always)]
fn trilinear(hist: &mut [f32; PADDED_LEN], (u, v, phi): (f32, f32, f32), w: f32) {
    let (u0, v0, p0) = (floor(u), floor(v), phi as i32 as f32);
    let (fu, fv, fp) = (u - u0, v - v0, phi - p0);
    let (cu, cv, d) = ((u0 + 1.0) as usize, (v0 + 1.0) as usize, p0 as usize);
    for (du, wu) in [(0, 1.0 - fu), (1, fu)] {
        for (dv, wv) in [(0, 1.0 - fv), (1, fv)] {
            let cell = ((cv + dv) * PADDED_CELLS + cu + du) * DIRECTIONS;
            for (dp, wp) in [(0, 1.0 - fp), (1, fp)] {
                hist[cell + (d + dp) % DIRECTIONS] += w * wu * wv * wp;
            }
        }
    }
}

#[inline(always)]
fn normalise(v: &mut [f32]) {
    let norm = v.iter().map(|x| x * x).sum::<f32>().sqrt();
    if norm > 0.0 {
        for x in v {
            *x /= norm;
        }
    }
}

/// θ* in [0, 2π): the peak of the magnitude-weighted histogram of gradient directions within
/// a Gaussian window of σ `sigma`, smoothed twice with [1, 2, 1]/4 and refined by a
/// parabola. `dxs`, `dys`: the offsets of the patch's columns and rows from the keypoint.
#[inline(always)]
fn dominant_orientation(patch: &Patch, (dxs, dys): (&[f32], &[f32]), sigma: f32) -> f32 {
    let mut hist = [0.0f32; ORIENTATION_BINS];
    let to_bin = ORIENTATION_BINS as f32 / TAU;
    let limit = (3.0 * sigma).powi(2);
    let (gx, gy) = (gaussian_factors(dxs, sigma), gaussian_factors(dys, sigma));
    for (j, &dy) in dys.iter().enumerate() {
        for (i, &dx) in dxs.iter().enumerate() {
            if dx * dx + dy * dy > limit {
                continue;
            }
            let k = j * patch.side + i;
            let w = patch.magnitude[k] * (gx[i] * gy[j]);
            // Linear vote between the two nearest bins keeps θ* continuous under rotation.
            let b = wrap_angle(patch.direction[k]) * to_bin - 0.5;
            let b0 = floor(b);
            let f = b - b0;
            let i0 = (b0 as i64).rem_euclid(ORIENTATION_BINS as i64) as usize;
            hist[i0] += w * (1.0 - f);
            hist[(i0 + 1) % ORIENTATION_BINS] += w * f;
        }
    }
    for _ in 0..2 {
        let h = hist;
        for (i, slot) in hist.iter_mut().enumerate() {
            let at = |d: usize| h[(i + ORIENTATION_BINS + d - 1) % ORIENTATION_BINS];
            *slot = 0.25 * at(0) + 0.5 * at(1) + 0.25 * at(2);
        }
    }
    let (peak, _) =
        hist.iter().enumerate().fold(
            (0, f32::MIN),
            |best, (i, &v)| if v > best.1 { (i, v) } else { best },
        );
    let at = |d: usize| hist[(peak + ORIENTATION_BINS + d - 1) % ORIENTATION_BINS];
    let offset = crate::features::harris::cpu::parabola_offset(at(0), at(1), at(2));
    wrap_angle((peak as f32 + 0.5 + offset) / to_bin)
}

/// Euclidean distance between two steered descriptors.
pub fn distance(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f32>()
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    #[test]
    fn an_edge_gives_its_normal_as_orientation_and_a_flat_patch_zeros() {
        // Brighter to the lower right: the gradient points along (1, 1)/√2.
        let (w, h) = (64, 64);
        let gray: Vec<f32> = (0..w * h)
            .map(|k| {
                if (k % w + k / w) as f32 > 64.0 {
                    0.8
                } else {
                    0.2
                }
            })
            .collect();
        let d = describe_steered(&gray, w, h, 32.0, 32.0, 1.0);
        assert!((d.orientation - PI / 4.0).abs() < 0.05, "{}", d.orientation);
        let norm: f32 = d.values.iter().map(|v| v * v).sum();
        assert!((norm - 1.0).abs() < 1e-4);
        let flat = vec![0.5f32; w * h];
        let d = describe_steered(&flat, w, h, 10.0, 50.0, 2.0);
        assert!(d.values.iter().all(|&v| v == 0.0));
        // At the very corner, borders are clamped and nothing is out of bounds.
        let d = describe_steered(&gray, w, h, 0.0, 63.0, 3.84);
        assert_eq!(d.values.len(), STEERED_LEN);
    }
}
