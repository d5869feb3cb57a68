//! The command line end to end: detect's JSON and CSV, --out/--draw, batch with a corrupt
//! file, re-runs that skip finished images, --force, info, --help.

mod common;

use std::path::Path;
use std::process::Command;

use common::{assert_ok, refused, run_ok, sample, steernav};

#[test]
fn detect_prints_the_design_json_for_one_image() {
    let out = run_ok(
        steernav()
            .args(["detect", "--backend", "cpu", "--max-keypoints", "50"])
            .arg(sample()),
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let obj = v.as_object().unwrap();
    let keys: Vec<&str> = obj.keys().map(String::as_str).collect();
    assert_eq!(keys.len(), 7);
    for k in [
        "image",
        "width",
        "height",
        "backend",
        "descriptor",
        "descriptor_length",
        "keypoints",
    ] {
        assert!(obj.contains_key(k), "missing {k}");
    }
    assert_eq!(
        (
            v["width"].as_u64(),
            v["height"].as_u64(),
            v["backend"].as_str()
        ),
        (Some(640), Some(480), Some("cpu"))
    );
    let kps = v["keypoints"].as_array().unwrap();
    assert_eq!(kps.len(), 50);
    let mut fields: Vec<&str> = kps[0]
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    fields.sort_unstable();
    assert_eq!(
        fields,
        ["angle", "descriptor", "response", "scale", "x", "y"]
    );
    assert_eq!(v["descriptor"], "steered");
    assert_eq!(v["descriptor_length"], 128);
    assert_eq!(kps[0]["descriptor"].as_array().unwrap().len(), 128);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("keypoints per scale"), "{stderr}");
}

#[test]
fn detect_writes_files_and_pictures_for_several_images() {
    let dir = tempfile::tempdir().unwrap();
    let second = dir.path().join("copy.png");
    std::fs::copy(sample(), &second).unwrap();
    let out_dir = dir.path().join("out");
    run_ok(
        steernav()
            .args(["detect", "--backend", "cpu", "--csv", "--draw"])
            .args(["--descriptor", "entropy", "--out"])
            .arg(&out_dir)
            .arg(sample())
            .arg(&second),
    );
    let csv = std::fs::read_to_string(out_dir.join("sample.csv")).unwrap();
    assert!(csv.starts_with("x,y,scale,angle,response,h16,h32,h64,h128,h256\n"));
    assert_eq!(csv.lines().count(), 501);
    assert!(out_dir.join("copy.csv").exists());
    let png = image::open(out_dir.join("sample_keypoints.png")).unwrap();
    assert_eq!((png.width(), png.height()), (640, 480));
}

#[test]
fn detect_reports_bad_files_and_keeps_going() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("broken.png");
    std::fs::write(&bad, b"\x89PNG\r\n\x1a\nbroken").unwrap();
    let out_dir = dir.path().join("out");
    refused(
        steernav()
            .args(["detect", "--backend", "cpu", "--out"])
            .arg(&out_dir)
            .arg(&bad)
            .arg(sample()),
        &["broken.png"],
    );
    assert!(
        out_dir.join("sample.json").exists(),
        "the good image's result is kept"
    );
}

#[test]
fn batch_processes_a_tree_skips_done_work_and_reports_failures() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in");
    std::fs::create_dir_all(input.join("sub")).unwrap();
    std::fs::copy(sample(), input.join("a.png")).unwrap();
    let small = image::open(sample()).unwrap().resize_exact(
        160,
        120,
        image::imageops::FilterType::Triangle,
    );
    small.save(input.join("sub/b.bmp")).unwrap();
    small.to_luma8().save(input.join("sub/c.pgm")).unwrap();
    std::fs::write(input.join("sub/corrupt.jpg"), b"not a jpeg").unwrap();
    std::fs::write(input.join("notes.txt"), b"ignored").unwrap();
    let output = dir.path().join("out");
    let run = |extra: &[&str]| {
        steernav()
            .args(["batch", "--backend", "cpu"])
            .arg(&input)
            .arg("--out")
            .arg(&output)
            .args(extra)
            .output()
            .unwrap()
    };
    let first = run(&[]);
    assert!(
        !first.status.success(),
        "a failed image makes the exit code non-zero"
    );
    assert!(String::from_utf8_lossy(&first.stderr).contains("corrupt.jpg"));
    for f in ["a.png.json", "sub/b.bmp.json", "sub/c.pgm.json"] {
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(output.join(f)).unwrap()).unwrap();
        assert!(!v["keypoints"].as_array().unwrap().is_empty(), "{f}");
    }
    let summary = std::fs::read_to_string(output.join("summary.csv")).unwrap();
    assert!(
        summary.starts_with("image,status,width,height,keypoints,candidates,backend,ms,error\n")
    );
    assert_eq!(summary.lines().filter(|l| l.contains(",done,")).count(), 3);
    assert_eq!(
        summary.lines().filter(|l| l.contains(",failed,")).count(),
        1
    );

    let before = std::fs::metadata(output.join("a.png.json"))
        .unwrap()
        .modified()
        .unwrap();
    std::fs::remove_file(input.join("sub/corrupt.jpg")).unwrap();
    let second = run(&[]);
    assert_ok(&second);
    let summary = std::fs::read_to_string(output.join("summary.csv")).unwrap();
    assert_eq!(
        summary.lines().filter(|l| l.contains(",skipped,")).count(),
        3
    );
    assert_eq!(
        std::fs::metadata(output.join("a.png.json"))
            .unwrap()
            .modified()
            .unwrap(),
        before
    );
    let third = run(&["--force"]);
    assert!(third.status.success());
    let summary = std::fs::read_to_string(output.join("summary.csv")).unwrap();
    assert_eq!(summary.lines().filter(|l| l.contains(",done,")).count(), 3);
}

