//! CPU reference of the multiscale steered Harris detector (eqs 5–8): derivative images,
//! window-blurred products, per-orientation responses, non-maximum suppression in space and
//! scale with a sub-pixel quadratic fit. Twin of `shaders/harris_{convolve,products,response,nms}.wgsl`.

use std::sync::Mutex;

use rayon::prelude::*;

use super::plan::{harris_response, HarrisPlan};
use crate::features::convolve::{column_at, convolve_separable, row_at};
use crate::features::pyramid::Pyramid;
use crate::features::Candidate;
use crate::simd::{max_or, multiply, set_bits, strict_maxima, tensor_responses};

/// Rows `[first_row, first_row + rows)` of one scale's grid, for every orientation (layout
/// `[θ][row][i]`).
#[derive(Default)]
struct ScaleBand {
    first_row: usize,
    rows: usize,
    data: Vec<f32>,
}

/// Bytes of response rows the CPU backend holds at once. The suppression runs over bands of
/// image rows, so a whole 12-orientation stack of every scale — 4.3 GB at 24 MP for the
/// default 16 scales — never exists at once; frames up to about 2 MP (1920×1080: 379 MiB at
/// the defaults, 253 MiB at two scales per octave) fit in one band and pay no halo. Two
/// bands there cost 20% more time.
const RESPONSE_BUDGET_BYTES: usize = 512 << 20;

/// The CPU backend of the Harris stage; reuses its buffers across frames of one size.
pub struct CpuHarris {
    plan: HarrisPlan,
    /// Sets of bands (one per scale), reused (and resized) from frame to frame: a frame takes
    /// one set out of the pool and puts it back, so frames detected at once on several
    /// threads (a CPU batch) never wait for each other.
    bands: Mutex<Vec<Vec<ScaleBand>>>,
    /// The structure tensor's non-zero weights per orientation, built once.
    terms: TensorTerms,
    response_budget: usize,
}

/// Wall-clock time of the CPU Harris stage's two parts.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CpuTimings {
    /// Derivative filters, structure tensor and responses (fused in the row-band pipeline).
    pub responses_ms: f64,
    /// Non-maximum suppression, sub-pixel fit and sorting.
    pub nms_ms: f64,
}

/// Output of the Harris stage for inspection: responses of every scale and orientation.
pub struct ResponseStack {
    /// `responses[s]` holds N planes on scale s's grid (layout `[θ][j][i]`, sample (i, j) at
    /// pixel (i·step, j·step)).
    pub responses: Vec<Vec<f32>>,
    /// Grid size (columns, rows) of each scale.
    pub grids: Vec<(usize, usize)>,
}

impl CpuHarris {
    /// Prepares the backend for a plan.
    pub fn new(plan: HarrisPlan) -> Self {
        Self {
            bands: Mutex::new(Vec::new()),
            terms: tensor_terms(&plan),
            plan,
            response_budget: RESPONSE_BUDGET_BYTES,
        }
    }

    /// The plan this backend runs.
    pub fn plan(&self) -> &HarrisPlan {
        &self.plan
    }

    /// Derivative planes D_k of scale `s` (scale-normalised) at the samples of the scale's
    /// grid, for parity tests.
    pub fn derivatives(
        &self,
        gray: &[f32],
        width: usize,
        height: usize,
        s: usize,
    ) -> Vec<Vec<f32>> {
        let scale = &self.plan.scales[s];
        let g = scale.level_step() as usize;
        let pyramid = Pyramid::new(gray, width, height, &self.plan.pyramid);
        let (level, width, height) = pyramid.level(scale.level);
        let mut scratch = vec![0.0; width * height];
        let mut full = vec![0.0; width * height];
        scale
            .derivatives
            .iter()
            .map(|f| {
                convolve_separable(level, &mut full, &mut scratch, width, height, f);
                full.chunks(width)
                    .step_by(g)
                    .flat_map(|row| row.iter().step_by(g).copied())
                    .collect()
            })
            .collect()
    }

