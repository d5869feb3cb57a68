//! GPU backend of the multiscale steered Harris stage (eqs 4–8): drives
//! `shaders/harris_{convolve,products,response,nms}.wgsl`. CPU twin: `harris::cpu`. The image
//! pyramid of the octaves is built on the device with the convolution shader at step 2 (twin:
//! `features::pyramid`), inside the first filter-bank pass.
//!
//! Per frame: one upload of the luminance plane, every scale's passes recorded into one command
//! encoder, one submission, then a readback of the candidate counter followed by exactly the
//! surviving candidates. Buffers and bind groups are built once per image size and reused.

use std::sync::{Arc, Mutex};

use crate::error::{Error, Result};
use crate::features::harris::plan::Tile;
use crate::features::harris::ResponseStack;
use crate::features::{harris::HarrisPlan, steerable::Kernel1d};
use crate::features::{raised_threshold, sort_candidates, Candidate};
use crate::gpu::layout::gpu_struct;
use crate::gpu::util::{groups_2d, storage_init};
use crate::gpu::GpuContext;

mod encode;
mod flight;
mod pipelines;
mod resources;

use flight::{HarrisResult, ReadbackLayout, READBACK_CANDIDATES, SYNC_SLOT};
pub use flight::{PendingFrame, FLIGHT_SLOTS};

pub(crate) use pipelines::HarrisPipelines;
pub use pipelines::SHADERS;

gpu_struct! {
    struct Dims as "Dims" {
        src_width: u32,
        src_height: u32,
        dst_width: u32,
        dst_height: u32,
        step: u32,
        src_plane: u32,
        dst_plane: u32,
        _pad: u32,
    }
}

impl Dims {
    /// A pass from a `w`×`h` plane; `rows` subsamples x by `step`, otherwise y.
    fn pass(w: u32, h: u32, step: u32, rows: bool) -> Self {
        let (dw, dh) = if rows {
            (w.div_ceil(step), h)
        } else {
            (w, h.div_ceil(step))
        };
        Self {
            src_width: w,
            src_height: h,
            dst_width: dw,
            dst_height: dh,
            step,
            src_plane: w * h,
            dst_plane: dw * dh,
            _pad: 0,
        }
    }
}

gpu_struct! {
    struct ProductParams as "Params" {
        width: u32,
        height: u32,
        plane: u32,
        count: u32,
    }
}

gpu_struct! {
    struct Job as "Job" {
        src: u32,
        dst: u32,
        taps: u32,
        radius: u32,
    }
}

gpu_struct! {
    struct ResponseParams as "Params" {
        width: u32,
        height: u32,
        plane: u32,
        products: u32,
        orientations: u32,
        k: f32,
        _pad0: u32,
        _pad1: u32,
    }
}

gpu_struct! {
    struct NmsParams as "Params" {
        width: u32,
        height: u32,
        plane: u32,
        orientations: u32,
        scale: u32,
        has_prev: u32,
        has_next: u32,
        margin: u32,
        step: u32,
        prev_width: u32,
        prev_height: u32,
        prev_step: u32,
        next_width: u32,
        next_height: u32,
        next_step: u32,
        _pad: u32,
    }
}

gpu_struct! {
    struct NmsSettings as "Settings" {
        threshold: f32,
        capacity: u32,
        relative: f32,
        _pad: u32,
        core_x0: u32,
        core_y0: u32,
        core_x1: u32,
        core_y1: u32,
        origin_x: u32,
        origin_y: u32,
        _pad1: u32,
        _pad2: u32,
    }
}

gpu_struct! {
    /// The candidate count and the bits of the strongest response (both u32 atomics).
    struct Stats as "Stats" {
        count: u32,
        peak_bits: u32,
    }
}

/// Offset and radius of one kernel in the taps buffer.
#[derive(Clone, Copy)]
struct TapRef {
    offset: u32,
    radius: u32,
}

/// GPU time per stage, summed over scales, from timestamp queries (absent without support).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GpuTimings {
    /// Steered-gradient basis (derivative filters).
    pub filter_bank_ms: f64,
    /// Products and their window blur (structure tensor, eq 7).
    pub structure_tensor_ms: f64,
    /// Harris responses for all orientations (eq 8).
    pub response_ms: f64,
    /// Non-maximum suppression and compaction.
    pub nms_ms: f64,
}

