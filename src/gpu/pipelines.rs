//! Every compute pipeline of steernav, compiled once per [`super::GpuContext`].

/// WGSL sources, embedded at build time; `tests/shaders.rs` validates each with naga.
pub mod sources {
    /// Separable convolution (entry points `columns`, `rows`).
    pub const CONVOLVE: &str = include_str!("../../shaders/convolve.wgsl");
    /// Products of derivative planes.
    pub const PRODUCTS: &str = include_str!("../../shaders/products.wgsl");
    /// Harris responses for all orientations.
    pub const RESPONSE: &str = include_str!("../../shaders/response.wgsl");
    /// Non-maximum suppression and compaction.
    pub const NMS: &str = include_str!("../../shaders/nms.wgsl");
    /// Steering of basis responses.
    pub const STEER: &str = include_str!("../../shaders/steer.wgsl");
    /// The dynamic neural field.
    pub const DNF: &str = include_str!("../../shaders/dnf.wgsl");
    /// The GIST filter bank.
    pub const GIST: &str = include_str!("../../shaders/gist.wgsl");
    /// The GIST filter bank by mixed-radix FFTs.
    pub const GIST_FFT: &str = include_str!("../../shaders/gist_fft.wgsl");
    /// Every shader with its file name.
    pub const ALL: [(&str, &str); 8] = [
        ("dnf.wgsl", DNF),
        ("gist.wgsl", GIST),
        ("gist_fft.wgsl", GIST_FFT),
        ("convolve.wgsl", CONVOLVE),
        ("products.wgsl", PRODUCTS),
        ("response.wgsl", RESPONSE),
        ("nms.wgsl", NMS),
        ("steer.wgsl", STEER),
    ];
}

/// The compiled pipelines.
pub struct Pipelines {
    /// Vertical pass of `convolve.wgsl`.
    pub convolve_columns: wgpu::ComputePipeline,
    /// Horizontal pass of `convolve.wgsl`.
    pub convolve_rows: wgpu::ComputePipeline,
    /// `products.wgsl`.
    pub products: wgpu::ComputePipeline,
    /// `response.wgsl`.
    pub response: wgpu::ComputePipeline,
    /// `nms.wgsl`.
    pub nms: wgpu::ComputePipeline,
    /// `steer.wgsl`.
    pub steer: wgpu::ComputePipeline,
    /// `dnf.wgsl`.
    pub dnf: wgpu::ComputePipeline,
    /// `gist.wgsl`, entry points in pass order: forward rows, forward columns, inverse
    /// columns (with the filter), inverse rows (with |.|), window means.
    pub gist: [wgpu::ComputePipeline; 5],
    /// `gist_fft.wgsl`: one FFT stage, the filter products, the window means.
    pub gist_fft: [wgpu::ComputePipeline; 3],
}

impl Pipelines {
    /// Compiles every shader and builds its pipeline.
    pub fn new(device: &wgpu::Device) -> Self {
        let module = |label: &str, src: &str| {
            device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(src.into()),
            })
        };
        let pipeline = |label: &str, module: &wgpu::ShaderModule, entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let convolve = module("convolve", sources::CONVOLVE);
        Self {
            convolve_columns: pipeline("convolve_columns", &convolve, "columns"),
            convolve_rows: pipeline("convolve_rows", &convolve, "rows"),
            products: pipeline("products", &module("products", sources::PRODUCTS), "main"),
            response: pipeline("response", &module("response", sources::RESPONSE), "main"),
            nms: pipeline("nms", &module("nms", sources::NMS), "main"),
            steer: pipeline("steer", &module("steer", sources::STEER), "main"),
            dnf: pipeline("dnf", &module("dnf", sources::DNF), "main"),
            gist: {
                let gist = module("gist", sources::GIST);
                [
                    "forward_rows",
                    "forward_columns",
                    "inverse_columns",
                    "inverse_rows",
                    "window_means",
                ]
                .map(|entry| pipeline(entry, &gist, entry))
            },
            gist_fft: {
                let fft = module("gist_fft", sources::GIST_FFT);
                ["fft_stage", "apply_filters", "window_means"]
                    .map(|entry| pipeline(entry, &fft, entry))
            },
        }
    }
}
