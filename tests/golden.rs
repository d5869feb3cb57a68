//! Golden outputs: the CPU keypoints of `assets/sample.png` with the default settings, and the
//! trajectory of SLAM (tracking preset, default settings, revised frames applied) on the first
//! 90 frames of the generated room. A change that moves either beyond the tolerances below fails here, so a
//! change that means to move them says so by regenerating them:
//!
//! ```text
//! STEERNAV_BLESS=1 cargo test --release --test golden
//! ```
//!
//! which rewrites `tests/golden/*` (review the diff before committing it).
//!
//! Tolerances, for other CPUs and compilers (fused multiply-adds, vector widths): the same
//! keypoint count within 1%, 98% of the golden keypoints with a twin within 0.5 px at the same
//! scale, twins' responses within 1% of each other; every SLAM position within 0.5% of the
//! path length of the golden one, and no frame lost.

mod common;

use std::path::PathBuf;

use steernav::slam::config::SlamConfig;
use steernav::slam::data::synthetic::{SyntheticConfig, SyntheticSequence};
use steernav::slam::Slam;
use steernav::{DetectorConfig, Frame};

fn golden(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(name)
}

fn bless() -> bool {
    std::env::var_os("STEERNAV_BLESS").is_some_and(|v| v == "1")
}

/// (x, y, scale, response) of each keypoint, as the golden file holds them.
type Row = [f32; 4];

#[test]
fn sample_keypoints_match_the_golden_file() {
    let detector = common::cpu_detector(&DetectorConfig::default());
    let frame = Frame::load(&common::sample()).unwrap();
    let found: Vec<Row> = detector
        .detect(&frame)
        .unwrap()
        .keypoints
        .iter()
        .map(|k| [k.x, k.y, k.scale, k.response])
        .collect();
    let path = golden("sample_keypoints.json");
    if bless() {
        std::fs::write(&path, serde_json::to_string(&found).unwrap() + "\n").unwrap();
        return;
    }
    let text = std::fs::read_to_string(&path).expect("tests/golden/sample_keypoints.json");
    let expected: Vec<Row> = serde_json::from_str(&text).unwrap();
    let (n, m) = (expected.len(), found.len());
    assert!(n > 100, "the golden file holds {n} keypoints");
    assert!(m.abs_diff(n) * 100 <= n, "{m} keypoints against {n} golden");
    let mut twins = 0;
    for e in &expected {
        let twin = found
            .iter()
            .find(|f| (f[0] - e[0]).hypot(f[1] - e[1]) <= 0.5 && (f[2] / e[2] - 1.0).abs() < 1e-3);
        if let Some(f) = twin {
            assert!(
                (f[3] - e[3]).abs() <= 0.01 * e[3].abs(),
                "response {} against {} at ({}, {})",
                f[3],
                e[3],
                e[0],
                e[1]
            );
            twins += 1;
        }
    }
    assert!(
        twins * 100 >= 98 * n,
        "{twins} of {n} golden keypoints found again"
    );
}

#[test]
fn slam_trajectory_on_the_generated_room_matches_the_golden_file() {
    let seq = SyntheticSequence::new(SyntheticConfig {
        frames: 90,
        ..SyntheticConfig::default()
    })
    .unwrap();
    let detector = common::cpu_detector(&DetectorConfig::tracking());
    let mut slam = Slam::new(seq.camera.clone(), SlamConfig::default()).unwrap();
    let mut rows: Vec<[f64; 4]> = Vec::new();
    for (k, truth) in seq.poses.iter().enumerate() {
        let report = slam
            .process(&seq.render(k), truth.timestamp, None, &detector)
            .unwrap();
        assert!(!report.lost, "frame {k} lost");
        // The trajectory a caller keeps: frames the start revised take their new poses.
        for earlier in slam.take_revised() {
            let row = rows
                .iter_mut()
                .find(|r| r[0] == earlier.timestamp)
                .expect("a revised frame was reported before");
            let [x, y, z] = earlier.position;
            *row = [earlier.timestamp, x, y, z];
        }
        let [x, y, z] = report.position;
        rows.push([report.timestamp, x, y, z]);
    }
    let path = golden("room_trajectory.txt");
    if bless() {
        let text: String = rows
            .iter()
            .map(|r| format!("{:.6} {:.9} {:.9} {:.9}\n", r[0], r[1], r[2], r[3]))
            .collect();
        std::fs::write(&path, text).unwrap();
        return;
    }
    let text = std::fs::read_to_string(&path).expect("tests/golden/room_trajectory.txt");
    let expected: Vec<[f64; 4]> = text
        .lines()
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect();
    assert_eq!(rows.len(), expected.len());
    let length = seq.path_length();
    for (r, e) in rows.iter().zip(&expected) {
        assert!(
            (r[0] - e[0]).abs() < 1e-6,
            "timestamps {} and {}",
            r[0],
            e[0]
        );
        let d = ((r[1] - e[1]).powi(2) + (r[2] - e[2]).powi(2) + (r[3] - e[3]).powi(2)).sqrt();
        assert!(
            d <= 0.005 * length,
            "t={}: {d:.4} m from the golden position on a {length:.2} m path",
            r[0]
        );
    }
}