/// Bind groups of one pyramid decimation (level l into level l + 1).
struct PyramidGroups {
    column_groups: (u32, u32),
    row_groups: (u32, u32),
    columns: wgpu::BindGroup,
    rows: wgpu::BindGroup,
}

/// Bind groups and job counts of one scale.
struct ScaleGroups {
    /// Workgroups covering the derivative column pass's output (full width, grid rows) and
    /// the scale's grid.
    column_groups: (u32, u32),
    grid_groups: (u32, u32),
    derivative_columns: wgpu::BindGroup,
    derivative_rows: wgpu::BindGroup,
    products: wgpu::BindGroup,
    blur_columns: wgpu::BindGroup,
    blur_rows: wgpu::BindGroup,
    response: wgpu::BindGroup,
    nms: wgpu::BindGroup,
}

/// Everything allocated for one image size.
struct FrameResources {
    width: u32,
    height: u32,
    gray: wgpu::Buffer,
    /// Pyramid levels 1, 2, … (level 0 is `gray`), kept alive for the bind groups.
    _levels: Vec<wgpu::Buffer>,
    pyramid: Vec<PyramidGroups>,
    derivatives: wgpu::Buffer,
    responses: Vec<wgpu::Buffer>,
    nms_settings: wgpu::Buffer,
    counter: wgpu::Buffer,
    candidates: wgpu::Buffer,
    /// The frame's one readback: the count and the strongest response, the timestamps, and
    /// the first `readback_candidates` candidates (see [`ReadbackLayout`]).
    readback: wgpu::Buffer,
    layout: ReadbackLayout,
    /// Candidates past `readback_candidates`, read only when that many survive.
    candidate_staging: wgpu::Buffer,
    queries: Option<(wgpu::QuerySet, wgpu::Buffer)>,
    /// Which in-flight slot these buffers belong to (see [`GpuHarris::submit`]).
    slot: usize,
    scales: Vec<ScaleGroups>,
}

/// Number of image sizes whose buffers are kept at once.
/// Frame resources kept at once: a tiled frame has interior, right, bottom and corner tile
/// sizes, and in-flight frames their own slots.
const CACHED_SIZES: usize = 6;

/// The GPU Harris stage for one plan; safe to share between threads (frames are serialised).
pub struct GpuHarris {
    ctx: Arc<GpuContext>,
    plan: HarrisPlan,
    taps: wgpu::Buffer,
    weights: wgpu::Buffer,
    derivative_columns: Vec<Vec<TapRef>>,
    derivative_rows: Vec<Vec<TapRef>>,
    windows: Vec<TapRef>,
    pyramid_kernels: Vec<TapRef>,
    frames: Mutex<Vec<FrameResources>>,
    /// Which in-flight slots hold a submitted frame not finished yet.
    busy: Mutex<[bool; FLIGHT_SLOTS]>,
    /// Held by a synchronous run from its upload to its readback: the synchronous slot is one
    /// set of resources, and `frames` is released between the submission and the wait.
    sync_slot: Mutex<()>,
}

impl GpuHarris {
    /// Uploads the plan's kernels and weights.
    pub fn new(ctx: Arc<GpuContext>, plan: HarrisPlan) -> Self {
        let mut taps: Vec<f32> = Vec::new();
        let mut push = |k: &Kernel1d| {
            let r = TapRef {
                offset: taps.len() as u32,
                radius: k.radius() as u32,
            };
            taps.extend(&k.taps);
            r
        };
        let mut derivative_columns = Vec::new();
        let mut derivative_rows = Vec::new();
        let mut windows = Vec::new();
        for s in &plan.scales {
            derivative_columns.push(s.derivatives.iter().map(|f| push(&f.column)).collect());
            derivative_rows.push(s.derivatives.iter().map(|f| push(&f.row)).collect());
            windows.push(push(&s.window));
        }
        let pyramid_kernels = plan.pyramid.iter().map(&mut push).collect();
        let device = &ctx.device;
        let taps = storage_init(device, "taps", &taps);
        let weights = storage_init(device, "tensor weights", &plan.tensor_weights);
        Self {
            ctx,
            plan,
            taps,
            weights,
            derivative_columns,
            derivative_rows,
            windows,
            pyramid_kernels,
            frames: Mutex::new(Vec::new()),
            busy: Mutex::new([false; FLIGHT_SLOTS]),
            sync_slot: Mutex::new(()),
        }
    }

