//! Property tests of every text parser and of detect on arbitrary small images, and a seeded
//! fuzz pass over real-looking files: whatever the input, a result or an error that names the
//! input, never a panic. Cases are few and small so that the suite stays within the CI budget.

mod common;

use std::path::Path;
use std::time::{Duration, Instant};

use proptest::prelude::*;
use steernav::low_level::synth::Rng;
use steernav::settings::Settings;
use steernav::{Backend, Detector, DetectorConfig, Frame};

/// Runs `parse` on `text` written to a file named `name`; an error must name the file.
fn parses_or_names<T>(name: &str, text: &[u8], parse: impl Fn(&Path) -> steernav::Result<T>) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    if let Err(e) = parse(&path) {
        let message = e.to_string();
        assert!(message.contains(name), "{name}: {message}");
    }
}

/// Lines made of the tokens these formats use, shuffled and mangled.
fn token_lines() -> impl Strategy<Value = String> {
    let token = prop_oneof![
        Just("FLASER".to_string()),
        Just("ODOM".to_string()),
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-1e308".to_string()),
        Just("18446744073709551615".to_string()),
        Just("#".to_string()),
        Just("P0:".to_string()),
        (-1e6f64..1e6).prop_map(|v| format!("{v}")),
        (0u32..400).prop_map(|v| v.to_string()),
        "[a-z./]{0,8}",
    ];
    prop::collection::vec(prop::collection::vec(token, 0..24), 0..8).prop_map(|lines| {
        lines
            .iter()
            .map(|l| l.join(" "))
            .collect::<Vec<_>>()
            .join("\n")
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn carmen_logs(text in token_lines()) {
        parses_or_names("log.txt", text.as_bytes(), steernav::nav::carmen::read_log);
    }

    #[test]
    fn tum_trajectories(text in token_lines()) {
        parses_or_names("traj.txt", text.as_bytes(), steernav::slam::data::trajectory::read_tum);
    }

    #[test]
    fn kitti_files(text in token_lines()) {
        parses_or_names("poses.txt", text.as_bytes(), |p| steernav::slam::data::kitti::read_poses(p, &[0.0, 0.1, 0.2]));
        parses_or_names("times.txt", text.as_bytes(), steernav::slam::data::kitti::read_times);
        parses_or_names("calib.txt", text.as_bytes(), |p| steernav::slam::data::kitti::read_calibration(p, 640, 480));
    }

    #[test]
    fn homographies(text in token_lines()) {
        parses_or_names("H1to2p", text.as_bytes(), steernav::eval::homography::load);
    }

    #[test]
    fn tum_frame_lists(text in token_lines()) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("rgb")).unwrap();
        std::fs::write(dir.path().join("rgb.txt"), &text).unwrap();
        if let Err(e) = steernav::slam::data::sequence::open(dir.path(), None) {
            let message = e.to_string();
            prop_assert!(message.contains("rgb") || message.contains(&dir.path().display().to_string()), "{message}");
        }
    }

    #[test]
    fn settings_files(
        table in prop_oneof![Just("detector"), Just("slam"), Just("gist"), Just("nav"), Just("replay"), Just("synthetic"), Just("other")],
        key in "[a-z_]{1,16}",
        value in prop_oneof![
            Just("nan".to_string()), Just("-1".to_string()), Just("1e308".to_string()),
            Just("\"x\"".to_string()), Just("[]".to_string()), (0u32..100).prop_map(|v| v.to_string()),
        ],
    ) {
        let text = format!("[{table}]\n{key} = {value}\n");
        // Parsing either succeeds or says where: a line, a table or a key.
        if let Err(e) = Settings::from_toml_str(&text) {
            prop_assert!(e.line.is_some() || e.table.is_some() || e.key.is_some(), "{text}: {e}");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn detect_on_any_small_image(
        width in 1u32..=64,
        height in 1u32..=64,
        seed in any::<u64>(),
        flat in any::<bool>(),
    ) {
        let mut rng = Rng(seed);
        let n = (width * height * 3) as usize;
        let rgb: Vec<u8> = (0..n).map(|_| if flat { 128 } else { rng.next_u64() as u8 }).collect();
        let frame = Frame::from_rgb(width, height, rgb).unwrap();
        let detector = common::cpu_detector(&DetectorConfig::default());
        match detector.detect(&frame) {
            Ok(found) => prop_assert!(found.keypoints.len() <= 500),
            Err(e) => prop_assert!(e.to_string().contains("image"), "{e}"),
        }
    }
}

/// Flips, deletes, duplicates and truncates bytes of `original`, seeded.
fn mutate(original: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut bytes = original.to_vec();
    for _ in 0..1 + rng.next_u64() % 8 {
        if bytes.is_empty() {
            break;
        }
        let at = (rng.next_u64() % bytes.len() as u64) as usize;
        match rng.next_u64() % 4 {
            0 => bytes[at] ^= 1 << (rng.next_u64() % 8),
            1 => {
                bytes.remove(at);
            }
            2 => {
                let b = bytes[at];
                bytes.insert(at, b);
            }
            _ => bytes.truncate(at),
        }
    }
    bytes
}

#[test]
fn seeded_fuzz_of_images_logs_and_settings_never_panics() {
    let dir = tempfile::tempdir().unwrap();
    let scene = steernav::low_level::synth::textured_scene(48, 40, 3);
    let img = image::RgbImage::from_raw(48, 40, scene.rgb).unwrap();
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let mut jpeg = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut jpeg),
        image::ImageFormat::Jpeg,
    )
    .unwrap();
    let ranges: Vec<String> = (0..20)
        .map(|i| format!("{:.2}", 1.0 + 0.1 * i as f64))
        .collect();
    let log = format!(
        "ODOM 0 0 0 0 0 0 1.0 host 1.0\nFLASER 20 {} 0 0 0 0 0 0 1.0 host 1.0\nFLASER 20 {} 1 0 0 1 0 0 2.5 host 2.5\n",
        ranges.join(" "),
        ranges.join(" ")
    );
    let settings = "[detector]\norientations = 8\nscales = 3\n[slam.map]\nmax_landmarks = 60\n[gist]\nblocks = 4\n";
    let detector = Detector::new(
        &DetectorConfig {
            max_keypoints: 50,
            ..DetectorConfig::default()
        },
        Backend::Cpu,
    )
    .unwrap();
    let mut rng = Rng(2026);
    let slowest = |cases: &mut Vec<Duration>, start: Instant| cases.push(start.elapsed());
    let mut times = Vec::new();
    for case in 0..200 {
        let t = Instant::now();
        let path = dir.path().join(format!("case{case}.png"));
        std::fs::write(&path, mutate(&png, &mut rng)).unwrap();
        if let Ok(frame) = Frame::load(&path) {
            let _ = detector.detect(&frame);
        }
        let path = dir.path().join(format!("case{case}.jpg"));
        std::fs::write(&path, mutate(&jpeg, &mut rng)).unwrap();
        if let Ok(frame) = Frame::load(&path) {
            let _ = detector.detect(&frame);
        }
        let path = dir.path().join(format!("case{case}.log"));
        std::fs::write(&path, mutate(log.as_bytes(), &mut rng)).unwrap();
        let _ = steernav::nav::carmen::read_log(&path);
        let text = String::from_utf8_lossy(&mutate(settings.as_bytes(), &mut rng)).into_owned();
        let _ = Settings::from_toml_str(&text);
        slowest(&mut times, t);
    }
    let worst = times.iter().max().unwrap();
    assert!(
        *worst < Duration::from_secs(5),
        "a case took {worst:?}: work is not bounded by the input"
    );
}
