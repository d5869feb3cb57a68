//! The two-view start of a hand-held camera that walks sideways while it turns (issue 25):
//! from the defaults (`[slam.start] two_view_search`) the start tries the searched motion
//! beside the eight-point one and keeps the searched one here, revising the frames it had
//! reported.

mod common;

use common::pose_of;

use steernav::slam::config::SlamConfig;
use steernav::slam::data::synthetic::{SyntheticConfig, SyntheticMotion, SyntheticSequence};
use steernav::slam::data::trajectory::{evaluate, Pose};
use steernav::slam::Slam;
use steernav::DetectorConfig;

/// Runs `config` over `seq` as a caller keeping a trajectory does: revised frames replace
/// the ones reported before. Returns the ATE in % of the path and the frames revised.
fn ate_percent(seq: &SyntheticSequence, config: SlamConfig) -> (f64, usize) {
    let (revised, _) = ate_percent_as_reported(seq, config);
    revised
}

/// [`ate_percent`], and the ATE of the trajectory as first reported (revisions ignored).
fn ate_percent_as_reported(seq: &SyntheticSequence, config: SlamConfig) -> ((f64, usize), f64) {
    let detector = common::cpu_detector(&DetectorConfig::tracking());
    let mut slam = Slam::new(seq.camera.clone(), config).unwrap();
    let (mut estimate, mut revised, mut lost) = (Vec::<Pose>::new(), 0, 0);
    let mut as_reported = Vec::new();
    for (k, truth) in seq.poses.iter().enumerate() {
        let report = slam
            .process(&seq.render(k), truth.timestamp, None, &detector)
            .unwrap();
        for earlier in slam.take_revised() {
            let i = estimate
                .iter()
                .position(|p| p.timestamp == earlier.timestamp)
                .expect("a revised frame was reported before");
            estimate[i] = pose_of(&earlier);
            revised += 1;
        }
        lost += usize::from(report.lost);
        estimate.push(pose_of(&report));
        as_reported.push(pose_of(&report));
    }
    assert_eq!(lost, 0, "no frame may be lost");
    let percent = |poses: &[Pose]| {
        let error = evaluate(poses, &seq.poses, 0.02).unwrap();
        100.0 * error.ate_rmse / seq.path_length()
    };
    ((percent(&estimate), revised), percent(&as_reported))
}

/// The generated walk, seed 7, at 240×180 (three rays a side per pixel), 5 s: the eight-point
/// start direction is 40–50° off and the filter keeps the error (measured 8.20% of the path);
/// the trial keeps the searched motion (measured 1.40%) and revises its 30 frames.
#[test]
fn a_sideways_start_keeps_the_searched_motion() {
    let seq = SyntheticSequence::new(SyntheticConfig {
        seed: 7,
        width: 240,
        height: 180,
        supersample: 3,
        frames: 150,
        ..SyntheticConfig::for_motion(SyntheticMotion::Walk)
    })
    .unwrap();
    let mut eight_point_only = SlamConfig::default();
    eight_point_only.start.two_view_search = false;
    let (eight_point, none) = ate_percent(&seq, eight_point_only);
    let (searched, revised) = ate_percent(&seq, SlamConfig::default());
    eprintln!("walk-7 240x180: eight-point {eight_point:.2}%, trial {searched:.2}% ({revised} frames revised)");
    // Both place the frames before the seat; the trial's frames are revised only when the
    // searched motion is kept.
    let trial = SlamConfig::default().start.trial_frames;
    assert!(
        revised >= none + trial,
        "{revised} frames revised against {none} without the search: the trial kept the eight-point motion"
    );
    assert!(searched <= 2.0, "ATE {searched:.2}% of the path");
    assert!(
        searched < 0.5 * eight_point,
        "{searched:.2}% against {eight_point:.2}%"
    );
}

