//! nav-replay on a generated CARMEN log: a robot driving down a 2-m corridor. The field must
//! pick free headings that follow the motion; gzip and malformed lines are handled.

use std::io::Write;
mod common;

use common::{run_ok, steernav};
use steernav::nav::carmen::{parse, read_log};
use steernav::nav::replay::{replay, ReplayConfig};

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
                let r = if b.sin().abs() < 1e-6 {
                    30.0
                } else {
                    (1.0 / b.sin().abs()).min(30.0)
                };
                format!("{r:.3}")
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
    assert_eq!(keys, ["free_fraction", "mean_abs_deviation_deg", "scans"]);
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
