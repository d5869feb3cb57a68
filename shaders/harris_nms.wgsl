// Non-maximum suppression in space (3x3) and across adjacent scales (3x3 in each, around the
// nearest sample of their grid), response threshold, border margin, sub-pixel quadratic fit,
// the sub-scale offset (the parabola through the adjacent scales' responses), and compaction
// of the survivors with an atomic counter (paper section 2.2.2: local maxima of R in scale
// and space). Each scale lives on its own grid (sample (i, j) at pixel (i, j)*step).
// CPU twin: suppress, peak_offset and parabola_offset in src/features/harris/cpu.rs.

struct Params {
    width: u32,       // this scale's grid
    height: u32,
    plane: u32,
    orientations: u32,
    scale: u32,
    has_prev: u32,
    has_next: u32,
    margin: u32,      // in grid cells
    step: u32,
    prev_width: u32,
    prev_height: u32,
    prev_step: u32,
    next_width: u32,
    next_height: u32,
    next_step: u32,
    _pad: u32,
}

// The threshold is max(threshold, relative * the frame's strongest response), as in
// DetectorConfig::effective_threshold; a re-run after an overflow passes the raised threshold
// with relative = 0.
// core_*: the pixels (of this plane's image or tile) whose samples may become candidates;
// a tile's halo only feeds its neighbours' suppression.
struct Settings {
    threshold: f32,
    capacity: u32,
    relative: f32,
    _pad: u32,
    core_x0: u32,
    core_y0: u32,
    core_x1: u32,
    core_y1: u32,
    origin_x: u32,  // the tile's first pixel in the image (a multiple of every step)
    origin_y: u32,
    _pad1: u32,
    _pad2: u32,
}

// Shared with harris_response.wgsl.
struct Stats {
    count: atomic<u32>,
    peak_bits: atomic<u32>,
}

