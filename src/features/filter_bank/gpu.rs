//! GPU steerable filter bank (eqs 3–4): basis responses by `harris_convolve.wgsl`, steering by
//! `filter_bank_steer.wgsl`. CPU twin: [`super::cpu`]. An inspection API: it allocates
//! per call, unlike the detector's per-size cache.

use std::sync::Arc;

use crate::features::harris::gpu::HarrisPipelines;
use crate::gpu::layout::gpu_struct;
use crate::gpu::pipelines::single_pipeline_stage;
use crate::gpu::util::{bind, groups_2d, read_storage, storage, storage_init, uniform};
use crate::gpu::GpuContext;

// The separable passes are Harris's.
single_pipeline_stage!(SteerPipeline, "filter_bank_steer.wgsl");
use super::basis_filters;
use crate::error::Result;
use crate::features::filter_bank::steering_table;
use crate::features::DetectorConfig;

gpu_struct! {
    struct SteerParams as "Params" {
        width: u32,
        height: u32,
        plane: u32,
        basis: u32,
        orientations: u32,
        _pad0: u32,
        _pad1: u32,
        _pad2: u32,
    }
}

/// The N steered images F(θ_n) computed on the GPU.
pub fn steered_images(
    ctx: &Arc<GpuContext>,
    config: &DetectorConfig,
    gray: &[f32],
    width: u32,
    height: u32,
) -> Result<Vec<Vec<f32>>> {
    let device = &ctx.device;
    let harris = ctx.pipelines::<HarrisPipelines>();
    let steer = ctx.pipelines::<SteerPipeline>();
    let plane = width * height;
    let filters = basis_filters(config);
    let b = filters.len() as u32;
    let n = config.orientations as u32;
    let mut taps: Vec<f32> = Vec::new();
    let mut col_jobs = Vec::new();
    let mut row_jobs = Vec::new();
    for (i, f) in filters.iter().enumerate() {
        col_jobs.push([0u32, i as u32, taps.len() as u32, f.column.radius() as u32]);
        taps.extend(&f.column.taps);
        row_jobs.push([i as u32, i as u32, taps.len() as u32, f.row.radius() as u32]);
        taps.extend(&f.row.taps);
    }
    let taps = storage_init(device, "basis taps", &taps);
    let col_jobs = storage_init(device, "basis column jobs", &col_jobs);
    let row_jobs = storage_init(device, "basis row jobs", &row_jobs);
    // The convolve shader's Dims: a full-resolution pass (step 1).
    let dims = uniform(
        device,
        "dims",
        &[width, height, width, height, 1, plane, plane, 0u32],
    );
    let gray_buf = storage_init(device, "gray", gray);
    let tmp = storage(device, "column pass", plane as u64 * 4 * b as u64);
    let basis = storage(device, "basis", plane as u64 * 4 * b as u64);
    let steered = storage(device, "steered", plane as u64 * 4 * n as u64);
    let coefs = storage_init(device, "steering", &steering_table(config));
    let params = uniform(
        device,
        "steer",
        &SteerParams {
            width,
            height,
            plane,
            basis: b,
            orientations: n,
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        },
    );
    let g_cols = bind(
        device,
        &harris.convolve_columns,
        &[&dims, &col_jobs, &taps, &gray_buf, &tmp],
    );
    let g_rows = bind(
        device,
        &harris.convolve_rows,
        &[&dims, &row_jobs, &taps, &tmp, &basis],
    );
    let g_steer = bind(device, &steer.0, &[&params, &coefs, &basis, &steered]);
    let (gx, gy) = groups_2d(width, height);
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&harris.convolve_columns);
        pass.set_bind_group(0, &g_cols, &[]);
        pass.dispatch_workgroups(gx, gy, b);
        pass.set_pipeline(&harris.convolve_rows);
        pass.set_bind_group(0, &g_rows, &[]);
        pass.dispatch_workgroups(gx, gy, b);
        pass.set_pipeline(&steer.0);
        pass.set_bind_group(0, &g_steer, &[]);
        pass.dispatch_workgroups(gx, gy, 1);
    }
    ctx.queue.submit([enc.finish()]);
    let all = read_storage(device, &ctx.queue, &steered)?;
    Ok(all.chunks(plane as usize).map(<[f32]>::to_vec).collect())
}

#[cfg(test)]
mod layout_tests {
    use super::*;

    #[test]
    fn shared_structs_match_the_wgsl_declarations() {
        crate::gpu::layout::check::<SteerParams>(SHADERS[0].1);
    }
}
