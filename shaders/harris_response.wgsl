// Harris response R = det M - k tr^2 M (eq 8) for every steered orientation, where the
// structure tensor M(theta) (eq 7) is a fixed quadratic form in the blurred products Q:
// Mxx = wxx(theta) . Q, Mxy = wxy(theta) . Q, Myy = wyy(theta) . Q.
// CPU twin: tensor_responses in src/features/harris.rs.

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

@compute @workgroup_size(16, 16, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= params.width || gid.y >= params.height) {
        return;
    }
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
        responses[t * params.plane + i] = mxx * myy - mxy * mxy - params.k * tr * tr;
    }
}
