//! Times `detect` (keypoints and descriptors) frame after frame on your own images, as a peer's
//! per-image figure is taken: 3 warm-up frames, then the median of 15, on one backend.
//! `cargo run --release --example time_images -- [cpu|gpu] [--config SETTINGS.toml] IMAGE...`
//! (the settings file's `[detector]` table over the defaults, as the CLI's `--config`).
use std::time::Instant;

use steernav::{Backend, Detector, DetectorConfig, Frame, Settings};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let backend: Backend = args
        .next()
        .ok_or("usage: time_images cpu|gpu [--config SETTINGS.toml] IMAGE...")?
        .parse()?;
    let mut args = args.peekable();
    let mut config = DetectorConfig::default();
    if args.peek().map(String::as_str) == Some("--config") {
        let path = args.nth(1).ok_or("--config needs a settings file")?;
        config = Settings::load(std::path::Path::new(&path))?.detector_over(config)?;
    }
    let detector = Detector::new(&config, backend)?;
    for path in args {
        let frame = Frame::load(std::path::Path::new(&path))?;
        for _ in 0..3 {
            detector.detect(&frame)?;
        }
        let mut ms: Vec<f64> = (0..15)
            .map(|_| {
                let t = Instant::now();
                detector
                    .detect(&frame)
                    .map(|_| t.elapsed().as_secs_f64() * 1e3)
            })
            .collect::<Result<_, _>>()?;
        ms.sort_by(f64::total_cmp);
        println!(
            "{path}: {}x{} median {:.1} ms on {} (10th–90th {:.1}–{:.1})",
            frame.width,
            frame.height,
            ms[7],
            detector.backend(),
            ms[1],
            ms[13]
        );
    }
    Ok(())
}
