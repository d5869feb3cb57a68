//! GPU plumbing: one shared context, pipelines compiled once, per-size buffer caches, and the
//! drivers of the WGSL stages.

pub mod context;

pub mod pipelines;
pub mod util;

pub use context::{gpu_required, GpuContext};
