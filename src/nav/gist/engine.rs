//! Either GIST backend behind one call (eqs 38–41): the controller, the simulator and the
//! front ends describe frames without knowing which one runs. The GPU engine reuses its
//! buffers between calls, so it sits behind a lock; the CPU engine is shared freely.

use std::sync::{Arc, Mutex};

use rayon::prelude::*;

use super::cpu::{GistConfig, GistEngine};
use super::gpu::GpuGist;
use crate::error::{Error, Result};
use crate::features::Backend;
use crate::gpu::GpuContext;
use crate::image::Frame;

/// A GIST engine on the CPU or the GPU.
// Built once per run and never moved in a loop: the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
pub enum Gist {
    /// [`GistEngine`].
    Cpu(GistEngine),
    /// [`GpuGist`], one caller at a time.
    Gpu(Mutex<GpuGist>),
}

impl Gist {
    /// An engine on `backend`, resolved as everywhere else ([`Backend::resolve`]).
    pub fn new(config: GistConfig, backend: Backend) -> Result<Self> {
        Self::with_context(backend.resolve()?, config)
    }

    /// An engine on the caller's GPU context, or on the CPU without one.
    pub fn with_context(context: Option<Arc<GpuContext>>, config: GistConfig) -> Result<Self> {
        Ok(match context {
            Some(ctx) => Gist::Gpu(Mutex::new(GpuGist::new(ctx, config)?)),
            None => Gist::Cpu(GistEngine::new(config)?),
        })
    }

    /// Where it runs.
    pub fn backend(&self) -> Backend {
        match self {
            Gist::Cpu(_) => Backend::Cpu,
            Gist::Gpu(_) => Backend::Gpu,
        }
    }

    /// The descriptor of one frame.
    pub fn describe(&self, frame: &Frame) -> Result<Vec<f32>> {
        match self {
            Gist::Cpu(engine) => engine.describe(frame),
            Gist::Gpu(_) => Ok(self
                .describe_batch(std::slice::from_ref(frame))?
                .pop()
                .expect("one descriptor per frame")),
        }
    }

    /// The descriptors of many frames: one submission per batch on the GPU, frames in
    /// parallel on the CPU.
    pub fn describe_batch(&self, frames: &[Frame]) -> Result<Vec<Vec<f32>>> {
        match self {
            Gist::Cpu(engine) => frames.par_iter().map(|f| engine.describe(f)).collect(),
            Gist::Gpu(gpu) => gpu
                .lock()
                .map_err(|_| Error::Gpu {
                    operation: "GIST: an earlier caller panicked holding the GPU engine".into(),
                    source: None,
                })?
                .describe_batch(frames),
        }
    }
}

impl From<GistEngine> for Gist {
    fn from(engine: GistEngine) -> Self {
        Gist::Cpu(engine)
    }
}

impl From<GpuGist> for Gist {
    fn from(engine: GpuGist) -> Self {
        Gist::Gpu(Mutex::new(engine))
    }
}
