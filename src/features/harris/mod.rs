//! The multiscale steered Harris stage (eqs 4–8): the plan both backends execute
//! ([`plan`]), the row-band CPU twin ([`cpu`]) and the driver of
//! `shaders/harris_{convolve,products,response,nms}.wgsl` ([`gpu`]).

pub mod cpu;
pub mod gpu;
pub mod plan;

pub use cpu::{CpuHarris, CpuTimings, ResponseStack};
pub use gpu::{GpuHarris, GpuTimings};
pub use plan::{grid_step, harris_response, HarrisPlan, ScalePlan};
