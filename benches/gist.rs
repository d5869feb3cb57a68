//! Criterion bench of the GIST descriptor (eqs 38–41) per image: 256×256 with the reference
//! settings (4 scales × 8 orientations, 4×4 windows, pre-filter) and the simulator's 64×64 on
//! the CPU, and (with an adapter) the GPU bank on batches of 8 images.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use steernav::nav::gist::{GistConfig, GistEngine};
use steernav::nav::visual::VisualConfig;

fn gist(c: &mut Criterion) {
    let mut group = c.benchmark_group("gist per image");
    group.sample_size(20);
    group.throughput(Throughput::Elements(1));
    let frame = steernav::low_level::synth::textured_scene(320, 240, 5);
    for (name, config) in [
        ("256x256 reference", GistConfig::default()),
        ("64x64 simulator", VisualConfig::default().gist),
    ] {
        let engine = GistEngine::new(config).expect("valid config");
        group.bench_function(name, |b| {
            b.iter(|| engine.describe(&frame).expect("describes"))
        });
    }
    // The GPU bank (exact), FFT and direct DFTs. On lavapipe this measures a CPU rasteriser.
    match steernav::GpuContext::shared() {
        Ok(ctx) => {
            use steernav::nav::gist::{GistMethod, GpuGist};
            let frames = vec![frame.clone(); 8];
            group.throughput(Throughput::Elements(8));
            for (name, config) in [
                ("256x256", GistConfig::default()),
                ("64x64", VisualConfig::default().gist),
            ] {
                for method in [GistMethod::Fft, GistMethod::Direct] {
                    if name == "256x256" && method == GistMethod::Direct {
                        continue; // seconds per image on lavapipe
                    }
                    let mut gpu =
                        GpuGist::with_method(ctx.clone(), config.clone(), method).expect("fits");
                    group.bench_function(format!("{name} gpu {method:?}, batch of 8"), |b| {
                        b.iter(|| gpu.describe_batch(&frames).expect("describes"))
                    });
                }
            }
        }
        Err(e) => eprintln!("no GPU bench: {e}"),
    }
    group.finish();
}

criterion_group!(benches, gist);
criterion_main!(benches);