    /// Harris responses R(σ_s, θ_n) of every scale and orientation.
    pub fn responses(&self, gray: &[f32], width: usize, height: usize) -> ResponseStack {
        let plan = &self.plan;
        let grids = plan.grids(width, height);
        let pyramid = Pyramid::new(gray, width, height, &plan.pyramid);
        let responses = grids
            .iter()
            .enumerate()
            .map(|(s, &(gw, gh))| {
                let mut plane = vec![0.0; gw * gh * plan.orientations.len()];
                scale_responses(plan, &self.terms, s, &pyramid, 0..gh, &mut plane);
                plane
            })
            .collect();
        ResponseStack { responses, grids }
    }

    /// Candidates surviving non-maximum suppression, sorted strongest first, the threshold
    /// finally used (raised ×4 until at most `candidate_capacity` survive, as on the GPU) and
    /// the stage's timings.
    ///
    /// Responses are computed and suppressed one band of image rows at a time (each band with
    /// the halo of rows its suppression reads), so memory is bounded by
    /// `RESPONSE_BUDGET_BYTES` (512 MiB) rather than by the image; the candidates are those of the
    /// whole-image suppression, bit for bit.
    pub fn candidates(
        &self,
        gray: &[f32],
        width: usize,
        height: usize,
    ) -> (Vec<Candidate>, f32, CpuTimings) {
        let t0 = std::time::Instant::now();
        let pyramid = Pyramid::new(gray, width, height, &self.plan.pyramid);
        let built = t0.elapsed();
        let (found, threshold, mut timings) = self.candidates_on(&pyramid);
        timings.responses_ms += built.as_secs_f64() * 1e3;
        (found, threshold, timings)
    }

    /// [`Self::candidates`] on a frame whose pyramid is already built (with this plan's
    /// kernels), so that the detector's descriptors read the same levels.
    pub fn candidates_on(&self, pyramid: &Pyramid) -> (Vec<Candidate>, f32, CpuTimings) {
        let (_, width, height) = pyramid.level(0);
        let plan = &self.plan;
        let taken = self.bands.lock().unwrap_or_else(|e| e.into_inner()).pop();
        let mut bands =
            taken.unwrap_or_else(|| plan.scales.iter().map(|_| ScaleBand::default()).collect());
        let grids = plan.grids(width, height);
        let max_step = plan.max_step() as usize;
        // Bytes of responses per image row, over all scales and orientations.
        let row_bytes: usize = grids
            .iter()
            .zip(&plan.scales)
            .map(|(&(gw, _), sc)| gw * plan.orientations.len() * 4 / sc.step as usize)
            .sum::<usize>()
            .max(1);
        // A multiple of every scale's step, so bands start on every grid's rows.
        let band_rows = (self.response_budget / row_bytes).max(4 * max_step) / max_step * max_step;
        let (mut responses_time, mut nms_time) = (
            std::time::Duration::default(),
            std::time::Duration::default(),
        );
        let config = &plan.config;
        let capacity = config.candidate_capacity;
        // The strongest response so far; the final one is at least this, so candidates below
        // the threshold it gives can be dropped as the bands come.
        let mut strongest = 0.0f32;
        // Candidates at or below this are dropped: more than `capacity` exceeded it, so the
        // final threshold is at least it (see `overflows`).
        let mut capacity_floor = f32::NEG_INFINITY;
        let mut found: Vec<Candidate> = Vec::new();
        for y0 in (0..height).step_by(band_rows) {
            let y1 = (y0 + band_rows).min(height);
            let t0 = std::time::Instant::now();
            for (s, band) in bands.iter_mut().enumerate() {
                let (gw, gh) = grids[s];
                let g = plan.scales[s].step as usize;
                // Rows of this scale the band's suppression reads beyond its own: ±1 grid row
                // for its own samples, and the 3×3 around the nearest sample (±1.5 steps) for
                // the adjacent scales'. A coarse scale's reach never widens a fine scale's band.
                let halo = 2 * g + 1;
                let first = y0.saturating_sub(halo) / g;
                let last = ((y1 + halo) / g + 1).min(gh);
                band.first_row = first;
                band.rows = last - first;
                band.data
                    .resize(band.rows * gw * plan.orientations.len(), 0.0);
                let peak =
                    scale_responses(plan, &self.terms, s, pyramid, first..last, &mut band.data);
                strongest = strongest.max(peak);
            }
            let t1 = std::time::Instant::now();
            let floor = config.effective_threshold(strongest);
            found.retain(|c| c.response > floor);
            found.extend(suppress(plan, &bands, &grids, y0..y1, floor));
            if found.len() > capacity {
                let (_, &mut kth, _) = found
                    .select_nth_unstable_by(capacity, |a, b| b.response.total_cmp(&a.response));
                capacity_floor = capacity_floor.max(kth.response);
                found.retain(|c| c.response > capacity_floor);
            }
            responses_time += t1 - t0;
            nms_time += t1.elapsed();
        }
        let t2 = std::time::Instant::now();
        // As on the GPU: the relative threshold, raised ×4 while more than `capacity`
        // candidates exceed it. Below `capacity_floor`, more than `capacity` did.
        let mut threshold = config.effective_threshold(strongest);
        let overflows = |t: f32, found: &[Candidate]| {
            t < capacity_floor || found.iter().filter(|c| c.response > t).count() > capacity
        };
        while overflows(threshold, &found) {
            threshold = crate::features::raised_threshold(threshold);
        }
        found.retain(|c| c.response > threshold);
        crate::features::sort_candidates(&mut found);
        nms_time += t2.elapsed();
        let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
        let timings = CpuTimings {
            responses_ms: ms(responses_time),
            nms_ms: ms(nms_time),
        };
        self.bands
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(bands);
        (found, threshold, timings)
    }
}

