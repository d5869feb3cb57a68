//! nav-replay on a generated CARMEN log: a robot driving down a 2-m corridor. The field must
//! pick free headings that follow the motion; gzip and malformed lines are handled.

use std::io::Write;
use std::path::Path;
mod common;

use common::{run_ok, steernav};
use steernav::nav::carmen::{parse, read_log};
use steernav::nav::replay::{replay, ReplayConfig};

/// The range from (x, 0) along bearing `b` to the walls at y = ±1 (30 m at most).
fn corridor_range(b: f64) -> f64 {
    if b.sin().abs() < 1e-6 {
        30.0
    } else {
        (1.0 / b.sin().abs()).min(30.0)
    }
}

/// FLASER lines of a robot at (0.1·k, 0) heading along x between walls at y = ±1.
fn corridor_log() -> String {
    let n = 181;
    let mut s = String::from("# generated\nPARAM robot_use_laser on 0 test 0\n");
    for k in 0..120 {
        let (x, t) = (0.1 * k as f64, 0.1 * k as f64);
        let ranges: Vec<String> = (0..n)
            .map(|i| {
                let b =
                    -std::f64::consts::FRAC_PI_2 + i as f64 * std::f64::consts::PI / (n - 1) as f64;
                format!("{:.3}", corridor_range(b))
            })
            .collect();
        s.push_str(&format!("ODOM {x} 0 0 0 0 0 {t} test {t}\n"));
        s.push_str(&format!(
            "FLASER {n} {} {x} 0 0 {x} 0 0 {t} test {t}\n",
            ranges.join(" ")
        ));
    }
    s
}

#[test]
fn the_field_follows_the_corridor() {
    let scans = parse(
        std::path::Path::new("corridor.log"),
        corridor_log().as_bytes(),
    )
    .unwrap();
    assert_eq!(scans.len(), 120);
    let r = replay(&scans, &ReplayConfig::default()).unwrap();
    assert!(r.scans > 100, "{r:?}");
    assert_eq!(r.free_fraction, 1.0, "{r:?}");
    assert!(r.mean_abs_deviation_deg < 5.0, "{r:?}");
}

/// FLASER lines of a robot in open space (every beam 30 m), its scans 2.5 s apart as in the
/// corrected CARMEN logs, facing +x and moving 1 m per scan in directions that swing within
/// ±25° of it.
fn sparse_swinging_log() -> String {
    let n = 181;
    let ranges = vec!["30.000"; n].join(" ");
    let mut s = String::from("# generated\n");
    let (mut x, mut y) = (0.0f64, 0.0f64);
    for k in 0..80 {
        let t = 2.5 * k as f64;
        s.push_str(&format!(
            "FLASER {n} {ranges} {x} {y} 0 {x} {y} 0 {t} test {t}\n"
        ));
        let swing = (25.0 * (0.9 * k as f64).sin() * (0.37 * k as f64).cos()).to_radians();
        x += swing.cos();
        y += swing.sin();
    }
    s
}

#[test]
fn the_field_runs_for_the_time_between_scans_and_follows_a_swinging_motion() {
    let scans = parse(Path::new("sparse.log"), sparse_swinging_log().as_bytes()).unwrap();
    let defaults = replay(&scans, &ReplayConfig::default()).unwrap();
    // The field of the controller, stepped 0.3 s per scan: the replay before issue 26.
    let before = ReplayConfig {
        field: steernav::low_level::dnf::FieldConfig::default(),
        steps_per_scan: Some(30),
        ..ReplayConfig::default()
    };
    let before = replay(&scans, &before).unwrap();
    assert_eq!(defaults.forward.scans, 79, "{defaults:?}");
    // Measured: 0.24° against 5.1°.
    assert!(defaults.forward.mean_deg < 1.0, "{defaults:?}");
    assert!(before.forward.mean_deg > 3.0, "{before:?}");
    // A field time beyond 10 000 Euler steps is refused by name.
    let long = ReplayConfig {
        max_field_time: 1e3,
        ..ReplayConfig::default()
    };
    let message = replay(&scans, &long).unwrap_err().to_string();
    assert!(message.contains("max_field_time"), "{message}");
    // So is a field time that is not a time, by a robot program calling the controller.
    use steernav::nav::{Controller, ControllerConfig, LaserScan, Mode};
    let mut robot =
        Controller::new(ControllerConfig::default(), Mode::Laser, Default::default()).unwrap();
    let scan = LaserScan::new(
        vec![3.0; 181],
        -std::f32::consts::FRAC_PI_2,
        1f32.to_radians(),
        4.0,
    );
    for bad in [f32::NAN, -1.0, 1e6] {
        let message = robot
            .step_towards_over(&scan, [0.0; 3], 0.0, 1.0, None, bad)
            .unwrap_err()
            .to_string();
        assert!(message.contains("field time"), "{message}");
    }
    let command = robot
        .step_towards_over(&scan, [0.0; 3], 0.3, 1.0, None, 2.0)
        .unwrap();
    assert!((command.heading - 0.3).abs() < 0.1, "{command:?}");
}

