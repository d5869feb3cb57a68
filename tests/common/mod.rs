//! Helpers shared by the integration tests: the CLI binary and its checked runs, the bundled
//! sample, the CPU detector, keypoint positions, the GPU context (with the count of GPU
//! tests skipped without an adapter) and the comparisons the parity tests make.
#![allow(dead_code)]

use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use steernav::low_level::gpu::gpu_required;
use steernav::GpuContext;
use steernav::{Backend, Detection, Detector, DetectorConfig, Frame};

/// The CLI built for this test run.
pub fn steernav() -> Command {
    Command::new(env!("CARGO_BIN_EXE_steernav"))
}

/// Runs `command` and fails the test, with its stderr, unless it succeeded.
pub fn run_ok(command: &mut Command) -> Output {
    let out = command.output().expect("the command starts");
    assert_ok(&out);
    out
}

/// Runs `command`, fails the test unless it was refused with a message that names every one
/// of `names` (the input and the reason a user reads), and returns that message.
pub fn refused(command: &mut Command, names: &[&str]) -> String {
    let out = command.output().expect("the command starts");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "accepted: {stderr}");
    for name in names {
        assert!(stderr.contains(name), "{name:?} not named: {stderr}");
    }
    stderr
}

/// Fails the test, with the command's stderr, unless it succeeded.
pub fn assert_ok(out: &Output) {
    assert!(
        out.status.success(),
        "{} ({})",
        String::from_utf8_lossy(&out.stderr),
        out.status
    );
}

/// The bundled sample image.
pub fn sample() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/sample.png")
}

/// A CPU detector with `config`.
pub fn cpu_detector(config: &DetectorConfig) -> Detector {
    Detector::new(config, Backend::Cpu).expect("the CPU detector builds")
}

/// Keypoint positions of a detection.
pub fn points(d: &Detection) -> Vec<(f32, f32)> {
    d.keypoints.iter().map(|k| (k.x, k.y)).collect()
}

static SKIPPED: AtomicUsize = AtomicUsize::new(0);

extern "C" fn report_skipped() {
    let n = SKIPPED.load(Ordering::SeqCst);
    // Straight to the stream: the test harness captures `eprintln!` of passing tests.
    let _ = writeln!(
        std::io::stderr(),
        "{n} GPU test(s) of this file skipped: no GPU adapter (STEERNAV_REQUIRE_GPU=1 fails them instead)"
    );
}

/// The shared GPU context, or None when there is no adapter: the test then checks nothing,
/// and the test binary says at exit how many were skipped. With STEERNAV_REQUIRE_GPU=1 (CI) a
/// missing adapter fails the test instead.
pub fn gpu() -> Option<Arc<GpuContext>> {
    match GpuContext::shared() {
        Ok(ctx) => Some(ctx),
        Err(e) if gpu_required() => panic!("STEERNAV_REQUIRE_GPU=1 but {e}"),
        Err(_) => {
            if SKIPPED.fetch_add(1, Ordering::SeqCst) == 0 {
                // SAFETY: registers a plain function that only reads an atomic and writes to
                // stderr; libtest leaves through `exit`, which runs it once.
                unsafe {
                    libc::atexit(report_skipped);
                }
            }
            None
        }
    }
}

/// Largest absolute difference between two planes, and the largest magnitude in `a`.
pub fn max_diff(a: &[f32], b: &[f32]) -> (f32, f32) {
    assert_eq!(a.len(), b.len());
    let diff = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    let scale = a.iter().map(|x| x.abs()).fold(0.0, f32::max);
    (diff, scale)
}

/// Fraction of points of `a` with a point of `b` within `radius`.
pub fn twin_fraction(a: &[(f32, f32)], b: &[(f32, f32)], radius: f32) -> f64 {
    if a.is_empty() {
        return 1.0;
    }
    let hits = a
        .iter()
        .filter(|p| {
            b.iter()
                .any(|q| (p.0 - q.0).powi(2) + (p.1 - q.1).powi(2) <= radius * radius)
        })
        .count();
    hits as f64 / a.len() as f64
}

/// The frame magnified `z` times about its origin (bilinear): source pixel p lands at z·p.
pub fn magnified(frame: &Frame, z: f64) -> Frame {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let (ow, oh) = ((w as f64 * z) as usize, (h as f64 * z) as usize);
    let mut rgb = vec![0u8; 3 * ow * oh];
    for y in 0..oh {
        for x in 0..ow {
            let (sx, sy) = (x as f64 / z, y as f64 / z);
            let (x0, y0) = (sx.floor() as usize, sy.floor() as usize);
            let (fx, fy) = (sx - x0 as f64, sy - y0 as f64);
            for k in 0..3 {
                let p = |xx: usize, yy: usize| {
                    frame.rgb[3 * (yy.min(h - 1) * w + xx.min(w - 1)) + k] as f64
                };
                let v = p(x0, y0) * (1.0 - fx) * (1.0 - fy)
                    + p(x0 + 1, y0) * fx * (1.0 - fy)
                    + p(x0, y0 + 1) * (1.0 - fx) * fy
                    + p(x0 + 1, y0 + 1) * fx * fy;
                rgb[3 * (y * ow + x) + k] = v.round() as u8;
            }
        }
    }
    Frame::from_rgb(ow as u32, oh as u32, rgb).unwrap()
}

/// The pose a SLAM frame reports, as a trajectory pose.
pub fn pose_of(r: &steernav::slam::FrameReport) -> steernav::slam::data::trajectory::Pose {
    steernav::slam::data::trajectory::Pose {
        timestamp: r.timestamp,
        position: r.position.into(),
        orientation: nalgebra::Vector4::from(r.orientation),
    }
}
