//! GPU twin of the GIST filter bank (eqs 38–41): a batch of images in one submission — their
//! 2-D transforms, every Gabor filter applied in the frequency domain, inverse transforms, |·|
//! and the K×K window means — and one readback of the descriptors. Two methods:
//! [`GistMethod::Fft`] (`shaders/gist_fft.wgsl`, mixed-radix Stockham FFTs, one dispatch per
//! radix stage; the default whenever the padded side factors into 2, 3, 5 and 7) and
//! [`GistMethod::Direct`] (`shaders/gist.wgsl`, direct DFT sums, any size, O(n³)). The pre-filter (two small FFTs) stays on the CPU
//! ([`GistEngine::padded_input`]); the bank, 1 forward and L·M inverse transforms per image,
//! is the heavy part. The CPU reference is [`GistEngine`] with `decimate = false`.

use std::sync::Arc;

use bytemuck::Zeroable;

use crate::error::{Error, Result};
use crate::gpu::layout::gpu_struct;
use crate::gpu::pipelines::{compute_pipeline, shader_module, PipelineSet};
use crate::gpu::util::{bind_at, read_staging, staging, storage, storage_init, uniform};
use crate::gpu::GpuContext;
use crate::image::Frame;
use crate::nav::gist::{gabor_bank, GistConfig, GistEngine};

/// The stage's WGSL sources with their file names.
pub const SHADERS: [(&str, &str); 2] = [
    ("gist.wgsl", include_str!("../../../shaders/gist.wgsl")),
    (
        "gist_fft.wgsl",
        include_str!("../../../shaders/gist_fft.wgsl"),
    ),
];

/// `gist.wgsl`: the direct method's passes.
struct GistPipelines {
    forward_rows: wgpu::ComputePipeline,
    forward_columns: wgpu::ComputePipeline,
    inverse_columns: wgpu::ComputePipeline,
    inverse_rows: wgpu::ComputePipeline,
    window_means: wgpu::ComputePipeline,
}

impl GistPipelines {
    /// The passes in the order one batch runs them (their bind groups follow that order).
    fn in_pass_order(&self) -> [&wgpu::ComputePipeline; 5] {
        [
            &self.forward_rows,
            &self.forward_columns,
            &self.inverse_columns,
            &self.inverse_rows,
            &self.window_means,
        ]
    }
}

impl PipelineSet for GistPipelines {
    fn build(device: &wgpu::Device) -> Self {
        let module = shader_module(device, SHADERS[0].0, SHADERS[0].1);
        let entry = |name| compute_pipeline(device, &module, name);
        Self {
            forward_rows: entry("forward_rows"),
            forward_columns: entry("forward_columns"),
            inverse_columns: entry("inverse_columns"),
            inverse_rows: entry("inverse_rows"),
            window_means: entry("window_means"),
        }
    }
}

/// `gist_fft.wgsl`: the FFT method's passes.
struct GistFftPipelines {
    fft_stage: wgpu::ComputePipeline,
    apply_filters: wgpu::ComputePipeline,
    window_means: wgpu::ComputePipeline,
}

impl PipelineSet for GistFftPipelines {
    fn build(device: &wgpu::Device) -> Self {
        let module = shader_module(device, SHADERS[1].0, SHADERS[1].1);
        let entry = |name| compute_pipeline(device, &module, name);
        Self {
            fft_stage: entry("fft_stage"),
            apply_filters: entry("apply_filters"),
            window_means: entry("window_means"),
        }
    }
}

gpu_struct! {
    struct Params as "Params" {
        n: u32,
        m: u32,
        boundary: u32,
        filters: u32,
        blocks: u32,
        images: u32,
        inv_n2: f32,
        _pad: u32,
    }
}

/// How the GPU computes the transforms.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GistMethod {
    /// Mixed-radix FFTs: O(n² log n) per plane.
    Fft,
    /// Direct DFT sums: O(n³) per plane, any n.
    Direct,
}