#[test]
fn malformed_config_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("bad.toml");
    std::fs::write(&cfg, "[detector]\nbasis_sigma = nan\n").unwrap();
    refused(
        steernav()
            .args(["detect", "--backend", "cpu", "--config"])
            .arg(&cfg)
            .arg(sample()),
        &["bad.toml", "basis_sigma"],
    );
}

#[test]
fn help_explains_every_flag() {
    for cmd in ["detect", "batch"] {
        let out = steernav().args([cmd, "--help"]).output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        for flag in [
            "--backend",
            "--orientations",
            "--scales",
            "--max-keypoints",
            "--config",
            "--merge",
            "--out",
        ] {
            assert!(text.contains(flag), "{cmd} --help lacks {flag}");
        }
    }
    let out = steernav().arg("info").output().unwrap();
    assert!(String::from_utf8_lossy(&out.stdout).contains("cpu threads"));
}

#[test]
fn eval_rotation_writes_the_csv_and_the_figure() {
    let dir = tempfile::tempdir().unwrap();
    let small = image::open(sample()).unwrap().resize_exact(
        200,
        150,
        image::imageops::FilterType::Triangle,
    );
    let img = dir.path().join("small.png");
    small.save(&img).unwrap();
    let (csv, png) = (
        dir.path().join("rotation.csv"),
        dir.path().join("rotation.png"),
    );
    let out = run_ok(
        steernav()
            .args([
                "eval",
                "rotation",
                "--backend",
                "cpu",
                "--detectors",
                "steernav",
                "--angles",
                "0,90",
                "--images",
            ])
            .arg(&img)
            .arg("--out")
            .arg(dir.path()),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("steernav") && stdout.contains("mean rep."),
        "{stdout}"
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("detector,image,angle,eps,repeatability,recall,count\n"));
    assert_eq!(text.lines().count(), 1 + 2 * 3);
    assert!(image::open(&png).is_ok());
    refused(
        steernav()
            .args(["eval", "rotation", "--detectors", "nope", "--images"])
            .arg(&img),
        &["unknown detector 'nope'"],
    );
}

#[test]
fn bench_prints_json_rows_with_the_documented_keys() {
    let out = run_ok(steernav().args([
        "bench",
        "--sizes",
        "96x64",
        "--backend",
        "cpu",
        "--runs",
        "3",
        "--warmup",
        "1",
        "--json",
    ]));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v.as_array().unwrap();
    let stages: Vec<&str> = rows.iter().map(|r| r["stage"].as_str().unwrap()).collect();
    for s in [
        "filters + tensor + responses",
        "nms + compaction",
        "clustering",
        "descriptors",
        "end to end",
    ] {
        assert!(stages.contains(&s), "missing {s}: {stages:?}");
    }
    for r in rows {
        let mut keys: Vec<&str> = r.as_object().unwrap().keys().map(String::as_str).collect();
        keys.sort_unstable();
        assert_eq!(
            keys,
            ["backend", "median_ms", "p10_ms", "p90_ms", "size", "stage"]
        );
        assert_eq!(
            (r["backend"].as_str(), r["size"].as_str()),
            (Some("cpu"), Some("96x64"))
        );
        let (p10, med, p90) = (
            r["p10_ms"].as_f64().unwrap(),
            r["median_ms"].as_f64().unwrap(),
            r["p90_ms"].as_f64().unwrap(),
        );
        assert!(p10 <= med && med <= p90);
    }
    refused(
        steernav().args(["bench", "--sizes", "0x10", "--backend", "cpu"]),
        &["0x10"],
    );
}