#[test]
fn gzipped_logs_and_the_cli_json() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("corridor.log.gz");
    let mut gz = flate2::write::GzEncoder::new(
        std::fs::File::create(&path).unwrap(),
        flate2::Compression::default(),
    );
    gz.write_all(corridor_log().as_bytes()).unwrap();
    gz.finish().unwrap();
    assert_eq!(read_log(&path).unwrap().len(), 120);
    let out = run_ok(steernav().arg("nav-replay").arg(&path).arg("--json"));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let mut keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    keys.sort_unstable();
    assert_eq!(
        keys,
        [
            "forward",
            "forward_free_fraction",
            "free_fraction",
            "mean_abs_deviation_deg",
            "motion",
            "reference",
            "reference_missing",
            "scans"
        ]
    );
    // Down a straight corridor every scan drives forward, and the real motion is free.
    assert_eq!(v["motion"]["forward"], v["scans"]);
    assert_eq!(v["reference"]["mean_deg"], 0.0);
    assert_eq!(v["reference_missing"], 0);
}

#[test]
fn malformed_lines_are_named() {
    let e = parse(
        std::path::Path::new("bad.log"),
        "FLASER 3 1.0 2.0\n".as_bytes(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("bad.log") && e.contains("line 1"), "{e}");
    let e = parse(
        std::path::Path::new("bad.log"),
        "ODOM 0 0 0\nFLASER 2 1 x 0 0 0 0 0 0 0 h 0\n".as_bytes(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("line 2") && e.contains("'x'"), "{e}");
    assert!(read_log(std::path::Path::new("/nonexistent/log")).is_err());
}

#[test]
fn a_log_without_motion_and_out_of_range_settings_are_refused() {
    let scans = parse(
        std::path::Path::new("corridor.log"),
        corridor_log().as_bytes(),
    )
    .unwrap();
    // The robot standing still: every scan is the first one.
    let still: Vec<_> = scans.iter().map(|_| scans[0].clone()).collect();
    let message = replay(&still, &ReplayConfig::default())
        .unwrap_err()
        .to_string();
    assert!(message.contains("nothing to evaluate"), "{message}");
    let negative = ReplayConfig {
        free_halfwidth_deg: -10.0,
        ..ReplayConfig::default()
    };
    let message = replay(&scans, &negative).unwrap_err().to_string();
    assert!(message.contains("free_halfwidth_deg"), "{message}");
}

/// ROBOTLASER1 lines of the same corridor drive, seen by a scanner of `fov_deg` degrees.
fn robotlaser_log(fov_deg: f64, beams: usize) -> String {
    let fov = fov_deg.to_radians();
    let full = fov_deg >= 360.0;
    let resolution = if full {
        fov / beams as f64
    } else {
        fov / (beams - 1) as f64
    };
    let start = -0.5 * fov;
    let mut s = String::new();
    for k in 0..120 {
        let (x, t) = (0.1 * k as f64, 0.1 * k as f64);
        let ranges: Vec<String> = (0..beams)
            .map(|i| format!("{:.3}", corridor_range(start + i as f64 * resolution)))
            .collect();
        s.push_str(&format!(
            "ROBOTLASER1 0 {start} {fov} {resolution} 30.0 0.01 0 {beams} {} 0 {x} 0 0 {x} 0 0 0 0 0 0 0 {t} test {t}\n",
            ranges.join(" ")
        ));
    }
    s
}

#[test]
fn scanners_of_270_and_360_degrees_replay_like_the_180_degree_one() {
    for (fov, beams) in [(270.0, 541), (360.0, 720), (180.0, 361)] {
        let log = robotlaser_log(fov, beams);
        let scans = parse(Path::new("robotlaser.log"), log.as_bytes()).unwrap();
        assert_eq!(scans.len(), 120);
        assert_eq!(scans[0].ranges.len(), beams);
        let span = scans[0]
            .bearings
            .iter()
            .copied()
            .fold(f32::NEG_INFINITY, f32::max)
            - scans[0]
                .bearings
                .iter()
                .copied()
                .fold(f32::INFINITY, f32::min);
        assert!(
            span.to_degrees() > fov as f32 - 1.5,
            "{fov}: {}",
            span.to_degrees()
        );
        let r = replay(&scans, &ReplayConfig::default()).unwrap();
        assert_eq!(r.free_fraction, 1.0, "{fov}: {r:?}");
        assert!(r.mean_abs_deviation_deg < 5.0, "{fov}: {r:?}");
        assert_eq!(r.motion.forward, r.scans, "{fov}: {r:?}");
    }
    // Beside FLASER copies of the same scans, only the ROBOTLASER1 lines are read.
    let both = format!("{}{}", corridor_log(), robotlaser_log(270.0, 541));
    let scans = parse(Path::new("both.log"), both.as_bytes()).unwrap();
    assert_eq!((scans.len(), scans[0].ranges.len()), (120, 541));
    let short = "ROBOTLASER1 0 -1.5 3.1 0.01 30 0.01 0 3 1 2 3 0 0 0 0\n";
    let e = parse(Path::new("bad.log"), short.as_bytes())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("line 1") && e.contains("ROBOTLASER1 line with 3 beams"),
        "{e}"
    );
    let bad_fov = robotlaser_log(180.0, 181).replacen(" 3.14159", " -3.14159", 1);
    let e = parse(Path::new("fov.log"), bad_fov.as_bytes())
        .unwrap_err()
        .to_string();
    assert!(e.contains("field of view"), "{e}");
}

#[test]
fn missing_readings_are_dropped_not_obstacles() {
    // NaN, inf, zero and negative readings, as scanners write a missing return.
    let mut holes = String::new();
    for (no, line) in corridor_log().lines().enumerate() {
        if !line.starts_with("FLASER") {
            holes.push_str(line);
            holes.push('\n');
            continue;
        }
        let mut fields: Vec<String> = line.split(' ').map(String::from).collect();
        for (i, f) in fields.iter_mut().enumerate().skip(2).take(181) {
            match (i + no) % 9 {
                0 => *f = "nan".into(),
                3 => *f = "0".into(),
                5 if i % 2 == 0 => *f = "-1".into(),
                7 if i % 3 == 0 => *f = "inf".into(),
                _ => {}
            }
        }
        holes.push_str(&fields.join(" "));
        holes.push('\n');
    }
    let scans = parse(Path::new("holes.log"), holes.as_bytes()).unwrap();
    assert_eq!(scans.len(), 120);
    assert!(scans
        .iter()
        .all(|s| s.ranges.len() < 181 && s.ranges.len() > 100));
    assert!(scans
        .iter()
        .all(|s| s.ranges.iter().all(|r| r.is_finite() && *r > 0.0)));
    assert!(scans
        .iter()
        .all(|s| s.angle_increment == scans[0].angle_increment));
    let r = replay(&scans, &ReplayConfig::default()).unwrap();
    assert_eq!(r.free_fraction, 1.0, "{r:?}");
    assert!(r.mean_abs_deviation_deg < 5.0, "{r:?}");
}

#[test]
fn logs_without_front_laser_lines_say_what_they_hold_and_odd_bytes_outside_them_pass() {
    let rear = "RLASER 3 1 2 3 0 0 0 0 0 0 1.0 host 1.0\nODOM 0 0 0 0 0 0 1.0 host 1.0\n";
    let e = parse(Path::new("rear.log"), rear.as_bytes())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("rear.log") && e.contains("FLASER and ROBOTLASER1") && e.contains("1 rear"),
        "{e}"
    );
    let e = parse(Path::new("empty.log"), &b""[..])
        .unwrap_err()
        .to_string();
    assert!(e.contains("empty.log") && e.contains("has none"), "{e}");
    // A Latin-1 comment does not stop the log; a bad byte inside a laser line names its line.
    let mut log = b"# recorded in K\xf6ln\n".to_vec();
    log.extend_from_slice(corridor_log().as_bytes());
    let scans = parse(Path::new("latin1.log"), &log[..]).unwrap();
    assert_eq!(scans.len(), 120);
    let mut broken = corridor_log().into_bytes();
    let at = broken.iter().position(|&b| b == b'.').unwrap();
    broken[at] = 0xff;
    let e = parse(Path::new("broken.log"), &broken[..])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("broken.log") && e.contains("line 4") && e.contains("not a number"),
        "{e}"
    );
}
