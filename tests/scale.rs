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
    // A quarter octave: halfway between two sampled scales, where rounding to them errs most.
    let z = 2f32.powf(0.25);
    let zoomed = magnified(&frame, z as f64);
    let a = detector.detect(&frame).unwrap().keypoints;
    let b = detector.detect(&zoomed).unwrap().keypoints;
    // The scales rounded to the sampled σ_D: what the keypoints carried before the offset.
    let sampled = |s: f32| {
        let sigma_d = detection_scale(s);
        total_scale(step.powf((sigma_d / config.sigma0).log(step).round()) * config.sigma0)
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
