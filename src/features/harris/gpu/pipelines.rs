//! The Harris stage's shaders and the pipelines built from them, once per device.

use crate::gpu::pipelines::{compute_pipeline, shader_module, PipelineSet};

/// The stage's WGSL sources with their file names.
pub const SHADERS: [(&str, &str); 4] = [
    (
        "harris_convolve.wgsl",
        include_str!("../../../../shaders/harris_convolve.wgsl"),
    ),
    (
        "harris_products.wgsl",
        include_str!("../../../../shaders/harris_products.wgsl"),
    ),
    (
        "harris_response.wgsl",
        include_str!("../../../../shaders/harris_response.wgsl"),
    ),
    (
        "harris_nms.wgsl",
        include_str!("../../../../shaders/harris_nms.wgsl"),
    ),
];

/// The Harris stage's pipelines (the filter bank reuses the convolution).
pub(crate) struct HarrisPipelines {
    pub(crate) convolve_columns: wgpu::ComputePipeline,
    pub(crate) convolve_rows: wgpu::ComputePipeline,
    pub(super) products: wgpu::ComputePipeline,
    pub(super) response: wgpu::ComputePipeline,
    pub(super) nms: wgpu::ComputePipeline,
}

impl PipelineSet for HarrisPipelines {
    fn build(device: &wgpu::Device) -> Self {
        let [convolve, products, response, nms] =
            SHADERS.map(|(name, source)| shader_module(device, name, source));
        Self {
            convolve_columns: compute_pipeline(device, &convolve, "columns"),
            convolve_rows: compute_pipeline(device, &convolve, "rows"),
            products: compute_pipeline(device, &products, "main"),
            response: compute_pipeline(device, &response, "main"),
            nms: compute_pipeline(device, &nms, "main"),
        }
    }
}
