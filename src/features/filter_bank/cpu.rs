//! The steerable filter bank itself (eqs 3–4): basis responses I * B_i and the steered images
//! F(θ_n) = Σ c_i(θ_n)(I * B_i). CPU twin of `shaders/filter_bank_steer.wgsl` (driven by
//! [`crate::features::filter_bank::gpu`]). The detector never materialises F(θ): it steers the gradient
//! basis instead (see `features::steerable`); these images are for inspection and parity.

use rayon::prelude::*;

use super::basis_filters;
use crate::features::config::DetectorConfig;
use crate::features::convolve::convolve_separable;
use crate::features::steerable::{orientations, steering_coefficients};

/// Steering coefficients of every orientation, layout `[θ][basis]`.
pub fn steering_table(config: &DetectorConfig) -> Vec<f32> {
    orientations(config.orientations)
        .into_iter()
        .flat_map(|t| steering_coefficients(config.basis.order(), t))
        .collect()
}

/// The basis responses I * B_i, i = 0..=n.
pub fn basis_responses(
    config: &DetectorConfig,
    gray: &[f32],
    width: usize,
    height: usize,
) -> Vec<Vec<f32>> {
    let mut scratch = vec![0.0; width * height];
    basis_filters(config)
        .iter()
        .map(|f| {
            let mut out = vec![0.0; width * height];
            convolve_separable(gray, &mut out, &mut scratch, width, height, f);
            out
        })
        .collect()
}

/// The N steered images F(θ_n) (eq 4).
pub fn steered_images(
    config: &DetectorConfig,
    gray: &[f32],
    width: usize,
    height: usize,
) -> Vec<Vec<f32>> {
    let basis = basis_responses(config, gray, width, height);
    let table = steering_table(config);
    let b = basis.len();
    table
        .chunks(b)
        .map(|c| {
            let mut out = vec![0.0f32; width * height];
            out.par_iter_mut().enumerate().for_each(|(i, o)| {
                *o = c
                    .iter()
                    .zip(&basis)
                    .fold(0.0, |acc, (w, plane)| acc + w * plane[i]);
            });
            out
        })
        .collect()
}
