//! Peak memory of CPU detection on a 24 MP image stays under 2 GB (issue 11's bar): the CLI
//! runs as a child process on a 6000×4000 image tiled from the bundled sample, and its peak
//! resident set is read back with `getrusage(RUSAGE_CHILDREN)`. This file holds this one test,
//! so no other child of the test process is counted. `benches/memory.sh` measures the same on a
//! generated scene of any size. `ru_maxrss` is in kibibytes on Linux only (bytes on macOS), and
//! the bar is Linux's: the file is Linux's too.
#![cfg(target_os = "linux")]

mod common;

/// Issue 11's bar, in MiB.
const LIMIT_MIB: i64 = 2048;

/// The bundled 640×480 sample repeated over `width`×`height`: a real-looking texture at the
/// density of the sample everywhere, built in milliseconds.
fn tiled_sample(width: u32, height: u32) -> image::RgbImage {
    let sample = image::open(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/sample.png"))
        .expect("the bundled sample decodes")
        .to_rgb8();
    image::RgbImage::from_fn(width, height, |x, y| {
        *sample.get_pixel(x % sample.width(), y % sample.height())
    })
}

/// Peak resident set of the waited-for children, in MiB (`ru_maxrss` is in KiB on Linux).
fn children_peak_mib() -> i64 {
    let mut usage = std::mem::MaybeUninit::<libc::rusage>::zeroed();
    // SAFETY: getrusage fills the struct it is given; RUSAGE_CHILDREN is a valid `who`.
    let rc = unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, usage.as_mut_ptr()) };
    assert_eq!(rc, 0, "getrusage failed");
    // SAFETY: initialised by the successful call above.
    unsafe { usage.assume_init() }.ru_maxrss / 1024
}

#[test]
fn cpu_detect_on_24_megapixels_peaks_under_2_gb() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("24mp.ppm");
    tiled_sample(6000, 4000).save(&input).unwrap();
    let out = common::run_ok(
        common::steernav()
            .args(["detect", "--backend", "cpu"])
            .arg(&input),
    );
    let detection: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let found = detection["keypoints"].as_array().map_or(0, Vec::len);
    assert_eq!(found, 500, "the defaults' 500 keypoints");
    let peak = children_peak_mib();
    eprintln!("24 MP CPU detect: peak {peak} MiB (limit {LIMIT_MIB} MiB)");
    assert!(
        peak <= LIMIT_MIB,
        "peak resident set {peak} MiB over {LIMIT_MIB} MiB"
    );
}
