//! The examples in examples/ run and say what they did. `cargo test` builds them beside the
//! test binaries, so they are run from there.

use std::path::PathBuf;
use std::process::Command;

fn example(name: &str) -> (bool, String) {
    let exe = std::env::current_exe().unwrap();
    let dir: PathBuf = exe.parent().unwrap().parent().unwrap().join("examples");
    let path = dir.join(format!("{name}{}", std::env::consts::EXE_SUFFIX));
    assert!(path.exists(), "{} is built by cargo test", path.display());
    let out = Command::new(&path).output().unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    (out.status.success(), text)
}

#[test]
fn detect_buffer_finds_keypoints_in_memory() {
    let (ok, out) = example("detect_buffer");
    assert!(ok && out.contains("keypoints on the cpu backend"), "{out}");
}

#[test]
fn slam_loop_tracks_every_frame() {
    let (ok, out) = example("slam_loop");
    assert!(
        ok && out.contains("frame 19") && !out.contains("lost"),
        "{out}"
    );
}

#[test]
fn nav_controller_reaches_the_goal() {
    let (ok, out) = example("nav_controller");
    assert!(ok && out.contains("goal reached"), "{out}");
}

#[test]
fn shared_device_runs_detector_and_gist_on_one_device() {
    let (ok, out) = example("shared_device");
    assert!(ok, "{out}");
    if steernav::low_level::gpu::gpu_required() {
        assert!(
            out.contains("gpu backend") && out.contains("GIST of 512"),
            "{out}"
        );
    }
}

#[test]
fn bag_slam_tracks_a_recorded_drive() {
    let (ok, out) = example("bag_slam");
    assert!(
        ok && out.contains("recorded") && out.contains("frame 19") && !out.contains("lost"),
        "{out}"
    );
}