/// The radices (each 2..=8) whose product is n, largest first; `None` when n has a prime
/// factor above 7.
pub fn radices(n: usize) -> Option<Vec<u32>> {
    let mut left = n;
    let mut primes = Vec::new();
    for p in [2usize, 3, 5, 7] {
        while left.is_multiple_of(p) {
            primes.push(p as u32);
            left /= p;
        }
    }
    if left != 1 || n < 2 {
        return None;
    }
    let twos = primes.iter().filter(|&&p| p == 2).count() as u32;
    let mut out: Vec<u32> = vec![8; (twos / 3) as usize];
    match twos % 3 {
        1 => out.push(2),
        2 => out.push(4),
        _ => {}
    }
    out.extend(primes.into_iter().filter(|&p| p != 2));
    Some(out)
}

gpu_struct! {
    struct Stage as "Stage" {
        n: u32,
        ns: u32,
        radix: u32,
        inverse: u32,
        axis: u32,
        planes: u32,
        _p0: u32,
        _p1: u32,
    }
}

/// FFT-method buffers for up to `capacity` images.
struct FftBatch {
    capacity: usize,
    bank: wgpu::Buffer,
    input: wgpu::Buffer,
    windows: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Forward stages (rows then columns) and inverse stages: uniform, bind group, stage.
    forward: Vec<(wgpu::Buffer, wgpu::BindGroup, Stage)>,
    inverse: Vec<(wgpu::Buffer, wgpu::BindGroup, Stage)>,
    filters_group: wgpu::BindGroup,
    windows_group: wgpu::BindGroup,
}

/// Buffers for a batch of up to `capacity` images, reused across calls.
struct Batch {
    capacity: usize,
    params: wgpu::Buffer,
    input: wgpu::Buffer,
    windows: wgpu::Buffer,
    readback: wgpu::Buffer,
    groups: Vec<wgpu::BindGroup>,
}

/// GIST descriptors on the GPU.
pub struct GpuGist {
    ctx: Arc<GpuContext>,
    cpu: GistEngine,
    n: usize,
    m: usize,
    filters: usize,
    blocks: usize,
    twiddle: wgpu::Buffer,
    gains: wgpu::Buffer,
    batch: Option<Batch>,
    method: GistMethod,
    fft: Option<FftBatch>,
}

impl GpuGist {
    /// Uploads the filter bank and the twiddle table. `decimate` is ignored: the GPU computes
    /// the exact full-resolution responses. FFTs when the padded side allows, else direct.
    pub fn new(ctx: Arc<GpuContext>, config: GistConfig) -> Result<Self> {
        if config.decimate {
            log::warn!(
                "GIST decimate = true is a CPU approximation; the GPU computes the exact bank, \
                 so its descriptors differ from a decimating CPU's by up to 6%"
            );
        }
        let mut gist = Self::with_method(ctx, config, GistMethod::Fft)?;
        if radices(gist.n).is_none() {
            gist.method = GistMethod::Direct;
        }
        Ok(gist)
    }

    /// The method in use.
    pub fn method(&self) -> GistMethod {
        self.method
    }

    /// As [`GpuGist::new`] with a chosen method; `Fft` on a side with a prime factor above 7
    /// is an error.
    pub fn with_method(
        ctx: Arc<GpuContext>,
        config: GistConfig,
        method: GistMethod,
    ) -> Result<Self> {
        let cpu = GistEngine::new(GistConfig {
            decimate: false,
            ..config
        })?;
        let config = cpu.config().clone();
        let n = cpu.padded_size();
        let bank = gabor_bank(&config, n);
        let gains: Vec<f32> = bank.concat();
        let twiddle: Vec<[f32; 2]> = (0..n)
            .map(|j| {
                let a = -std::f64::consts::TAU * j as f64 / n as f64;
                [a.cos() as f32, a.sin() as f32]
            })
            .collect();
        let device = &ctx.device;
        Ok(Self {
            twiddle: storage_init(device, "gist twiddle", &twiddle),
            gains: storage_init(device, "gist gains", &gains),
            n,
            m: config.size,
            filters: bank.len(),
            blocks: config.blocks,
            cpu,
            ctx,
            batch: None,
            method,
            fft: None,
        })
        .and_then(|g: Self| {
            if method == GistMethod::Fft && radices(g.n).is_none() {
                return Err(Error::config(
                    "gist",
                    g.n,
                    "the padded side (size + 2·boundary) must factor into 2, 3, 5 and 7 for the FFT method",
                ));
            }
            Ok(g)
        })
    }

