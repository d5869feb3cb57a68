//! The plan of the multiscale Harris stage (eqs 5–8) that both backends execute: per scale,
//! the derivative filters D_k at σ_e, the integration window w(σ_I), the sampling grid, and the
//! Harris response R = det − k·tr² (eq 8). Built once per configuration and image size.
//!
//! Why the plan steers gradients and never filtered images: see [`crate::features::steerable`].

use crate::features::config::DetectorConfig;
use crate::features::steerable::{orientations, steering_coefficients, Kernel1d, Separable};

/// Everything one detection scale needs.
#[derive(Clone, Debug)]
pub struct ScalePlan {
    /// Differentiation scale σ_D.
    pub sigma_d: f32,
    /// Integration scale σ_I.
    pub sigma_i: f32,
    /// The n+2 derivative filters D_k at σ_e, scale-normalised by σ_e^p.
    pub derivatives: Vec<Separable>,
    /// The integration window w(σ_I) (eq 7), used along both axes, in grid units: a Gaussian
    /// of σ_I / step applied to the products sampled on the scale's grid.
    pub window: Kernel1d,
    /// Border margin in pixels: no candidate closer to the border.
    pub margin: u32,
    /// Factor applied to this scale's responses when clusters are ranked:
    /// (σ_e / σ_e of the finest scale)^(4(p_r − p)) (see `rank_normalization`).
    pub rank_weight: f32,
    /// Sampling step of this scale's grid (1, 2, 4 …). The derivative planes are sampled every
    /// `step` pixels and the products, their window blur, the responses and the suppression
    /// all live on that grid: the window integral of eq 7 becomes a sum over the grid's
    /// samples, accurate because the window is wide against the step (step = largest power
    /// of two ≤ σ_I / 1.4: the window passes at most exp(−π²·1.4²/2) ≈ 6e-5 at the grid's
    /// Nyquist frequency).
    pub step: u32,
}

impl ScalePlan {
    /// Size of the response grid for a `width`×`height` image.
    pub fn grid(&self, width: usize, height: usize) -> (usize, usize) {
        let g = self.step as usize;
        (width.div_ceil(g), height.div_ceil(g))
    }

    /// The border margin in grid cells.
    pub fn grid_margin(&self) -> usize {
        (self.margin.div_ceil(self.step)).max(1) as usize
    }
}

/// The grid step of a scale with integration scale `sigma_i`.
pub fn grid_step(sigma_i: f32) -> u32 {
    let mut step = 1u32;
    while sigma_i / (2 * step) as f32 >= 1.4 && step < 64 {
        step *= 2;
    }
    step
}

/// The whole multiscale steered Harris computation, shared by the CPU and GPU backends.
#[derive(Clone, Debug)]
pub struct HarrisPlan {
    /// The configuration it was built from.
    pub config: DetectorConfig,
    /// Steered orientations θ_n.
    pub orientations: Vec<f32>,
    /// One entry per detection scale.
    pub scales: Vec<ScalePlan>,
    /// Index pairs (j, k), j ≤ k, of the products D_j·D_k.
    pub products: Vec<(usize, usize)>,
    /// Per orientation, three rows of `products.len()` weights giving Mxx, Mxy, Myy as dot
    /// products with the blurred products Q (layout `[θ][entry][product]`).
    pub tensor_weights: Vec<f32>,
}

impl HarrisPlan {
    /// Builds the kernels and weights of a validated configuration.
    pub fn new(config: &DetectorConfig) -> Self {
        let n = config.basis.order();
        let m = n + 1; // derivative order of the D_k
        let count = m + 1;
        let products: Vec<(usize, usize)> = (0..count)
            .flat_map(|j| (j..count).map(move |k| (j, k)))
            .collect();
        let index = |j: usize, k: usize| {
            let (j, k) = if j <= k { (j, k) } else { (k, j) };
            products
                .iter()
                .position(|&p| p == (j, k))
                .expect("pair exists")
        };
        let orientations = orientations(config.orientations);
        let p = products.len();
        let mut tensor_weights = vec![0.0f32; orientations.len() * 3 * p];
        for (t, &theta) in orientations.iter().enumerate() {
            let c = steering_coefficients(n, theta);
            let base = t * 3 * p;
            for i in 0..=n {
                for j in 0..=n {
                    let w = c[i] * c[j];
                    tensor_weights[base + index(i, j)] += w;
                    tensor_weights[base + p + index(i, j + 1)] += w;
                    tensor_weights[base + 2 * p + index(i + 1, j + 1)] += w;
                }
            }
        }
        let scales = (0..config.scales)
            .map(|s| {
                let sigma_d = config.sigma_d(s);
                let sigma_e = config.sigma_e(s);
                let norm = sigma_e.powf(config.scale_normalization);
                let derivatives = (0..count)
                    .map(|k| Separable {
                        column: Kernel1d::gaussian_derivative(sigma_e, k, config.truncate),
                        row: Kernel1d::gaussian_derivative(sigma_e, m - k, config.truncate)
                            .scaled(norm),
                    })
                    .collect();
                ScalePlan {
                    sigma_d,
                    sigma_i: config.sigma_i(s),
                    derivatives,
                    window: Kernel1d::gaussian_derivative(
                        config.sigma_i(s) / grid_step(config.sigma_i(s)) as f32,
                        0,
                        config.truncate,
                    ),
                    margin: config.margin(s),
                    rank_weight: (sigma_e / config.sigma_e(0))
                        .powf(4.0 * (config.rank_normalization - config.scale_normalization)),
                    step: grid_step(config.sigma_i(s)),
                }
            })
            .collect();
        Self {
            config: config.clone(),
            orientations,
            scales,
            products,
            tensor_weights,
        }
    }

    /// The response grid (columns, rows) of every scale for a `width`×`height` image.
    pub fn grids(&self, width: usize, height: usize) -> Vec<(usize, usize)> {
        self.scales
            .iter()
            .map(|sc| sc.grid(width, height))
            .collect()
    }

    /// The coarsest grid step: bands and tiles start on multiples of it, so every grid stays
    /// aligned.
    pub fn max_step(&self) -> u32 {
        self.scales.iter().map(|s| s.step).max().unwrap_or(1)
    }

    /// Number of derivative images per scale (n + 2).
    pub fn derivative_count(&self) -> usize {
        self.config.basis.order() + 2
    }
}

/// Harris response of eq 8 from the structure tensor entries.
#[inline]
pub fn harris_response(mxx: f32, mxy: f32, myy: f32, k: f32) -> f32 {
    let tr = mxx + myy;
    mxx * myy - mxy * mxy - k * tr * tr
}
