//! GPU twin of [`crate::nav::dnf::FieldBatch`]: B fields advanced by `shaders/dnf.wgsl`, one
//! workgroup per field, many Euler steps per dispatch and several dispatches per submission
//! (lavapipe stops loops past 65,535 iterations per invocation: each dispatch stays well below).

use std::sync::Arc;

use crate::gpu::layout::gpu_struct;
use crate::gpu::pipelines::single_pipeline_stage;
use crate::gpu::util::{bind, read_storage, storage, storage_init, uniform};
use crate::gpu::GpuContext;

single_pipeline_stage!(DnfPipeline, "dnf.wgsl");
use crate::error::{Error, Result};
use crate::nav::dnf::{check_stimulus, Activation, FieldConfig, Interaction};

gpu_struct! {
    struct Params as "Params" {
        neurons: u32,
        fields: u32,
        steps: u32,
        amari: u32,
        width: u32,
        sigmoid: u32,
        beta: f32,
        rate: f32,
        h: f32,
        excite: f32,
        inhibit: f32,
        groups_x: u32,
    }
}

/// Loop iterations one invocation may spend per dispatch (lavapipe's cap is 65,535).
const LOOP_BUDGET: usize = 30_000;

/// B fields on the GPU; state stays on the device between calls.
pub struct GpuFieldBatch {
    ctx: Arc<GpuContext>,
    config: FieldConfig,
    fields: usize,
    u: wgpu::Buffer,
    stimulus: wgpu::Buffer,
    params: wgpu::Buffer,
    group: wgpu::BindGroup,
    steps_per_dispatch: usize,
    groups: (u32, u32),
    base: Params,
}

impl GpuFieldBatch {
    /// B fields at rest (u = h).
    pub fn new(ctx: Arc<GpuContext>, config: FieldConfig, fields: usize) -> Result<Self> {
        config.validate()?;
        if fields == 0 {
            return Err(Error::Config {
                field: "fields",
                value: "0".into(),
                reason: "at least one field".into(),
            });
        }
        let n = config.neurons;
        if n > 1024 {
            return Err(Error::GpuLimit(format!(
                "the GPU field holds at most 1024 neurons per field (asked {n})"
            )));
        }
        let bytes = (fields * n * 4) as u64;
        if bytes > ctx.limits.max_storage_buffer_binding_size {
            return Err(Error::GpuLimit(format!(
                "{fields} fields of {n} neurons need {} MiB, over max_storage_buffer_binding_size = {} MiB",
                bytes >> 20,
                ctx.limits.max_storage_buffer_binding_size >> 20
            )));
        }
        let device = &ctx.device;
        let u = storage(device, "field", bytes);
        ctx.queue
            .write_buffer(&u, 0, bytemuck::cast_slice(&vec![config.h; fields * n]));
        let stimulus = storage(device, "stimulus", bytes);
        let kernel = storage_init(device, "kernel", &config.kernel_by_distance());
        let max_groups = ctx.limits.max_compute_workgroups_per_dimension as usize;
        let groups_x = fields.min(max_groups);
        let groups = (groups_x as u32, fields.div_ceil(groups_x) as u32);
        let (amari, width, excite, inhibit) = match config.interaction {
            Interaction::Amari {
                excite,
                inhibit,
                width,
            } => (1, width as u32, excite, inhibit),
            Interaction::GaussianDifference { .. } => (0, 0, 0.0, 0.0),
        };
        let (sigmoid, beta) = match config.activation {
            Activation::Heaviside => (0, 0.0),
            Activation::Sigmoid { beta } => (1, beta),
        };
        let per = n.div_ceil(64);
        let cost = 4 * per
            + n
            + per
                * if amari == 1 {
                    2 * width as usize + 1
                } else {
                    n
                }
            + 8;
        let base = Params {
            neurons: n as u32,
            fields: fields as u32,
            steps: 0,
            amari,
            width,
            sigmoid,
            beta,
            rate: config.dt / config.tau,
            h: config.h,
            excite,
            inhibit,
            groups_x: groups.0,
        };
        let params = uniform(device, "dnf params", &base);
        let group = bind(
            device,
            &ctx.pipelines::<DnfPipeline>().0,
            &[&params, &kernel, &stimulus, &u],
        );
        Ok(Self {
            ctx,
            config,
            fields,
            u,
            stimulus,
            params,
            group,
            steps_per_dispatch: (LOOP_BUDGET / cost).max(1),
            groups,
            base,
        })
    }

    /// Advances every field by `steps` Euler steps under `stimulus` (`fields × neurons`).
    pub fn step(&mut self, stimulus: &[f32], steps: usize) -> Result<()> {
        check_stimulus(stimulus, self.fields, self.config.neurons)?;
        let queue = &self.ctx.queue;
        queue.write_buffer(&self.stimulus, 0, bytemuck::cast_slice(stimulus));
        let mut left = steps;
        while left > 0 {
            // One submission per chunk of dispatches sharing a step count.
            let chunk = left.min(self.steps_per_dispatch);
            let dispatches = (left / chunk).clamp(1, 64);
            let params = Params {
                steps: chunk as u32,
                ..self.base
            };
            queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
            let mut enc = self.ctx.device.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_compute_pass(&Default::default());
                pass.set_pipeline(&self.ctx.pipelines::<DnfPipeline>().0);
                pass.set_bind_group(0, &self.group, &[]);
                for _ in 0..dispatches {
                    pass.dispatch_workgroups(self.groups.0, self.groups.1, 1);
                }
            }
            queue.submit([enc.finish()]);
            left -= chunk * dispatches;
        }
        Ok(())
    }

    /// Reads all fields back (`fields × neurons`).
    pub fn read(&self) -> Result<Vec<f32>> {
        let mut all = read_storage(&self.ctx.device, &self.ctx.queue, &self.u)?;
        all.truncate(self.fields * self.config.neurons);
        Ok(all)
    }
}

#[cfg(test)]
mod layout_tests {
    use super::*;

    #[test]
    fn shared_structs_match_the_wgsl_declarations() {
        crate::gpu::layout::check::<Params>(SHADERS[0].1);
    }
}