/// Per orientation, the (product, weight) pairs of Mxx, Mxy and Myy that are non-zero (21 of
/// 30 for the second-order basis).
type TensorTerms = Vec<[Vec<(usize, f32)>; 3]>;

fn tensor_terms(plan: &HarrisPlan) -> TensorTerms {
    let p = plan.products.len();
    (0..plan.orientations.len())
        .map(|t| {
            let w = &plan.tensor_weights[t * 3 * p..(t + 1) * 3 * p];
            std::array::from_fn(|e| {
                (0..p)
                    .filter(|&q| w[e * p + q] != 0.0)
                    .map(|q| (q, w[e * p + q]))
                    .collect()
            })
        })
        .collect()
}

/// Thread-local buffers of one band.
#[derive(Default)]
struct BandScratch {
    column: Vec<f32>,
    padded: Vec<f32>,
    derivatives: Vec<f32>,
    products: Vec<f32>,
    blurred_row: Vec<f32>,
    q: Vec<f32>,
}

thread_local! {
    /// Each worker's band buffers, kept from band to band and frame to frame: sized once for
    /// the largest band, they are overwritten, never zeroed again (fresh ones per band cost
    /// the SLAM loop 5% of its time in memset). Nothing inside a band calls into rayon, so a
    /// worker never re-enters it.
    static SCRATCH: std::cell::RefCell<BandScratch> = std::cell::RefCell::new(BandScratch::default());
}

/// Grid rows per parallel band: enough rows that the halo the window needs above and below
/// (its radius) is a modest overhead, few enough that a band's planes stay in L2.
const BAND_PIXEL_ROWS: usize = 48;

