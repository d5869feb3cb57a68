//! A dim copy of a scene keeps its keypoints. Harris responses scale with contrast⁴, so a fixed
//! response floor alone loses dim and blurred images; the floor relative to the image's
//! strongest candidate (`relative_threshold`) does not.

use steernav::eval::repeatability::repeatability;
use steernav::synth::textured_scene;
use steernav::{Backend, Detector, DetectorConfig, Frame};

const ID: [f64; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

/// Contrast × `gain` around mid-grey (responses × gain⁴, up to 8-bit rounding).
fn dimmed(frame: &Frame, gain: f32) -> Frame {
    let rgb = frame
        .rgb
        .iter()
        .map(|&v| {
            (128.0 + (v as f32 - 128.0) * gain)
                .round()
                .clamp(0.0, 255.0) as u8
        })
        .collect();
    Frame::from_rgb(frame.width, frame.height, rgb).unwrap()
}

fn points(det: &Detector, frame: &Frame) -> Vec<(f64, f64)> {
    det.detect(frame)
        .unwrap()
        .keypoints
        .iter()
        .map(|k| (k.x as f64, k.y as f64))
        .collect()
}

#[test]
fn a_dim_copy_keeps_its_keypoints() {
    let scene = textured_scene(320, 240, 11);
    let dim = dimmed(&scene, 0.3);
    let size = (scene.width, scene.height);
    let config = DetectorConfig {
        max_keypoints: 200,
        ..Default::default()
    };
    let det = Detector::new(&config, Backend::Cpu).unwrap();
    let (bright, faint) = (points(&det, &scene), points(&det, &dim));
    assert_eq!((bright.len(), faint.len()), (200, 200));
    let r = repeatability(&bright, size, &faint, size, &ID, 1.0, 0.0);
    assert!(r.ratio >= 0.9, "dim copy repeats {:.3}", r.ratio);

    // The former fixed floor alone, for contrast: the dim copy loses most of its keypoints.
    let fixed = Detector::new(
        &DetectorConfig {
            threshold: 1e-8,
            relative_threshold: 0.0,
            ..config
        },
        Backend::Cpu,
    )
    .unwrap();
    let (bright, faint) = (points(&fixed, &scene), points(&fixed, &dim));
    assert!(
        faint.len() * 2 < bright.len(),
        "{} of {}",
        faint.len(),
        bright.len()
    );
}

#[test]
fn grey_noise_alone_gives_no_keypoints() {
    // Flat grey with ±2 grey levels of uniform noise: below the absolute floor everywhere,
    // so the relative threshold cannot turn the noise into keypoints.
    let (w, h) = (160u32, 120u32);
    let mut rng = steernav::synth::Rng(5);
    let rgb: Vec<u8> = (0..w * h)
        .flat_map(|_| {
            let v = (128.0 + rng.range(-2.0, 2.0)).round() as u8;
            [v, v, v]
        })
        .collect();
    let frame = Frame::from_rgb(w, h, rgb).unwrap();
    let det = Detector::new(&DetectorConfig::default(), Backend::Cpu).unwrap();
    assert_eq!(det.detect(&frame).unwrap().keypoints.len(), 0);
}
