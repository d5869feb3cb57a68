//! The dynamic neural field over headings (eqs 28–31): parameters and the CPU twin
//! ([`cpu`]), and the driver of `shaders/dnf.wgsl` ([`gpu`]).

pub mod cpu;
pub mod gpu;

pub use cpu::*;
pub use gpu::GpuFieldBatch;