/// Harris responses (eqs 5–8) of scale `s` on its grid, computed band by band: each band
/// filters the scale's pyramid level into the derivative planes D_k at the grid's samples, forms their
/// products, blurs them with the window on the grid (columns, then rows) and evaluates R for
/// every orientation, all in buffers that stay in cache. The arithmetic is that of the
/// GPU's passes (same taps and clamping; folded sums). Only `grid_rows` are computed,
/// into `out` laid out `[θ][row − grid_rows.start][i]`; every row's value is the same whatever the
/// range. Returns the strongest response computed (0 when none is positive): the maximum the
/// relative threshold needs, fused into the pass.
fn scale_responses(
    plan: &HarrisPlan,
    terms: &TensorTerms,
    s: usize,
    pyramid: &Pyramid,
    grid_rows: std::ops::Range<usize>,
    out: &mut [f32],
) -> f32 {
    let scale = &plan.scales[s];
    let (gray, width, height) = pyramid.level(scale.level);
    let step = scale.level_step() as usize;
    // The full-resolution grid is every `step` pixels of the level (sizes round up alike).
    let (gw, gh) = (width.div_ceil(step), height.div_ceil(step));
    let plane = gw * grid_rows.len();
    let count = scale.derivatives.len();
    let products = plan.products.len();
    let rw = scale.window.radius();
    let k = plan.config.harris_k;
    let band_rows = (BAND_PIXEL_ROWS / step).max(1);
    let out_ptr = SharedOut(out.as_mut_ptr());
    let image_row = |y: isize| {
        let sy = y.clamp(0, height as isize - 1) as usize;
        &gray[sy * width..(sy + 1) * width]
    };
    assert!(grid_rows.end <= gh && out.len() >= plane * terms.len());
    (0..grid_rows.len().div_ceil(band_rows))
        .into_par_iter()
        .map(|band| {
            SCRATCH.with(|cell| {
                let b = &mut *cell.borrow_mut();
                let mut peak = 0.0f32;
                let out_ptr = &out_ptr;
                // Grid rows [j0, j1) of output need grid rows [jl, jh] of products.
                let j0 = grid_rows.start + band * band_rows;
                let j1 = (j0 + band_rows).min(grid_rows.end);
                let jl = j0.saturating_sub(rw);
                let jh = (j1 - 1 + rw).min(gh - 1);
                let rows = jh - jl + 1;
                b.column.resize(width, 0.0);
                b.derivatives.resize(count * rows * gw, 0.0);
                b.products.resize(products * rows * gw, 0.0);
                b.blurred_row.resize(gw, 0.0);
                b.q.resize(products * gw, 0.0);
                // Derivative planes D_k at the grid's samples (eqs 5–6 through the steerable basis).
                for (kk, filter) in scale.derivatives.iter().enumerate() {
                    for jj in jl..=jh {
                        column_at(
                            image_row,
                            (jj * step) as isize,
                            &filter.column,
                            &mut b.column,
                        );
                        let o = (kk * rows + jj - jl) * gw;
                        row_at(
                            &b.column,
                            &filter.row,
                            step,
                            &mut b.padded,
                            &mut b.derivatives[o..o + gw],
                        );
                    }
                }
                // Products D_j D_k (the integrands of eq 7).
                for (p, &(a, c)) in plan.products.iter().enumerate() {
                    let (da, dc) = (
                        &b.derivatives[a * rows * gw..(a + 1) * rows * gw],
                        &b.derivatives[c * rows * gw..(c + 1) * rows * gw],
                    );
                    multiply(&mut b.products[p * rows * gw..(p + 1) * rows * gw], da, dc);
                }
                for j in j0..j1 {
                    // Window blur of every product at grid row j (columns, then rows).
                    for p in 0..products {
                        let band_plane = &b.products[p * rows * gw..(p + 1) * rows * gw];
                        let row = |jj: isize| {
                            let r = jj.clamp(0, gh as isize - 1) as usize - jl;
                            &band_plane[r * gw..(r + 1) * gw]
                        };
                        column_at(row, j as isize, &scale.window, &mut b.blurred_row);
                        row_at(
                            &b.blurred_row,
                            &scale.window,
                            1,
                            &mut b.padded,
                            &mut b.q[p * gw..(p + 1) * gw],
                        );
                    }
                    // R = det M − k tr² M for every orientation (eq 8).
                    for (t, entries) in terms.iter().enumerate() {
                        // SAFETY: band `band` writes only grid rows [j0, j1) of each orientation plane,
                        // which no other band touches, and `out` outlives the parallel loop.
                        let r = unsafe {
                            std::slice::from_raw_parts_mut(
                                out_ptr.0.add(t * plane + (j - grid_rows.start) * gw),
                                gw,
                            )
                        };
                        tensor_responses(&b.q, entries, r, |xx, xy, yy| {
                            harris_response(xx, xy, yy, k)
                        });
                        peak = max_or(r, peak);
                    }
                }
                peak
            })
        })
        .reduce(|| 0.0, f32::max)
}