    /// Images whose intermediates fit in one binding of this device.
    fn capacity(&self) -> usize {
        let (n, m, f) = (self.n as u64, self.m as u64, self.filters as u64);
        let per_image = (f * m * n * 8).max(f * m * m * 4).max(n * n * 8);
        (self.ctx.limits.max_storage_buffer_binding_size / per_image).clamp(1, 16) as usize
    }

    fn batch(&mut self) -> Result<&Batch> {
        if self.batch.is_none() {
            let capacity = self.capacity();
            let (n, m, f, k) = (
                self.n as u64,
                self.m as u64,
                self.filters as u64,
                self.blocks as u64,
            );
            let c = capacity as u64;
            let device = &self.ctx.device;
            let params = uniform(device, "gist params", &Params::zeroed());
            let input = storage(device, "gist input", c * n * n * 4);
            let rows = storage(device, "gist rows", c * n * n * 8);
            let spectrum = storage(device, "gist spectrum", c * n * n * 8);
            let partial = storage(device, "gist partial", c * f * m * n * 8);
            let magnitude = storage(device, "gist magnitude", c * f * m * m * 4);
            let windows = storage(device, "gist windows", c * f * k * k * 4);
            let readback = staging(device, "gist readback", c * f * k * k * 4);
            let direct = self.ctx.pipelines::<GistPipelines>();
            let p = direct.in_pass_order();
            let bind = |pipeline: &wgpu::ComputePipeline, entries: &[(u32, &wgpu::Buffer)]| {
                bind_at(device, pipeline, entries)
            };
            let groups = vec![
                bind(
                    p[0],
                    &[(0, &params), (1, &self.twiddle), (2, &input), (3, &rows)],
                ),
                bind(
                    p[1],
                    &[(0, &params), (1, &self.twiddle), (3, &rows), (4, &spectrum)],
                ),
                bind(
                    p[2],
                    &[
                        (0, &params),
                        (1, &self.twiddle),
                        (4, &spectrum),
                        (5, &self.gains),
                        (6, &partial),
                    ],
                ),
                bind(
                    p[3],
                    &[
                        (0, &params),
                        (1, &self.twiddle),
                        (6, &partial),
                        (7, &magnitude),
                    ],
                ),
                bind(p[4], &[(0, &params), (7, &magnitude), (8, &windows)]),
            ];
            self.batch = Some(Batch {
                capacity,
                params,
                input,
                windows,
                readback,
                groups,
            });
        }
        Ok(self.batch.as_ref().expect("just built"))
    }

    /// Descriptors of many frames: the CPU pre-filters, the GPU runs the bank on batches of
    /// images in one submission each, and each batch is read back once.
    pub fn describe_batch(&mut self, frames: &[Frame]) -> Result<Vec<Vec<f32>>> {
        let inputs: Vec<Vec<f32>> = frames
            .iter()
            .map(|f| self.cpu.padded_input(f))
            .collect::<Result<_>>()?;
        if self.method == GistMethod::Fft {
            return self.describe_fft(&inputs);
        }
        let (n, m, filters, k) = (self.n, self.m, self.filters, self.blocks);
        let per = filters * k * k;
        let max_groups = self.ctx.limits.max_compute_workgroups_per_dimension as usize;
        let mut out = Vec::with_capacity(frames.len());
        let capacity = self.batch()?.capacity;
        let batch = self.batch.as_ref().expect("built above");
        let ctx = &self.ctx;
        for chunk in inputs.chunks(capacity) {
            let images = chunk.len();
            if images * filters > max_groups {
                return Err(Error::GpuLimit(format!(
                    "{images} images × {filters} filters exceed max_compute_workgroups_per_dimension = {max_groups}"
                )));
            }
            let queue = &ctx.queue;
            let params = self.params(images);
            queue.write_buffer(&batch.params, 0, bytemuck::bytes_of(&params));
            queue.write_buffer(&batch.input, 0, bytemuck::cast_slice(&chunk.concat()));
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_compute_pass(&Default::default());
                let direct = ctx.pipelines::<GistPipelines>();
                let p = direct.in_pass_order();
                let x = |width: usize| width.div_ceil(64) as u32;
                let dispatches = [
                    (x(n), n as u32, images as u32),
                    (x(n), n as u32, images as u32),
                    (x(n), m as u32, (images * filters) as u32),
                    (x(m), m as u32, (images * filters) as u32),
                    (x(images * per), 1, 1),
                ];
                for (stage, &(gx, gy, gz)) in dispatches.iter().enumerate() {
                    pass.set_pipeline(p[stage]);
                    pass.set_bind_group(0, &batch.groups[stage], &[]);
                    pass.dispatch_workgroups(gx, gy, gz);
                }
            }
            let bytes = (images * per * 4) as u64;
            let data = submit_and_read(ctx, enc, &batch.windows, &batch.readback, bytes)?;
            out.extend(data.chunks(per).map(|d| d.to_vec()));
        }
        Ok(out)
    }
}

