// Dynamic neural field (eqs 28-31): one workgroup advances one field of N <= 1024 heading
// neurons by `steps` Euler steps of tau du/dt = -u + S + h + sum_j w(i,j) f(u_j).
// CPU twin: src/nav/dnf.rs. lavapipe stops loops past 65,535 iterations per invocation, so the
// driver splits long runs into several dispatches of `steps` each (state stays in `u`).

struct Params {
    neurons: u32,
    fields: u32,
    steps: u32,
    amari: u32,       // 1: eq 31 (window form), 0: dense kernel by ring distance
    width: u32,       // eq 31 half-width
    sigmoid: u32,     // 0: Heaviside, 1: sigmoid
    beta: f32,
    rate: f32,        // dt / tau
    h: f32,
    excite: f32,
    inhibit: f32,
    groups_x: u32,    // workgroups along x (fields beyond 65535 use y)
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> kernel: array<f32>;     // w by ring distance 0..N/2
@group(0) @binding(2) var<storage, read> stimulus: array<f32>;   // [field][neuron]
@group(0) @binding(3) var<storage, read_write> u: array<f32>;    // [field][neuron]

const THREADS: u32 = 64u;

var<workgroup> f: array<f32, 1024>;  // 64 threads x 16 neurons at most

fn activation(x: f32) -> f32 {
    if (params.sigmoid == 1u) {
        return 1.0 / (1.0 + exp(-params.beta * x));
    }
    return select(0.0, 1.0, x > 0.0);
}

fn ring_distance(i: u32, j: u32, n: u32) -> u32 {
    let d = max(i, j) - min(i, j);
    return min(d, n - d);
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let field = wg.y * params.groups_x + wg.x;
    let live = field < params.fields;
    let n = params.neurons;
    let base = field * n;
    var next: array<f32, 16>;
    let per = (n + THREADS - 1u) / THREADS;  // neurons per thread: loop bounds stay small
    for (var step = 0u; step < params.steps; step++) {
        for (var k = 0u; k < per; k++) {
            let i = lid + k * THREADS;
            if (live && i < n) {
                f[i] = activation(u[base + i]);
            }
        }
        workgroupBarrier();
        if (live) {
            var total = 0.0;
            if (params.amari == 1u) {
                for (var j = 0u; j < n; j++) {
                    total += f[j];
                }
            }
            for (var k = 0u; k < per; k++) {
                let i = lid + k * THREADS;
                if (i < n) {
                    var lateral = 0.0;
                    if (params.amari == 1u) {
                        var window = 0.0;
                        for (var d = 0u; d <= 2u * params.width; d++) {
                            window += f[(i + n + d - params.width) % n];
                        }
                        lateral = params.inhibit * total + (params.excite - params.inhibit) * window;
                    } else {
                        for (var j = 0u; j < n; j++) {
                            lateral += kernel[ring_distance(i, j, n)] * f[j];
                        }
                    }
                    let ui = u[base + i];
                    next[k] = ui + params.rate * (-ui + stimulus[base + i] + params.h + lateral);
                }
            }
        }
        workgroupBarrier();
        for (var k = 0u; k < per; k++) {
            let i = lid + k * THREADS;
            if (live && i < n) {
                u[base + i] = next[k];
            }
        }
    }
}