/// The response planes' base pointer, shared by the chunks that write disjoint ranges of it.
struct SharedOut(*mut f32);
// SAFETY: only used for the disjoint writes in `scale_responses`.
unsafe impl Sync for SharedOut {}

/// Non-maximum suppression in space (3×3) and across adjacent scales (3×3 each, around the
/// nearest sample of their grid), threshold, border margin, the 3×3 quadratic fit
/// ([`peak_offset`]) for the sub-pixel position and the parabola through the adjacent scales'
/// responses at the nearest samples ([`parabola_offset`]) for the sub-scale offset (the
/// characteristic scale between the sampled ones), for the samples whose pixel row lies in
/// `pixel_rows`. `bands[s]` must hold every row of scale s that these samples' suppression
/// reads. Candidates come out in pixel coordinates.
fn suppress(
    plan: &HarrisPlan,
    bands: &[ScaleBand],
    grids: &[(usize, usize)],
    pixel_rows: std::ops::Range<usize>,
    threshold: f32,
) -> Vec<Candidate> {
    let scales = plan.scales.len();
    let tasks: Vec<(usize, usize)> = (0..scales)
        .flat_map(|s| (0..plan.orientations.len()).map(move |t| (s, t)))
        .collect();
    // Row `y` of orientation `t` of scale `sc`, which the band holds.
    let row = |sc: usize, t: usize, y: usize| {
        let (w, _) = grids[sc];
        let band = &bands[sc];
        let o = (t * band.rows + y - band.first_row) * w;
        &band.data[o..o + w]
    };
    tasks
        .par_iter()
        .flat_map_iter(|&(s, t)| {
            let (gw, gh) = grids[s];
            let g = plan.scales[s].step as usize;
            let m = plan.scales[s].grid_margin();
            // The 3×3 neighbourhood of scale sc around its sample nearest pixel row `py`.
            let adjacent = |sc: usize, py: usize| {
                let (w, h) = grids[sc];
                let shift = plan.scales[sc].step.trailing_zeros();
                let cy = nearest_sample(py, shift);
                Adjacent {
                    rows: [cy.saturating_sub(1), cy, cy + 1].map(|ny| row(sc, t, ny.min(h - 1))),
                    shift,
                    last: w - 1,
                }
            };
            let mut out = Vec::new();
            if gw <= 2 * m || gh <= 2 * m {
                return out.into_iter();
            }
            let first = pixel_rows.start.div_ceil(g).max(m);
            let end = pixel_rows.end.div_ceil(g).min(gh - m);
            let mut maxima = vec![0u64; gw.div_ceil(64)];
            for y in first..end {
                // Strict maxima of the 3×3 same-scale neighbourhood above the threshold, as
                // bits from a branch-free pass eight samples wide; the rare survivors, visited
                // by their set bits, get the rest.
                let (up, mid, down) = (row(s, t, y - 1), row(s, t, y), row(s, t, y + 1));
                strict_maxima([up, mid, down], threshold, m..gw - m, &mut maxima);
                let py = y * g;
                let below = (s > 0).then(|| adjacent(s - 1, py));
                let above = (s + 1 < scales).then(|| adjacent(s + 1, py));
                for x in set_bits(&maxima) {
                    let v = mid[x];
                    let px = x * g;
                    let keep = below.as_ref().is_none_or(|a| a.at_most(px, v))
                        && above.as_ref().is_none_or(|a| a.at_most(px, v));
                    if keep {
                        let (ox, oy) = peak_offset(
                            [up[x - 1], up[x], up[x + 1]],
                            [mid[x - 1], v, mid[x + 1]],
                            [down[x - 1], down[x], down[x + 1]],
                        );
                        let offset = match (&below, &above) {
                            (Some(b), Some(a)) => parabola_offset(b.centre(px), v, a.centre(px)),
                            _ => 0.0,
                        };
                        out.push(Candidate {
                            x: (x as f32 + ox) * g as f32,
                            y: (y as f32 + oy) * g as f32,
                            response: v,
                            packed: Candidate::pack_with_offset(s, t, offset),
                        });
                    }
                }
            }
            out.into_iter()
        })
        .collect()
}

