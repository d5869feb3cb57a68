//! Monocular EKF SLAM end to end on the generated room sequence: convergence with the
//! constant-velocity and the odometry motion models, forward driving at 10 and 5 Hz, the walk
//! through furnished rooms, the rover with the wheeled model, a car that waits before it drives off, a consistent covariance, tracking lost
//! on blank frames and recovered against the kept map, the GPU detector feeding the filter, and bad input.

mod common;

use common::pose_of;

use nalgebra::{DMatrix, SymmetricEigen, Vector3};
use steernav::low_level::motion::{relative_motion, MotionModel, OdometryStep};
use steernav::low_level::synth::Rng;
use steernav::slam::camera::PinholeCamera;
use steernav::slam::config::SlamConfig;
use steernav::slam::data::synthetic::{SyntheticConfig, SyntheticMotion, SyntheticSequence};
use steernav::slam::data::trajectory::{evaluate, Pose, TrajectoryError};
use steernav::slam::Slam;
use steernav::{Backend, Detector, DetectorConfig, Frame};

fn cpu_detector() -> Detector {
    common::cpu_detector(&DetectorConfig::default())
}

fn assert_covariance_is_consistent(p: &DMatrix<f64>) {
    assert_eq!(p, &p.transpose(), "covariance must stay exactly symmetric");
    let eig = SymmetricEigen::new(p.clone());
    let min = eig.eigenvalues.min();
    let max = eig.eigenvalues.max();
    assert!(
        min > -1e-9 * max,
        "covariance not positive: eigenvalues in [{min}, {max}]"
    );
}

/// Runs the filter from the defaults over every frame of `seq`: the session, its estimated
/// poses and the frames on which tracking was lost.
fn track(seq: &SyntheticSequence, detector: &Detector) -> (Slam, Vec<Pose>, usize) {
    track_with(seq, detector, SlamConfig::default())
}

/// [`track`] with other settings.
fn track_with(
    seq: &SyntheticSequence,
    detector: &Detector,
    config: SlamConfig,
) -> (Slam, Vec<Pose>, usize) {
    let mut slam = Slam::new(seq.camera.clone(), config).unwrap();
    let (mut estimate, mut lost) = (Vec::new(), 0);
    for (k, truth) in seq.poses.iter().enumerate() {
        let report = slam
            .process(&seq.render(k), truth.timestamp, None, detector)
            .unwrap();
        lost += usize::from(report.lost);
        estimate.push(pose_of(&report));
    }
    (slam, estimate, lost)
}

#[test]
fn constant_velocity_filter_converges_on_the_generated_sequence() {
    let seq = SyntheticSequence::new(SyntheticConfig::default()).unwrap();
    let (slam, estimate, lost) = track(&seq, &cpu_detector());
    let error = evaluate(&estimate, &seq.poses, 0.02).unwrap();
    let length = seq.path_length();
    eprintln!(
        "ATE {:.4} m on a {length:.2} m path ({:.2}%), scale {:.3}",
        error.ate_rmse,
        100.0 * error.ate_rmse / length,
        error.scale
    );
    assert_eq!(error.matched, seq.poses.len());
    assert!(error.ate_rmse < 0.03 * length, "{error:?}");
    assert_eq!(lost, 0, "tracking must not be lost on a textured room");
    assert!(slam.map().len() >= 15);
    assert_covariance_is_consistent(slam.filter().covariance());
}

/// Drives the generated car path and returns (frames lost, ATE as a share of the path).
fn drive(config: SyntheticConfig) -> (usize, f64) {
    let seq = SyntheticSequence::new(config).unwrap();
    let (slam, estimate, lost) = track(&seq, &common::cpu_detector(&DetectorConfig::tracking()));
    let error = evaluate(&estimate, &seq.poses, 0.02).unwrap();
    let length = seq.path_length();
    eprintln!(
        "drive at {} Hz: {lost} lost, ATE {:.3} m on a {length:.1} m path ({:.2}%)",
        seq.config.fps,
        error.ate_rmse,
        100.0 * error.ate_rmse / length
    );
    assert!(length > 50.0, "a car-like path: {length} m");
    assert_covariance_is_consistent(slam.filter().covariance());
    (lost, error.ate_rmse / length)
}

