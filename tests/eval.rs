//! Evaluation end to end on generated images: the rotation sweep, an Oxford-layout sequence
//! made on the fly, the CSV and the figure. Peers are not needed (CI has no OpenCV).

mod common;

use std::path::Path;

use steernav::eval::homography::{self, IDENTITY};
use steernav::eval::sweep::{
    homography_sequence, parse_angles, rotation_sweep, summarize, to_csv, EvalOptions, CSV_HEADER,
};
use steernav::low_level::synth::textured_scene;
use steernav::DetectorConfig;

fn save(frame: &steernav::Frame, path: &Path) {
    image::RgbImage::from_raw(frame.width, frame.height, frame.rgb.clone())
        .unwrap()
        .save(path)
        .unwrap();
}

#[test]
fn rotation_sweep_on_a_small_scene_writes_csv_and_figure() {
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("scene.png");
    save(&textured_scene(256, 192, 21), &img);
    let det = common::cpu_detector(&DetectorConfig::default());
    let angles = parse_angles("0:360:90").unwrap();
    assert_eq!(angles, vec![0.0, 90.0, 180.0, 270.0]);
    let opts = EvalOptions::default();
    let rows = rotation_sweep(
        std::slice::from_ref(&img),
        &angles,
        Some(&det),
        None,
        &opts,
        &|_| {},
    )
    .unwrap();
    assert_eq!(rows.len(), angles.len() * opts.eps.len());
    for r in &rows {
        assert!((0.0..=1.0).contains(&r.repeatability) && (0.0..=1.0).contains(&r.recall));
        assert!(r.count > 20.0, "{r:?}");
        if r.angle == 0.0 {
            assert_eq!(r.repeatability, 1.0, "the identical view repeats fully");
        } else if r.eps >= 2.0 {
            assert!(r.repeatability >= 0.85, "{r:?}");
        }
    }
    let summary = summarize(&rows, 2.0);
    assert_eq!(summary.len(), 1);
    assert!(
        summary[0].mean_repeatability >= 0.85
            && summary[0].min_repeatability <= summary[0].mean_repeatability
    );
    // CSV: exact header, parseable numbers.
    let csv = to_csv(&rows);
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some(CSV_HEADER));
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), 7, "{line}");
        assert_eq!(f[0], "steernav");
        for v in &f[2..] {
            v.parse::<f64>().unwrap();
        }
    }
    let png = dir.path().join("fig/rotation.png");
    steernav::eval::figure::metrics_figure(&png, &rows, 2.0, "rotation", "angle").unwrap();
    let fig = image::open(&png).unwrap();
    assert!(fig.width() > 500 && fig.height() > 300);
}

#[test]
fn homography_sequence_in_the_oxford_layout() {
    let dir = tempfile::tempdir().unwrap();
    let scene = textured_scene(400, 300, 22);
    save(&scene, &dir.path().join("img1.png"));
    // img2: the scene rotated by 30° on an expanded canvas, with its ground truth H1to2p.
    let (cw, ch) = steernav::eval::sweep::expanded_canvas(400, 300, 30.0);
    let (turned, m) = steernav::low_level::synth::rotate(&scene, 30f32.to_radians(), cw, ch);
    save(&turned, &dir.path().join("img2.png"));
    let h = homography::from_affine(&m);
    let text: String = h
        .chunks(3)
        .map(|r| format!("{} {} {}\n", r[0], r[1], r[2]))
        .collect();
    std::fs::write(dir.path().join("H1to2p"), text).unwrap();
    // img3 without its homography is ignored.
    save(&scene, &dir.path().join("img3.png"));
    let det = common::cpu_detector(&DetectorConfig::default());
    let (rows, matching) =
        homography_sequence(dir.path(), Some(&det), None, &EvalOptions::default()).unwrap();
    assert_eq!(rows.len(), 3);
    // The rotated view matches, and its RANSAC homography is the true one at the corners.
    assert_eq!(matching.len(), 1);
    assert!(
        matching[0].matches >= 50 && matching[0].mma(3) >= 0.8,
        "{:?}",
        matching[0]
    );
    assert!(matching[0].accurate(3.0), "{:?}", matching[0]);
    let at2 = rows.iter().find(|r| r.eps == 2.0).unwrap();
    assert_eq!(at2.angle, 2.0);
    // 0.756 with the octave defaults (coarse keypoints are placed less exactly than 2 px).
    assert!(at2.repeatability >= 0.7, "{at2:?}");
}

#[test]
fn generated_sequences_are_judged_like_the_given_ones() {
    use steernav::eval::generate::{write_sequence, Change};
    let scene = textured_scene(400, 300, 23);
    let det = common::cpu_detector(&DetectorConfig::matching());
    for change in [Change::Blur, Change::Jpeg, Change::Zoom] {
        let dir = tempfile::tempdir().unwrap();
        write_sequence(dir.path(), &scene, change).unwrap();
        let (_, matching) =
            homography_sequence(dir.path(), Some(&det), None, &EvalOptions::default()).unwrap();
        assert_eq!(matching.len(), 5, "{change:?}");
        // The mildest view of each change matches well and gives the true map.
        assert!(
            matching[0].mma(3) >= 0.8 && matching[0].accurate(3.0),
            "{change:?}: {:?}",
            matching[0]
        );
    }
}

#[test]
fn malformed_inputs_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let h = dir.path().join("H1to2p");
    std::fs::write(&h, "1 0 0\n0 1 0\n0 0").unwrap();
    let e = homography::load(&h).unwrap_err().to_string();
    assert!(
        e.contains("H1to2p") && e.contains("expected 9 numbers"),
        "{e}"
    );
    std::fs::write(&h, "1 0 0 0 1 0 0 0 nan").unwrap();
    assert!(homography::load(&h).is_err());
    std::fs::write(&h, "0 0 0 0 0 0 0 0 0").unwrap();
    assert!(homography::load(&h)
        .unwrap_err()
        .to_string()
        .contains("invertible"));
    let e = homography_sequence(dir.path(), None, None, &EvalOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("img1"), "{e}");
    for bad in ["0:360:0", "10:0:5", "a,b", "", "0:1e9:1e-9"] {
        assert!(parse_angles(bad).is_err(), "{bad}");
    }
    assert_eq!(homography::project(&IDENTITY, 3.0, 4.0), Some((3.0, 4.0)));
}

#[test]
fn a_negative_region_margin_is_refused_by_name() {
    let out = common::steernav()
        .args([
            "eval",
            "rotation",
            "--detectors",
            "steernav",
            "--backend",
            "cpu",
        ])
        .args(["--region-margin=-1", "--images"])
        .arg(common::sample())
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--region-margin"));
}