/// `steernav slam` rewrites trajectory.txt and the report when the trial keeps the searched
/// motion: one row per frame, in order, and the trial's frames differ from the eight-point
/// run's (the same walk, 60 frames).
#[test]
fn slam_writes_the_revised_start_frames() {
    let dir = tempfile::tempdir().unwrap();
    let settings = dir.path().join("walk.toml");
    std::fs::write(
        &settings,
        "[synthetic]\nseed = 7\nwidth = 240\nheight = 180\nsupersample = 3\n",
    )
    .unwrap();
    let seq = dir.path().join("walk");
    common::run_ok(
        common::steernav()
            .args(["slam-synth", "--motion", "walk", "--frames", "60"])
            .arg("--config")
            .arg(&settings)
            .arg("--out")
            .arg(&seq),
    );
    let eight_point_only = dir.path().join("eight.toml");
    std::fs::write(&eight_point_only, "[slam.start]\ntwo_view_search = false\n").unwrap();
    let run = |out: &str, extra: &[&std::ffi::OsStr]| {
        let out = dir.path().join(out);
        let report = out.join("report.csv");
        let done = common::run_ok(
            common::steernav()
                .arg("--verbose")
                .args(["slam", "--backend", "cpu"])
                .arg(&seq)
                .arg("--out")
                .arg(&out)
                .arg("--report")
                .arg(&report)
                .args(extra),
        );
        let rows = |path: &std::path::Path| -> Vec<String> {
            std::fs::read_to_string(path)
                .unwrap()
                .lines()
                .skip(1)
                .map(str::to_owned)
                .collect()
        };
        (
            rows(&out.join("trajectory.txt")),
            rows(&report),
            String::from_utf8_lossy(&done.stderr).into_owned(),
        )
    };
    let (trajectory, report, stderr) = run("trial", &[]);
    assert!(stderr.contains("keeping the searched"), "{stderr}");
    assert_eq!(trajectory.len(), 60, "one pose per frame");
    assert_eq!(report.len(), 60, "one report row per frame");
    let times: Vec<f64> = trajectory
        .iter()
        .map(|l| l.split_whitespace().next().unwrap().parse().unwrap())
        .collect();
    assert!(times.windows(2).all(|w| w[0] < w[1]), "{times:?}");
    let (eight, _, _) = run(
        "eight",
        &["--config".as_ref(), eight_point_only.as_os_str()],
    );
    let revised = (0..20).filter(|&k| trajectory[k] != eight[k]).count();
    assert!(
        revised > 10,
        "{revised} of the first 20 poses differ from the eight-point run"
    );
}

/// `slam-synth --motion slider`, seed 3: the slider starts slowly, so the start waits about
/// 20 frames for two views, reported at the reference pose. Once seated they are placed by
/// resection on the triangulated points: the ATE over the sequence drops (measured 2.50% as
/// first reported, 1.60% placed).
#[test]
fn the_frames_before_the_seat_are_placed() {
    let seq = SyntheticSequence::new(SyntheticConfig {
        seed: 3,
        ..SyntheticConfig::for_motion(SyntheticMotion::Slider)
    })
    .unwrap();
    let ((placed, revised), reported) = ate_percent_as_reported(&seq, SlamConfig::default());
    eprintln!("slider-3: {reported:.2}% as reported, {placed:.2}% placed ({revised} revised)");
    assert!(revised >= 10, "{revised} frames placed");
    assert!(
        placed < 0.8 * reported,
        "{placed:.2}% against {reported:.2}%"
    );
}

/// `slam-synth --motion slider`, seed 7: the slider never turns, the eight-point start reads a
/// forward motion with a turn (11° off the motion the trial's whole baseline settles on), and
/// over the trial the normalised innovations favour it (ratio 1.80). The points the start
/// followed, scored against each hypothesis's motion since the reference frame, favour the
/// searched motion by a factor of 3: it is kept (measured 5.96% → 1.06% of the path).
#[test]
fn the_whole_trial_baseline_chooses_the_sliders_sideways_motion() {
    let seq = SyntheticSequence::new(SyntheticConfig {
        seed: 7,
        ..SyntheticConfig::for_motion(SyntheticMotion::Slider)
    })
    .unwrap();
    let (ate, revised) = ate_percent(&seq, SlamConfig::default());
    eprintln!("slider-7: {ate:.2}% ({revised} revised)");
    let trial = SlamConfig::default().start.trial_frames;
    assert!(
        revised >= trial,
        "{revised} frames revised: the eight-point motion was kept"
    );
    assert!(ate <= 2.0, "ATE {ate:.2}% of the path");
}
