// Separable convolution, clamp-to-edge borders (paper eqs 4-7: every Gaussian and
// Gaussian-derivative filter of the detector). CPU twin: src/features/convolve.rs.
// One dispatch runs a batch of jobs (global_invocation_id.z), each reading one plane of `src`
// and writing one plane of `dst` with its own taps; taps are summed in ascending order.
// With step > 1 only every step-th output row (columns) or column (rows) is computed: the
// detector's coarse scales keep their window-blurred products on a subsampled grid.

struct Dims {
    src_width: u32,
    src_height: u32,
    dst_width: u32,
    dst_height: u32,
    step: u32,
    src_plane: u32,
    dst_plane: u32,
    _pad: u32,
}

struct Job {
    src: u32,     // plane index in `src`
    dst: u32,     // plane index in `dst`
    taps: u32,    // offset of the first tap in `taps`
    radius: u32,  // the kernel has 2 * radius + 1 taps
}

@group(0) @binding(0) var<uniform> dims: Dims;
@group(0) @binding(1) var<storage, read> jobs: array<Job>;
@group(0) @binding(2) var<storage, read> taps: array<f32>;
@group(0) @binding(3) var<storage, read> src: array<f32>;
@group(0) @binding(4) var<storage, read_write> dst: array<f32>;

@compute @workgroup_size(16, 16, 1)
fn columns(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= dims.dst_width || gid.y >= dims.dst_height) {
        return;
    }
    let job = jobs[gid.z];
    let r = i32(job.radius);
    let last = i32(dims.src_height) - 1;
    let centre = i32(gid.y * dims.step);
    let base = job.src * dims.src_plane + gid.x;
    var acc = 0.0;
    for (var i = 0; i <= 2 * r; i++) {
        let sy = u32(clamp(centre + i - r, 0, last));
        acc += taps[job.taps + u32(i)] * src[base + sy * dims.src_width];
    }
    dst[job.dst * dims.dst_plane + gid.y * dims.dst_width + gid.x] = acc;
}

@compute @workgroup_size(16, 16, 1)
fn rows(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= dims.dst_width || gid.y >= dims.dst_height) {
        return;
    }
    let job = jobs[gid.z];
    let r = i32(job.radius);
    let last = i32(dims.src_width) - 1;
    let centre = i32(gid.x * dims.step);
    let base = job.src * dims.src_plane + gid.y * dims.src_width;
    var acc = 0.0;
    for (var i = 0; i <= 2 * r; i++) {
        let sx = u32(clamp(centre + i - r, 0, last));
        acc += taps[job.taps + u32(i)] * src[base + sx];
    }
    dst[job.dst * dims.dst_plane + gid.y * dims.dst_width + gid.x] = acc;
}
