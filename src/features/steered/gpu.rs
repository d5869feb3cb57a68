//! GPU twin of the steered descriptor: drives `shaders/steered_descriptor.wgsl`, one workgroup
//! per keypoint. CPU twin: [`super::cpu`].
//!
//! Per frame: one upload of the luminance plane and of the keypoint jobs, the dispatches, and
//! one readback of every descriptor with its orientation. Each keypoint smooths its own patch
//! in a scratch area; keypoints go in chunks whose scratch fits `SCRATCH_BUDGET_BYTES` (64 MiB), so
//! memory stays bounded whatever the scales. A keypoint whose patch is too large for one
//! invocation's loops (σ_D above about 9 px) is described on the CPU.

use std::sync::{Arc, Mutex};

use super::{patch_geometry, Steered, STEERED_LEN};
use crate::error::{Error, Result};
use crate::features::harris::plan::IMAGE_BLUR;
use crate::gpu::layout::gpu_struct;
use crate::gpu::pipelines::single_pipeline_stage;
use crate::gpu::util::{bind, read_staging, staging, storage, uniform};
use crate::gpu::GpuContext;

single_pipeline_stage!(SteeredPipeline, "steered_descriptor.wgsl");

gpu_struct! {
    struct Params as "Params" {
        count: u32,
        groups_x: u32,
        slots: u32,
        first: u32,
        _pad0: u32,
        _pad1: u32,
        _pad2: u32,
        _pad3: u32,
    }
}

gpu_struct! {
    struct Job as "Job" {
        x: f32,
        y: f32,
        sigma: f32,
        half: u32,
        radius: u32,
        taps: u32,
        scratch: u32,
        slot: u32,
        plane: u32,
        width: u32,
        height: u32,
        _pad: u32,
    }
}

/// One plane the descriptors read: a luminance image (a pyramid level) and the Gaussian blur
/// it already carries, in its own pixels.
#[derive(Clone, Copy, Debug)]
pub struct Plane<'a> {
    /// Row-major luminance, `width`×`height`.
    pub gray: &'a [f32],
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Blur already in the plane (0 for a camera image, 1 for a pyramid level).
    pub prior_blur: f32,
}

/// A keypoint to describe: the index of the plane it is read on, and (x, y, σ_D) in that
/// plane's pixels.
pub type PlanePoint = (usize, (f32, f32, f32));

/// Bytes of patch scratch one dispatch may use.
const SCRATCH_BUDGET_BYTES: u64 = 64 << 20;
/// Pixels of one keypoint's gradient window the shader's per-invocation loops may visit
/// (lavapipe stops loops past 65,535 iterations).
const MAX_WINDOW_PIXELS: usize = 65_535;

/// Buffers for a plane capacity and a keypoint capacity.
struct Resources {
    /// Floats the planes' buffer holds.
    pixels: usize,
    capacity: usize,
    gray: wgpu::Buffer,
    taps: wgpu::Buffer,
    jobs: wgpu::Buffer,
    scratch: wgpu::Buffer,
    out: wgpu::Buffer,
    readback: wgpu::Buffer,
    params: wgpu::Buffer,
    /// Every chunk's parameters, copied into `params` before its dispatch (at most one chunk
    /// per keypoint).
    chunk_params: wgpu::Buffer,
    group: wgpu::BindGroup,
}

/// The GPU steered-descriptor stage; safe to share between threads (frames are serialised).
pub struct GpuSteered {
    ctx: Arc<GpuContext>,
    resources: Mutex<Option<Resources>>,
}

/// One keypoint's work as planned on the CPU.
struct Planned {
    job: Job,
    scratch_floats: usize,
}

impl GpuSteered {
    /// The stage on a context; buffers are made on first use.
    pub fn new(ctx: Arc<GpuContext>) -> Self {
        Self {
            ctx,
            resources: Mutex::new(None),
        }
    }

    /// Descriptors of keypoints at `points` (x, y, scale: the total blur, as
    /// [`super::cpu::describe_steered`]) on a `width`×`height` luminance plane,
    /// in the order given.
    pub fn describe(
        &self,
        gray: &[f32],
        width: u32,
        height: u32,
        points: &[(f32, f32, f32)],
    ) -> Result<Vec<Steered>> {
        self.describe_blurred(gray, width, height, points, IMAGE_BLUR)
    }