#[test]
fn slam_synth_slam_and_slam_eval_work_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let seq = dir.path().join("room");
    run_ok(steernav().args([
        "slam-synth",
        "--out",
        seq.to_str().unwrap(),
        "--frames",
        "30",
    ]));
    let traj = dir.path().join("trajectory.txt");
    let map = dir.path().join("map.json");
    let plot = dir.path().join("slam.png");
    let out = steernav()
        .args(["slam", seq.to_str().unwrap(), "--backend", "cpu", "--calib"])
        .arg(seq.join("calib.toml"))
        .arg("--out")
        .arg(dir.path())
        .arg("--map")
        .arg(&map)
        .arg("--plot")
        .arg(&plot)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_ok(&out);
    assert!(stdout.contains("ATE"), "{stdout}");
    // The processing rate is set against the rate the frames were taken at (30 Hz room).
    assert!(stdout.contains("the sequence's 30.0"), "{stdout}");
    let lines: Vec<String> = std::fs::read_to_string(&traj)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(String::from)
        .collect();
    assert_eq!(lines.len(), 30);
    assert_eq!(
        lines[0].split_whitespace().count(),
        8,
        "TUM: t tx ty tz qx qy qz qw"
    );
    let points: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&map).unwrap()).unwrap();
    assert!(points.as_array().unwrap()[0]["covariance"].is_array());
    assert!(image::open(&plot).is_ok());
    let out = run_ok(
        steernav()
            .args(["slam-eval", "--json"])
            .arg(&traj)
            .arg(seq.join("groundtruth.txt")),
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in ["ate_rmse", "scale", "path_length", "matched"] {
        assert!(v[key].is_number(), "missing {key}: {v}");
    }
    // 30 frames at 30 Hz span 0.97 s, less than the RPE's 1 s: null, not a meaningless 0.
    assert!(v["rpe_trans"].is_null(), "{v}");
    assert_eq!(v["matched"], 30);
    // A calibration with zero focal length is refused, naming the field and the file.
    let bad = dir.path().join("bad.toml");
    std::fs::write(
        &bad,
        "[camera]\nfx = 0\nfy = 100\ncx = 1\ncy = 1\nwidth = 320\nheight = 240\n",
    )
    .unwrap();
    refused(
        steernav().args([
            "slam",
            seq.to_str().unwrap(),
            "--calib",
            bad.to_str().unwrap(),
        ]),
        &["bad.toml", "camera.fx"],
    );
    let out = steernav().args(["slam", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    for flag in [
        "--calib",
        "--odometry",
        "--out",
        "--map",
        "--plot",
        "--fps",
        "--backend",
    ] {
        assert!(help.contains(flag), "slam --help lacks {flag}");
    }
}

#[test]
fn nav_and_nav_eval_run_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let plot = dir.path().join("nav.png");
    let out = run_ok(
        steernav()
            .args([
                "nav", "--random", "3", "--mode", "laser", "--json", "--plot",
            ])
            .arg(&plot),
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        v["outcome"].is_string() && v["path_length"].is_number(),
        "{v}"
    );
    assert!(image::open(&plot).is_ok());
    let out = steernav()
        .args([
            "nav-eval",
            "--episodes",
            "3",
            "--train",
            "2",
            "--seed",
            "4",
            "--json",
            "--plot",
        ])
        .arg(dir.path().join("eval.png"))
        .output()
        .unwrap();
    assert!(image::open(dir.path().join("eval.png")).is_ok());
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for mode in ["laser", "fusion"] {
        for key in [
            "episodes",
            "success_rate",
            "collisions",
            "path_length",
            "time_to_goal",
            "position_error_std",
        ] {
            assert!(v[mode][key].is_number(), "{mode}.{key} missing: {v}");
        }
    }
    assert_eq!(v["laser"]["episodes"], 3);
    assert_eq!(
        v.as_object().unwrap().len(),
        2,
        "exactly laser and fusion: {v}"
    );
    let out = steernav()
        .args([
            "nav-sweep",
            "--samples",
            "2",
            "--episodes",
            "3",
            "--seed",
            "2",
        ])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && text.contains("(base)"), "{text}");
    let best = text
        .split("Best as a config file:\n")
        .nth(1)
        .expect("best config printed");
    let config = dir.path().join("best.toml");
    std::fs::write(&config, best).unwrap();
    let out = steernav()
        .args(["nav", "--random", "3", "--json", "--config"])
        .arg(&config)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "the printed config must load: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let bad = dir.path().join("bad.toml");
    std::fs::write(
        &bad,
        "size = [8.0, 8.0]\nstart = [-1.0, 1.0, 0.0]\ngoal = [7.0, 7.0]\n",
    )
    .unwrap();
    refused(
        steernav().args(["nav", "--world", bad.to_str().unwrap()]),
        &["bad.toml", "world.start"],
    );
}

