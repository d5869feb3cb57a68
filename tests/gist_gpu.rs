//! GIST on the GPU against its CPU reference (the exact, undecimated bank), several images in
//! one submission.

mod common;

use steernav::nav::gist::{radices, GistMethod, GpuGist};
use steernav::nav::gist::{GistConfig, GistEngine};

#[test]
fn gpu_gist_matches_the_cpu_reference_on_a_batch() {
    let Some(ctx) = common::gpu() else { return };
    let config = GistConfig {
        size: 64,
        boundary: 8,
        decimate: false,
        ..GistConfig::default()
    };
    let cpu = GistEngine::new(config.clone()).unwrap();
    let frames: Vec<_> = (0..3)
        .map(|s| steernav::low_level::synth::textured_scene(96 + 16 * s, 80, 40 + s as u64))
        .collect();
    for method in [GistMethod::Fft, GistMethod::Direct] {
        let mut gpu = GpuGist::with_method(ctx.clone(), config.clone(), method).unwrap();
        let got = gpu.describe_batch(&frames).unwrap();
        assert_eq!(got.len(), frames.len());
        for (frame, g) in frames.iter().zip(&got) {
            let want = cpu.describe(frame).unwrap();
            assert_eq!(g.len(), want.len());
            let scale = want.iter().fold(0.0f32, |a, &b| a.max(b.abs()));
            let worst = g
                .iter()
                .zip(&want)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0f32, f32::max);
            // f32 transforms on the GPU against rustfft: measured below 1e-6 of the largest
            // value for both methods; the bound is 1e-5.
            assert!(
                worst <= 1e-5 * scale,
                "{method:?}: worst {worst} of {scale}"
            );
        }
        // Different images give different descriptors (the batch is not one image repeated).
        assert_ne!(got[0], got[1]);
    }
    // The default picks FFTs for 80 = 8·2·5.
    assert_eq!(radices(80), Some(vec![8, 2, 5]));
    assert_eq!(radices(2 * 11), None);
    assert_eq!(GpuGist::new(ctx, config).unwrap().method(), GistMethod::Fft);
}

#[test]
fn the_default_gist_agrees_on_both_backends() {
    // The default configuration, as `steernav gist` and a robot use it, on a textured scene:
    // the two backends must give the same descriptor (within 1e-3 of its largest value), so a
    // map built on one matches descriptors computed on the other.
    let Some(ctx) = common::gpu() else { return };
    let config = GistConfig::default();
    let frame = steernav::low_level::synth::textured_scene(400, 320, 12);
    let cpu = GistEngine::new(config.clone())
        .unwrap()
        .describe(&frame)
        .unwrap();
    let gpu = GpuGist::new(ctx, config)
        .unwrap()
        .describe_batch(&[frame])
        .unwrap();
    let scale = cpu.iter().fold(0.0f32, |a, &b| a.max(b.abs()));
    let worst = gpu[0]
        .iter()
        .zip(&cpu)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(worst <= 1e-3 * scale, "worst {worst} of {scale}");
}