    /// [`Self::describe`] on a plane that already carries a Gaussian blur of `prior_blur`
    /// pixels (a pyramid level), as [`super::cpu::describe_steered_blurred`].
    pub fn describe_blurred(
        &self,
        gray: &[f32],
        width: u32,
        height: u32,
        points: &[(f32, f32, f32)],
        prior_blur: f32,
    ) -> Result<Vec<Steered>> {
        let plane = Plane {
            gray,
            width,
            height,
            prior_blur,
        };
        let points: Vec<PlanePoint> = points.iter().map(|&p| (0, p)).collect();
        self.describe_planes(&[plane], &points)
    }

    /// Descriptors of keypoints read on several planes (a frame's pyramid levels) with one
    /// upload of every plane, one submission and one readback; each point as
    /// [`super::cpu::describe_steered_blurred`] gives it on its plane, in the order given.
    pub fn describe_planes(&self, planes: &[Plane], points: &[PlanePoint]) -> Result<Vec<Steered>> {
        let mut out: Vec<Option<Steered>> = vec![None; points.len()];
        let mut offsets = Vec::with_capacity(planes.len());
        let mut pixels = 0usize;
        for (i, p) in planes.iter().enumerate() {
            if p.gray.len() != p.width as usize * p.height as usize || p.gray.is_empty() {
                return Err(Error::Config {
                    field: "plane",
                    value: i.to_string(),
                    reason: format!(
                        "{} values for a {}x{} plane",
                        p.gray.len(),
                        p.width,
                        p.height
                    ),
                });
            }
            offsets.push(pixels);
            pixels += p.gray.len();
        }
        // Plan: kernels deduplicated by σ and blur (a handful), scratch per keypoint.
        let mut taps: Vec<f32> = Vec::new();
        let mut kernels: Vec<((u32, u32), u32)> = Vec::new();
        let mut planned: Vec<Planned> = Vec::new();
        for (slot, &(index, (x, y, sigma))) in points.iter().enumerate() {
            let plane = planes.get(index).ok_or_else(|| Error::Config {
                field: "plane",
                value: index.to_string(),
                reason: format!(
                    "keypoint {slot} names a plane past the {} given",
                    planes.len()
                ),
            })?;
            let (half, kernel) = patch_geometry(sigma, plane.prior_blur);
            let side = 2 * half + 1;
            if side * side > MAX_WINDOW_PIXELS {
                out[slot] = Some(super::cpu::describe_steered_blurred(
                    plane.gray,
                    plane.width as usize,
                    plane.height as usize,
                    (x, y, sigma),
                    plane.prior_blur,
                ));
                continue;
            }
            let r = kernel.radius();
            let key = (sigma.to_bits(), plane.prior_blur.to_bits());
            let offset = match kernels.iter().find(|k| k.0 == key) {
                Some(k) => k.1,
                None => {
                    let o = taps.len() as u32;
                    taps.extend(&kernel.taps);
                    kernels.push((key, o));
                    o
                }
            };
            let (inner, outer) = (side + 2, side + 2 * (r + 1));
            planned.push(Planned {
                job: Job {
                    x,
                    y,
                    sigma,
                    half: half as u32,
                    radius: r as u32,
                    taps: offset,
                    scratch: 0,
                    slot: slot as u32,
                    plane: offsets[index] as u32,
                    width: plane.width,
                    height: plane.height,
                    _pad: 0,
                },
                scratch_floats: outer * inner + inner * inner + 2 * side * side,
            });
        }
        if !planned.is_empty() {
            let values = self.run(planes, pixels, &taps, &mut planned, points.len())?;
            for p in &planned {
                let s = p.job.slot as usize;
                out[s] = Some(Steered {
                    orientation: values[points.len() * STEERED_LEN + s],
                    values: values[s * STEERED_LEN..(s + 1) * STEERED_LEN].to_vec(),
                });
            }
        }
        Ok(out
            .into_iter()
            .map(|s| s.expect("every slot described"))
            .collect())
    }

