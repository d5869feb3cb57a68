//! Per-frame cost of the whole SLAM loop (paper §2.6: prediction, active search, update, map
//! management, and detection when the map needs landmarks) on generated drives and walks at
//! the sizes a robot's camera delivers, with the split per stage. Speed is measured here, never in tests.

use serde::Serialize;

use steernav::error::Result;
use steernav::features::{Backend, Detector, DetectorConfig};
use steernav::slam::config::SlamConfig;
use steernav::slam::data::synthetic::{SyntheticConfig, SyntheticMotion, SyntheticSequence};
use steernav::slam::{FrameReport, Slam};

/// One size and backend.
#[derive(Clone, Debug, Serialize)]
pub struct SlamBenchRow {
    /// The generated motion: `drive` (10 Hz car) or `walk` (30 Hz, furnished rooms).
    pub motion: SyntheticMotion,
    /// "cpu" or "gpu": where detection ran.
    pub backend: steernav::Backend,
    /// Frame size, pixels.
    pub width: u32,
    /// Frame size, pixels.
    pub height: u32,
    /// Frames processed.
    pub frames: usize,
    /// Median per-frame total, milliseconds.
    pub median_total_ms: f64,
    /// 90th percentile of the per-frame total, milliseconds.
    pub p90_total_ms: f64,
    /// Frames per second at the median total.
    pub frames_per_second: f64,
    /// Mean per frame of each stage, milliseconds: detection (only on frames that need new
    /// landmarks), association (KLT, search, RANSAC) and filter (prediction, update, map).
    pub mean_detection_ms: f64,
    /// See `mean_detection_ms`.
    pub mean_association_ms: f64,
    /// See `mean_detection_ms`.
    pub mean_filter_ms: f64,
    /// Frames on which detection ran.
    pub detections: usize,
}

/// Runs a generated 10 Hz drive and a 30 Hz walk through furnished rooms, `frames` frames
/// each, at each size on each backend, with the given detector and SLAM settings (`steernav
/// slam`'s: the tracking preset and the default `SlamConfig` unless a settings file changes
/// them); `progress` is called once per frame.
pub fn run(
    sizes: &[(u32, u32)],
    backends: &[Backend],
    frames: usize,
    (detector_config, slam_config): (&DetectorConfig, &SlamConfig),
    mut progress: impl FnMut(),
) -> Result<Vec<SlamBenchRow>> {
    let mut rows = Vec::new();
    for &(width, height) in sizes {
        for motion in MOTIONS {
            let seq = SyntheticSequence::new(sequence(motion, width, height, frames))?;
            let images: Vec<_> = (0..seq.poses.len()).map(|k| seq.render(k)).collect();
            for &backend in backends {
                let detector = Detector::new(detector_config, backend)?;
                let mut slam = Slam::new(seq.camera.clone(), slam_config.clone())?;
                let mut reports: Vec<FrameReport> = Vec::with_capacity(images.len());
                for (image, pose) in images.iter().zip(&seq.poses) {
                    reports.push(slam.process(image, pose.timestamp, None, &detector)?);
                    progress();
                }
                rows.push(summarise(
                    &reports,
                    motion,
                    detector.backend(),
                    width,
                    height,
                ));
            }
        }
    }
    Ok(rows)
}

/// The motions every size runs.
pub const MOTIONS: [SyntheticMotion; 2] = [SyntheticMotion::Drive, SyntheticMotion::Walk];

/// The generated sequence of `motion` at one size.
fn sequence(motion: SyntheticMotion, width: u32, height: u32, frames: usize) -> SyntheticConfig {
    let preset = SyntheticConfig::for_motion(motion);
    // A KITTI-like lens for wide frames, a usual webcam's otherwise.
    let fov_deg = if width as f64 > 2.5 * height as f64 {
        82.0
    } else {
        70.0
    };
    if motion != SyntheticMotion::Drive {
        return SyntheticConfig {
            width,
            height,
            frames,
            fov_deg,
            ..preset
        };
    }
    // Long enough for the whole drive at its fastest, with the far wall 35 m beyond.
    let length = 1.3 * preset.speed * frames as f64 / preset.fps;
    SyntheticConfig {
        width,
        height,
        frames,
        room: [
            preset.room[0],
            preset.room[1],
            preset.room[2].max(0.5 * length + 30.0),
        ],
        fov_deg,
        ..preset
    }
}

fn summarise(
    reports: &[FrameReport],
    motion: SyntheticMotion,
    backend: steernav::Backend,
    width: u32,
    height: u32,
) -> SlamBenchRow {
    let mut totals: Vec<f64> = reports.iter().map(|r| r.timings.total_ms).collect();
    totals.sort_by(f64::total_cmp);
    let quantile = |q: f64| totals[((totals.len() - 1) as f64 * q).round() as usize];
    let n = reports.len().max(1) as f64;
    let mean = |f: fn(&FrameReport) -> f64| reports.iter().map(f).sum::<f64>() / n;
    let median = quantile(0.5);
    SlamBenchRow {
        motion,
        backend,
        width,
        height,
        frames: reports.len(),
        median_total_ms: median,
        p90_total_ms: quantile(0.9),
        frames_per_second: 1e3 / median.max(1e-9),
        mean_detection_ms: mean(|r| r.timings.detection_ms),
        mean_association_ms: mean(|r| r.timings.association_ms),
        mean_filter_ms: mean(|r| r.timings.filter_ms),
        detections: reports
            .iter()
            .filter(|r| r.timings.detection_ms > 0.0)
            .count(),
    }
}

/// The rows as a text table.
pub fn table(rows: &[SlamBenchRow]) -> String {
    let mut out = String::from(
        "SLAM per frame (generated 10 Hz drive and 30 Hz walk; the [slam] and [detector] settings `steernav slam` would use)\n\
         motion  backend  size        frames  median ms  p90 ms  frames/s  detect ms  assoc ms  filter ms  detections\n",
    );
    for r in rows {
        out.push_str(&format!(
            "{:<7} {:<8} {:<11} {:>6} {:>10.2} {:>7.2} {:>9.1} {:>10.2} {:>9.2} {:>10.2} {:>11}\n",
            format!("{:?}", r.motion).to_lowercase(),
            r.backend.to_string(),
            format!("{}x{}", r.width, r.height),
            r.frames,
            r.median_total_ms,
            r.p90_total_ms,
            r.frames_per_second,
            r.mean_detection_ms,
            r.mean_association_ms,
            r.mean_filter_ms,
            r.detections
        ));
    }
    out
}
