//! Criterion benches of the dynamic neural field (eqs 28–31): 100 Euler steps of B fields of
//! N = 72 neurons, B = 1, 64, 4096, CPU and (with an adapter) GPU. Throughput is reported in
//! neuron-steps per second (criterion's elements/s).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use steernav::low_level::dnf::{bell, FieldBatch, FieldConfig};

const STEPS: usize = 100;

fn fields(c: &mut Criterion) {
    let mut group = c.benchmark_group("dnf N=72, 100 steps");
    group.sample_size(10);
    let gpu = steernav::GpuContext::shared().ok();
    for b in [1usize, 64, 4096] {
        let stimulus: Vec<f32> = (0..b)
            .flat_map(|i| bell(72, (i % 72) as f32, 5.0, 3.0))
            .collect();
        group.throughput(Throughput::Elements((b * 72 * STEPS) as u64));
        let mut cpu = FieldBatch::new(FieldConfig::default(), b).expect("valid config");
        group.bench_function(format!("cpu/B={b}"), |bench| {
            bench.iter(|| cpu.step(&stimulus, STEPS).unwrap())
        });
        if let Some(ctx) = &gpu {
            let mut field = steernav::low_level::dnf::GpuFieldBatch::new(
                ctx.clone(),
                FieldConfig::default(),
                b,
            )
            .expect("fits");
            group.bench_function(format!("gpu/B={b}"), |bench| {
                bench.iter(|| {
                    field.step(&stimulus, STEPS).unwrap();
                    // Include the wait for the device: read one field back.
                    field.read().unwrap().len()
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, fields);
criterion_main!(benches);
