// Products D_j * D_k (j <= k) of the steered-gradient basis, the integrands of the structure
// tensor (eq 7) before the window blur. CPU twin: CpuHarris::compute in src/features/harris.rs.

struct Params {
    width: u32,
    height: u32,
    plane: u32,
    count: u32,  // number of derivative planes (n + 2)
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> derivatives: array<f32>;
@group(0) @binding(2) var<storage, read_write> products: array<f32>;

@compute @workgroup_size(16, 16, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= params.width || gid.y >= params.height) {
        return;
    }
    let i = gid.y * params.width + gid.x;
    var p = 0u;
    for (var j = 0u; j < params.count; j++) {
        let a = derivatives[j * params.plane + i];
        for (var k = j; k < params.count; k++) {
            products[p * params.plane + i] = a * derivatives[k * params.plane + i];
            p++;
        }
    }
}
