//! CPU reference of the multiscale steered Harris detector (eqs 5–8): derivative images,
//! window-blurred products, per-orientation responses, non-maximum suppression in space and
//! scale with a sub-pixel parabola fit. Twin of `shaders/{convolve,products,response,nms}.wgsl`.

use std::sync::Mutex;

use rayon::prelude::*;

use super::convolve::{convolve_columns_strided, convolve_rows_strided, convolve_separable};
use super::simd::axpy;
use super::steerable::{harris_response, HarrisPlan};
use super::Candidate;

/// Per-frame scratch planes, kept between frames of the same size.
#[derive(Default)]
struct Workspace {
    width: usize,
    height: usize,
    scratch: Vec<f32>,
    derivatives: Vec<Vec<f32>>,
    product: Vec<f32>,
    blurred: Vec<Vec<f32>>,
    responses: Vec<Vec<f32>>,
}

/// The CPU backend of the Harris stage; reuses its buffers across frames of one size.
pub struct CpuHarris {
    plan: HarrisPlan,
    workspace: Mutex<Workspace>,
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
            plan,
            workspace: Mutex::new(Workspace::default()),
        }
    }

    /// The plan this backend runs.
    pub fn plan(&self) -> &HarrisPlan {
        &self.plan
    }

    /// Derivative images D_k of scale `s` (scale-normalised), for parity tests.
    pub fn derivatives(
        &self,
        gray: &[f32],
        width: usize,
        height: usize,
        s: usize,
    ) -> Vec<Vec<f32>> {
        let mut scratch = vec![0.0; width * height];
        self.plan.scales[s]
            .derivatives
            .iter()
            .map(|f| {
                let mut out = vec![0.0; width * height];
                convolve_separable(gray, &mut out, &mut scratch, width, height, f);
                out
            })
            .collect()
    }

    /// Harris responses R(σ_s, θ_n) of every scale and orientation.
    pub fn responses(&self, gray: &[f32], width: usize, height: usize) -> ResponseStack {
        let mut ws = self.workspace.lock().unwrap_or_else(|e| e.into_inner());
        self.compute(&mut ws, gray, width, height);
        ResponseStack {
            responses: ws.responses.clone(),
            grids: self
                .plan
                .scales
                .iter()
                .map(|sc| sc.grid(width, height))
                .collect(),
        }
    }

    /// Candidates surviving non-maximum suppression, sorted strongest first, and the threshold
    /// finally used (raised ×4 until at most `candidate_capacity` survive, as on the GPU).
    pub fn candidates(&self, gray: &[f32], width: usize, height: usize) -> (Vec<Candidate>, f32) {
        let mut ws = self.workspace.lock().unwrap_or_else(|e| e.into_inner());
        self.compute(&mut ws, gray, width, height);
        let mut threshold = self.plan.config.threshold;
        loop {
            let mut found = suppress(&self.plan, &ws.responses, width, height, threshold);
            if found.len() <= self.plan.config.candidate_capacity {
                super::sort_candidates(&mut found);
                return (found, threshold);
            }
            threshold = super::raised_threshold(threshold);
        }
    }

    fn compute(&self, ws: &mut Workspace, gray: &[f32], width: usize, height: usize) {
        let plan = &self.plan;
        let n = width * height;
        let planes = |count: usize| vec![vec![0.0f32; n]; count];
        if ws.width != width || ws.height != height || ws.responses.len() != plan.scales.len() {
            *ws = Workspace {
                width,
                height,
                scratch: vec![0.0; n],
                derivatives: planes(plan.derivative_count()),
                product: vec![0.0; n],
                blurred: planes(plan.products.len()),
                responses: plan
                    .scales
                    .iter()
                    .map(|sc| {
                        let (gw, gh) = sc.grid(width, height);
                        vec![0.0; gw * gh * plan.orientations.len()]
                    })
                    .collect(),
            };
        }
        let Workspace {
            scratch,
            derivatives,
            product,
            blurred,
            responses,
            ..
        } = ws;
        for (s, scale) in plan.scales.iter().enumerate() {
            for (d, filter) in derivatives.iter_mut().zip(&scale.derivatives) {
                convolve_separable(gray, d, scratch, width, height, filter);
            }
            let step = scale.step as usize;
            let (gw, gh) = scale.grid(width, height);
            for (q, &(j, k)) in blurred.iter_mut().zip(&plan.products) {
                let (a, b) = (&derivatives[j], &derivatives[k]);
                product
                    .par_iter_mut()
                    .zip(a.par_iter().zip(b.par_iter()))
                    .for_each(|(p, (x, y))| *p = x * y);
                convolve_columns_strided(product, scratch, width, height, &scale.window, step);
                convolve_rows_strided(scratch, q, width, gh, &scale.window, step);
            }
            tensor_responses(plan, blurred, &mut responses[s], gw * gh);
        }
    }
}

