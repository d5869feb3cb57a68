//! CPU twin of the steered descriptor (see [`crate::low_level::steered`]); the GPU twin is
//! [`crate::low_level::steered::gpu`]
//! (`shaders/steered_descriptor.wgsl`), which follows this arithmetic step for step.

use std::f32::consts::TAU;

use super::{
    fast_atan2, floor, nearest_pixel, patch_geometry, Steered, CELLS, CELL_SIGMAS, CLIP,
    DIRECTIONS, ORIENTATION_BINS, ORIENTATION_SIGMAS, STEERED_LEN, TWIN_PEAK,
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

/// A worker's patch and vote buffers, kept from keypoint to keypoint instead of allocated
/// and freed for each of a frame's descriptors.
#[derive(Default)]
struct Scratch {
    rows: Vec<f32>,
    source: Vec<f32>,
    smooth: Vec<f32>,
    magnitude: Vec<f32>,
    direction: Vec<f32>,
    votes: Votes,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// `v` holding `len` zeros, reusing its allocation.
#[inline(always)]
fn zeroed<T: Copy + Default>(v: &mut Vec<T>, len: usize) {
    v.clear();
    v.resize(len, T::default());
}

impl Patch {
    /// The `side`×`side` window whose centre pixel is nearest (x, y), smoothed with `kernel`
    /// (borders clamped), and its central-difference gradient, in `scratch`'s buffers.
    #[inline(always)]
    fn around(
        &Plane {
            gray,
            width,
            height,
            ..
        }: &Plane,
        (x, y): (f32, f32),
        half: usize,
        kernel: &Kernel1d,
        scratch: &mut Scratch,
    ) -> Self {
        let r = kernel.radius();
        let side = 2 * half + 1;
        let outer = side + 2 * (r + 1);
        let (cx, cy) = (nearest_pixel(x), nearest_pixel(y));
        let (ox, oy) = (cx - (half + r + 1) as i64, cy - (half + r + 1) as i64);
        // Rows first: `outer` rows of `side + 2` smoothed columns, each from the row's pixels
        // [ox, ox + inner + 2r) gathered once with the border clamped.
        let inner = side + 2;
        let rows = &mut scratch.rows;
        zeroed(rows, outer * inner);
        let source = &mut scratch.source;
        zeroed(source, inner + 2 * r);
        // Away from the left and right borders a row is one slice; clamping is for the rest.
        let span = source.len();
        let interior = ox >= 0 && ox as usize + span <= width;
        for j in 0..outer {
            let v = (oy + j as i64).clamp(0, height as i64 - 1) as usize;
            let line = &gray[v * width..(v + 1) * width];
            if interior {
                source.copy_from_slice(&line[ox as usize..ox as usize + span]);
            } else {
                for (k, p) in source.iter_mut().enumerate() {
                    *p = line[(ox + k as i64).clamp(0, width as i64 - 1) as usize];
                }
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
        let smooth = &mut scratch.smooth;
        zeroed(smooth, inner * inner);
        for j in 0..inner {
            let out = &mut smooth[j * inner..(j + 1) * inner];
            for (t, &w) in kernel.taps.iter().enumerate() {
                for (o, &p) in out.iter_mut().zip(&rows[(j + t) * inner..]) {
                    *o += w * p;
                }
            }
        }
        let mut magnitude = std::mem::take(&mut scratch.magnitude);
        let mut direction = std::mem::take(&mut scratch.direction);
        zeroed(&mut magnitude, side * side);
        zeroed(&mut direction, side * side);
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
    let plane = Plane {
        gray,
        width,
        height,
        prior_blur,
    };
    described(&plane, point, false).0
}

/// [`describe_steered_blurred`] and, where the orientation histogram has a second peak of at
/// least 0.8 of the highest, the descriptor read in that peak's frame too (the
/// `steered-twin` kind).
pub fn describe_steered_twin_blurred(
    gray: &[f32],
    width: usize,
    height: usize,
    point: (f32, f32, f32),
    prior_blur: f32,
) -> (Steered, Option<Steered>) {
    let plane = Plane {
        gray,
        width,
        height,
        prior_blur,
    };
    described(&plane, point, true)
}

/// A luminance plane and the blur it already carries (pixels).
struct Plane<'a> {
    gray: &'a [f32],
    width: usize,
    height: usize,
    prior_blur: f32,
}

/// The descriptor of the keypoint `point` (x, y, scale) on `plane`, and with `twin` the one
/// in its second orientation peak's frame.
fn described(plane: &Plane, point: (f32, f32, f32), twin: bool) -> (Steered, Option<Steered>) {
    // The buffers are taken here, outside the AVX2 build: a closure inside it would be
    // compiled without its target features.
    SCRATCH.with(|cell| {
        let scratch = &mut *cell.borrow_mut();
        #[cfg(target_arch = "x86_64")]
        if crate::simd::has_avx2_fma() {
            // SAFETY: the CPU supports AVX2 (checked above).
            return unsafe { describe_avx2(plane, point, twin, scratch) };
        }
        describe::<Truncated>(plane, point, twin, scratch)
    })
}

/// [`describe`] compiled for AVX2: the smoothing, gradient and weighting loops run 8 lanes
/// wide instead of 4. Rust never contracts a multiply and an add into an FMA unless told to,
/// so the arithmetic, and every descriptor, is the baseline build's bit for bit.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn describe_avx2(
    plane: &Plane,
    point: (f32, f32, f32),
    twin: bool,
    scratch: &mut Scratch,
) -> (Steered, Option<Steered>) {
    describe::<Rounded>(plane, point, twin, scratch)
}

/// How a build rounds down. Both give the same value wherever the descriptor rounds (|t| <
/// 2³¹), so every descriptor is the same bit for bit either way: [`Truncated`] is the
/// baseline x86-64 build's (where `f32::floor` calls the C library), [`Rounded`] the AVX2
/// build's, where `f32::floor` is one instruction (`roundps`) and the loops around it
/// vectorise; the truncation's saturating conversion keeps them scalar.
trait Floor {
    fn floor(t: f32) -> f32;

    /// `a` wrapped into [0, 2π), written out as the GPU twin computes it.
    #[inline(always)]
    fn wrap(a: f32) -> f32 {
        a - TAU * Self::floor(a / TAU)
    }
}

/// [`super::floor`]: a truncation and a correction.
struct Truncated;

impl Floor for Truncated {
    #[inline(always)]
    fn floor(t: f32) -> f32 {
        floor(t)
    }
}

/// `f32::floor`.
#[cfg(target_arch = "x86_64")]
struct Rounded;

#[cfg(target_arch = "x86_64")]
impl Floor for Rounded {
    #[inline(always)]
    fn floor(t: f32) -> f32 {
        t.floor()
    }
}

#[inline(always)]
fn describe<F: Floor>(
    plane: &Plane,
    (x, y, sigma): (f32, f32, f32),
    twin: bool,
    scratch: &mut Scratch,
) -> (Steered, Option<Steered>) {
    let cell = CELL_SIGMAS * sigma;
    let window = CELLS as f32 * cell;
    let (half, kernel) = patch_geometry(sigma, plane.prior_blur);
    let patch = Patch::around(plane, (x, y), half, &kernel, scratch);
    let offsets = (patch.offsets(patch.x0, x), patch.offsets(patch.y0, y));
    let (first, second) =
        orientations::<F>(&patch, (&offsets.0, &offsets.1), ORIENTATION_SIGMAS * sigma);
    let mut read = |orientation| {
        describe_patch::<F>(
            &patch,
            &offsets,
            orientation,
            (cell, window),
            &mut scratch.votes,
        )
    };
    let described = read(first);
    let twin = second.filter(|_| twin).map(read);
    scratch.magnitude = patch.magnitude;
    scratch.direction = patch.direction;
    (described, twin)
}

/// The descriptor of a keypoint from its smoothed patch, read in the frame of direction
/// `orientation`, with cells of side `cell` in a window of side `window` (pixels); `dxs`,
/// `dys`: the offsets of the patch's columns and rows from the keypoint.
#[inline(always)]
fn describe_patch<F: Floor>(
    patch: &Patch,
    (dxs, dys): &(Vec<f32>, Vec<f32>),
    orientation: f32,
    (cell, window): (f32, f32),
    votes: &mut Votes,
) -> Steered {
    let (sin, cos) = orientation.sin_cos();
    // Votes go to a histogram with a ring of spare cells around the 4×4, so that the
    // trilinear vote needs no bounds checks; the spare cells are dropped afterwards. Each
    // kept bin receives the same additions in the same order as a checked vote would.
    let mut padded: Padded = [[0.0; DIRECTIONS]; PADDED_CELLS * PADDED_CELLS];
    let weight_sigma = 0.5 * window;
    let to_bin = DIRECTIONS as f32 / TAU;
    let (gx, gy) = (
        gaussian_factors(dxs, weight_sigma),
        gaussian_factors(dys, weight_sigma),
    );
    // Row by row: first every pixel's place in the frame, weight and direction bin in a loop
    // without branches over plain arrays (it vectorises), then the votes of the pixels inside
    // the window.
    let side = patch.side;
    votes.resize(side);
    for (j, &dy) in dys.iter().enumerate() {
        let magnitude = &patch.magnitude[j * side..(j + 1) * side];
        let direction = &patch.direction[j * side..(j + 1) * side];
        let Votes {
            cell: cells,
            bin: bins,
            fraction: [fus, fvs, fps],
            weight: weights,
            inside: insides,
        } = votes;
        let (dxs, gx) = (&dxs[..side], &gx[..side]);
        let (cells, bins, weights, insides) = (
            &mut cells[..side],
            &mut bins[..side],
            &mut weights[..side],
            &mut insides[..side],
        );
        let (fus, fvs, fps) = (&mut fus[..side], &mut fvs[..side], &mut fps[..side]);
        for i in 0..side {
            let (dx, m, d) = (dxs[i], magnitude[i], direction[i]);
            // The pixel in the keypoint's frame, in cells, with cell centres at integers.
            let u = (cos * dx + sin * dy) / cell + 0.5 * CELLS as f32 - 0.5;
            let v = (-sin * dx + cos * dy) / cell + 0.5 * CELLS as f32 - 0.5;
            insides[i] =
                !(u <= -1.0 || v <= -1.0 || u >= CELLS as f32 || v >= CELLS as f32) & (m != 0.0);
            weights[i] = m * (gx[i] * gy[j]);
            // Direction of steepest steered response relative to the frame, in bins.
            let phi = F::wrap(d - orientation) * to_bin;
            // The lower corner of the 2×2×2 bins and the offsets from it; for a pixel inside
            // the window every corner value is a small integer (φ ≥ 0: its floor is the
            // truncation the vote used to take).
            let (u0, v0, p0) = (F::floor(u), F::floor(v), F::floor(phi));
            fus[i] = u - u0;
            fvs[i] = v - v0;
            fps[i] = phi - p0;
            cells[i] = ((v0 + 1.0) * PADDED_CELLS as f32 + (u0 + 1.0)) as i32;
            bins[i] = p0 as i32;
        }
        for i in 0..side {
            if insides[i] {
                let corner = (cells[i] as usize, bins[i] as usize);
                trilinear(&mut padded, corner, (fus[i], fvs[i], fps[i]), weights[i]);
            }
        }
    }
    let mut hist = vec![0.0f32; STEERED_LEN];
    for cv in 0..CELLS {
        for cu in 0..CELLS {
            let to = (cv * CELLS + cu) * DIRECTIONS;
            hist[to..to + DIRECTIONS].copy_from_slice(&padded[(cv + 1) * PADDED_CELLS + cu + 1]);
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

/// A patch row's votes, one entry per pixel: the padded cell and the direction bin of the
/// lower corner of the 2×2×2 bins around its place in the frame, its offsets from that corner
/// (cells, cells, bins), its weight, and whether it lies inside the window with a gradient.
#[derive(Default)]
struct Votes {
    cell: Vec<i32>,
    bin: Vec<i32>,
    fraction: [Vec<f32>; 3],
    weight: Vec<f32>,
    inside: Vec<bool>,
}

impl Votes {
    /// Room for rows of `len` pixels.
    fn resize(&mut self, len: usize) {
        self.cell.resize(len, 0);
        self.bin.resize(len, 0);
        for f in &mut self.fraction {
            f.resize(len, 0.0);
        }
        self.weight.resize(len, 0.0);
        self.inside.resize(len, false);
    }
}

/// Cells per side of the histogram the votes go to: the 4×4 and a spare ring around it.
const PADDED_CELLS: usize = CELLS + 2;
/// Lane i of row d is 1 where i = d: the direction bins a vote's two weights go to.
const ONE_HOT: [[f32; DIRECTIONS]; DIRECTIONS] = {
    let mut rows = [[0.0; DIRECTIONS]; DIRECTIONS];
    let mut d = 0;
    while d < DIRECTIONS {
        rows[d][d] = 1.0;
        d += 1;
    }
    rows
};
/// That histogram: each cell's direction bins, row by row.
type Padded = [[f32; DIRECTIONS]; PADDED_CELLS * PADDED_CELLS];

/// Adds a pixel's weight `w` to the 2×2×2 bins around its place (u, v, φ) (cells, cells,
/// direction bins) with trilinear weights, in the padded histogram: `corner` is the padded
/// cell of (⌊u⌋, ⌊v⌋), `bin` ⌊φ⌋ and the offsets (u − ⌊u⌋, v − ⌊v⌋, φ − ⌊φ⌋). u and v lie
/// in (−1, CELLS), so the cells reached are 0 … CELLS + 1 after the shift by one.
///
/// A cell's eight direction bins are one 8-lane block: the vote adds to each of its four
/// cells a block that is zero but for the two direction bins, so it makes four vector
/// additions instead of eight scalar ones. Every bin still receives w·w_u·w_v·w_φ, in the
/// same order (adding the other lanes' +0 to a non-negative sum changes nothing).
#[inline(always)]
fn trilinear(
    hist: &mut Padded,
    (corner, bin): (usize, usize),
    (fu, fv, fp): (f32, f32, f32),
    w: f32,
) {
    let d = bin % DIRECTIONS;
    let next = (d + 1) % DIRECTIONS;
    let (low, high) = (&ONE_HOT[d], &ONE_HOT[next]);
    let mut spread = [0.0f32; DIRECTIONS];
    for ((slot, &l), &h) in spread.iter_mut().zip(low).zip(high) {
        // Exactly 1 − f_φ, f_φ or 0 in each lane: x·1 = x, x·0 + y = y.
        *slot = l * (1.0 - fp) + h * fp;
    }
    for (du, wu) in [(0, 1.0 - fu), (1, fu)] {
        for (dv, wv) in [(0, 1.0 - fv), (PADDED_CELLS, fv)] {
            let share = w * wu * wv;
            let block = &mut hist[corner + dv + du];
            for (bin, &wp) in block.iter_mut().zip(&spread) {
                *bin += share * wp;
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
/// parabola; and the highest other local peak when it reaches [`TWIN_PEAK`] of θ*'s.
/// `dxs`, `dys`: the offsets of the patch's columns and rows from the keypoint.
#[inline(always)]
fn orientations<F: Floor>(
    patch: &Patch,
    (dxs, dys): (&[f32], &[f32]),
    sigma: f32,
) -> (f32, Option<f32>) {
    let mut hist = [0.0f32; ORIENTATION_BINS];
    let to_bin = ORIENTATION_BINS as f32 / TAU;
    let limit = (3.0 * sigma).powi(2);
    let (gx, gy) = (gaussian_factors(dxs, sigma), gaussian_factors(dys, sigma));
    for (j, &dy) in dys.iter().enumerate() {
        // dx² + dy² rounds to at least dy², so a row beyond the disc has no pixel in it.
        if dy * dy > limit {
            continue;
        }
        for (i, &dx) in dxs.iter().enumerate() {
            if dx * dx + dy * dy > limit {
                continue;
            }
            let k = j * patch.side + i;
            let w = patch.magnitude[k] * (gx[i] * gy[j]);
            // Linear vote between the two nearest bins keeps θ* continuous under rotation.
            let b = F::wrap(patch.direction[k]) * to_bin - 0.5;
            let b0 = F::floor(b);
            let f = b - b0;
            // b lies in [−0.5, 35.5] (and rounding): the bin below wraps by one turn at most.
            let i0 = match b0 as i64 {
                i if i < 0 => i + ORIENTATION_BINS as i64,
                i if i >= ORIENTATION_BINS as i64 => i - ORIENTATION_BINS as i64,
                i => i,
            } as usize;
            let i1 = if i0 + 1 == ORIENTATION_BINS {
                0
            } else {
                i0 + 1
            };
            hist[i0] += w * (1.0 - f);
            hist[i1] += w * f;
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
    let refined = |i: usize| {
        let at = |d: usize| hist[(i + ORIENTATION_BINS + d - 1) % ORIENTATION_BINS];
        let offset = crate::features::harris::cpu::parabola_offset(at(0), at(1), at(2));
        F::wrap((i as f32 + 0.5 + offset) / to_bin)
    };
    let second = (0..ORIENTATION_BINS)
        .filter(|&i| i != peak)
        .filter(|&i| {
            let at = |d: usize| hist[(i + ORIENTATION_BINS + d - 1) % ORIENTATION_BINS];
            at(1) > at(0) && at(1) >= at(2) && at(1) >= TWIN_PEAK * hist[peak]
        })
        .max_by(|&a, &b| hist[a].total_cmp(&hist[b]));
    (refined(peak), second.map(refined))
}

/// Euclidean distance between two steered descriptors, read as one frame.
pub fn distance(a: &[f32], b: &[f32]) -> f32 {
    super::squared_distance(a, b, 1).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    /// A corner whose two edges have like contrast has two orientation peaks a quarter turn
    /// apart: the twin descriptor reads both frames, its first frame is the plain steered
    /// descriptor, and the twin of a keypoint matches the same corner turned so that the other
    /// edge wins. A lone edge has one peak and no second frame.
    #[test]
    fn a_corner_gets_a_second_frame_and_an_edge_does_not() {
        let (w, h) = (64usize, 64usize);
        // Bright where x > 32 or y > 32 (an L of two edges, the lower one a little stronger).
        let corner = |gain: f32| -> Vec<f32> {
            (0..w * h)
                .map(|k| {
                    let (x, y) = (k % w, k / w);
                    0.2 + if y > 32 {
                        0.6
                    } else if x > 32 {
                        0.6 * gain
                    } else {
                        0.0
                    }
                })
                .collect()
        };
        let gray = corner(0.95);
        let point = (32.5, 32.5, 2.0);
        let (first, second) = describe_steered_twin_blurred(&gray, w, h, point, IMAGE_BLUR);
        assert_eq!(
            first,
            describe_steered_blurred(&gray, w, h, point, IMAGE_BLUR)
        );
        let second = second.expect("two edges of like contrast give two peaks");
        let apart = (second.orientation - first.orientation).rem_euclid(TAU);
        let apart = apart.min(TAU - apart);
        assert!((apart - PI / 2.0).abs() < 0.3, "{apart}");
        let plain =
            |a: &Steered, b: &Steered| super::super::squared_distance(&a.values, &b.values, 1);
        assert!(plain(&first, &second) > 0.1);
        // Both frames concatenated: as near as the nearest pair of frames.
        let twin = [first.values.clone(), second.values.clone()].concat();
        let alone = [second.values.clone(), second.values.clone()].concat();
        assert_eq!(super::super::squared_distance(&twin, &alone, 2), 0.0);
        // Read as one frame of 256 values, the same pair is far apart.
        assert!(super::super::squared_distance(&twin, &alone, 1) > 0.1);
        let edge: Vec<f32> = (0..w * h)
            .map(|k| if k / w > 32 { 0.8 } else { 0.2 })
            .collect();
        let (_, none) = describe_steered_twin_blurred(&edge, w, h, point, IMAGE_BLUR);
        assert!(none.is_none());
    }

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