    /// The context this stage runs on.
    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    /// Checks that a `width`×`height` frame can run, in tiles if need be (allocating
    /// nothing); the error names the limit when not even a tile fits.
    pub fn check_frame(&self, width: u32, height: u32) -> Result<()> {
        self.tiles(width, height).map(|_| ())
    }

    /// Checks that a `width`×`height` frame fits the device's limits untiled, naming the
    /// limit if not.
    pub fn check_fits(&self, width: u32, height: u32) -> Result<()> {
        let plane = width as u64 * height as u64 * 4;
        let planes = [
            (
                "orientation responses of one scale",
                self.plan.orientations.len() as u64,
            ),
            (
                "blurred structure-tensor products",
                self.plan.products.len() as u64,
            ),
        ];
        let limits = &self.ctx.limits;
        for (what, count) in planes {
            let need = plane * count;
            if need > limits.max_storage_buffer_binding_size || need > limits.max_buffer_size {
                return Err(Error::GpuLimit(format!(
                    "a {width}x{height} image needs {} MiB for the {what} ({count} planes), but this \
                     device ({}) allows max_storage_buffer_binding_size = {} MiB and \
                     max_buffer_size = {} MiB; use --backend cpu or a smaller image",
                    need >> 20,
                    self.ctx.info.name,
                    limits.max_storage_buffer_binding_size >> 20,
                    limits.max_buffer_size >> 20
                )));
            }
        }
        let max_groups = limits.max_compute_workgroups_per_dimension;
        let (gx, gy) = groups_2d(width, height);
        if gx > max_groups || gy > max_groups {
            return Err(Error::GpuLimit(format!(
                "a {width}x{height} image needs {gx}x{gy} workgroups, over this device's \
                 max_compute_workgroups_per_dimension = {max_groups}"
            )));
        }
        Ok(())
    }

    /// The tiles of a `width`×`height` frame on this device ([`HarrisPlan::tiles`]).
    fn tiles(&self, width: u32, height: u32) -> Result<Vec<Tile>> {
        // The largest square tile whose planes fit the binding and buffer limits and whose
        // workgroups fit a dispatch.
        let limits = &self.ctx.limits;
        let planes = self.plan.orientations.len().max(self.plan.products.len()) as u64;
        let bytes = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let by_memory = ((bytes / (4 * planes)) as f64).sqrt() as u64;
        let by_groups = limits.max_compute_workgroups_per_dimension as u64 * 16;
        let largest = by_memory.min(by_groups).min(u32::MAX as u64) as u32;
        self.plan
            .tiles(width, height, largest, |w, h| self.check_fits(w, h))
    }

    /// Runs the whole stage on a luminance plane: candidates sorted strongest first, the
    /// threshold finally used, and per-stage GPU timings (summed over tiles).
    ///
    /// A frame past the device's limits, or any frame when `gpu_tile_size` is set, runs in
    /// overlapping tiles (see [`HarrisPlan::tile_halo`]); each tile reports the candidates of its
    /// core in image coordinates, and the relative threshold and the capacity rule are then
    /// applied to the union with the frame's strongest response: the same candidates as an
    /// untiled run, unless a single tile overflowed the capacity.
    pub fn candidates(
        &self,
        gray: &[f32],
        width: u32,
        height: u32,
    ) -> Result<(Vec<Candidate>, f32, Option<GpuTimings>)> {
        let tiles = self.tiles(width, height)?;
        self.run_tiles(gray, width, &tiles)
    }