#[test]
fn bench_slam_suite_times_the_drive_and_the_walk() {
    let out = run_ok(steernav().args([
        "bench",
        "--suite",
        "slam",
        "--backend",
        "cpu",
        "--sizes",
        "160x120",
        "--frames",
        "10",
        "--json",
    ]));
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    let motions: Vec<&str> = rows.iter().map(|r| r["motion"].as_str().unwrap()).collect();
    assert_eq!(motions, ["drive", "walk"]);
    for r in &rows {
        assert_eq!(r["frames"], 10, "{r}");
        assert!(r["median_total_ms"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["detections"].as_u64().unwrap() >= 1, "{r}");
    }
    // It reads the [slam] table as `steernav slam` does: a bad value is refused by name.
    let dir = tempfile::tempdir().unwrap();
    let settings = dir.path().join("s.toml");
    std::fs::write(&settings, "[slam.map]\nmax_landmarks = 4\n").unwrap();
    refused(
        steernav()
            .args(["bench", "--suite", "slam", "--backend", "cpu"])
            .args(["--frames", "10", "--config"])
            .arg(&settings),
        &["slam.map.max_landmarks"],
    );
}

#[test]
fn bench_nav_suite_times_gist_and_the_field() {
    let out = run_ok(steernav().args([
        "bench",
        "--suite",
        "nav",
        "--backend",
        "cpu",
        "--runs",
        "1",
        "--warmup",
        "0",
        "--json",
    ]));
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(rows.len(), 5, "2 GIST sizes + 3 field sizes");
    for r in &rows {
        for key in ["stage", "backend", "size", "median_ms", "p10_ms", "p90_ms"] {
            assert!(!r[key].is_null(), "{key} missing in {r}");
        }
    }
    assert!(rows.iter().any(|r| r["size"] == "B=4096"));
}

/// A `slam-synth` sequence of `frames` frames of `motion` in `dir`/synth.
fn generated(dir: &std::path::Path, motion: &str, frames: usize) -> std::path::PathBuf {
    let synth = dir.join("synth");
    run_ok(
        steernav()
            .args(["slam-synth", "--out", synth.to_str().unwrap()])
            .args(["--motion", motion, "--frames", &frames.to_string()]),
    );
    synth
}

/// `slam --wheeled` runs the wheeled motion model and says the arm it learnt; it refuses to be
/// combined with wheel odometry, which measures the motion instead of modelling it.
#[test]
fn slam_wheeled_reports_the_arm_and_refuses_odometry_beside_it() {
    let dir = tempfile::tempdir().unwrap();
    let synth = generated(dir.path(), "drive", 20);
    let out = run_ok(
        steernav()
            .args(["slam", synth.to_str().unwrap(), "--backend", "cpu"])
            .args([
                "--wheeled",
                "--out",
                dir.path().join("out").to_str().unwrap(),
            ]),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("wheeled model: camera"), "{stdout}");
    assert!(stdout.contains("the arm at the fitted scale"), "{stdout}");
    refused(
        steernav()
            .args(["slam", synth.to_str().unwrap(), "--wheeled", "--odometry"])
            .arg(synth.join("groundtruth.txt")),
        &["--wheeled", "--odometry"],
    );
}

/// `slam --hand-held` reaches the filter (the trajectory differs from the default's on the
/// same frames) and refuses to be combined with the wheeled model.
#[test]
fn slam_hand_held_changes_the_motion_model_and_refuses_wheeled_beside_it() {
    let dir = tempfile::tempdir().unwrap();
    let synth = generated(dir.path(), "room", 40);
    let trajectory = |name: &str, flags: &[&str]| {
        let out = dir.path().join(name);
        run_ok(
            steernav()
                .args(["slam", synth.to_str().unwrap(), "--backend", "cpu"])
                .args(["--out", out.to_str().unwrap()])
                .args(flags),
        );
        std::fs::read_to_string(out.join("trajectory.txt")).unwrap()
    };
    let default = trajectory("default", &[]);
    let hand_held = trajectory("hand-held", &["--hand-held"]);
    assert_eq!(default.lines().count(), hand_held.lines().count());
    assert_ne!(default, hand_held, "--hand-held left the filter unchanged");
    refused(
        steernav().args(["slam", synth.to_str().unwrap(), "--hand-held", "--wheeled"]),
        &["--hand-held", "--wheeled"],
    );
}

#[test]
fn slam_reads_a_kitti_folder_and_refuses_a_broken_one_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let synth = dir.path().join("synth");
    let config = dir.path().join("drive.toml");
    std::fs::write(&config, "[synthetic]\nk1 = 0.0\n").unwrap();
    run_ok(
        steernav()
            .args([
                "slam-synth",
                "--out",
                synth.to_str().unwrap(),
                "--motion",
                "drive",
            ])
            .args(["--frames", "20", "--config", config.to_str().unwrap()]),
    );
    // The KITTI layout: image_0/, calib.txt (labelled P0 row), poses.txt; no times.txt.
    let kitti = dir.path().join("kitti");
    std::fs::create_dir_all(kitti.join("image_0")).unwrap();
    for k in 0..20 {
        let name = format!("{k:06}.png");
        std::fs::copy(
            synth.join("rgb").join(&name),
            kitti.join("image_0").join(&name),
        )
        .unwrap();
    }
    let camera = steernav::slam::camera::PinholeCamera::load(&synth.join("calib.toml")).unwrap();
    std::fs::write(
        kitti.join("calib.txt"),
        format!(
            "P0: {} 0 {} 0 0 {} {} 0 0 0 1 0\nP1: {} 0 {} -386 0 {} {} 0 0 0 1 0\n",
            camera.fx, camera.cx, camera.fy, camera.cy, camera.fx, camera.cx, camera.fy, camera.cy
        ),
    )
    .unwrap();
    let truth = steernav::slam::data::trajectory::read_tum(&synth.join("groundtruth.txt")).unwrap();
    let rows: Vec<String> = truth
        .iter()
        .map(steernav::slam::data::kitti::pose_row)
        .collect();
    std::fs::write(kitti.join("poses.txt"), rows.join("\n") + "\n").unwrap();
    let traj = dir.path().join("trajectory.txt");
    let run = |extra: &[&str]| {
        let mut slam = steernav();
        slam.args(["slam", kitti.to_str().unwrap(), "--backend", "cpu", "--out"])
            .arg(dir.path())
            .args(extra);
        slam
    };
    let out = run_ok(&mut run(&["--format", "kitti"]));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("kitti layout") && stdout.contains("ATE"),
        "{stdout}"
    );
    let written = std::fs::read_to_string(&traj).unwrap();
    assert_eq!(written.lines().count(), 20);
    assert!(written.lines().all(|l| l.split_whitespace().count() == 12));
    // 10 frames/s without times.txt: slam-eval pairs the KITTI rows with the ground truth.
    let out = run_ok(
        steernav()
            .arg("slam-eval")
            .arg(&traj)
            .arg(kitti.join("poses.txt")),
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("20 poses matched"));
    // A --times file must give one timestamp per pose row, and is named when it does not.
    let times = dir.path().join("short_times.txt");
    std::fs::write(&times, "0.0\n0.1\n0.2\n").unwrap();
    refused(
        steernav()
            .arg("slam-eval")
            .arg(&traj)
            .arg(kitti.join("poses.txt"))
            .arg("--times")
            .arg(&times),
        &["short_times.txt", "3 timestamps for the 20 pose rows"],
    );
    // A short poses.txt is refused before the run, naming the file.
    std::fs::write(kitti.join("poses.txt"), rows[..5].join("\n") + "\n").unwrap();
    refused(&mut run(&[]), &["poses.txt", "5 pose rows for 20 frames"]);
    // A bad times.txt names its line; a missing calib.txt names the file.
    std::fs::write(kitti.join("times.txt"), "0.0\n0.1\nten\n").unwrap();
    refused(&mut run(&[]), &["times.txt", "line 3"]);
    std::fs::remove_file(kitti.join("times.txt")).unwrap();
    std::fs::remove_file(kitti.join("calib.txt")).unwrap();
    refused(&mut run(&[]), &["calib.txt"]);
}

