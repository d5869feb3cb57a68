//! Scale selection: a keypoint's scale follows a zoom of the image, between the sampled scales
//! too (the sub-scale offset of the peak across scales).

mod common;

use common::magnified;

use steernav::features::{DetectorConfig, Keypoint};
use steernav::low_level::harris::plan::{detection_scale, total_scale};
use steernav::low_level::synth::textured_scene;

/// |log2(scale ratio / z)| of every keypoint of `a` whose magnified position has a keypoint
/// of `b` within 1.5 px, with each scale passed through `scale`.
fn scale_errors(a: &[Keypoint], b: &[Keypoint], z: f32, scale: impl Fn(f32) -> f32) -> Vec<f32> {
    a.iter()
        .filter_map(|p| {
            let (x, y) = (p.x * z, p.y * z);
            let q = b.iter().min_by(|u, v| {
                let d = |k: &&Keypoint| (k.x - x).hypot(k.y - y);
                d(u).total_cmp(&d(v))
            })?;
            ((q.x - x).hypot(q.y - y) <= 1.5)
                .then(|| (scale(q.scale) / (z * scale(p.scale))).log2().abs())
        })
        .collect()
}

fn median(mut v: Vec<f32>) -> f32 {
    v.sort_by(f32::total_cmp);
    v[v.len() / 2]
}

#[test]
fn keypoint_scales_follow_a_zoom_between_the_sampled_scales() {
    let config = DetectorConfig::default();
    let step = config.scale_step;
    let detector = common::cpu_detector(&config);
    let frame = textured_scene(320, 240, 4);
    // Half a scale step: halfway between two sampled scales, where rounding to them errs most.
    let z = step.sqrt();
    let zoomed = magnified(&frame, z as f64);
    let a = detector.detect(&frame).unwrap().keypoints;
    let b = detector.detect(&zoomed).unwrap().keypoints;
    // The scales rounded to the sampled σ_D: what the keypoints carried before the offset.
    let sampled = |s: f32| {
        let sigma_d = detection_scale(s, config.image_blur);
        total_scale(
            step.powf((sigma_d / config.sigma0).log(step).round()) * config.sigma0,
            config.image_blur,
        )
    };
    let continuous = scale_errors(&a, &b, z, |s| s);
    let rounded = scale_errors(&a, &b, z, sampled);
    println!("{} of {}", continuous.len(), a.len());
    assert!(
        continuous.len() >= 40,
        "{} correspondences",
        continuous.len()
    );
    let (c, r) = (median(continuous), median(rounded));
    println!("median |log2 scale error|: continuous {c:.3}, rounded {r:.3}");
    assert!(c < 0.8 * r, "continuous {c} against rounded {r}");
}

#[test]
fn the_image_blur_setting_moves_the_scales_and_not_the_keypoints() {
    let frame = textured_scene(320, 240, 5);
    let sharp = DetectorConfig {
        image_blur: 0.4,
        ..DetectorConfig::default()
    };
    let (a, b) = (
        common::cpu_detector(&DetectorConfig::default())
            .detect(&frame)
            .unwrap()
            .keypoints,
        common::cpu_detector(&sharp)
            .detect(&frame)
            .unwrap()
            .keypoints,
    );
    assert!(a.len() > 30 && a.len() == b.len());
    let default_blur = DetectorConfig::default().image_blur;
    let mut described_apart = 0;
    for (p, q) in a.iter().zip(&b) {
        assert!(p.x == q.x && p.y == q.y && p.response == q.response);
        let (dp, dq) = (
            detection_scale(p.scale, default_blur),
            detection_scale(q.scale, 0.4),
        );
        assert!((dp - dq).abs() < 1e-4 * dp, "σ_D {dp} against {dq}");
        assert!(q.scale < p.scale);
        described_apart += usize::from(p.descriptor != q.descriptor);
    }
    // The descriptor's window and smoothing follow the scale.
    assert!(described_apart > a.len() / 2);
    let bad = DetectorConfig {
        image_blur: -0.1,
        ..DetectorConfig::default()
    };
    let err = bad.validate().unwrap_err().to_string();
    assert!(err.contains("image_blur"), "{err}");
}
