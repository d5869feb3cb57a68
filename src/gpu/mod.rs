//! GPU plumbing only: the context (steernav's own or the caller's device), per-stage pipeline
//! caches, the layout of structs shared with WGSL, and buffer helpers. The stages' drivers
//! live beside their CPU twins (`features::harris::gpu`, `nav::dnf::gpu`, `nav::gist::gpu`).

pub mod context;
pub(crate) mod layout;
pub(crate) mod pipelines;
pub(crate) mod util;

pub use context::GpuContext;