/// Copies the descriptors to the staging buffer, submits the batch and reads them back.
fn submit_and_read(
    ctx: &GpuContext,
    mut enc: wgpu::CommandEncoder,
    windows: &wgpu::Buffer,
    readback: &wgpu::Buffer,
    bytes: u64,
) -> Result<Vec<f32>> {
    enc.copy_buffer_to_buffer(windows, 0, readback, 0, Some(bytes));
    ctx.queue.submit([enc.finish()]);
    Ok(bytemuck::pod_collect_to_vec(&read_staging(
        &ctx.device,
        readback,
        bytes,
    )?))
}

impl GpuGist {
    /// The bank's parameters for a batch of `images`.
    fn params(&self, images: usize) -> Params {
        Params {
            n: self.n as u32,
            m: self.m as u32,
            boundary: self.cpu.config().boundary as u32,
            filters: self.filters as u32,
            blocks: self.blocks as u32,
            images: images as u32,
            inv_n2: 1.0 / (self.n * self.n) as f32,
            _pad: 0,
        }
    }

    fn fft_batch(&mut self) -> Result<()> {
        if self.fft.is_some() {
            return Ok(());
        }
        let (n, f, k) = (self.n as u64, self.filters as u64, self.blocks as u64);
        let limit = self.ctx.limits.max_storage_buffer_binding_size;
        let capacity = (limit / (f * n * n * 8)).clamp(1, 16);
        let c = capacity;
        let device = &self.ctx.device;
        let bank = uniform(device, "gist bank", &Params::zeroed());
        let a = storage(device, "gist fft a", c * n * n * 8);
        let b = storage(device, "gist fft b", c * n * n * 8);
        let planes_c = storage(device, "gist fft c", c * f * n * n * 8);
        let planes_d = storage(device, "gist fft d", c * f * n * n * 8);
        let windows = storage(device, "gist windows", c * f * k * k * 4);
        let readback = staging(device, "gist readback", c * f * k * k * 4);
        let p = self.ctx.pipelines::<GistFftPipelines>();
        let bind = |pipeline: &wgpu::ComputePipeline, entries: &[(u32, &wgpu::Buffer)]| {
            bind_at(device, pipeline, entries)
        };
        let radices = radices(self.n).expect("checked at construction");
        // Rows then columns; the stages ping-pong between two buffers, an even count, so the
        // result lands back in the first.
        let stages = |inverse: u32, first: &wgpu::Buffer, second: &wgpu::Buffer| {
            let mut out = Vec::new();
            for axis in 0..2u32 {
                let mut ns = 1u32;
                for &radix in &radices {
                    let stage = Stage {
                        n: n as u32,
                        ns,
                        radix,
                        inverse,
                        axis,
                        planes: 0,
                        _p0: 0,
                        _p1: 0,
                    };
                    let buffer = uniform(device, "gist fft stage", &stage);
                    let (src, dst) = if out.len() % 2 == 0 {
                        (first, second)
                    } else {
                        (second, first)
                    };
                    let group = bind(&p.fft_stage, &[(0, &buffer), (1, src), (2, dst)]);
                    out.push((buffer, group, stage));
                    ns *= radix;
                }
            }
            out
        };
        let forward = stages(0, &a, &b);
        let inverse = stages(1, &planes_c, &planes_d);
        let filters_group = bind(
            &p.apply_filters,
            &[(0, &bank), (3, &a), (4, &self.gains), (5, &planes_c)],
        );
        let windows_group = bind(
            &p.window_means,
            &[(0, &bank), (6, &planes_c), (7, &windows)],
        );
        self.fft = Some(FftBatch {
            capacity: capacity as usize,
            bank,
            input: a,
            windows,
            readback,
            forward,
            inverse,
            filters_group,
            windows_group,
        });
        Ok(())
    }

