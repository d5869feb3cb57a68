//! The buffers and bind groups of one frame size and slot, built once and cached: the
//! luminance plane, the pyramid's levels, every scale's derivative planes, products,
//! responses and the candidate list.

use crate::error::Result;
use crate::gpu::util::{bind, groups_2d, staging, storage, storage_init, uniform};

use super::*;

impl GpuHarris {
    /// Finds (or allocates) the buffers of a frame size and slot and moves them to the front
    /// of the cache. Beyond [`CACHED_SIZES`] entries the least recently used one whose slot is
    /// not in flight is dropped.
    pub(super) fn select_frame<'a>(
        &self,
        frames: &'a mut Vec<FrameResources>,
        width: u32,
        height: u32,
        slot: usize,
    ) -> Result<&'a FrameResources> {
        if let Some(i) = frames
            .iter()
            .position(|f| f.width == width && f.height == height && f.slot == slot)
        {
            let f = frames.remove(i);
            frames.insert(0, f);
        } else {
            self.check_fits(width, height)?;
            let f = self.allocate(width, height, slot);
            frames.insert(0, f);
            let busy = *self.busy.lock().unwrap_or_else(|e| e.into_inner());
            while frames.len() > CACHED_SIZES {
                let idle = frames
                    .iter()
                    .rposition(|f| f.slot >= FLIGHT_SLOTS || !busy[f.slot]);
                match idle {
                    Some(i) if i > 0 => drop(frames.remove(i)),
                    _ => break,
                }
            }
        }
        Ok(&frames[0])
    }

    pub(super) fn allocate(&self, width: u32, height: u32, slot: usize) -> FrameResources {
        let device = &self.ctx.device;
        let pipes = self.ctx.pipelines::<HarrisPipelines>();
        let plan = &self.plan;
        let plane = width as u64 * height as u64;
        let count = plan.derivative_count();
        let products = plan.products.len();
        let n = plan.orientations.len();
        let gray = storage(device, "gray", plane * 4);
        let tmp = storage(
            device,
            "column pass",
            plane * 4 * count.max(products) as u64,
        );
        let derivatives = storage(device, "derivatives", plane * 4 * count as u64);
        let (w, h) = (width as usize, height as usize);
        let level_dims = |l: u32| {
            let (lw, lh) = crate::features::harris::plan::level_size(w, h, l);
            (lw as u32, lh as u32)
        };
        let (levels, pyramid) = self.pyramid_resources(width, height, &gray, &tmp);
        let level_buffer = |l: u32| {
            if l == 0 {
                &gray
            } else {
                &levels[l as usize - 1]
            }
        };
        let prod = storage(device, "products", plane * 4 * products as u64);
        let grids: Vec<(u32, u32)> = plan
            .grids(width as usize, height as usize)
            .into_iter()
            .map(|(gw, gh)| (gw as u32, gh as u32))
            .collect();
        let responses: Vec<_> = grids
            .iter()
            .map(|&(gw, gh)| storage(device, "responses", (gw * gh) as u64 * 4 * n as u64))
            .collect();
        let capacity = plan.config.candidate_capacity as u64;
        let counter = storage(device, "count and strongest response", 8);
        let candidates = storage(device, "candidates", capacity * 16);
        let queries = self.ctx.timestamps.then(|| {
            let count = 8 * plan.scales.len() as u32;
            let set = device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("stage timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count,
            });
            let resolve = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size: count as u64 * 8,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            (set, resolve)
        });
        let layout = ReadbackLayout::new(
            queries.as_ref().map_or(0, |(_, r)| r.size()),
            capacity.min(READBACK_CANDIDATES),
        );
        let readback = staging(device, "count, timestamps and candidates", layout.size());
        let candidate_staging = staging(
            device,
            "candidate overflow readback",
            (capacity - layout.candidates) * 16,
        );
        let nms_settings = uniform(
            device,
            "nms settings",
            &NmsSettings {
                threshold: plan.config.threshold,
                capacity: capacity as u32,
                relative: plan.config.relative_threshold,
                _pad: 0,
                core_x0: 0,
                core_y0: 0,
                core_x1: width,
                core_y1: height,
                origin_x: 0,
                origin_y: 0,
                _pad1: 0,
                _pad2: 0,
            },
        );
        let jobs = |label: &str, list: Vec<Job>| storage_init(device, label, &list);
        let scales = (0..plan.scales.len())
            .map(|s| {
                let dc = jobs(
                    "derivative column jobs",
                    self.derivative_columns[s]
                        .iter()
                        .enumerate()
                        .map(|(k, t)| Job {
                            src: 0,
                            dst: k as u32,
                            taps: t.offset,
                            radius: t.radius,
                        })
                        .collect(),
                );
                let dr = jobs(
                    "derivative row jobs",
                    self.derivative_rows[s]
                        .iter()
                        .enumerate()
                        .map(|(k, t)| Job {
                            src: k as u32,
                            dst: k as u32,
                            taps: t.offset,
                            radius: t.radius,
                        })
                        .collect(),
                );
                let w = self.windows[s];
                let blur = jobs(
                    "blur jobs",
                    (0..products as u32)
                        .map(|p| Job {
                            src: p,
                            dst: p,
                            taps: w.offset,
                            radius: w.radius,
                        })
                        .collect(),
                );
                let step = plan.scales[s].step;
                let level_step = plan.scales[s].level_step();
                let level = plan.scales[s].level;
                let (lw, lh) = level_dims(level);
                let (gw, gh) = grids[s];
                let (ps, ns) = (s.saturating_sub(1), (s + 1).min(plan.scales.len() - 1));
                // Derivatives sampled on the grid from the scale's pyramid level: columns at
                // the level's rows of the grid, then rows at its columns; products and window
                // blur on the grid.
                let column_dims = Dims::pass(lw, lh, level_step, false);
                let derivative_column_dims =
                    uniform(device, "derivative column dims", &column_dims);
                let derivative_row_dims = uniform(
                    device,
                    "derivative row dims",
                    &Dims::pass(lw, gh, level_step, true),
                );
                let blur_column_dims =
                    uniform(device, "blur column dims", &Dims::pass(gw, gh, 1, false));
                let blur_row_dims = uniform(device, "blur row dims", &Dims::pass(gw, gh, 1, true));
                let product_params = uniform(
                    device,
                    "products",
                    &ProductParams {
                        width: gw,
                        height: gh,
                        plane: gw * gh,
                        count: count as u32,
                    },
                );
                let response_params = uniform(
                    device,
                    "response",
                    &ResponseParams {
                        width: gw,
                        height: gh,
                        plane: gw * gh,
                        products: products as u32,
                        orientations: n as u32,
                        k: plan.config.harris_k,
                        _pad0: 0,
                        _pad1: 0,
                    },
                );
                let nms_params = uniform(
                    device,
                    "nms",
                    &NmsParams {
                        width: gw,
                        height: gh,
                        plane: gw * gh,
                        orientations: n as u32,
                        scale: s as u32,
                        has_prev: (s > 0) as u32,
                        has_next: (s + 1 < plan.scales.len()) as u32,
                        margin: plan.scales[s].grid_margin() as u32,
                        step,
                        prev_width: grids[ps].0,
                        prev_height: grids[ps].1,
                        prev_step: plan.scales[ps].step,
                        next_width: grids[ns].0,
                        next_height: grids[ns].1,
                        next_step: plan.scales[ns].step,
                        _pad: 0,
                    },
                );
                let prev = &responses[s.saturating_sub(1)];
                let next = &responses[(s + 1).min(plan.scales.len() - 1)];
                ScaleGroups {
                    column_groups: groups_2d(lw, column_dims.dst_height),
                    grid_groups: groups_2d(gw, gh),
                    derivative_columns: bind(
                        device,
                        &pipes.convolve_columns,
                        &[
                            &derivative_column_dims,
                            &dc,
                            &self.taps,
                            level_buffer(level),
                            &tmp,
                        ],
                    ),
                    derivative_rows: bind(
                        device,
                        &pipes.convolve_rows,
                        &[&derivative_row_dims, &dr, &self.taps, &tmp, &derivatives],
                    ),
                    products: bind(
                        device,
                        &pipes.products,
                        &[&product_params, &derivatives, &prod],
                    ),
                    blur_columns: bind(
                        device,
                        &pipes.convolve_columns,
                        &[&blur_column_dims, &blur, &self.taps, &prod, &tmp],
                    ),
                    blur_rows: bind(
                        device,
                        &pipes.convolve_rows,
                        &[&blur_row_dims, &blur, &self.taps, &tmp, &prod],
                    ),
                    response: bind(
                        device,
                        &pipes.response,
                        &[
                            &response_params,
                            &self.weights,
                            &prod,
                            &responses[s],
                            &counter,
                        ],
                    ),
                    nms: bind(
                        device,
                        &pipes.nms,
                        &[
                            &nms_params,
                            &nms_settings,
                            prev,
                            &responses[s],
                            next,
                            &counter,
                            &candidates,
                        ],
                    ),
                }
            })
            .collect();
        FrameResources {
            width,
            height,
            gray,
            _levels: levels,
            pyramid,
            derivatives,
            responses,
            nms_settings,
            counter,
            candidates,
            readback,
            layout,
            candidate_staging,
            queries,
            slot,
            scales,
        }
    }

    /// The pyramid levels above `gray` (a `width`×`height` plane) and the bind groups that
    /// build them: level l into level l + 1, blurred columns at every second row into `tmp`,
    /// then blurred rows at every second column into the next level.
    pub(super) fn pyramid_resources(
        &self,
        width: u32,
        height: u32,
        gray: &wgpu::Buffer,
        tmp: &wgpu::Buffer,
    ) -> (Vec<wgpu::Buffer>, Vec<PyramidGroups>) {
        let device = &self.ctx.device;
        let pipes = self.ctx.pipelines::<HarrisPipelines>();
        let level_dims = |l: u32| {
            let (lw, lh) =
                crate::features::harris::plan::level_size(width as usize, height as usize, l);
            (lw as u32, lh as u32)
        };
        let levels: Vec<wgpu::Buffer> = (1..self.plan.levels() as u32)
            .map(|l| {
                let (lw, lh) = level_dims(l);
                storage(device, "pyramid level", lw as u64 * lh as u64 * 4)
            })
            .collect();
        let level_buffer = |l: u32| {
            if l == 0 {
                gray
            } else {
                &levels[l as usize - 1]
            }
        };
        let groups = self
            .pyramid_kernels
            .iter()
            .enumerate()
            .map(|(l, k)| {
                let (lw, lh) = level_dims(l as u32);
                let columns = Dims::pass(lw, lh, 2, false);
                let rows = Dims::pass(lw, columns.dst_height, 2, true);
                let job = storage_init(
                    device,
                    "pyramid job",
                    &[Job {
                        src: 0,
                        dst: 0,
                        taps: k.offset,
                        radius: k.radius,
                    }],
                );
                PyramidGroups {
                    column_groups: groups_2d(lw, columns.dst_height),
                    row_groups: groups_2d(rows.dst_width, rows.dst_height),
                    columns: bind(
                        device,
                        &pipes.convolve_columns,
                        &[
                            &uniform(device, "pyramid column dims", &columns),
                            &job,
                            &self.taps,
                            level_buffer(l as u32),
                            tmp,
                        ],
                    ),
                    rows: bind(
                        device,
                        &pipes.convolve_rows,
                        &[
                            &uniform(device, "pyramid row dims", &rows),
                            &job,
                            &self.taps,
                            tmp,
                            level_buffer(l as u32 + 1),
                        ],
                    ),
                }
            })
            .collect();
        (levels, groups)
    }
}