#[test]
fn slam_refuses_a_calibration_of_another_size_before_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let seq = dir.path().join("room");
    run_ok(steernav().args([
        "slam-synth",
        "--out",
        seq.to_str().unwrap(),
        "--frames",
        "3",
    ]));
    let calib = dir.path().join("wide.toml");
    std::fs::write(
        &calib,
        "[camera]\nfx = 700\nfy = 700\ncx = 600\ncy = 180\nwidth = 1226\nheight = 370\n",
    )
    .unwrap();
    let out = steernav()
        .args(["slam", seq.to_str().unwrap(), "--backend", "cpu", "--calib"])
        .arg(&calib)
        .arg("--out")
        .arg(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "a run that processes nothing must fail"
    );
    assert!(
        stderr.contains("320x240") && stderr.contains("1226x370") && stderr.contains("wide.toml"),
        "{stderr}"
    );
}

/// A full stdout is an error with a message and a non-zero exit, never a panic.
#[cfg(target_os = "linux")]
#[test]
fn a_full_stdout_is_an_error_not_a_panic() {
    for args in [
        vec!["detect", "--backend", "cpu", "--max-keypoints", "20"],
        vec!["info"],
    ] {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let mut command = steernav();
        command.args(&args);
        if args[0] == "detect" {
            command.arg(sample());
        }
        let out = command.stdout(full).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(
            stderr.contains("cannot write to stdout"),
            "{args:?}: {stderr}"
        );
    }
}

#[test]
fn batch_names_unreadable_entries_and_leaves_its_own_output_alone() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in");
    std::fs::create_dir(&input).unwrap();
    std::fs::copy(sample(), input.join("a.png")).unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink(dir.path().join("nowhere.png"), input.join("dangling.png")).unwrap();
    let out_dir = input.join("out");
    let run = || {
        steernav()
            .args([
                "batch",
                "--backend",
                "cpu",
                "--draw",
                "--max-keypoints",
                "50",
            ])
            .arg(&input)
            .arg("--out")
            .arg(&out_dir)
            .output()
            .unwrap()
    };
    let first = run();
    let stderr = String::from_utf8_lossy(&first.stderr);
    assert!(first.status.success(), "{stderr}");
    #[cfg(unix)]
    assert!(
        stderr.contains("dangling.png") && stderr.contains("skipped"),
        "{stderr}"
    );
    // The second run finds the drawn PNG inside its input tree but does not take it for an
    // input: only a.png, already done.
    let second = run();
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(stderr.contains("0 detected, 1 skipped"), "{stderr}");
}

#[test]
fn slam_eval_gives_no_rpe_for_a_span_shorter_than_its_interval() {
    let dir = tempfile::tempdir().unwrap();
    let traj = dir.path().join("t.txt");
    let rows: String = (0..6)
        .map(|k| {
            format!(
                "{} {} 0 {} 0 0 0 1\n",
                0.1 * k as f64,
                0.2 * k as f64,
                0.05 * (k * k) as f64
            )
        })
        .collect();
    std::fs::write(&traj, rows).unwrap();
    let out = steernav()
        .args(["slam-eval", "--json"])
        .arg(&traj)
        .arg(&traj)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert!(v["rpe_trans"].is_null(), "{stdout}");
    let out = steernav()
        .arg("slam-eval")
        .arg(&traj)
        .arg(&traj)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("no RPE") && !stdout.contains("RPE 0"),
        "{stdout}"
    );
}

#[test]
fn batch_reruns_draw_what_is_missing_keep_their_rows_and_refuse_a_second_writer() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in");
    std::fs::create_dir(&input).unwrap();
    std::fs::copy(sample(), input.join("a.png")).unwrap();
    let out_dir = dir.path().join("out");
    let run = |draw: bool| {
        let mut cmd = steernav();
        cmd.args(["batch", "--backend", "cpu", "--max-keypoints", "50"])
            .arg(&input)
            .arg("--out")
            .arg(&out_dir);
        if draw {
            cmd.arg("--draw");
        }
        cmd.output().unwrap()
    };
    assert!(run(false).status.success());
    assert!(!out_dir.join("a.png.png").exists());
    // With --draw, an image done without its picture is done again.
    let second = run(true);
    assert!(String::from_utf8_lossy(&second.stderr).contains("1 detected"));
    assert!(out_dir.join("a.png.png").exists());
    // A re-run that skips everything keeps each row's figures from the JSON.
    assert!(run(true).status.success());
    let summary = std::fs::read_to_string(out_dir.join("summary.csv")).unwrap();
    let row = summary.lines().nth(1).unwrap();
    assert!(row.contains(",skipped,640,480,"), "{summary}");
    // While another batch holds the folder, a second one refuses to start.
    let lock = std::fs::File::create(out_dir.join(".steernav-batch.lock")).unwrap();
    lock.lock().unwrap();
    let refused = run(true);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && stderr.contains("another steernav batch"),
        "{stderr}"
    );
}

#[test]
fn detect_keeps_both_outputs_of_inputs_sharing_a_name() {
    let dir = tempfile::tempdir().unwrap();
    for folder in ["a", "b"] {
        std::fs::create_dir(dir.path().join(folder)).unwrap();
        std::fs::copy(sample(), dir.path().join(folder).join("img.png")).unwrap();
    }
    let out_dir = dir.path().join("o");
    run_ok(
        steernav()
            .args([
                "detect",
                "--backend",
                "cpu",
                "--max-keypoints",
                "20",
                "--out",
            ])
            .arg(&out_dir)
            .arg(dir.path().join("a/img.png"))
            .arg(dir.path().join("b/img.png")),
    );
    assert!(out_dir.join("a_img.json").exists() && out_dir.join("b_img.json").exists());
}

