// The steered descriptor: one workgroup per keypoint. The patch around the keypoint is
// smoothed to its scale, the total blur (rows, then columns, borders clamped), on the plane
// it reads (its pyramid level; every level of a frame lies in `gray`), differentiated, and read in
// the frame of its dominant first-order steered direction: a 36-bin orientation histogram,
// then 4x4 cells x 8 directions with trilinear weights, normalised, clipped at 0.2 and
// normalised again. Every histogram bin is summed by one invocation over the patch's pixels
// in raster order, the order of the CPU twin, so the sums agree to rounding.
// CPU twin: describe_steered in src/features/steered/cpu.rs.

struct Params {
    count: u32,     // keypoints in this dispatch
    groups_x: u32,  // workgroups along x (keypoint k = wg.y * groups_x + wg.x)
    slots: u32,     // keypoints of the whole frame: the orientations follow their descriptors
    first: u32,     // this dispatch's first job
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    _pad3: u32,
}

struct Job {
    x: f32,
    y: f32,
    sigma: f32,
    half: u32,      // half-side of the gradient window, pixels
    radius: u32,    // smoothing kernel radius
    taps: u32,      // offset of its taps
    scratch: u32,   // offset of this keypoint's scratch
    slot: u32,      // output slot
    plane: u32,     // offset in `gray` of the plane (pyramid level) it reads
    width: u32,     // that plane's size
    height: u32,
    _pad: u32,
}

const CELLS: u32 = 4u;
const DIRECTIONS: u32 = 8u;
const LEN: u32 = 128u;
const BINS: u32 = 36u;
const CELL_SIGMAS: f32 = 4.1;
const ORIENTATION_SIGMAS: f32 = 3.3;
const CLIP: f32 = 0.2;
const TAU: f32 = 6.2831855;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> gray: array<f32>;
@group(0) @binding(2) var<storage, read> taps: array<f32>;
@group(0) @binding(3) var<storage, read> jobs: array<Job>;
@group(0) @binding(4) var<storage, read_write> scratch: array<f32>;
// [slot][0..128) the descriptors, then [slots * 128 + slot] the orientations.
@group(0) @binding(5) var<storage, read_write> out: array<f32>;

var<workgroup> hist: array<f32, 36>;
var<workgroup> desc: array<f32, 128>;
var<workgroup> frame_angle: f32;

// CPU twin: fast_atan2 in src/features/steered/mod.rs (within 1e-5 rad of atan2).
fn fast_atan2(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    var num = ay;
    var den = ax;
    if (ay > ax) {
        num = ax;
        den = ay;
    }
    if (den == 0.0) {
        return 0.0;
    }
    let z = num / den;
    let z2 = z * z;
    var a = z * (0.99997726 + z2 * (-0.33262347 + z2 * (0.19354346 + z2 * (-0.11643287 + z2 * (0.05265332 + z2 * -0.0117212)))));
    if (ay > ax) {
        a = 1.5707964 - a;
    }
    if (x < 0.0) {
        a = 3.1415927 - a;
    }
    if (y < 0.0) {
        a = -a;
    }
    return a;
}

fn wrap_angle(a: f32) -> f32 {
    return a - TAU * floor(a / TAU);
}

// The plane of the keypoint this workgroup describes (set at the top of main).
var<private> plane_base: u32;
var<private> plane_width: u32;
var<private> plane_height: u32;

fn pixel(u: i32, v: i32) -> f32 {
    let x = u32(clamp(u, 0, i32(plane_width) - 1));
    let y = u32(clamp(v, 0, i32(plane_height) - 1));
    return gray[plane_base + y * plane_width + x];
}

fn parabola_offset(l: f32, c: f32, r: f32) -> f32 {
    let den = l - 2.0 * c + r;
    if (den < 0.0) {
        return clamp(0.5 * (l - r) / den, -0.5, 0.5);
    }
    return 0.0;
}