#[test]
fn forward_driving_at_10_hz_keeps_tracking() {
    let (lost, ate) = drive(SyntheticConfig::for_motion(SyntheticMotion::Drive));
    assert_eq!(lost, 0, "no frame may be lost while driving");
    assert!(ate <= 0.02, "ATE {:.2}% of the path", 100.0 * ate);
}

/// The same drive without the local bundle adjustment over the keyframes (`[slam.refine]
/// keyframes = 0`): the filter alone still tracks it (the suite measured 0.40% without the
/// refinement and 0.24% with it, docs/SLAM.md).
#[test]
fn the_drive_is_tracked_without_keyframe_refinement() {
    let seq = SyntheticSequence::new(SyntheticConfig::for_motion(SyntheticMotion::Drive)).unwrap();
    let mut config = SlamConfig::default();
    config.refine.keyframes = 0;
    let detector = common::cpu_detector(&DetectorConfig::tracking());
    let (slam, estimate, lost) = track_with(&seq, &detector, config);
    let error = evaluate(&estimate, &seq.poses, 0.02).unwrap();
    let ate = error.ate_rmse / seq.path_length();
    eprintln!(
        "drive with keyframe refinement: {lost} lost, ATE {:.2}%",
        100.0 * ate
    );
    assert_eq!(lost, 0);
    assert!(ate <= 0.01, "ATE {:.2}% of the path", 100.0 * ate);
    assert_covariance_is_consistent(slam.filter().covariance());
}

/// Every other frame of the drive (2 m between frames): the scale change of forward motion
/// between frames is what used to lose half of these frames (15 of 30, ATE 16.5%), when the
/// templates were scored at the predicted scale only; new landmarks at the prior depth then
/// kept the error near 3% until they started at their two-frame depth.
#[test]
fn forward_driving_at_5_hz_keeps_tracking() {
    let (lost, ate) = drive(SyntheticConfig {
        fps: 5.0,
        frames: 30,
        ..SyntheticConfig::for_motion(SyntheticMotion::Drive)
    });
    assert_eq!(lost, 0, "no frame may be lost while driving");
    assert!(ate <= 0.025, "ATE {:.2}% of the path", 100.0 * ate);
}

/// `slam-synth --motion walk` as generated (12 s at 30 Hz, 640×480): a person carrying the
/// camera through two furnished rooms while looking around, with motion blur, sensor noise,
/// auto-exposure and radial distortion. No frame lost, ATE within 2% of the path and the scale
/// within 10% from the first third to the last (issue 25; measured 0.67% and 0.98 with the
/// keyframe refinement, 1.56% and 1.28 without: the suite's walk-7).
#[test]
fn a_walk_through_furnished_rooms_keeps_tracking() {
    let seq = SyntheticSequence::new(SyntheticConfig::for_motion(SyntheticMotion::Walk)).unwrap();
    let (slam, estimate, lost) = track(&seq, &common::cpu_detector(&DetectorConfig::tracking()));
    let error = evaluate(&estimate, &seq.poses, 0.02).unwrap();
    let length = seq.path_length();
    eprintln!(
        "walk: {lost} lost, ATE {:.3} m on {length:.2} m ({:.2}%)",
        error.ate_rmse,
        100.0 * error.ate_rmse / length
    );
    assert!(length > 5.0, "a walk: {length} m");
    assert_eq!(lost, 0, "no frame may be lost on the walk");
    assert!(error.ate_rmse <= 0.02 * length, "{error:?}");
    let drift = error.scale_drift.expect("a scale drift over 360 poses");
    assert!((0.9..=1.1).contains(&drift), "scale drift {drift}");
    assert_covariance_is_consistent(slam.filter().covariance());
}

