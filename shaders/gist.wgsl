// GIST filter bank (eqs 38-41) on the GPU: a 2-D DFT of each padded, pre-filtered image, then
// for every Gabor filter the product with its transfer function, the inverse DFT restricted to
// the unpadded rows and columns, |.|, and the K x K window means.
// CPU twin: src/nav/gist.rs (GistEngine with decimate = false). The DFTs are direct sums over
// one axis at a time (n <= a few hundred iterations per invocation, far below lavapipe's
// 65,535-iteration cap); twiddles come from a table so every factor is exact to f32.

struct Params {
    n: u32,          // padded side
    m: u32,          // image side
    boundary: u32,   // padding on each side
    filters: u32,
    blocks: u32,     // K
    images: u32,
    inv_n2: f32,     // 1 / n^2
    _pad: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> twiddle: array<vec2<f32>>;    // exp(-2 pi i j / n)
@group(0) @binding(2) var<storage, read> input: array<f32>;            // [image][y][x], n x n
@group(0) @binding(3) var<storage, read_write> rows: array<vec2<f32>>; // [image][y][kx]
@group(0) @binding(4) var<storage, read_write> spectrum: array<vec2<f32>>; // [image][ky][kx]
@group(0) @binding(5) var<storage, read> gains: array<f32>;           // [filter][ky][kx]
@group(0) @binding(6) var<storage, read_write> partial: array<vec2<f32>>; // [image*filter][yy][kx]
@group(0) @binding(7) var<storage, read_write> magnitude: array<f32>;  // [image*filter][yy][xx]
@group(0) @binding(8) var<storage, read_write> windows: array<f32>;    // [image][filter][cell]

fn cmul(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x);
}

fn conj(a: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.x, -a.y);
}

// rows[i][y][kx] = sum_x input[i][y][x] w^(x kx)
@compute @workgroup_size(64, 1, 1)
fn forward_rows(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = params.n;
    let kx = id.x;
    let y = id.y;
    let i = id.z;
    if (kx >= n || y >= n || i >= params.images) { return; }
    let base = (i * n + y) * n;
    var acc = vec2<f32>(0.0, 0.0);
    for (var x = 0u; x < n; x = x + 1u) {
        acc = acc + input[base + x] * twiddle[(x * kx) % n];
    }
    rows[base + kx] = acc;
}

// spectrum[i][ky][kx] = sum_y rows[i][y][kx] w^(y ky)
@compute @workgroup_size(64, 1, 1)
fn forward_columns(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = params.n;
    let kx = id.x;
    let ky = id.y;
    let i = id.z;
    if (kx >= n || ky >= n || i >= params.images) { return; }
    var acc = vec2<f32>(0.0, 0.0);
    for (var y = 0u; y < n; y = y + 1u) {
        acc = acc + cmul(rows[(i * n + y) * n + kx], twiddle[(y * ky) % n]);
    }
    spectrum[(i * n + ky) * n + kx] = acc;
}

// partial[i,f][yy][kx] = sum_ky spectrum[i][ky][kx] G_f[ky][kx] w^(-y ky), y = yy + boundary
@compute @workgroup_size(64, 1, 1)
fn inverse_columns(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = params.n;
    let m = params.m;
    let kx = id.x;
    let yy = id.y;
    let pair = id.z;
    if (kx >= n || yy >= m || pair >= params.images * params.filters) { return; }
    let i = pair / params.filters;
    let f = pair % params.filters;
    let y = yy + params.boundary;
    var acc = vec2<f32>(0.0, 0.0);
    for (var ky = 0u; ky < n; ky = ky + 1u) {
        let s = spectrum[(i * n + ky) * n + kx] * gains[(f * n + ky) * n + kx];
        acc = acc + cmul(s, conj(twiddle[(y * ky) % n]));
    }
    partial[(pair * m + yy) * n + kx] = acc;
}

// magnitude[i,f][yy][xx] = |sum_kx partial[i,f][yy][kx] w^(-x kx)| / n^2, x = xx + boundary
@compute @workgroup_size(64, 1, 1)
fn inverse_rows(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = params.n;
    let m = params.m;
    let xx = id.x;
    let yy = id.y;
    let pair = id.z;
    if (xx >= m || yy >= m || pair >= params.images * params.filters) { return; }
    let x = xx + params.boundary;
    let base = (pair * m + yy) * n;
    var acc = vec2<f32>(0.0, 0.0);
    for (var kx = 0u; kx < n; kx = kx + 1u) {
        acc = acc + cmul(partial[base + kx], conj(twiddle[(x * kx) % n]));
    }
    magnitude[(pair * m + yy) * m + xx] = length(acc) * params.inv_n2;
}

// windows[i][f][cell] = mean of magnitude over the cell (eq 40)
@compute @workgroup_size(64, 1, 1)
fn window_means(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = params.blocks;
    let m = params.m;
    let cells = k * k;
    let index = id.x;
    if (index >= params.images * params.filters * cells) { return; }
    let pair = index / cells;
    let cell = index % cells;
    let row = cell / k;
    let col = cell % k;
    // Rows yy with yy*k/m == row: [ceil(row*m/k), ceil((row+1)*m/k)).
    let y0 = (row * m + k - 1u) / k;
    let y1 = ((row + 1u) * m + k - 1u) / k;
    let x0 = (col * m + k - 1u) / k;
    let x1 = ((col + 1u) * m + k - 1u) / k;
    var sum = 0.0;
    for (var yy = y0; yy < y1; yy = yy + 1u) {
        for (var xx = x0; xx < x1; xx = xx + 1u) {
            sum = sum + magnitude[(pair * m + yy) * m + xx];
        }
    }
    windows[index] = sum / f32((y1 - y0) * (x1 - x0));
}
