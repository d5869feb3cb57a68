// Mixed-radix Stockham FFT passes for the GPU GIST bank (eqs 38-41): the fast alternative to
// the direct DFTs of gist.wgsl. One dispatch per radix stage along one axis of many n x n
// complex planes; after all stages of an axis the data is in natural order (Stockham
// autosort, after Govindaraju et al. 2008). Then the filter products, and |.| with the
// K x K window means of the unpadded region.
// CPU twin: src/nav/gist.rs (GistEngine with decimate = false).

struct Stage {
    n: u32,
    ns: u32,        // length of the sub-transforms already done along this axis
    radix: u32,     // 2..8
    inverse: u32,   // 1: exp(+i...)
    axis: u32,      // 0: along rows (stride 1), 1: along columns (stride n)
    planes: u32,
    _p0: u32,
    _p1: u32,
}

struct Bank {
    n: u32,
    m: u32,
    boundary: u32,
    filters: u32,
    blocks: u32,
    images: u32,
    inv_n2: f32,
    _pad: u32,
}

const TAU: f32 = 6.283185307179586;

fn cmul(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x);
}

@group(0) @binding(0) var<uniform> stage: Stage;
@group(0) @binding(1) var<storage, read> src: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read_write> dst: array<vec2<f32>>;

@compute @workgroup_size(64, 1, 1)
fn fft_stage(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = stage.n;
    let r = stage.radix;
    let count = n / r;
    let j = id.x;
    let line = id.y;
    let plane = id.z;
    if (j >= count || line >= n || plane >= stage.planes) { return; }
    var stride = 1u;
    var base = plane * n * n + line * n;
    if (stage.axis == 1u) {
        stride = n;
        base = plane * n * n + line;
    }
    let sign = select(-1.0, 1.0, stage.inverse == 1u);
    let k = j % stage.ns;
    let angle = sign * TAU * f32(k) / f32(stage.ns * r);
    var v: array<vec2<f32>, 8>;
    for (var q = 0u; q < r; q = q + 1u) {
        let a = angle * f32(q);
        v[q] = cmul(src[base + (j + q * count) * stride], vec2<f32>(cos(a), sin(a)));
    }
    let out = (j / stage.ns) * stage.ns * r + k;
    for (var q = 0u; q < r; q = q + 1u) {
        var acc = vec2<f32>(0.0, 0.0);
        for (var t = 0u; t < r; t = t + 1u) {
            let a = sign * TAU * f32((q * t) % r) / f32(r);
            acc = acc + cmul(v[t], vec2<f32>(cos(a), sin(a)));
        }
        dst[base + (out + q * stage.ns) * stride] = acc;
    }
}

@group(0) @binding(0) var<uniform> bank: Bank;
@group(0) @binding(3) var<storage, read> spectrum: array<vec2<f32>>;  // [image][ky][kx]
@group(0) @binding(4) var<storage, read> gains: array<f32>;           // [filter][ky][kx]
@group(0) @binding(5) var<storage, read_write> filtered: array<vec2<f32>>; // [image*filter][ky][kx]

// filtered[i,f] = spectrum[i] * G_f (eq 38 in the frequency domain)
@compute @workgroup_size(64, 1, 1)
fn apply_filters(@builtin(global_invocation_id) id: vec3<u32>) {
    let n2 = bank.n * bank.n;
    let index = id.x + id.y * 65535u * 64u;
    let pair = id.z;
    if (index >= n2 || pair >= bank.images * bank.filters) { return; }
    let i = pair / bank.filters;
    let f = pair % bank.filters;
    filtered[pair * n2 + index] = spectrum[i * n2 + index] * gains[f * n2 + index];
}

@group(0) @binding(6) var<storage, read> responses: array<vec2<f32>>; // [image*filter][y][x]
@group(0) @binding(7) var<storage, read_write> windows: array<f32>;    // [image][filter][cell]

// windows[i][f][cell] = mean over the cell of |response| / n^2 (eqs 39-40)
@compute @workgroup_size(64, 1, 1)
fn window_means(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = bank.blocks;
    let m = bank.m;
    let n = bank.n;
    let cells = k * k;
    let index = id.x;
    if (index >= bank.images * bank.filters * cells) { return; }
    let pair = index / cells;
    let cell = index % cells;
    let row = cell / k;
    let col = cell % k;
    let y0 = (row * m + k - 1u) / k;
    let y1 = ((row + 1u) * m + k - 1u) / k;
    let x0 = (col * m + k - 1u) / k;
    let x1 = ((col + 1u) * m + k - 1u) / k;
    var sum = 0.0;
    for (var yy = y0; yy < y1; yy = yy + 1u) {
        for (var xx = x0; xx < x1; xx = xx + 1u) {
            let y = yy + bank.boundary;
            let x = xx + bank.boundary;
            sum = sum + length(responses[(pair * n + y) * n + x]);
        }
    }
    windows[index] = sum * bank.inv_n2 / f32((y1 - y0) * (x1 - x0));
}
