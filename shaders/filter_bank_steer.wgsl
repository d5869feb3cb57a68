// Steering (eqs 3-4): F(theta) = sum_i c_i(theta) (I * B_i), the steered filter-bank images from
// the basis responses. CPU twin: steered_images in src/features/filter_bank.rs.

struct Params {
    width: u32,
    height: u32,
    plane: u32,
    basis: u32,         // number of basis planes (n + 1)
    orientations: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> coefficients: array<f32>;  // [theta][basis]
@group(0) @binding(2) var<storage, read> basis: array<f32>;         // [basis][y][x]
@group(0) @binding(3) var<storage, read_write> steered: array<f32>; // [theta][y][x]

@compute @workgroup_size(16, 16, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= params.width || gid.y >= params.height) {
        return;
    }
    let i = gid.y * params.width + gid.x;
    for (var t = 0u; t < params.orientations; t++) {
        var acc = 0.0;
        for (var b = 0u; b < params.basis; b++) {
            acc += coefficients[t * params.basis + b] * basis[b * params.plane + i];
        }
        steered[t * params.plane + i] = acc;
    }
}