/// R = det M − k·tr² M for every orientation, M from the blurred products (eqs 7–8).
///
/// Pixels are processed in chunks small enough that the chunk's products stay in L1 while all
/// N orientations are evaluated, with the arithmetic laid out across pixels so it vectorises.
fn tensor_responses(plan: &HarrisPlan, blurred: &[Vec<f32>], out: &mut [f32], plane: usize) {
    const CHUNK: usize = 256;
    let p = plan.products.len();
    let k = plan.config.harris_k;
    let orientations = plan.orientations.len();
    // Each θ's tensor entries use only some of the products (21 of 30 weights are non-zero
    // for the second-order basis): keep the (product, weight) pairs that matter.
    let terms: Vec<[Vec<(usize, f32)>; 3]> = (0..orientations)
        .map(|t| {
            let w = &plan.tensor_weights[t * 3 * p..(t + 1) * 3 * p];
            std::array::from_fn(|e| {
                (0..p)
                    .filter(|&q| w[e * p + q] != 0.0)
                    .map(|q| (q, w[e * p + q]))
                    .collect()
            })
        })
        .collect();
    let out_ptr = SharedOut(out.as_mut_ptr());
    (0..plane.div_ceil(CHUNK)).into_par_iter().for_each(|c| {
        let out_ptr = &out_ptr;
        let start = c * CHUNK;
        let len = CHUNK.min(plane - start);
        let mut m = [[0.0f32; CHUNK]; 3];
        for (t, entries) in terms.iter().enumerate() {
            for (acc, list) in m.iter_mut().zip(entries) {
                let acc = &mut acc[..len];
                acc.fill(0.0);
                for &(q, w) in list {
                    axpy(acc, &blurred[q][start..start + len], w);
                }
            }
            // SAFETY: chunk c writes only indices t*plane + [start, start+len) of `out`, which
            // no other chunk touches, and `out` outlives the parallel loop.
            let r =
                unsafe { std::slice::from_raw_parts_mut(out_ptr.0.add(t * plane + start), len) };
            for (i, r) in r.iter_mut().enumerate() {
                *r = harris_response(m[0][i], m[1][i], m[2][i], k);
            }
        }
    });
}

/// The response planes' base pointer, shared by the chunks that write disjoint ranges of it.
struct SharedOut(*mut f32);
// SAFETY: only used for the disjoint writes in `tensor_responses`.
unsafe impl Sync for SharedOut {}

/// Non-maximum suppression in space (3×3) and across adjacent scales (3×3 each, around the
/// nearest sample of their grid), threshold, border margin and a parabola fit per axis for the
/// sub-pixel position. Candidates come out in pixel coordinates.
pub fn suppress(
    plan: &HarrisPlan,
    responses: &[Vec<f32>],
    width: usize,
    height: usize,
    threshold: f32,
) -> Vec<Candidate> {
    let scales = plan.scales.len();
    let grids: Vec<(usize, usize)> = plan
        .scales
        .iter()
        .map(|sc| sc.grid(width, height))
        .collect();
    let tasks: Vec<(usize, usize)> = (0..scales)
        .flat_map(|s| (0..plan.orientations.len()).map(move |t| (s, t)))
        .collect();
    tasks
        .par_iter()
        .flat_map_iter(|&(s, t)| {
            let (gw, gh) = grids[s];
            let g = plan.scales[s].step as usize;
            let m = plan.scales[s].grid_margin();
            let plane_of = |sc: usize| {
                let (w, h) = grids[sc];
                &responses[sc][t * w * h..(t + 1) * w * h]
            };
            let cur = plane_of(s);
            let at = |x: usize, y: usize| cur[y * gw + x];
            // Is v at least every value of scale sc's 3×3 neighbourhood around pixel (px, py)?
            let across = |sc: usize, px: usize, py: usize, v: f32| {
                let (w, h) = grids[sc];
                let gs = plan.scales[sc].step as usize;
                let (cx, cy) = ((px + gs / 2) / gs, (py + gs / 2) / gs);
                let other = plane_of(sc);
                (0..9).all(|i| {
                    let nx = (cx + i % 3).saturating_sub(1).min(w - 1);
                    let ny = (cy + i / 3).saturating_sub(1).min(h - 1);
                    other[ny * w + nx] <= v
                })
            };
            let mut out = Vec::new();
            if gw <= 2 * m || gh <= 2 * m {
                return out.into_iter();
            }
            for y in m..gh - m {
                for x in m..gw - m {
                    let v = at(x, y);
                    if v.is_nan() || v <= threshold {
                        continue;
                    }
                    // Same-scale neighbours first: they reject most samples and are in cache.
                    let spatial = (0..9).all(|i| i == 4 || at(x + i % 3 - 1, y + i / 3 - 1) < v);
                    let (px, py) = (x * g, y * g);
                    let keep = spatial
                        && (s == 0 || across(s - 1, px, py, v))
                        && (s + 1 == scales || across(s + 1, px, py, v));
                    if keep {
                        let ox = parabola_offset(at(x - 1, y), v, at(x + 1, y));
                        let oy = parabola_offset(at(x, y - 1), v, at(x, y + 1));
                        out.push(Candidate {
                            x: (x as f32 + ox) * g as f32,
                            y: (y as f32 + oy) * g as f32,
                            response: v,
                            packed: Candidate::pack(s, t),
                        });
                    }
                }
            }
            out.into_iter()
        })
        .collect()
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