/// The index of the sample nearest pixel `p` on a grid whose step is 2^`shift`:
/// (p + step/2) / step.
#[inline]
fn nearest_sample(p: usize, shift: u32) -> usize {
    (p + ((1usize << shift) >> 1)) >> shift
}

/// The three rows of an adjacent scale's grid around the sample nearest one pixel row, for
/// the suppression across scales, indices clamped to the grid.
struct Adjacent<'a> {
    rows: [&'a [f32]; 3],
    /// log2 of the adjacent grid's step (a power of two).
    shift: u32,
    last: usize,
}

impl Adjacent<'_> {
    /// Columns of the 3×3 neighbourhood around the sample nearest pixel column `px`, the
    /// centre first.
    #[inline]
    fn columns(&self, px: usize) -> [usize; 3] {
        let cx = nearest_sample(px, self.shift);
        [cx, cx.saturating_sub(1), cx + 1].map(|c| c.min(self.last))
    }

    /// Is `v` at least every value of the neighbourhood? The centre first: the same point at
    /// the adjacent scale rejects most samples.
    #[inline]
    fn at_most(&self, px: usize, v: f32) -> bool {
        let [c, l, r] = self.columns(px);
        let [up, mid, down] = self.rows;
        mid[c] <= v
            && mid[l] <= v
            && mid[r] <= v
            && up[c] <= v
            && up[l] <= v
            && up[r] <= v
            && down[c] <= v
            && down[l] <= v
            && down[r] <= v
    }

    /// The value at the centre of the neighbourhood.
    #[inline]
    fn centre(&self, px: usize) -> f32 {
        self.rows[1][self.columns(px)[0]]
    }
}

/// Sub-pixel offset of a 3×3 maximum (rows `up`, `mid`, `down`; the centre is `mid[1]`):
/// the vertex of the quadratic fitted with central differences, cross term included, so the
/// peak of a corner lying obliquely to the pixel axes is found where it is rather than
/// projected onto each axis. Falls back to one parabola per axis when the fitted surface is
/// not a cap. Each component within ±0.5.
#[inline]
pub fn peak_offset(up: [f32; 3], mid: [f32; 3], down: [f32; 3]) -> (f32, f32) {
    let c = mid[1];
    let (dx, dy) = (0.5 * (mid[2] - mid[0]), 0.5 * (down[1] - up[1]));
    let (dxx, dyy) = (mid[2] - 2.0 * c + mid[0], down[1] - 2.0 * c + up[1]);
    let dxy = 0.25 * (down[2] - down[0] - up[2] + up[0]);
    let det = dxx * dyy - dxy * dxy;
    if det > 0.0 && dxx < 0.0 {
        (
            ((dxy * dy - dyy * dx) / det).clamp(-0.5, 0.5),
            ((dxy * dx - dxx * dy) / det).clamp(-0.5, 0.5),
        )
    } else {
        (
            parabola_offset(mid[0], c, mid[2]),
            parabola_offset(up[1], c, down[1]),
        )
    }
}

