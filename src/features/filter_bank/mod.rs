//! The steerable filter bank itself (eqs 3–4), materialised: basis responses I * B_i and the
//! steered images F(θ_n). The detector never needs these (it steers gradients, see
//! [`crate::features::harris::plan`]); they exist for inspection and for the parity of
//! `shaders/filter_bank_steer.wgsl` ([`gpu`]) against its CPU twin ([`cpu`]).

pub mod cpu;
pub mod gpu;

pub use cpu::{basis_responses, steered_images, steering_table};

use crate::features::config::DetectorConfig;
use crate::features::steerable::{Kernel1d, Separable};

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