@compute @workgroup_size(128, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let k = wg.y * params.groups_x + wg.x;
    if (k >= params.count) {
        return;
    }
    let job = jobs[params.first + k];
    plane_base = job.plane;
    plane_width = job.width;
    plane_height = job.height;
    let r = job.radius;
    let half = job.half;
    let side = 2u * half + 1u;
    let inner = side + 2u;
    let outer = side + 2u * (r + 1u);
    let cx = i32(floor(job.x + 0.5));
    let cy = i32(floor(job.y + 0.5));
    let ox = cx - i32(half + r + 1u);
    let oy = cy - i32(half + r + 1u);
    let rows = job.scratch;
    let smoothed = rows + outer * inner;
    let gx = smoothed + inner * inner;
    let gy = gx + side * side;
    // Rows: `outer` rows of `inner` smoothed columns.
    for (var e = lid; e < outer * inner; e += 128u) {
        let j = e / inner;
        let i = e % inner;
        let u = ox + i32(r + i);
        var acc = 0.0;
        for (var t = 0u; t <= 2u * r; t++) {
            acc += taps[job.taps + t] * pixel(u + i32(t) - i32(r), oy + i32(j));
        }
        scratch[rows + e] = acc;
    }
    storageBarrier();
    workgroupBarrier();
    for (var e = lid; e < inner * inner; e += 128u) {
        let j = e / inner;
        let i = e % inner;
        var acc = 0.0;
        for (var t = 0u; t <= 2u * r; t++) {
            acc += taps[job.taps + t] * scratch[rows + (j + t) * inner + i];
        }
        scratch[smoothed + e] = acc;
    }
    storageBarrier();
    workgroupBarrier();
    for (var e = lid; e < side * side; e += 128u) {
        let j = e / side;
        let i = e % side;
        let at = smoothed + j * inner + i;
        scratch[gx + e] = 0.5 * (scratch[at + inner + 2u] - scratch[at + inner]);
        scratch[gy + e] = 0.5 * (scratch[at + 2u * inner + 1u] - scratch[at + 1u]);
    }
    storageBarrier();
    workgroupBarrier();
    let x0 = cx - i32(half);
    let y0 = cy - i32(half);
    // Orientation histogram: invocation b sums bin b.
    let sigma_o = ORIENTATION_SIGMAS * job.sigma;
    let limit = (3.0 * sigma_o) * (3.0 * sigma_o);
    let to_bin_o = f32(BINS) / TAU;
    if (lid < BINS) {
        var acc = 0.0;
        for (var e = 0u; e < side * side; e++) {
            let dx = f32(x0 + i32(e % side)) - job.x;
            let dy = f32(y0 + i32(e / side)) - job.y;
            let d2 = dx * dx + dy * dy;
            if (d2 > limit) {
                continue;
            }
            let g_x = scratch[gx + e];
            let g_y = scratch[gy + e];
            // The Gaussian window as the product of its separable factors, as on the CPU.
            let w = sqrt(g_x * g_x + g_y * g_y)
                * (exp(-(dx * dx) / (2.0 * sigma_o * sigma_o)) * exp(-(dy * dy) / (2.0 * sigma_o * sigma_o)));
            let b = wrap_angle(fast_atan2(g_y, g_x)) * to_bin_o - 0.5;
            let b0 = floor(b);
            let f = b - b0;
            let i0 = u32((i32(b0) + i32(BINS)) % i32(BINS));
            if (i0 == lid) {
                acc += w * (1.0 - f);
            }
            if ((i0 + 1u) % BINS == lid) {
                acc += w * f;
            }
        }
        hist[lid] = acc;
    }
    workgroupBarrier();
    if (lid == 0u) {
        for (var round = 0u; round < 2u; round++) {
            var h: array<f32, 36>;
            for (var i = 0u; i < BINS; i++) {
                h[i] = hist[i];
            }
            for (var i = 0u; i < BINS; i++) {
                hist[i] = 0.25 * h[(i + BINS - 1u) % BINS] + 0.5 * h[i] + 0.25 * h[(i + 1u) % BINS];
            }
        }
        var peak = 0u;
        var best = -3.4028235e38;
        for (var i = 0u; i < BINS; i++) {
            if (hist[i] > best) {
                best = hist[i];
                peak = i;
            }
        }
        let offset = parabola_offset(hist[(peak + BINS - 1u) % BINS], hist[peak], hist[(peak + 1u) % BINS]);
        frame_angle = wrap_angle((f32(peak) + 0.5 + offset) / to_bin_o);
    }
    workgroupBarrier();
    let orientation = frame_angle;
    // Descriptor: invocation s sums slot s = (cell row * CELLS + cell column) * DIRECTIONS + d.
    let cell = CELL_SIGMAS * job.sigma;
    let window = f32(CELLS) * cell;
    let weight_sigma = 0.5 * window;
    let to_bin = f32(DIRECTIONS) / TAU;
    let s_cos = cos(orientation);
    let s_sin = sin(orientation);
    let my_d = lid % DIRECTIONS;
    let my_u = f32((lid / DIRECTIONS) % CELLS);
    let my_v = f32(lid / (DIRECTIONS * CELLS));
    var acc = 0.0;
    for (var e = 0u; e < side * side; e++) {
        let dx = f32(x0 + i32(e % side)) - job.x;
        let dy = f32(y0 + i32(e / side)) - job.y;
        let u = (s_cos * dx + s_sin * dy) / cell + 0.5 * f32(CELLS) - 0.5;
        let v = (-s_sin * dx + s_cos * dy) / cell + 0.5 * f32(CELLS) - 0.5;
        if (u <= -1.0 || v <= -1.0 || u >= f32(CELLS) || v >= f32(CELLS)) {
            continue;
        }
        let g_x = scratch[gx + e];
        let g_y = scratch[gy + e];
        let magnitude = sqrt(g_x * g_x + g_y * g_y);
        if (magnitude == 0.0) {
            continue;
        }
        let w = magnitude
            * (exp(-(dx * dx) / (2.0 * weight_sigma * weight_sigma)) * exp(-(dy * dy) / (2.0 * weight_sigma * weight_sigma)));
        let phi = wrap_angle(fast_atan2(g_y, g_x) - orientation) * to_bin;
        let u0 = floor(u);
        let v0 = floor(v);
        let p0 = floor(phi);
        var wu = 0.0;
        if (my_u == u0) {
            wu = 1.0 - (u - u0);
        } else if (my_u == u0 + 1.0) {
            wu = u - u0;
        } else {
            continue;
        }
        var wv = 0.0;
        if (my_v == v0) {
            wv = 1.0 - (v - v0);
        } else if (my_v == v0 + 1.0) {
            wv = v - v0;
        } else {
            continue;
        }
        var wp = 0.0;
        if (u32(p0) % DIRECTIONS == my_d) {
            wp = 1.0 - (phi - p0);
        } else if ((u32(p0) + 1u) % DIRECTIONS == my_d) {
            wp = phi - p0;
        } else {
            continue;
        }
        acc += w * wu * wv * wp;
    }
    desc[lid] = acc;
    workgroupBarrier();
    if (lid == 0u) {
        for (var round = 0u; round < 2u; round++) {
            var sum = 0.0;
            for (var i = 0u; i < LEN; i++) {
                sum += desc[i] * desc[i];
            }
            let norm = sqrt(sum);
            for (var i = 0u; i < LEN; i++) {
                var v = desc[i];
                if (norm > 0.0) {
                    v = v / norm;
                }
                if (round == 0u) {
                    v = min(v, CLIP);
                }
                desc[i] = v;
            }
        }
        out[params.slots * LEN + job.slot] = orientation;
    }
    workgroupBarrier();
    out[job.slot * LEN + lid] = desc[lid];
}