    /// The whole stage over `tiles` of a frame `width` pixels wide (one tile: the frame).
    fn run_tiles(&self, gray: &[f32], width: u32, tiles: &[Tile]) -> Result<HarrisResult> {
        if let [tile] = tiles {
            let run = self.run_tile(gray, tile)?;
            let mut list = run.candidates;
            sort_candidates(&mut list);
            return Ok((list, run.threshold, run.timings));
        }
        let config = &self.plan.config;
        let mut pixels = Vec::new();
        let mut found = Vec::new();
        let (mut strongest, mut overflowed_at) = (0.0f32, f32::NEG_INFINITY);
        let mut timings: Option<GpuTimings> = None;
        for tile in tiles {
            let (tw, th) = (tile.size.0 as usize, tile.size.1 as usize);
            pixels.clear();
            for y in 0..th {
                let start = (tile.origin.1 as usize + y) * width as usize + tile.origin.0 as usize;
                pixels.extend_from_slice(&gray[start..start + tw]);
            }
            let run = self.run_tile(&pixels, tile)?;
            strongest = strongest.max(run.strongest);
            overflowed_at = overflowed_at.max(run.overflowed_at);
            found.extend(run.candidates);
            if let Some(t) = run.timings {
                let sum = timings.get_or_insert_with(GpuTimings::default);
                sum.filter_bank_ms += t.filter_bank_ms;
                sum.structure_tensor_ms += t.structure_tensor_ms;
                sum.response_ms += t.response_ms;
                sum.nms_ms += t.nms_ms;
            }
        }
        let mut threshold = config.effective_threshold(strongest);
        let capacity = config.candidate_capacity;
        while threshold <= overflowed_at
            || found.iter().filter(|c| c.response > threshold).count() > capacity
        {
            threshold = raised_threshold(threshold);
        }
        found.retain(|c| c.response > threshold);
        sort_candidates(&mut found);
        Ok((found, threshold, timings))
    }

    fn timings(&self, raw: &[u8]) -> GpuTimings {
        let stamps: Vec<u64> = bytemuck::pod_collect_to_vec(raw);
        let period = self.ctx.queue.get_timestamp_period() as f64 * 1e-6;
        let mut t = GpuTimings::default();
        for s in 0..self.plan.scales.len() {
            let span = |i: usize| {
                stamps[8 * s + 2 * i + 1].saturating_sub(stamps[8 * s + 2 * i]) as f64 * period
            };
            t.filter_bank_ms += span(0);
            t.structure_tensor_ms += span(1);
            t.response_ms += span(2);
            t.nms_ms += span(3);
        }
        t
    }

    /// The scale-normalised derivative planes D_k of scale `s` (parity tests, inspection).
    pub fn derivatives(
        &self,
        gray: &[f32],
        width: u32,
        height: u32,
        s: usize,
    ) -> Result<Vec<Vec<f32>>> {
        let mut frames = self.frames.lock().unwrap_or_else(|e| e.into_inner());
        let f = self.select_frame(&mut frames, width, height, SYNC_SLOT)?;
        self.upload(f, gray);
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_responses(&mut enc, f, s, true);
        self.ctx.queue.submit([enc.finish()]);
        let all =
            crate::gpu::util::read_storage(&self.ctx.device, &self.ctx.queue, &f.derivatives)?;
        let (gw, gh) = self.plan.scales[s].grid(width as usize, height as usize);
        Ok(all
            .chunks(gw * gh)
            .take(self.plan.derivative_count())
            .map(<[f32]>::to_vec)
            .collect())
    }

    /// Harris responses of every scale and orientation (parity tests, inspection).
    pub fn responses(&self, gray: &[f32], width: u32, height: u32) -> Result<ResponseStack> {
        let mut frames = self.frames.lock().unwrap_or_else(|e| e.into_inner());
        let f = self.select_frame(&mut frames, width, height, SYNC_SLOT)?;
        self.upload(f, gray);
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_responses(&mut enc, f, self.plan.scales.len() - 1, false);
        self.ctx.queue.submit([enc.finish()]);
        let responses = f
            .responses
            .iter()
            .map(|b| crate::gpu::util::read_storage(&self.ctx.device, &self.ctx.queue, b))
            .collect::<Result<Vec<_>>>()?;
        Ok(ResponseStack {
            responses,
            grids: self.plan.grids(width as usize, height as usize),
        })
    }
}

#[cfg(test)]
mod layout_tests {
    use super::*;
    use crate::gpu::layout::check;

    #[test]
    fn shared_structs_match_the_wgsl_declarations() {
        let [convolve, products, response, nms] = SHADERS.map(|(_, source)| source);
        check::<Dims>(convolve);
        check::<Job>(convolve);
        check::<ProductParams>(products);
        check::<ResponseParams>(response);
        check::<NmsParams>(nms);
        check::<NmsSettings>(nms);
        check::<Stats>(nms);
        check::<Candidate>(nms);
    }
}