/// `slam-synth --motion rover` (seed 11, 24 s at 15 Hz): a wheeled robot whose camera sits
/// 0.1 m ahead of its turning axis, driving legs and turning in place by up to half a turn.
/// With the wheeled motion model (`[slam.motion.wheeled]`) no frame is lost, the ATE stays
/// within 2% of the path and the scale within 10% (issue 25; measured 0.23% and 1.04, the
/// suite's rover-11, against 2.12% and 1.42 with the constant-velocity model), and the
/// camera's height over the ground, learnt in the map's unit, is the rover's (0.298 m
/// measured, 0.3 m generated). The step's copy of the previous pose has left the state at
/// the end of every frame.
#[test]
fn a_rover_turning_in_place_keeps_its_scale_with_the_wheeled_model() {
    let (slam, error) = rover_within(11, 2.0);
    let filter = slam.filter();
    // The arm the turns taught the filter, in metres at the fitted scale: 0.1 m generated,
    // 0.098 m measured.
    let (arm, _) = filter.arm().expect("the wheeled model estimates the arm");
    let metres = arm * error.scale;
    assert!((0.07..0.13).contains(&metres), "arm {metres} m");
    // The camera's height over the ground, learnt from the map: 0.3 m generated.
    let (ground, _) = filter.ground().expect("the ground is seated on the rover");
    let metres = ground * error.scale;
    eprintln!("rover-11: ground {metres:.3} m below the camera");
    assert!((0.27..0.33).contains(&metres), "ground {metres} m");
    let landmarks: usize = filter.slots().iter().map(|s| s.kind.dim()).sum();
    assert_eq!(
        filter.dim(),
        15 + landmarks,
        "the state holds the camera and the map only"
    );
    assert_covariance_is_consistent(filter.covariance());
}

/// Rover seed 3 turns in place where the scene is much nearer or farther than where it looked:
/// with the wheeled model's ground prior, the ground's landmarks hold the camera's height
/// over them and the landmarks met in its turns start where their ray meets the ground, and
/// the map keeps its unit through the turns (issue 25: 0.58% and a drift of 1.02 measured;
/// 4.00% and 1.14 with `ground_prior = false`, where the next leg took the unit of landmarks
/// born too near).
#[test]
fn a_rover_keeps_its_unit_through_turns_with_the_ground_prior() {
    rover_within(3, 2.0);
}

/// Runs the generated rover of `seed` with the wheeled model from its defaults and checks the
/// bars every rover run must meet: no frame lost, ATE at most `percent` of the path, scale
/// drift within 10%. Returns the session and its evaluation.
fn rover_within(seed: u64, percent: f64) -> (Slam, TrajectoryError) {
    let config = SyntheticConfig {
        seed,
        ..SyntheticConfig::for_motion(SyntheticMotion::Rover)
    };
    let seq = SyntheticSequence::new(config).unwrap();
    let slam_config = SlamConfig {
        motion: MotionModel::wheeled(),
        ..SlamConfig::default()
    };
    let detector = common::cpu_detector(&DetectorConfig::tracking());
    let (slam, estimate, lost) = track_with(&seq, &detector, slam_config);
    let error = evaluate(&estimate, &seq.poses, 0.02).unwrap();
    let ate = 100.0 * error.ate_rmse / seq.path_length();
    eprintln!(
        "rover-{seed}: {lost} lost, ATE {ate:.2}%, drift {:?}",
        error.scale_drift
    );
    assert_eq!(lost, 0, "no frame may be lost on rover-{seed}");
    assert!(ate <= percent, "rover-{seed}: ATE {ate:.2}%: {error:?}");
    let drift = error.scale_drift.expect("a scale drift over 360 poses");
    assert!(
        (0.9..=1.1).contains(&drift),
        "rover-{seed}: scale drift {drift}"
    );
    (slam, error)
}

/// A car that waits 1.5 s before it drives off: the filter starts at rest after 1 s (the
/// paper's start, landmarks without depth), and must seat itself again from two views once
/// the car moves. Before that re-seating, the same start on a real KITTI clip gave 11.5%.
#[test]
fn a_car_waiting_before_it_drives_off_is_tracked() {
    let seq = SyntheticSequence::new(SyntheticConfig::for_motion(SyntheticMotion::Drive)).unwrap();
    let detector = common::cpu_detector(&DetectorConfig::tracking());
    let mut slam = Slam::new(seq.camera.clone(), SlamConfig::default()).unwrap();
    let wait = 15;
    let dt = 1.0 / seq.config.fps;
    let frames = (0..wait)
        .map(|k| (0, k as f64 * dt))
        .chain((0..seq.poses.len()).map(|k| (k, (wait + k) as f64 * dt)));
    let (mut estimate, mut truth) = (Vec::new(), Vec::new());
    let mut lost = 0;
    let first = seq.render(0);
    for (k, t) in frames {
        let frame = if k == 0 { first.clone() } else { seq.render(k) };
        let report = slam.process(&frame, t, None, &detector).unwrap();
        lost += usize::from(report.lost);
        estimate.push(pose_of(&report));
        truth.push(Pose {
            timestamp: t,
            ..seq.poses[k]
        });
    }
    let error = evaluate(&estimate, &truth, 0.02).unwrap();
    let length = seq.path_length();
    eprintln!(
        "waiting, then driving: {lost} lost, ATE {:.2}% of the path",
        100.0 * error.ate_rmse / length
    );
    assert_eq!(lost, 0, "no frame may be lost");
    // 0.50% with the re-seating; 1.09% when the filter goes on from its depthless start.
    assert!(error.ate_rmse <= 0.008 * length, "{error:?}");
    assert_covariance_is_consistent(slam.filter().covariance());
}

