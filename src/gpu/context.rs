//! The GPU context: a wgpu device and queue, either the process-wide one steernav creates
//! ([`GpuContext::shared`]) or one the application owns ([`GpuContext::from_device`]). Each
//! stage compiles its pipelines on its first use on a context (see `gpu::pipelines`).

use std::sync::{Arc, Mutex};

use crate::error::{Error, Result};

/// A wgpu device plus what we learned about it.
pub struct GpuContext {
    /// The logical device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Adapter name, backend, driver.
    pub info: wgpu::AdapterInfo,
    /// The limits the device was created with.
    pub limits: wgpu::Limits,
    /// Whether timestamp queries are available for per-stage timings.
    pub timestamps: bool,
    pipelines: super::pipelines::PipelineCache,
}

/// The process-wide context once created. A failure is not kept: the next call asks again,
/// so a robot whose GPU appears late (a driver still loading) can retry.
static SHARED: Mutex<Option<Arc<GpuContext>>> = Mutex::new(None);

impl GpuContext {
    /// The process-wide context, created on first success. The primary backends (Vulkan,
    /// Metal, DX12) are asked, not GL, which would find a software rasterizer even where a
    /// Vulkan GPU exists; `WGPU_BACKEND` overrides the choice.
    pub fn shared() -> Result<Arc<GpuContext>> {
        let mut shared = SHARED.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(ctx) = shared.as_ref() {
            return Ok(Arc::clone(ctx));
        }
        let ctx = Arc::new(Self::create()?);
        *shared = Some(Arc::clone(&ctx));
        Ok(ctx)
    }

    /// Wraps a device the application created and owns, so that steernav's stages run on it
    /// beside the application's own work. `info` describes its adapter (`adapter.get_info()`);
    /// timestamps are used when the device was created with `TIMESTAMP_QUERY`.
    pub fn from_device(device: wgpu::Device, queue: wgpu::Queue, info: wgpu::AdapterInfo) -> Self {
        Self {
            limits: device.limits(),
            timestamps: device.features().contains(wgpu::Features::TIMESTAMP_QUERY),
            device,
            queue,
            info,
            pipelines: Default::default(),
        }
    }

    /// Creates a new context of its own (most callers want [`GpuContext::shared`]).
    pub fn create() -> Result<Self> {
        pollster::block_on(async {
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
            desc.backends = wgpu::Backends::PRIMARY;
            let instance = wgpu::Instance::new(desc.with_env());
            let adapter = instance
                .request_adapter(&wgpu::RequestAdapterOptions {
                    power_preference: wgpu::PowerPreference::HighPerformance,
                    ..Default::default()
                })
                .await
                .map_err(|e| Error::NoGpu {
                    reason: format!("no adapter found ({e})"),
                    source: Some(Box::new(e)),
                })?;
            let wanted = wgpu::Features::TIMESTAMP_QUERY;
            let features = adapter.features() & wanted;
            let limits = adapter.limits();
            let (device, queue) = adapter
                .request_device(&wgpu::DeviceDescriptor {
                    label: Some("steernav"),
                    required_features: features,
                    required_limits: limits.clone(),
                    ..Default::default()
                })
                .await
                .map_err(|e| Error::NoGpu {
                    reason: format!(
                        "device request (features {features:?}, adapter limits) failed: {e}"
                    ),
                    source: Some(Box::new(e)),
                })?;
            Ok(Self::from_device(device, queue, adapter.get_info()))
        })
    }

    /// Whether `--backend auto` may use this adapter: only hardware (integrated, discrete or
    /// virtual GPUs). A software rasterizer such as Mesa's llvmpipe (lavapipe) runs the
    /// shaders on the CPU, two orders of magnitude slower than the CPU path itself, so `auto`
    /// takes the CPU path instead; `--backend gpu` still uses it when asked (CI does).
    pub fn auto_refusal(&self) -> Option<String> {
        auto_refusal(&self.info.name, self.info.device_type)
    }

    /// The pipelines of one stage on this context, compiled on the stage's first use.
    pub fn pipelines<P: super::pipelines::PipelineSet>(&self) -> Arc<P> {
        self.pipelines.get_or_build(&self.device)
    }

    /// A human-readable report of the adapter and the limits that matter to steernav.
    pub fn describe(&self) -> String {
        let i = &self.info;
        let l = &self.limits;
        format!(
            "adapter:  {}\nbackend:  {:?}\ntype:     {:?}\ndriver:   {} {}\nvendor:   0x{:04x} device 0x{:04x}\n\
             max_storage_buffer_binding_size: {} MiB\nmax_buffer_size: {} MiB\n\
             max_compute_invocations_per_workgroup: {}\nmax_compute_workgroup_storage_size: {} KiB\n\
             max_compute_workgroups_per_dimension: {}\nmax_storage_buffers_per_shader_stage: {}\n\
             timestamp queries: {}",
            i.name,
            i.backend,
            i.device_type,
            i.driver,
            i.driver_info,
            i.vendor,
            i.device,
            l.max_storage_buffer_binding_size / (1 << 20),
            l.max_buffer_size / (1 << 20),
            l.max_compute_invocations_per_workgroup,
            l.max_compute_workgroup_storage_size / 1024,
            l.max_compute_workgroups_per_dimension,
            l.max_storage_buffers_per_shader_stage,
            if self.timestamps { "yes" } else { "no" },
        )
    }
}

/// Why `--backend auto` would not use an adapter of this name and type, or `None` when it
/// would (see [`GpuContext::auto_refusal`]).
pub fn auto_refusal(name: &str, device_type: wgpu::DeviceType) -> Option<String> {
    match device_type {
        wgpu::DeviceType::IntegratedGpu
        | wgpu::DeviceType::DiscreteGpu
        | wgpu::DeviceType::VirtualGpu => None,
        other => Some(format!(
            "the only adapter, {name}, is not a hardware GPU (device type {other:?}: a software rasterizer runs shaders on the CPU)"
        )),
    }
}

/// The context `--backend auto` uses: the shared one when its adapter is a hardware GPU,
/// otherwise the reason it is not used.
pub fn auto_context() -> std::result::Result<Arc<GpuContext>, String> {
    let ctx = GpuContext::shared().map_err(|e| e.to_string())?;
    match ctx.auto_refusal() {
        None => Ok(ctx),
        Some(reason) => Err(reason),
    }
}

/// Whether the environment demands a GPU (CI sets `STEERNAV_REQUIRE_GPU=1`).
pub fn gpu_required() -> bool {
    std::env::var("STEERNAV_REQUIRE_GPU").is_ok_and(|v| v == "1" || v.eq_ignore_ascii_case("true"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_refuses_software_adapters_and_takes_hardware_ones() {
        let lavapipe = auto_refusal("llvmpipe (LLVM 15.0.6, 256 bits)", wgpu::DeviceType::Cpu);
        assert!(lavapipe.is_some_and(|r| r.contains("llvmpipe") && r.contains("Cpu")));
        assert!(auto_refusal("unknown", wgpu::DeviceType::Other).is_some());
        for t in [
            wgpu::DeviceType::DiscreteGpu,
            wgpu::DeviceType::IntegratedGpu,
            wgpu::DeviceType::VirtualGpu,
        ] {
            assert!(auto_refusal("NVIDIA H200", t).is_none());
        }
    }
}
