//! Criterion bench of the GIST descriptor (eqs 38–41) per image: 256×256 with the reference
//! settings (4 scales × 8 orientations, 4×4 windows, pre-filter), and the simulator's 64×64.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use steernav::nav::gist::{GistConfig, GistEngine};
use steernav::nav::sim::visual::VisualConfig;

fn gist(c: &mut Criterion) {
    let mut group = c.benchmark_group("gist per image");
    group.sample_size(20);
    group.throughput(Throughput::Elements(1));
    let frame = steernav::synth::textured_scene(320, 240, 5);
    for (name, config) in [
        ("256x256 reference", GistConfig::default()),
        ("64x64 simulator", VisualConfig::default().gist),
    ] {
        let engine = GistEngine::new(config).expect("valid config");
        group.bench_function(name, |b| {
            b.iter(|| engine.describe(&frame).expect("describes"))
        });
    }
    group.finish();
}

criterion_group!(benches, gist);
criterion_main!(benches);
