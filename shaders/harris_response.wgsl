// Harris response R = det M - k tr^2 M (eq 8) for every steered orientation, where the
// structure tensor M(theta) (eq 7) is a fixed quadratic form in the blurred products Q:
// Mxx = wxx(theta) . Q, Mxy = wxy(theta) . Q, Myy = wyy(theta) . Q.
// The frame's strongest response, which the relative threshold needs, is taken here: one
// atomicMax per workgroup on the float bits of the positive responses (their bit patterns
// order like the floats), after a max over the workgroup in shared memory.
// CPU twin: scale_responses in src/features/harris/cpu.rs.

struct Params {
    width: u32,
    height: u32,
    plane: u32,
    products: u32,      // at most 10
    orientations: u32,
    k: f32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> weights: array<f32>;  // [theta][entry][product]
@group(0) @binding(2) var<storage, read> blurred: array<f32>;  // [product][y][x]
@group(0) @binding(3) var<storage, read_write> responses: array<f32>;  // [theta][y][x]
@group(0) @binding(4) var<storage, read_write> stats: Stats;

// Shared with harris_nms.wgsl: the candidate counter and the strongest response's bits.
struct Stats {
    count: atomic<u32>,
    peak_bits: atomic<u32>,
}

var<workgroup> group_peak: atomic<u32>;

@compute @workgroup_size(16, 16, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(local_invocation_index) lid: u32) {
    if (gid.x < params.width && gid.y < params.height) {
        let peak = respond(gid);
        if (peak > 0.0) {
            atomicMax(&group_peak, bitcast<u32>(peak));
        }
    }
    workgroupBarrier();
    if (lid == 0u) {
        let peak = atomicLoad(&group_peak);
        if (peak > 0u) {
            atomicMax(&stats.peak_bits, peak);
        }
    }
}

// Writes the responses of every orientation at one sample; returns the largest.
fn respond(gid: vec3<u32>) -> f32 {
    var peak = 0.0;
    let i = gid.y * params.width + gid.x;
    let p = params.products;
    var q: array<f32, 10>;
    for (var j = 0u; j < p; j++) {
        q[j] = blurred[j * params.plane + i];
    }
    for (var t = 0u; t < params.orientations; t++) {
        let base = t * 3u * p;
        var mxx = 0.0;
        var mxy = 0.0;
        var myy = 0.0;
        for (var j = 0u; j < p; j++) {
            mxx += weights[base + j] * q[j];
            mxy += weights[base + p + j] * q[j];
            myy += weights[base + 2u * p + j] * q[j];
        }
        let tr = mxx + myy;
        let r = mxx * myy - mxy * mxy - params.k * tr * tr;
        responses[t * params.plane + i] = r;
        peak = max(peak, r);
    }
    return peak;
}