#[cfg(unix)]
#[test]
fn slam_interrupted_by_sigterm_still_writes_the_map_and_the_figure() {
    let dir = tempfile::tempdir().unwrap();
    let seq = dir.path().join("drive");
    run_ok(
        steernav()
            .args(["slam-synth", "--motion", "drive", "--frames", "80", "--out"])
            .arg(&seq),
    );
    let out_dir = dir.path().join("out");
    let child = steernav()
        .args(["slam", "--backend", "cpu", "--calib"])
        .arg(seq.join("calib.toml"))
        .arg(&seq)
        .arg("--out")
        .arg(&out_dir)
        .arg("--map")
        .arg(out_dir.join("map.json"))
        .arg("--plot")
        .arg(out_dir.join("slam.png"))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // The trajectory is written frame by frame: signal once a few frames are done.
    let traj = out_dir.join("trajectory.txt");
    let started = std::time::Instant::now();
    while std::fs::read_to_string(&traj).map_or(0, |t| t.lines().count()) < 4 {
        assert!(started.elapsed().as_secs() < 120, "slam never got going");
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    let kill = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("interrupted after"), "{stderr}");
    let frames = std::fs::read_to_string(&traj).unwrap().lines().count() - 1;
    assert!(frames < 80, "stopped early: {frames} frames");
    assert!(out_dir.join("map.json").exists() && out_dir.join("slam.png").exists());
}

#[test]
fn a_truncated_jpeg_is_named_and_counted_as_damaged() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in");
    std::fs::create_dir(&input).unwrap();
    let rgb = image::open(sample()).unwrap().to_rgb8();
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 90)
        .encode_image(&rgb)
        .unwrap();
    std::fs::write(input.join("whole.jpg"), &jpeg).unwrap();
    std::fs::write(input.join("cut.jpg"), &jpeg[..jpeg.len() / 3]).unwrap();
    let out = steernav()
        .args(["detect", "--backend", "cpu", "--max-keypoints", "20"])
        .arg(input.join("cut.jpg"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("cut.jpg") && stderr.contains("truncated"),
        "{stderr}"
    );
    let out_dir = dir.path().join("out");
    let out = steernav()
        .args(["batch", "--backend", "cpu", "--max-keypoints", "20"])
        .arg(&input)
        .arg("--out")
        .arg(&out_dir)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("1 damaged"), "{stderr}");
    let summary = std::fs::read_to_string(out_dir.join("summary.csv")).unwrap();
    assert!(
        summary.lines().any(|l| l.contains("cut.jpg,damaged,")),
        "{summary}"
    );
    assert!(
        summary.lines().any(|l| l.contains("whole.jpg,done,")),
        "{summary}"
    );
}

#[test]
fn keypoints_without_descriptors_are_refused_for_matching() {
    refused(
        steernav()
            .args(["match", "--backend", "cpu", "--descriptor", "none"])
            .arg(sample())
            .arg(sample()),
        &["--descriptor none"],
    );
    let out = run_ok(
        steernav()
            .args(["detect", "--backend", "cpu", "--descriptor", "none"])
            .args(["--max-keypoints", "20"])
            .arg(sample()),
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["descriptor"], "none", "{v}");
    assert_eq!(v["descriptor_length"], 0, "{v}");
}

#[cfg(unix)]
#[test]
fn a_full_or_closed_stderr_costs_the_messages_not_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let full = || {
        std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap()
    };
    // detect: its result on stdout; `auto` warns about the software adapter where there is one.
    let out = steernav()
        .args(["detect", "--backend", "auto", "--max-keypoints", "20"])
        .arg(sample())
        .stderr(full())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", out.status);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["keypoints"].as_array().unwrap().len(), 20);
    // batch with a damaged file: the warnings are lost, the outputs and the exit code are not.
    let input = dir.path().join("in");
    std::fs::create_dir(&input).unwrap();
    std::fs::copy(sample(), input.join("a.png")).unwrap();
    std::fs::write(input.join("bad.png"), b"not a png").unwrap();
    let status = steernav()
        .args([
            "batch",
            "--backend",
            "cpu",
            "--max-keypoints",
            "20",
            "--out",
        ])
        .arg(dir.path().join("out"))
        .arg(&input)
        .stderr(full())
        .status()
        .unwrap();
    assert_eq!(
        status.code(),
        Some(1),
        "one damaged file is a failure, not a panic"
    );
    assert!(dir.path().join("out/a.png.json").exists());
    // A closed stderr: the reader went away before the command started writing.
    let mut child = steernav()
        .args(["detect", "--backend", "cpu", "--max-keypoints", "20"])
        .arg(sample())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stderr.take());
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", out.status);
}

#[cfg(unix)]
#[test]
fn fifos_and_devices_as_inputs_are_refused_by_name_not_read_forever() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("f.png");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let gt = dir.path().join("gt.txt");
    std::fs::write(&gt, "0 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n").unwrap();
    let cases: Vec<Vec<std::ffi::OsString>> = vec![
        vec![
            "detect".into(),
            "--backend".into(),
            "cpu".into(),
            fifo.clone().into(),
        ],
        vec!["nav-replay".into(), fifo.clone().into()],
        vec!["nav-replay".into(), "/dev/zero".into()],
        vec!["slam-eval".into(), "/dev/zero".into(), gt.clone().into()],
        vec!["slam-eval".into(), fifo.clone().into(), gt.clone().into()],
    ];
    for args in cases {
        let mut child = steernav()
            .args(&args)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let start = std::time::Instant::now();
        let status = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break status;
            }
            if start.elapsed() > std::time::Duration::from_secs(20) {
                child.kill().unwrap();
                panic!("{args:?} still reading after 20 s");
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        };
        let mut err = String::new();
        std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
        let named = args.last().unwrap().to_string_lossy().into_owned();
        let input = if named == gt.to_string_lossy() {
            args[1].to_string_lossy().into_owned()
        } else {
            named
        };
        assert!(
            !status.success() && err.contains(&input) && err.contains("not a regular file"),
            "{args:?}: {status}: {err}"
        );
    }
}

