//! Steerable Gaussian-derivative filters (eqs 3–4) and the plan of the multiscale Harris
//! stage (eqs 5–8) that both backends execute.
//!
//! The basis of order n is B_i = ∂x^(n−i) ∂y^i G(σ_b) for i = 0..=n, steered with the
//! coefficients c_i(θ) = C(n, i) cos^(n−i)θ sin^iθ, so that F(θ) = Σ c_i(θ) (I * B_i) (eq 4).
//!
//! Harris needs ∂x and ∂y of G(σ_D) * F(θ) (eqs 5–6). Steering is linear and Gaussians compose
//! (G(σ_D) * G(σ_b) = G(σ_e), σ_e² = σ_D² + σ_b²), so these gradients are steered combinations
//! of the n+2 derivatives D_k = ∂x^(n+1−k) ∂y^k G(σ_e) * I:
//! Fx(θ) = Σ c_i D_i, Fy(θ) = Σ c_i D_(i+1). The structure-tensor entries (eq 7) are then
//! fixed quadratic forms in the window-blurred products Q_jk = w(σ_I) * (D_j D_k), so one scale
//! costs (n+2)(n+3)/2 blurred images whatever the number of orientations N.

use super::config::DetectorConfig;

/// A 1-D kernel in correlation form: `out[x] = Σ_t taps[t + radius] · in[x + t]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Kernel1d {
    /// The taps, `2 * radius + 1` of them.
    pub taps: Vec<f32>,
}

impl Kernel1d {
    /// Half-width of the kernel.
    pub fn radius(&self) -> usize {
        self.taps.len() / 2
    }

    /// The `order`-th derivative of a Gaussian of standard deviation `sigma`, sampled and
    /// truncated at `truncate`·σ, corrected so that it differentiates polynomials of degree
    /// ≤ order exactly (zero response to lower-degree terms, unit response to x^order/order!).
    pub fn gaussian_derivative(sigma: f32, order: usize, truncate: f32) -> Self {
        let sigma = sigma as f64;
        let radius = ((truncate as f64 * sigma).ceil() as i64).max(1);
        let ts: Vec<f64> = (-radius..=radius).map(|t| t as f64).collect();
        let gauss: Vec<f64> = ts
            .iter()
            .map(|t| (-t * t / (2.0 * sigma * sigma)).exp())
            .collect();
        let hermite = |u: f64, m: usize| match m {
            0 => 1.0,
            1 => u,
            2 => u * u - 1.0,
            3 => u * u * u - 3.0 * u,
            _ => unreachable!("derivative orders above 3 are never requested"),
        };
        // (−1)^m G^(m)(t) = σ^−m He_m(t/σ) G(t): correlation with it differentiates.
        let shape = |m: usize| -> Vec<f64> {
            ts.iter()
                .zip(&gauss)
                .map(|(t, g)| hermite(t / sigma, m) * g / sigma.powi(m as i32))
                .collect()
        };
        let mut taps = shape(order);
        let moment =
            |k: &[f64], p: i32| -> f64 { ts.iter().zip(k).map(|(t, v)| t.powi(p) * v).sum() };
        // Remove the response to the same-parity lower-degree term the truncation leaves.
        if order >= 2 {
            let lower = shape(order - 2);
            let p = order as i32 - 2;
            let ratio = moment(&taps, p) / moment(&lower, p);
            for (v, l) in taps.iter_mut().zip(&lower) {
                *v -= ratio * l;
            }
        }
        let factorial: f64 = (1..=order).map(|k| k as f64).product();
        let scale = factorial / moment(&taps, order as i32);
        Self {
            taps: taps.iter().map(|v| (v * scale) as f32).collect(),
        }
    }

    /// The kernel multiplied by `factor`.
    pub fn scaled(mut self, factor: f32) -> Self {
        for v in &mut self.taps {
            *v *= factor;
        }
        self
    }
}

/// A separable filter: a column (vertical) pass followed by a row (horizontal) pass.
#[derive(Clone, Debug, PartialEq)]
pub struct Separable {
    /// Applied along y first.
    pub column: Kernel1d,
    /// Then along x.
    pub row: Kernel1d,
}

/// Binomial coefficient for the small orders used here.
fn binomial(n: usize, k: usize) -> f32 {
    (1..=k).fold(1.0, |acc, i| acc * (n + 1 - i) as f32 / i as f32)
}

/// Steering coefficients c_i(θ), i = 0..=n, of a basis of order n (eq 3).
pub fn steering_coefficients(order: usize, theta: f32) -> Vec<f32> {
    let (s, c) = theta.sin_cos();
    (0..=order)
        .map(|i| binomial(order, i) * c.powi((order - i) as i32) * s.powi(i as i32))
        .collect()
}

/// The N steered orientations θ_n = nπ/N. F(θ + π) = ±F(θ) and Harris is blind to the sign,
/// so half a turn covers every distinct steered image for both basis orders.
pub fn orientations(n: usize) -> Vec<f32> {
    (0..n)
        .map(|i| i as f32 * std::f32::consts::PI / n as f32)
        .collect()
}

/// The basis filters B_i (eq 3) at σ_b as separable kernels.
pub fn basis_filters(config: &DetectorConfig) -> Vec<Separable> {
    let n = config.basis.order();
    (0..=n)
        .map(|i| Separable {
            column: Kernel1d::gaussian_derivative(config.basis_sigma, i, config.truncate),
            row: Kernel1d::gaussian_derivative(config.basis_sigma, n - i, config.truncate),
        })
        .collect()
}

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivative_kernels_differentiate_polynomials() {
        for order in 0..=3 {
            let k = Kernel1d::gaussian_derivative(1.7, order, 3.0);
            let r = k.radius() as i32;
            for degree in 0..=3 {
                let resp: f64 = (-r..=r)
                    .zip(&k.taps)
                    .map(|(t, &v)| v as f64 * (t as f64).powi(degree))
                    .sum();
                let factorial: f64 = (1..=order).map(|v| v as f64).product();
                let expected = if degree == order as i32 {
                    factorial
                } else if degree < order as i32 || (degree - order as i32) % 2 == 1 {
                    0.0
                } else {
                    resp
                };
                assert!(
                    (resp - expected).abs() < 1e-4,
                    "order {order} degree {degree}: {resp}"
                );
            }
        }
    }

    #[test]
    fn steering_reproduces_directional_derivatives() {
        // Second order: c = (cos², 2 cos sin, sin²) so that F(θ) = u·H·u with u = (cos, sin).
        let c = steering_coefficients(2, 0.3);
        let (s, co) = 0.3f32.sin_cos();
        assert!((c[0] - co * co).abs() < 1e-6);
        assert!((c[1] - 2.0 * co * s).abs() < 1e-6);
        assert!((c[2] - s * s).abs() < 1e-6);
        assert_eq!(
            orientations(4),
            vec![
                0.0,
                std::f32::consts::FRAC_PI_4,
                std::f32::consts::FRAC_PI_2,
                3.0 * std::f32::consts::FRAC_PI_4
            ]
        );
    }
}