    fn run(
        &self,
        planes: &[Plane],
        pixels: usize,
        taps: &[f32],
        planned: &mut [Planned],
        slots: usize,
    ) -> Result<Vec<f32>> {
        let device = &self.ctx.device;
        let queue = &self.ctx.queue;
        let limit = self.ctx.limits.max_storage_buffer_binding_size;
        let budget = (SCRATCH_BUDGET_BYTES.min(limit) / 4) as usize;
        let largest = planned.iter().map(|p| p.scratch_floats).max().unwrap_or(0);
        let scratch_floats = budget.max(largest);
        let mut guard = self.resources.lock().unwrap_or_else(|e| e.into_inner());
        let fits = guard.as_ref().is_some_and(|r| {
            r.pixels >= pixels
                && r.capacity >= slots
                && r.taps.size() >= (taps.len() * 4) as u64
                && r.scratch.size() >= (scratch_floats * 4) as u64
        });
        if !fits {
            *guard =
                Some(self.allocate(pixels, slots.max(64), taps.len().max(256), scratch_floats));
        }
        let res = guard.as_ref().expect("allocated above");
        let mut at = 0u64;
        for p in planes {
            queue.write_buffer(&res.gray, at, bytemuck::cast_slice(p.gray));
            at += p.gray.len() as u64 * 4;
        }
        queue.write_buffer(&res.taps, 0, bytemuck::cast_slice(taps));
        let pipeline = &self.ctx.pipelines::<SteeredPipeline>().0;
        // Chunks whose scratch fits the buffer, one dispatch each, in one submission: the
        // parameters of each chunk are copied into place by the encoder itself.
        let mut chunks: Vec<(usize, usize)> = Vec::new();
        let (mut start, mut used) = (0, 0);
        for (i, p) in planned.iter_mut().enumerate() {
            if used + p.scratch_floats > scratch_floats {
                chunks.push((start, i));
                start = i;
                used = 0;
            }
            p.job.scratch = used as u32;
            used += p.scratch_floats;
        }
        chunks.push((start, planned.len()));
        let jobs: Vec<Job> = planned.iter().map(|p| p.job).collect();
        queue.write_buffer(&res.jobs, 0, bytemuck::cast_slice(&jobs));
        let param_list: Vec<Params> = chunks
            .iter()
            .map(|&(a, b)| {
                let count = (b - a) as u32;
                Params {
                    count,
                    groups_x: count.clamp(1, 65_535),
                    slots: slots as u32,
                    first: a as u32,
                    _pad0: 0,
                    _pad1: 0,
                    _pad2: 0,
                    _pad3: 0,
                }
            })
            .collect();
        // Each chunk's parameters are copied into place by the encoder between dispatches.
        queue.write_buffer(&res.chunk_params, 0, bytemuck::cast_slice(&param_list));
        let mut enc = device.create_command_encoder(&Default::default());
        for (i, p) in param_list.iter().enumerate() {
            enc.copy_buffer_to_buffer(
                &res.chunk_params,
                (i * std::mem::size_of::<Params>()) as u64,
                &res.params,
                0,
                Some(std::mem::size_of::<Params>() as u64),
            );
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("steered descriptor"),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &res.group, &[]);
            pass.dispatch_workgroups(p.groups_x, p.count.div_ceil(p.groups_x), 1);
        }
        let bytes = (slots * (STEERED_LEN + 1) * 4) as u64;
        enc.copy_buffer_to_buffer(&res.out, 0, &res.readback, 0, Some(bytes));
        queue.submit([enc.finish()]);
        let raw = read_staging(device, &res.readback, bytes)?;
        Ok(bytemuck::pod_collect_to_vec(&raw))
    }

    fn allocate(
        &self,
        pixels: usize,
        capacity: usize,
        taps: usize,
        scratch_floats: usize,
    ) -> Resources {
        let device = &self.ctx.device;
        let pipeline = &self.ctx.pipelines::<SteeredPipeline>().0;
        let gray = storage(device, "steered planes", pixels.max(1) as u64 * 4);
        let taps = storage(device, "steered taps", taps as u64 * 4);
        let jobs = storage(
            device,
            "steered jobs",
            (capacity * std::mem::size_of::<Job>()) as u64,
        );
        let scratch = storage(device, "steered scratch", scratch_floats as u64 * 4);
        let out_bytes = (capacity * (STEERED_LEN + 1) * 4) as u64;
        let out = storage(device, "steered descriptors", out_bytes);
        let readback = staging(device, "steered readback", out_bytes);
        let params = uniform(
            device,
            "steered params",
            &Params {
                count: 0,
                groups_x: 1,
                slots: 0,
                first: 0,
                _pad0: 0,
                _pad1: 0,
                _pad2: 0,
                _pad3: 0,
            },
        );
        let chunk_params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("steered params per chunk"),
            size: (capacity * std::mem::size_of::<Params>()) as u64,
            usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let group = bind(
            device,
            pipeline,
            &[&params, &gray, &taps, &jobs, &scratch, &out],
        );
        Resources {
            pixels,
            capacity,
            gray,
            taps,
            jobs,
            scratch,
            out,
            readback,
            params,
            chunk_params,
            group,
        }
    }
}

#[cfg(test)]
mod layout_tests {
    use super::*;
    use crate::gpu::layout::check;

    #[test]
    fn shared_structs_match_the_wgsl_declarations() {
        check::<Params>(SHADERS[0].1);
        check::<Job>(SHADERS[0].1);
    }
}
