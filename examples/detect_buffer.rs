//! Detect keypoints on an RGB buffer the program already holds (a camera driver's frame, a
//! decoded video frame), without touching the file system:
//! `cargo run --release --example detect_buffer`.
use steernav::{Backend, Detector, DetectorConfig, Frame};

fn main() -> Result<(), steernav::Error> {
    // Stand-in for a camera frame: 320×240 RGB bytes, row after row.
    let (width, height) = (320u32, 240u32);
    let rgb = steernav::low_level::synth::textured_scene(width, height, 3).rgb;
    let frame = Frame::from_rgb(width, height, rgb)?;
    let config = DetectorConfig {
        max_keypoints: 200,
        ..DetectorConfig::default()
    };
    let detector = Detector::new(&config, Backend::Cpu)?;
    let found = detector.detect(&frame)?;
    println!(
        "{} keypoints on the {} backend",
        found.keypoints.len(),
        found.backend
    );
    for k in found.keypoints.iter().take(5) {
        println!(
            "  x {:6.1}  y {:6.1}  scale {:4.2}  angle {:4.2} rad",
            k.x, k.y, k.scale, k.angle
        );
    }
    Ok(())
}
