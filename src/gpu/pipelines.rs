//! Compute pipelines, compiled per stage on first use and cached in the [`super::GpuContext`]:
//! a robot that only runs the detector never compiles the GIST or DNF shaders.

use std::any::{Any, TypeId};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// The pipelines of one stage, built together from its WGSL sources. Each stage's driver
/// declares one implementor; [`super::GpuContext::pipelines`] builds it once per context.
pub trait PipelineSet: Send + Sync + 'static {
    /// Compiles the stage's shaders and builds its pipelines.
    fn build(device: &wgpu::Device) -> Self;
}

/// Type-keyed cache of built [`PipelineSet`]s.
#[derive(Default)]
pub(crate) struct PipelineCache(Mutex<HashMap<TypeId, Arc<dyn Any + Send + Sync>>>);

impl PipelineCache {
    pub(crate) fn get_or_build<P: PipelineSet>(&self, device: &wgpu::Device) -> Arc<P> {
        // A poisoned lock only means another thread panicked while building; the map itself
        // holds nothing half-made, so it is safe to keep using it.
        let mut map = self.0.lock().unwrap_or_else(|e| e.into_inner());
        let entry = map
            .entry(TypeId::of::<P>())
            .or_insert_with(|| Arc::new(P::build(device)));
        Arc::clone(entry)
            .downcast::<P>()
            .expect("the cache is keyed by the type it stores")
    }
}

/// Compiles one WGSL source.
pub fn shader_module(device: &wgpu::Device, label: &str, source: &str) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    })
}

/// A compute pipeline for one entry point, its bind group layout derived from the shader.
pub fn compute_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    entry: &str,
) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: None,
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// The pipeline of a stage with one shader and one entry point, `main`.
pub fn single_main(device: &wgpu::Device, (name, source): (&str, &str)) -> wgpu::ComputePipeline {
    compute_pipeline(device, &shader_module(device, name, source), "main")
}

/// A stage with one WGSL file and one `main` entry point: its `SHADERS` table (what the shader
/// tests validate) and the pipeline type `$name`, built once per device on first use.
macro_rules! single_pipeline_stage {
    ($name:ident, $file:literal) => {
        /// The stage's WGSL source with its file name.
        pub const SHADERS: [(&str, &str); 1] = [(
            $file,
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/shaders/", $file)),
        )];

        struct $name(wgpu::ComputePipeline);

        impl crate::gpu::pipelines::PipelineSet for $name {
            fn build(device: &wgpu::Device) -> Self {
                Self(crate::gpu::pipelines::single_main(device, SHADERS[0]))
            }
        }
    };
}
pub(crate) use single_pipeline_stage;