#[test]
fn odometry_filter_recovers_metric_scale() {
    let seq = SyntheticSequence::new(SyntheticConfig {
        frames: 150,
        ..Default::default()
    })
    .unwrap();
    let detector = cpu_detector();
    let config = SlamConfig {
        motion: MotionModel::odometry(),
        ..Default::default()
    };
    let mut slam = Slam::new(seq.camera.clone(), config).unwrap();
    let mut rng = Rng(3);
    let mut noise = |s: f64| {
        Vector3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        )
        .cast::<f64>()
            * s
    };
    let mut estimate = Vec::new();
    for (k, truth) in seq.poses.iter().enumerate() {
        // Wheel odometry: the true relative motion with 2% / 2 mm noise.
        let step = (k > 0).then(|| {
            let prev = &seq.poses[k - 1];
            let exact = relative_motion(
                &prev.position,
                &prev.orientation,
                &truth.position,
                &truth.orientation,
            );
            OdometryStep {
                translation: exact.translation + noise(0.02 * exact.translation.norm() + 0.002),
                rotation: exact.rotation + noise(0.002),
            }
        });
        let report = slam
            .process(&seq.render(k), truth.timestamp, step.as_ref(), &detector)
            .unwrap();
        estimate.push(pose_of(&report));
    }
    let error = evaluate(&estimate, &seq.poses, 0.02).unwrap();
    eprintln!("odometry: {error:?}");
    assert!(
        (error.scale - 1.0).abs() < 0.1,
        "odometry fixes the scale: {error:?}"
    );
    assert!(error.ate_rmse < 0.03 * error.path_length, "{error:?}");
    assert_covariance_is_consistent(slam.filter().covariance());
}

#[test]
fn blank_frames_are_reported_lost_and_the_pose_is_recovered_against_the_old_map() {
    let seq = SyntheticSequence::new(SyntheticConfig {
        frames: 110,
        ..Default::default()
    })
    .unwrap();
    let detector = cpu_detector();
    let config = SlamConfig::default();
    let lost_after = config.search.lost_after;
    let mut slam = Slam::new(seq.camera.clone(), config).unwrap();
    let (w, h) = (seq.camera.width, seq.camera.height);
    let blank = Frame::from_gray(w, h, vec![0.5; (w * h) as usize]).unwrap();
    let blanks = 50..60;
    let mut reports = Vec::new();
    let mut ids_before_blank = Vec::new();
    for (k, truth) in seq.poses.iter().enumerate() {
        if k == blanks.start {
            ids_before_blank = slam.map().iter().map(|m| m.id).collect();
        }
        let frame = if blanks.contains(&k) {
            blank.clone()
        } else {
            seq.render(k)
        };
        reports.push(
            slam.process(&frame, truth.timestamp, None, &detector)
                .unwrap(),
        );
    }
    assert!(reports[..blanks.start].iter().all(|r| !r.lost));
    assert!(
        reports[blanks.clone()].iter().all(|r| r.lost),
        "blank frames must be reported lost"
    );
    assert!(blanks.len() >= lost_after);
    assert!(
        reports[blanks.end..].iter().any(|r| r.relocalised),
        "resuming after the blank must be reported as a relocalisation"
    );
    let tail = &reports[blanks.end + 5..];
    assert!(
        tail.iter().all(|r| !r.lost),
        "tracking must resume on textured frames"
    );
    // The map was kept: landmarks from before the blank are still there and matched again.
    let map = slam.map();
    let old_seen_again = map
        .iter()
        .filter(|m| ids_before_blank.contains(&m.id))
        .count();
    assert!(old_seen_again >= 5, "{old_seen_again} old landmarks kept");
    // One similarity over every frame with an image (the ATE alignment) maps the estimate
    // onto the truth; after the blank the pose error must stay within 3× the error before it.
    let estimate: Vec<Pose> = reports.iter().map(pose_of).collect();
    let fit: Vec<usize> = (0..estimate.len())
        .filter(|k| !blanks.contains(k))
        .collect();
    let src: Vec<Vector3<f64>> = fit.iter().map(|&k| estimate[k].position).collect();
    let dst: Vec<Vector3<f64>> = fit.iter().map(|&k| seq.poses[k].position).collect();
    let (scale, rot, shift) = steernav::slam::data::trajectory::umeyama(&src, &dst, true);
    let error =
        |k: usize| (scale * rot * estimate[k].position + shift - seq.poses[k].position).norm();
    let mean = |r: std::ops::Range<usize>| r.clone().map(error).sum::<f64>() / r.len() as f64;
    let before = mean(blanks.start - 10..blanks.start);
    let after = mean(blanks.end + 5..blanks.end + 25);
    eprintln!("pose error before the blank {before:.4} m, after {after:.4} m");
    assert!(
        after <= 3.0 * before,
        "{after} m after vs {before} m before"
    );
    assert!(reports
        .iter()
        .all(|r| r.position.iter().all(|v| v.is_finite())));
}

