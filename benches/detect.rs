//! Criterion benches of each detector stage and of the whole `detect`, CPU versus GPU, on a
//! 640×480 scene (N = 8 orientations, S = 5 scales). GPU rows appear when an adapter exists;
//! on lavapipe they measure a CPU rasteriser, not a GPU.

use criterion::{criterion_group, criterion_main, Criterion};
use steernav::low_level::descriptor::describe;
use steernav::low_level::filter_bank::steered_images;
use steernav::low_level::merge::merge;
use steernav::low_level::synth::textured_scene;
use steernav::{Backend, Detector, DetectorConfig};

fn stages(c: &mut Criterion) {
    let frame = textured_scene(640, 480, 1);
    let cfg = DetectorConfig::default();
    let mut group = c.benchmark_group("detect 640x480");
    group.sample_size(10);
    let cpu = Detector::new(&cfg, Backend::Cpu).expect("valid config");
    group.bench_function("cpu/filter bank (steered images)", |b| {
        b.iter(|| steered_images(&cfg, &frame.gray, 640, 480))
    });
    group.bench_function("cpu/harris (filters + tensor + response + nms)", |b| {
        b.iter(|| cpu.candidates(&frame).unwrap())
    });
    let cands = cpu.candidates(&frame).unwrap().candidates;
    group.bench_function("cpu/merge", |b| b.iter(|| merge(&cands, cpu.plan())));
    let clusters = merge(&cands, cpu.plan());
    group.bench_function("cpu/descriptors", |b| {
        b.iter(|| {
            clusters
                .iter()
                .map(|k| describe(&frame, k.x, k.y))
                .collect::<Vec<_>>()
        })
    });
    group.bench_function("cpu/detect (end to end)", |b| {
        b.iter(|| cpu.detect(&frame).unwrap())
    });
    if let Ok(gpu) = Detector::new(&cfg, Backend::Gpu) {
        let ctx = gpu.gpu().expect("gpu backend").context().clone();
        group.bench_function("gpu/filter bank (steered images)", |b| {
            b.iter(|| {
                steernav::low_level::filter_bank::gpu::steered_images(
                    &ctx,
                    &cfg,
                    &frame.gray,
                    640,
                    480,
                )
                .unwrap()
            })
        });
        group.bench_function("gpu/harris (upload + passes + readback)", |b| {
            b.iter(|| gpu.candidates(&frame).unwrap())
        });
        group.bench_function("gpu/detect (end to end)", |b| {
            b.iter(|| gpu.detect(&frame).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, stages);
criterion_main!(benches);