    fn describe_fft(&mut self, inputs: &[Vec<f32>]) -> Result<Vec<Vec<f32>>> {
        self.fft_batch()?;
        let batch = self.fft.as_ref().expect("built above");
        let ctx = &self.ctx;
        let (n, filters, k) = (self.n, self.filters, self.blocks);
        let per = filters * k * k;
        let max_groups = ctx.limits.max_compute_workgroups_per_dimension as usize;
        let mut out = Vec::with_capacity(inputs.len());
        for chunk in inputs.chunks(batch.capacity) {
            let images = chunk.len();
            if images * filters > max_groups || (n * n).div_ceil(64) > max_groups {
                return Err(Error::GpuLimit(format!(
                    "{images} images × {filters} filters of {n}² exceed max_compute_workgroups_per_dimension = {max_groups}"
                )));
            }
            let queue = &ctx.queue;
            let bank = self.params(images);
            queue.write_buffer(&batch.bank, 0, bytemuck::bytes_of(&bank));
            for (buffer, _, stage) in &batch.forward {
                let s = Stage {
                    planes: images as u32,
                    ..*stage
                };
                queue.write_buffer(buffer, 0, bytemuck::bytes_of(&s));
            }
            for (buffer, _, stage) in &batch.inverse {
                let s = Stage {
                    planes: (images * filters) as u32,
                    ..*stage
                };
                queue.write_buffer(buffer, 0, bytemuck::bytes_of(&s));
            }
            let complex: Vec<[f32; 2]> = chunk.iter().flatten().map(|&v| [v, 0.0]).collect();
            queue.write_buffer(&batch.input, 0, bytemuck::cast_slice(&complex));
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_compute_pass(&Default::default());
                let p = ctx.pipelines::<GistFftPipelines>();
                pass.set_pipeline(&p.fft_stage);
                for (_, group, stage) in &batch.forward {
                    pass.set_bind_group(0, group, &[]);
                    pass.dispatch_workgroups(
                        (n / stage.radix as usize).div_ceil(64) as u32,
                        n as u32,
                        images as u32,
                    );
                }
                pass.set_pipeline(&p.apply_filters);
                pass.set_bind_group(0, &batch.filters_group, &[]);
                pass.dispatch_workgroups((n * n).div_ceil(64) as u32, 1, (images * filters) as u32);
                pass.set_pipeline(&p.fft_stage);
                for (_, group, stage) in &batch.inverse {
                    pass.set_bind_group(0, group, &[]);
                    pass.dispatch_workgroups(
                        (n / stage.radix as usize).div_ceil(64) as u32,
                        n as u32,
                        (images * filters) as u32,
                    );
                }
                pass.set_pipeline(&p.window_means);
                pass.set_bind_group(0, &batch.windows_group, &[]);
                pass.dispatch_workgroups((images * per).div_ceil(64) as u32, 1, 1);
            }
            let bytes = (images * per * 4) as u64;
            let data = submit_and_read(ctx, enc, &batch.windows, &batch.readback, bytes)?;
            out.extend(data.chunks(per).map(|d| d.to_vec()));
        }
        Ok(out)
    }
}

#[cfg(test)]
mod layout_tests {
    use super::*;
    use crate::gpu::layout::{check, check_as};

    #[test]
    fn shared_structs_match_the_wgsl_declarations() {
        check::<Params>(SHADERS[0].1);
        // The FFT shader reads the same parameters under the name `Bank`.
        check_as::<Params>(SHADERS[1].1, "Bank");
        check::<Stage>(SHADERS[1].1);
    }
}
