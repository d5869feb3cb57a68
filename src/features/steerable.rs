//! Steerable Gaussian-derivative filters (eqs 3–4): the basis B_i, the steering coefficients
//! and the orientations, shared by the filter bank and the Harris plan.
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