struct Candidate {
    x: f32,
    y: f32,
    response: f32,
    packed: u32,  // scale << 16 | sub-scale offset (signed byte) << 8 | orientation
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<uniform> settings: Settings;
@group(0) @binding(2) var<storage, read> prev: array<f32>;
@group(0) @binding(3) var<storage, read> cur: array<f32>;
@group(0) @binding(4) var<storage, read> next: array<f32>;
@group(0) @binding(5) var<storage, read_write> stats: Stats;
@group(0) @binding(6) var<storage, read_write> candidates: array<Candidate>;

fn parabola_offset(l: f32, c: f32, r: f32) -> f32 {
    let den = l - 2.0 * c + r;
    if (den < 0.0) {
        return clamp(0.5 * (l - r) / den, -0.5, 0.5);
    }
    return 0.0;
}

// CPU twin: peak_offset. The quadratic's vertex with the cross term; one parabola per axis
// when the fitted surface is not a cap.
fn peak_offset(i: u32, w: u32) -> vec2<f32> {
    let c = cur[i];
    let dx = 0.5 * (cur[i + 1u] - cur[i - 1u]);
    let dy = 0.5 * (cur[i + w] - cur[i - w]);
    let dxx = cur[i + 1u] - 2.0 * c + cur[i - 1u];
    let dyy = cur[i + w] - 2.0 * c + cur[i - w];
    let dxy = 0.25 * (cur[i + w + 1u] - cur[i + w - 1u] - cur[i - w + 1u] + cur[i - w - 1u]);
    let det = dxx * dyy - dxy * dxy;
    if (det > 0.0 && dxx < 0.0) {
        return clamp(vec2<f32>((dxy * dy - dyy * dx) / det, (dxy * dx - dxx * dy) / det),
                     vec2<f32>(-0.5), vec2<f32>(0.5));
    }
    return vec2<f32>(parabola_offset(cur[i - 1u], c, cur[i + 1u]),
                     parabola_offset(cur[i - w], c, cur[i + w]));
}

// The largest value of the 3x3 neighbourhood around pixel (px, py) on the grid of the previous
// (which = 0) or next (which = 1) scale, for orientation t, and the value at its centre (the
// sample nearest the pixel, for the sub-scale fit).
fn adjacent(which: u32, t: u32, px: u32, py: u32) -> vec2<f32> {
    var w = params.prev_width;
    var h = params.prev_height;
    var s = params.prev_step;
    if (which == 1u) {
        w = params.next_width;
        h = params.next_height;
        s = params.next_step;
    }
    let cx = (px + s / 2u) / s;
    let cy = (py + s / 2u) / s;
    let base = t * w * h;
    var m = -3.4e38;
    var centre = 0.0;
    for (var i = 0u; i < 9u; i++) {
        let nx = min(max(cx + i % 3u, 1u) - 1u, w - 1u);
        let ny = min(max(cy + i / 3u, 1u) - 1u, h - 1u);
        let n = base + ny * w + nx;
        var value: f32;
        if (which == 0u) {
            value = prev[n];
        } else {
            value = next[n];
        }
        m = max(m, value);
        if (i == 4u) {
            centre = value;
        }
    }
    return vec2<f32>(m, centre);
}

// CPU twin: Candidate::pack_with_offset. The sub-scale offset (scale steps, within ±0.5) as a
// signed byte in 1/254 steps, halves rounded up, in bits 8-15.
fn pack(scale: u32, t: u32, offset: f32) -> u32 {
    let q = i32(floor(clamp(offset, -0.5, 0.5) * 254.0 + 0.5));
    return (scale << 16u) | ((u32(q) & 0xffu) << 8u) | (t & 0xffu);
}

@compute @workgroup_size(16, 16, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let m = params.margin;
    if (params.width <= 2u * m || params.height <= 2u * m) {
        return;
    }
    if (gid.x < m || gid.y < m || gid.x >= params.width - m || gid.y >= params.height - m) {
        return;
    }
    let px = gid.x * params.step;
    let py = gid.y * params.step;
    if (px < settings.core_x0 || py < settings.core_y0 || px >= settings.core_x1 || py >= settings.core_y1) {
        return;
    }
    let w = params.width;
    let threshold = max(settings.threshold,
                        settings.relative * bitcast<f32>(atomicLoad(&stats.peak_bits)));
    for (var t = 0u; t < params.orientations; t++) {
        let base = t * params.plane;
        let i = base + gid.y * w + gid.x;
        let v = cur[i];
        if (!(v > threshold)) {
            continue;
        }
        var keep = true;
        for (var i = 0u; i < 9u; i++) {
            let n = base + (gid.y + i / 3u - 1u) * w + (gid.x + i % 3u - 1u);
            if (i != 4u && cur[n] >= v) {
                keep = false;
            }
        }
        var below = vec2<f32>(0.0);
        var above = vec2<f32>(0.0);
        if (keep && params.has_prev == 1u) {
            below = adjacent(0u, t, px, py);
            keep = !(below.x > v);
        }
        if (keep && params.has_next == 1u) {
            above = adjacent(1u, t, px, py);
            keep = !(above.x > v);
        }
        if (keep) {
            let o = peak_offset(i, w);
            // The vertex of the parabola through the adjacent scales' responses here.
            var scale_offset = 0.0;
            if (params.has_prev == 1u && params.has_next == 1u) {
                scale_offset = parabola_offset(below.y, v, above.y);
            }
            let slot = atomicAdd(&stats.count, 1u);
            if (slot < settings.capacity) {
                // In image pixels: the sample's index on the image's grid, then the offset.
                let g = f32(params.step);
                let ix = f32(gid.x + settings.origin_x / params.step);
                let iy = f32(gid.y + settings.origin_y / params.step);
                candidates[slot] = Candidate((ix + o.x) * g, (iy + o.y) * g, v, pack(params.scale, t, scale_offset));
            }
        }
    }
}