#[test]
fn gpu_detector_feeds_the_filter() {
    let Some(_ctx) = common::gpu() else { return };
    let seq = SyntheticSequence::new(SyntheticConfig {
        frames: 12,
        ..Default::default()
    })
    .unwrap();
    let detector = Detector::new(&DetectorConfig::default(), Backend::Gpu).unwrap();
    let mut slam = Slam::new(seq.camera.clone(), SlamConfig::default()).unwrap();
    let mut last = None;
    for (k, truth) in seq.poses.iter().enumerate() {
        last = Some(
            slam.process(&seq.render(k), truth.timestamp, None, &detector)
                .unwrap(),
        );
    }
    let last = last.unwrap();
    assert!(last.inliers >= 10, "{last:?}");
    assert!(!last.lost);
}

#[test]
fn bad_input_gives_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let calib = dir.path().join("calib.toml");
    std::fs::write(
        &calib,
        "[camera]\nfx = 0.0\nfy = 400\ncx = 160\ncy = 120\nwidth = 320\nheight = 240\n",
    )
    .unwrap();
    let message = PinholeCamera::load(&calib).unwrap_err().to_string();
    assert!(
        message.contains("calib.toml") && message.contains("camera.fx"),
        "{message}"
    );
    std::fs::write(&calib, "[camera]\nfx = 400\n").unwrap();
    let message = PinholeCamera::load(&calib).unwrap_err().to_string();
    assert!(
        message.contains("calib.toml") && message.contains("fy"),
        "{message}"
    );
    assert!(PinholeCamera::load(&dir.path().join("none.toml"))
        .unwrap_err()
        .to_string()
        .contains("none.toml"));

    let camera = PinholeCamera::ideal(200.0, 200.0, 79.5, 59.5, 160, 120);
    let detector = cpu_detector();
    let mut slam = Slam::new(camera, SlamConfig::default()).unwrap();
    let frame = steernav::low_level::synth::textured_scene(160, 120, 1);
    slam.process(&frame, 1.0, None, &detector).unwrap();
    let message = slam
        .process(&frame, 0.5, None, &detector)
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("timestamp") && message.contains("increase"),
        "{message}"
    );
    let message = slam
        .process(&frame, f64::NAN, None, &detector)
        .unwrap_err()
        .to_string();
    assert!(message.contains("timestamp"), "{message}");
    let big = steernav::low_level::synth::textured_scene(320, 240, 1);
    let message = slam
        .process(&big, 2.0, None, &detector)
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("320x240") && message.contains("160x120"),
        "{message}"
    );
    let mut bad = SlamConfig::default();
    bad.filter.pixel_sigma = f64::NAN;
    let message = Slam::new(
        PinholeCamera::ideal(200.0, 200.0, 79.5, 59.5, 160, 120),
        bad,
    )
    .err()
    .unwrap()
    .to_string();
    assert!(message.contains("slam.filter.pixel_sigma"), "{message}");
}
