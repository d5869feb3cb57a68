//! Recording a frame's passes: the responses of each scale (eqs 5–8), the suppression, the
//! upload and the threshold.

use crate::features::harris::plan::Tile;

use super::*;

impl GpuHarris {
    /// Records the filter, tensor and response passes of every scale (up to scale `last`,
    /// stopping after the derivative passes of `last` when `derivatives_only`).
    pub(super) fn encode_responses(
        &self,
        enc: &mut wgpu::CommandEncoder,
        f: &FrameResources,
        last: usize,
        derivatives_only: bool,
    ) {
        let pipes = self.ctx.pipelines::<HarrisPipelines>();
        let count = self.plan.derivative_count() as u32;
        let products = self.plan.products.len() as u32;
        // The strongest response starts at 0 (bits of +0.0).
        enc.clear_buffer(&f.counter, 4, Some(4));
        for (s, g) in f.scales.iter().enumerate().take(last + 1) {
            let stamp = |i: u32| {
                f.queries
                    .as_ref()
                    .map(|(set, _)| wgpu::ComputePassTimestampWrites {
                        query_set: set,
                        beginning_of_pass_write_index: Some(8 * s as u32 + 2 * i),
                        end_of_pass_write_index: Some(8 * s as u32 + 2 * i + 1),
                    })
            };
            let (gx, gy) = g.grid_groups;
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("filter bank"),
                    timestamp_writes: stamp(0),
                });
                if s == 0 {
                    // The pyramid first, inside the first filter-bank pass (its time counts
                    // there); dispatches in one pass see each other's writes.
                    for p in &f.pyramid {
                        pass.set_pipeline(&pipes.convolve_columns);
                        pass.set_bind_group(0, &p.columns, &[]);
                        pass.dispatch_workgroups(p.column_groups.0, p.column_groups.1, 1);
                        pass.set_pipeline(&pipes.convolve_rows);
                        pass.set_bind_group(0, &p.rows, &[]);
                        pass.dispatch_workgroups(p.row_groups.0, p.row_groups.1, 1);
                    }
                }
                pass.set_pipeline(&pipes.convolve_columns);
                pass.set_bind_group(0, &g.derivative_columns, &[]);
                pass.dispatch_workgroups(g.column_groups.0, g.column_groups.1, count);
                pass.set_pipeline(&pipes.convolve_rows);
                pass.set_bind_group(0, &g.derivative_rows, &[]);
                pass.dispatch_workgroups(gx, gy, count);
            }
            if derivatives_only && s == last {
                return;
            }
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("structure tensor"),
                    timestamp_writes: stamp(1),
                });
                pass.set_pipeline(&pipes.products);
                pass.set_bind_group(0, &g.products, &[]);
                pass.dispatch_workgroups(gx, gy, 1);
                pass.set_pipeline(&pipes.convolve_columns);
                pass.set_bind_group(0, &g.blur_columns, &[]);
                pass.dispatch_workgroups(gx, gy, products);
                pass.set_pipeline(&pipes.convolve_rows);
                pass.set_bind_group(0, &g.blur_rows, &[]);
                pass.dispatch_workgroups(gx, gy, products);
            }
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("response"),
                timestamp_writes: stamp(2),
            });
            pass.set_pipeline(&pipes.response);
            pass.set_bind_group(0, &g.response, &[]);
            pass.dispatch_workgroups(g.grid_groups.0, g.grid_groups.1, 1);
        }
    }

    pub(super) fn encode_nms(&self, enc: &mut wgpu::CommandEncoder, f: &FrameResources) {
        let pipes = self.ctx.pipelines::<HarrisPipelines>();
        enc.clear_buffer(&f.counter, 0, Some(4));
        for (s, g) in f.scales.iter().enumerate() {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("nms"),
                timestamp_writes: f.queries.as_ref().map(|(set, _)| {
                    wgpu::ComputePassTimestampWrites {
                        query_set: set,
                        beginning_of_pass_write_index: Some(8 * s as u32 + 6),
                        end_of_pass_write_index: Some(8 * s as u32 + 7),
                    }
                }),
            });
            pass.set_pipeline(&pipes.nms);
            pass.set_bind_group(0, &g.nms, &[]);
            pass.dispatch_workgroups(g.grid_groups.0, g.grid_groups.1, 1);
        }
        // The count and the first candidates go to the readback with one map: most frames
        // need nothing more.
        let l = &f.layout;
        enc.copy_buffer_to_buffer(&f.counter, 0, &f.readback, 0, Some(8));
        enc.copy_buffer_to_buffer(
            &f.candidates,
            0,
            &f.readback,
            l.candidates_at,
            Some(l.candidates * 16),
        );
    }

    pub(super) fn upload(&self, f: &FrameResources, gray: &[f32]) {
        self.ctx
            .queue
            .write_buffer(&f.gray, 0, bytemuck::cast_slice(gray));
    }

    /// Sets the suppression's threshold, max(threshold, relative × strongest response), and
    /// the core (x0, y0, x1, y1) whose samples may become candidates.
    pub(super) fn set_threshold(
        &self,
        f: &FrameResources,
        threshold: f32,
        relative: f32,
        tile: &Tile,
    ) {
        let core = tile.core;
        let settings = NmsSettings {
            threshold,
            capacity: self.plan.config.candidate_capacity as u32,
            relative,
            _pad: 0,
            core_x0: core[0],
            core_y0: core[1],
            core_x1: core[2],
            core_y1: core[3],
            origin_x: tile.origin.0,
            origin_y: tile.origin.1,
            _pad1: 0,
            _pad2: 0,
        };
        self.ctx
            .queue
            .write_buffer(&f.nms_settings, 0, bytemuck::bytes_of(&settings));
    }
}
