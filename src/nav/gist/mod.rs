//! GIST of the camera image (eqs 38–45): the Gabor bank, its parameters and the CPU twin
//! ([`cpu`]), and the driver of `shaders/gist.wgsl` and `shaders/gist_fft.wgsl` ([`gpu`]).

pub mod cpu;
pub mod gpu;

pub use cpu::*;
pub use gpu::{radices, GistMethod, GpuGist};