#[test]
fn batch_into_its_own_input_and_absurd_frame_rates_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(sample(), dir.path().join("a.png")).unwrap();
    refused(
        steernav()
            .args(["batch", "--backend", "cpu", "--out"])
            .arg(dir.path())
            .arg(dir.path()),
        &["both the input and the output"],
    );
    refused(
        steernav()
            .args(["slam", "--backend", "cpu", "--fps", "1e-320"])
            .arg(dir.path()),
        &["fps = 1e-320: must be a rate"],
    );
    // A bag's frames carry their own stamps: a rate given for one is refused, not ignored.
    let bag = dir.path().join("drive.mcap");
    std::fs::write(&bag, b"").unwrap();
    refused(
        steernav()
            .args(["slam", "--backend", "cpu", "--fps", "5"])
            .arg(&bag),
        &["does not apply to a ROS 2 bag"],
    );
}

#[test]
fn slam_checks_every_output_before_touching_any() {
    let dir = tempfile::tempdir().unwrap();
    let seq = dir.path().join("room");
    run_ok(
        steernav()
            .args(["slam-synth", "--frames", "12", "--out"])
            .arg(&seq),
    );
    let out = dir.path().join("out");
    run_ok(
        steernav()
            .arg("slam")
            .arg(&seq)
            .args(["--backend", "cpu", "--out"])
            .arg(&out),
    );
    let traj = out.join("trajectory.txt");
    let before = std::fs::read_to_string(&traj).unwrap();
    let refused = |flag: &str, value: &std::path::Path, says: &str| {
        let o = steernav()
            .arg("slam")
            .arg(&seq)
            .args(["--backend", "cpu", "--out"])
            .arg(&out)
            .arg(flag)
            .arg(value)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(!o.status.success() && err.contains(says), "{flag}: {err}");
        // The earlier run's trajectory is untouched.
        assert_eq!(std::fs::read_to_string(&traj).unwrap(), before);
    };
    refused("--report", dir.path(), "--report names a folder");
    refused("--plot", &dir.path().join("slam.jpg"), "name it .png");
    refused(
        "--map",
        &dir.path().join("nowhere/map.json"),
        "does not exist",
    );
    refused("--mcap", dir.path(), "--mcap names a folder");
}

#[test]
fn nav_figures_are_checked_before_the_episodes_run() {
    let dir = tempfile::tempdir().unwrap();
    for (command, extra) in [
        ("nav", &["--random", "1"][..]),
        ("nav-eval", &["--episodes", "500"][..]),
    ] {
        for (plot, says) in [
            (dir.path().join("figure.jpg"), "name it .png"),
            (dir.path().join("folder.png"), "names a directory"),
        ] {
            std::fs::create_dir_all(dir.path().join("folder.png")).unwrap();
            let o = steernav()
                .arg(command)
                .args(extra)
                .arg("--plot")
                .arg(&plot)
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(
                !o.status.success() && err.contains(says),
                "{command}: {err}"
            );
        }
    }
}

#[test]
fn match_says_when_verification_is_impossible() {
    let a = sample();
    let out = steernav()
        .arg("match")
        .arg(&a)
        .arg(&a)
        .args([
            "--max-keypoints",
            "6",
            "--verify",
            "fundamental",
            "--backend",
            "cpu",
        ])
        .output()
        .unwrap();
    assert_ok(&out);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("fundamental verification impossible") && err.contains("needs 8"),
        "{err}"
    );
}

/// The images of each row of a batch summary, with their status.
fn summary_rows(out: &Path) -> Vec<(String, String)> {
    let text = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let mut cols = l.split(',');
            let image = cols.next().unwrap();
            let name = Path::new(image).file_name().unwrap().to_string_lossy();
            (name.into_owned(), cols.next().unwrap().to_string())
        })
        .collect()
}

