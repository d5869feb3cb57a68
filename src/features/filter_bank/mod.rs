//! The steerable filter bank itself (eqs 3–4), materialised: basis responses I * B_i and the
//! steered images F(θ_n). The detector never needs these (it steers gradients, see
//! [`crate::features::harris::plan`]); they exist for inspection and for the parity of
//! `shaders/filter_bank_steer.wgsl` ([`gpu`]) against its CPU twin ([`cpu`]).

pub mod cpu;
pub mod gpu;

pub use cpu::{basis_responses, steered_images, steering_table};
