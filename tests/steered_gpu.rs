//! GPU–CPU parity of the steered descriptor: the same keypoints described by
//! `shaders/steered_descriptor.wgsl` and by the CPU twin agree to 2e-3 in every value
//! (unit-length vectors; the sums run in the same order, only exp/atan2/sin/cos and fused
//! multiply-adds differ) for at least 97% of keypoints, and the frame orientation to 1e-3 rad;
//! a keypoint whose orientation histogram has two near-equal peaks may legitimately turn
//! the other way on one backend.

mod common;

use steernav::low_level::harris::plan::detection_scale;
use steernav::low_level::steered::{describe_steered, GpuSteered};
use steernav::low_level::synth::textured_scene;

#[test]
fn gpu_descriptors_match_the_cpu_twin() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let frame = textured_scene(320, 240, 12);
    let (w, h) = (frame.width as usize, frame.height as usize);
    // Every detection scale, sub-pixel positions, and points whose patch leaves the image.
    let sigmas = [1.0f32, 1.4, 1.96, 2.744, 3.8416];
    let mut rng = steernav::low_level::synth::Rng(5);
    let points: Vec<(f32, f32, f32)> = (0..300)
        .map(|i| {
            (
                rng.range(-2.0, w as f32 + 1.0),
                rng.range(-2.0, h as f32 + 1.0),
                sigmas[i % sigmas.len()],
            )
        })
        .collect();
    let gpu = GpuSteered::new(ctx)
        .describe(&frame.gray, frame.width, frame.height, &points)
        .unwrap();
    let mut close = 0;
    for (&(x, y, s), g) in points.iter().zip(&gpu) {
        let c = describe_steered(&frame.gray, w, h, x, y, s);
        let diff = c
            .values
            .iter()
            .zip(&g.values)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        let turn = (c.orientation - g.orientation).abs();
        let turn = turn.min(std::f32::consts::TAU - turn);
        if diff <= 2e-3 && turn <= 1e-3 {
            close += 1;
        }
    }
    assert!(
        close as f64 >= 0.97 * points.len() as f64,
        "{close} of {} descriptors agree",
        points.len()
    );
}

#[test]
fn the_detector_describes_on_the_gpu_like_on_the_cpu() {
    if common::gpu().is_none() {
        return;
    }
    use steernav::{Backend, Detector, DetectorConfig};
    let frame = textured_scene(480, 360, 3);
    let cfg = DetectorConfig::default();
    let g = Detector::new(&cfg, Backend::Gpu)
        .unwrap()
        .detect(&frame)
        .unwrap();
    let c = Detector::new(&cfg, Backend::Cpu)
        .unwrap()
        .detect(&frame)
        .unwrap();
    // Keypoints at the same place carry nearly the same descriptor, those read on a pyramid
    // level (σ_D ≥ 2) included.
    let mut pairs = 0;
    let mut agree = 0;
    let mut on_levels = 0;
    for a in &g.keypoints {
        if let Some(b) = c
            .keypoints
            .iter()
            .find(|b| (a.x - b.x).abs() < 1e-3 && (a.y - b.y).abs() < 1e-3 && a.scale == b.scale)
        {
            pairs += 1;
            on_levels += usize::from(detection_scale(a.scale, cfg.image_blur) >= 2.0);
            let d = steernav::low_level::steered::cpu::distance(&a.descriptor, &b.descriptor);
            if d < 1e-2 {
                agree += 1;
            }
        }
    }
    assert!(
        pairs > 50,
        "{pairs} shared keypoints of {} and {}",
        g.keypoints.len(),
        c.keypoints.len()
    );
    assert!(
        on_levels >= 10,
        "{on_levels} shared keypoints read on a pyramid level"
    );
    assert!(agree as f64 >= 0.97 * pairs as f64, "{agree} of {pairs}");
}

#[test]
fn descriptors_on_a_blurred_plane_match_the_cpu_twin() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    // A pyramid level carries a blur of 1 px: both twins smooth by what is missing.
    use steernav::low_level::steered::cpu::describe_steered_blurred;
    let frame = textured_scene(160, 120, 8);
    let (w, h) = (frame.width as usize, frame.height as usize);
    let mut rng = steernav::low_level::synth::Rng(9);
    let points: Vec<(f32, f32, f32)> = (0..80)
        .map(|i| {
            (
                rng.range(0.0, w as f32),
                rng.range(0.0, h as f32),
                [1.0, 1.41, 1.9][i % 3],
            )
        })
        .collect();
    let gpu = GpuSteered::new(ctx)
        .describe_blurred(&frame.gray, frame.width, frame.height, &points, 1.0)
        .unwrap();
    let close = points
        .iter()
        .zip(&gpu)
        .filter(|(&p, g)| {
            let c = describe_steered_blurred(&frame.gray, w, h, p, 1.0);
            c.values
                .iter()
                .zip(&g.values)
                .all(|(a, b)| (a - b).abs() <= 2e-3)
        })
        .count();
    assert!(
        close as f64 >= 0.97 * points.len() as f64,
        "{close} of {}",
        points.len()
    );
}

#[test]
fn planes_and_points_that_do_not_fit_are_refused() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    use steernav::low_level::steered::gpu::Plane;
    let gray = vec![0.5f32; 64 * 48];
    let plane = Plane {
        gray: &gray,
        width: 64,
        height: 48,
        prior_blur: 0.0,
    };
    let steered = GpuSteered::new(ctx);
    // A point naming a plane that is not there.
    let e = steered
        .describe_planes(&[plane], &[(1, (10.0, 10.0, 1.0))])
        .unwrap_err()
        .to_string();
    assert!(e.contains("plane") && e.contains("past the 1 given"), "{e}");
    // A plane whose size is not its pixel count.
    let wrong = Plane { width: 65, ..plane };
    let e = steered
        .describe_planes(&[wrong], &[(0, (10.0, 10.0, 1.0))])
        .unwrap_err()
        .to_string();
    assert!(e.contains("65x48"), "{e}");
    // No point: nothing to do, no error.
    assert!(steered.describe_planes(&[plane], &[]).unwrap().is_empty());
}