/// Offset of the vertex of the parabola through (−1, l), (0, c), (1, r), within ±0.5.
#[inline]
pub fn parabola_offset(l: f32, c: f32, r: f32) -> f32 {
    let den = l - 2.0 * c + r;
    if den < 0.0 {
        (0.5 * (l - r) / den).clamp(-0.5, 0.5)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::DetectorConfig;

    #[test]
    fn banded_suppression_matches_the_whole_image_bit_for_bit() {
        let (w, h) = (263, 197);
        let image = crate::synth::textured_scene(w as u32, h as u32, 3);
        let plan = HarrisPlan::new(&DetectorConfig::default());
        let whole = CpuHarris::new(plan.clone());
        let (expected, t_expected, _) = whole.candidates(&image.gray, w, h);
        assert!(expected.len() >= 80, "{}", expected.len());
        // Budgets from the smallest band (4 × the coarsest step, many bands) upwards; a band
        // edge then falls on every kind of row.
        for budget in [1, 40_000, 150_000, 400_000] {
            let banded = CpuHarris {
                response_budget: budget,
                ..CpuHarris::new(plan.clone())
            };
            let (found, t, _) = banded.candidates(&image.gray, w, h);
            assert_eq!(t, t_expected);
            assert!(
                found == expected,
                "budget {budget}: {} vs {}",
                found.len(),
                expected.len()
            );
            // The workspace is reused for the next frame of the same size.
            assert!(banded.candidates(&image.gray, w, h).0 == expected);
        }
        // Raising the threshold while bands accumulate gives the whole-image result too.
        let small = DetectorConfig {
            candidate_capacity: expected.len() / 3,
            ..DetectorConfig::default()
        };
        let plan = HarrisPlan::new(&small);
        let (expected, t_expected, _) = CpuHarris::new(plan.clone()).candidates(&image.gray, w, h);
        let banded = CpuHarris {
            response_budget: 1,
            ..CpuHarris::new(plan)
        };
        let (found, t, _) = banded.candidates(&image.gray, w, h);
        assert!(t > DetectorConfig::default().threshold && t == t_expected);
        assert!(found == expected);
    }

    /// Samples f(x, y) = 10 − (a(x−x0)² + 2b(x−x0)(y−y0) + c(y−y0)²) on the 3×3 grid.
    fn cap(x0: f32, y0: f32, a: f32, b: f32, c: f32) -> [[f32; 3]; 3] {
        let f = |x: f32, y: f32| {
            let (u, v) = (x - x0, y - y0);
            10.0 - (a * u * u + 2.0 * b * u * v + c * v * v)
        };
        [-1.0f32, 0.0, 1.0].map(|y| [-1.0f32, 0.0, 1.0].map(|x| f(x, y)))
    }

    #[test]
    fn the_quadratic_fit_finds_an_oblique_peak() {
        // An elongated peak at 45° (strong cross term): the fit recovers it exactly, while one
        // parabola per axis lands elsewhere.
        let [up, mid, down] = cap(0.3, -0.2, 1.0, 0.8, 1.0);
        let (ox, oy) = peak_offset(up, mid, down);
        assert!(
            (ox - 0.3).abs() < 1e-5 && (oy + 0.2).abs() < 1e-5,
            "{ox} {oy}"
        );
        let per_axis = (
            parabola_offset(mid[0], mid[1], mid[2]),
            parabola_offset(up[1], mid[1], down[1]),
        );
        assert!((per_axis.0 - 0.3).abs() > 0.1, "{per_axis:?}");
        // A saddle is not a cap: per-axis parabolas, within ±0.5.
        let [up, mid, down] = cap(0.1, 0.1, 1.0, 2.0, 1.0);
        let (ox, oy) = peak_offset(up, mid, down);
        assert!(ox.abs() <= 0.5 && oy.abs() <= 0.5);
        assert_eq!(
            (ox, oy),
            (
                parabola_offset(mid[0], mid[1], mid[2]),
                parabola_offset(up[1], mid[1], down[1])
            )
        );
    }
}
