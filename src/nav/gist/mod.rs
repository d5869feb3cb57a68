//! GIST of the camera image (eqs 38–45): the Gabor bank, its parameters and the CPU twin
//! ([`cpu`]), the driver of `shaders/gist.wgsl` and `shaders/gist_fft.wgsl` ([`gpu`]), and
//! [`Gist`], either of them behind one call.

pub mod cpu;
mod engine;
pub mod gpu;

pub use cpu::*;
pub use engine::Gist;
pub use gpu::{radices, GistMethod, GpuGist};
