//! GIST of the camera image (eqs 38–45): the Gabor bank, its parameters and the CPU twin
//! ([`crate::low_level::gist::cpu`]), the driver of `shaders/gist.wgsl` and `shaders/gist_fft.wgsl`
//! ([`crate::low_level::gist::gpu`]), and
//! [`Gist`], either of them behind one call.

pub(crate) mod cpu;
mod engine;
pub(crate) mod gpu;

pub use cpu::*;
pub use engine::Gist;
pub use gpu::{radices, GistMethod, GpuGist};