#[test]
fn batch_shards_split_a_tree_alone_and_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in");
    std::fs::create_dir_all(input.join("sub")).unwrap();
    let base = image::open(sample()).unwrap();
    let mut names = Vec::new();
    for i in 0..12u32 {
        let name = if i % 3 == 0 {
            format!("sub/p{i}.png")
        } else {
            format!("p{i}.png")
        };
        base.crop_imm(20 * i, 10 * i, 120, 90)
            .save(input.join(&name))
            .unwrap();
        names.push(
            Path::new(&name)
                .file_name()
                .unwrap()
                .to_string_lossy()
                .into_owned(),
        );
    }
    names.sort();
    let shard = |k: u32, out: &Path| {
        let mut cmd = steernav();
        cmd.args(["batch", "--backend", "cpu", "--max-keypoints", "30"])
            .arg(&input)
            .arg("--out")
            .arg(out)
            .arg("--shard")
            .arg(format!("{k}/2"));
        cmd
    };
    let detected = |out: &std::process::Output| -> usize {
        let stderr = String::from_utf8_lossy(&out.stderr);
        let n = stderr
            .split(" detected")
            .next()
            .unwrap()
            .rsplit(' ')
            .next()
            .unwrap();
        n.trim().parse().unwrap_or_else(|_| panic!("{stderr}"))
    };
    // Alone, one after the other: each takes its share, the summary grows to the whole tree.
    let alone = dir.path().join("alone");
    let first = run_ok(&mut shard(0, &alone));
    let after_first = summary_rows(&alone);
    assert_eq!(after_first.len(), detected(&first));
    assert!(!after_first.is_empty() && after_first.len() < names.len());
    let second = run_ok(&mut shard(1, &alone));
    assert_eq!(detected(&first) + detected(&second), names.len());
    let rows = summary_rows(&alone);
    let mut seen: Vec<String> = rows.iter().map(|(n, _)| n.clone()).collect();
    seen.sort();
    assert_eq!(seen, names, "one row per image, no overlap, no gap");
    assert!(rows.iter().all(|(_, status)| status == "done"), "{rows:?}");
    // A re-run of one shard redoes nothing and keeps the other shard's rows.
    let again = run_ok(&mut shard(0, &alone));
    assert_eq!(detected(&again), 0);
    assert_eq!(summary_rows(&alone).len(), names.len());
    // At once, into one folder: the same split, every image once.
    let together = dir.path().join("together");
    let children: Vec<_> = (0..2)
        .map(|k| {
            shard(k, &together)
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    let outputs: Vec<_> = children
        .into_iter()
        .map(|c| c.wait_with_output().unwrap())
        .collect();
    for out in &outputs {
        assert_ok(out);
    }
    assert_eq!(outputs.iter().map(detected).sum::<usize>(), names.len());
    let mut seen: Vec<String> = summary_rows(&together)
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    seen.sort();
    assert_eq!(seen, names);
    for name in ["p1.png", "sub/p3.png"] {
        let a = std::fs::read_to_string(alone.join(format!("{name}.json"))).unwrap();
        let b = std::fs::read_to_string(together.join(format!("{name}.json"))).unwrap();
        let points =
            |t: &str| serde_json::from_str::<serde_json::Value>(t).unwrap()["keypoints"].clone();
        assert_eq!(points(&a), points(&b), "{name}");
    }
    // A whole-tree batch in the folder keeps the shards out, and a shard keeps it out.
    let lock = std::fs::File::create(alone.join(".steernav-batch.lock")).unwrap();
    lock.lock().unwrap();
    refused(&mut shard(1, &alone), &["whole tree"]);
    drop(lock);
    for bad in ["2/2", "x/2", "1"] {
        refused(
            steernav()
                .args(["batch"])
                .arg(&input)
                .arg("--out")
                .arg(&alone)
                .args(["--shard", bad]),
            &["K/N"],
        );
    }
}

#[cfg(unix)]
#[test]
fn batch_summaries_name_files_by_their_own_bytes() {
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in");
    std::fs::create_dir_all(&input).unwrap();
    // "café.png" in Latin-1: not UTF-8, a name the file system holds all the same.
    let name = std::ffi::OsStr::from_bytes(b"caf\xe9.png");
    image::open(sample())
        .unwrap()
        .crop_imm(0, 0, 120, 90)
        .save_with_format(input.join(name), image::ImageFormat::Png)
        .unwrap();
    let out = dir.path().join("out");
    let run = |shard: Option<&str>| {
        let mut cmd = steernav();
        cmd.args(["batch", "--backend", "cpu", "--max-keypoints", "30"])
            .arg(&input)
            .arg("--out")
            .arg(&out);
        if let Some(s) = shard {
            cmd.args(["--shard", s, "--force"]);
        }
        run_ok(&mut cmd);
        std::fs::read(out.join("summary.csv")).unwrap()
    };
    // Alone, and merged by a shard into the summary it finds.
    for summary in [run(None), run(Some("0/1"))] {
        let row = b"caf\xe9.png,done,120,90,";
        assert!(
            summary.windows(row.len()).any(|w| w.ends_with(row)),
            "{}",
            String::from_utf8_lossy(&summary)
        );
    }
}

/// `slam-synth --depth` writes the true depth as TUM RGB-D does (depth/ of 16-bit PNGs at
/// 5000 per metre, depth.txt), and `slam` on such a folder measures the map's depths against
/// it: per frame in depth_ratios.csv, and over the thirds of the run in the summary, where on
/// the generated room the map's unit is the trajectory's (measured 0.96 / 0.99 / 1.00).
#[test]
fn slam_measures_the_maps_depths_against_tum_depth_images() {
    let dir = tempfile::tempdir().unwrap();
    let synth = dir.path().join("synth");
    run_ok(
        steernav()
            .args(["slam-synth", "--frames", "60", "--depth", "--out"])
            .arg(&synth),
    );
    let listed = std::fs::read_to_string(synth.join("depth.txt")).unwrap();
    let first = listed
        .lines()
        .find(|l| !l.starts_with('#'))
        .and_then(|l| l.split_whitespace().nth(1))
        .unwrap();
    assert_eq!(listed.lines().filter(|l| !l.starts_with('#')).count(), 60);
    let depth = image::open(synth.join(first)).unwrap();
    assert!(matches!(depth, image::DynamicImage::ImageLuma16(_)));
    let out = dir.path().join("out");
    let run = run_ok(
        steernav()
            .args(["slam", "--backend", "cpu", "--out"])
            .arg(&out)
            .arg(&synth),
    );
    let stdout = String::from_utf8_lossy(&run.stdout);
    let line = stdout
        .lines()
        .find(|l| l.starts_with("map depths against depth.txt"))
        .unwrap_or_else(|| panic!("no depth line in {stdout}"));
    let metric: Vec<f64> = line
        .split("× the trajectory's scale ")
        .nth(1)
        .unwrap()
        .split(" (")
        .next()
        .unwrap()
        .split(" / ")
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(metric.len(), 3, "{line}");
    for m in metric {
        assert!((0.85..1.15).contains(&m), "{line}");
    }
    let rows = std::fs::read_to_string(out.join("depth_ratios.csv")).unwrap();
    assert!(rows.starts_with("timestamp,landmarks,ratio_q1,ratio_median,ratio_q3"));
    assert!(rows.lines().count() > 40, "{rows}");
}
