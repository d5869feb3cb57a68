//! `steernav slam`: monocular EKF SLAM on an image sequence — the trajectory frame by frame,
//! the map, the figure, the per-frame report, and the ATE when ground truth is there.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;
use steernav::bag::write::{self, BagWriter, PathOut, PointCloud2, PoseOut, PoseStamped};
use steernav::bag::{frames as bag_frames, Bag, Topic};
use steernav::low_level::motion::MotionModel;
use steernav::slam::data::figure::{slam_figure, EstimatedPose};
use steernav::slam::data::kitti;
use steernav::slam::data::odometry::OdometryTrack;
use steernav::slam::data::sequence::{self, Sequence};
use steernav::slam::data::trajectory::{self, Pose};
use steernav::slam::{FrameReport, Slam};
use steernav::{Frame, PinholeCamera};

use crate::args::{progress, DetectorArgs};
use crate::slam_depth::DepthCheck;
use crate::slam_revise::{
    create_report, create_trajectory, estimated_pose, revise, trajectory_line,
};

#[derive(Args)]
pub struct SlamCmd {
    /// The sequence: a TUM RGB-D folder (rgb.txt + rgb/), a EuRoC folder (cam0/data.csv +
    /// cam0/data/), a KITTI odometry folder (image_0/ or image_l/, calib.txt, optional
    /// times.txt and poses.txt), a plain folder of frames sorted by name (timestamps from
    /// --fps), or a ROS 2 bag (a rosbag2 folder with .mcap files, or one .mcap file): its
    /// Image or CompressedImage topic, stamped by the message headers, and its CameraInfo.
    sequence: PathBuf,
    /// The bag's image topic (sensor_msgs/msg/Image or CompressedImage), when it has several.
    #[arg(long, value_name = "TOPIC")]
    image_topic: Option<String>,
    /// The bag's sensor_msgs/msg/CameraInfo topic, when it has several (--calib overrides it).
    #[arg(long, value_name = "TOPIC")]
    camera_info_topic: Option<String>,
    /// Use the bag's nav_msgs/msg/Odometry on TOPIC as wheel odometry (as --odometry does a
    /// file): the base's poses, put on the camera by the bag's /tf_static transforms from
    /// the odometry's child_frame_id to the images' frame_id.
    #[arg(long, value_name = "TOPIC", conflicts_with = "odometry")]
    odom_topic: Option<String>,
    /// Calibration: TOML with a [camera] table (fx, fy, cx, cy, width, height, optional k1,
    /// k2, p1, p2, k3), a EuRoC sensor.yaml or a KITTI calib.txt (row P0). Defaults to the
    /// sequence's own sensor.yaml or calib.txt.
    #[arg(long, value_name = "FILE")]
    calib: Option<PathBuf>,
    /// Wheel odometry as a TUM trajectory of the camera; switches to the odometry motion
    /// model (u_k of eq 15 = relative motion between frames, interpolated at frame times).
    #[arg(long, value_name = "FILE")]
    odometry: Option<PathBuf>,
    /// The camera rides a wheeled robot or a car, looking forward: the wheeled motion model
    /// (no side slip, no vertical motion, the camera's arm ahead of the turning axis learnt
    /// in the turns), with the settings' [slam.motion.wheeled] values or its defaults. Without
    /// it (and without odometry) the camera may move any way (constant velocity).
    #[arg(long, conflicts_with_all = ["odometry", "odom_topic"])]
    wheeled: bool,
    /// The camera is carried by hand (walking, looking around): the constant-velocity model
    /// with a linear acceleration of 2 map units/s² instead of 1, so that the speed follows a
    /// walker who speeds up through a turn. Settings whose [slam.motion] is not the default
    /// constant-velocity model keep theirs. Not for cars: their jolts then reach the map's
    /// unit (docs/SLAM.md).
    #[arg(long, conflicts_with_all = ["odometry", "odom_topic", "wheeled"])]
    hand_held: bool,
    /// Output directory: the estimated trajectory goes to DIR/trajectory.txt, written frame by
    /// frame (see --format). When the start revises frames it reported (those it waited
    /// through before it seated, or a trial of two motions that the unreported one won,
    /// [slam.start] two_view_search), the file (and --report's) is written again.
    #[arg(long, value_name = "DIR", default_value = "slam-out")]
    out: PathBuf,
    /// Trajectory format: `tum` (t tx ty tz qx qy qz qw) or `kitti` (the 3×4 camera-to-world
    /// matrix, 12 values per row, one row per frame).
    #[arg(long, value_enum, default_value_t = TrajectoryFormat::Tum)]
    format: TrajectoryFormat,
    /// Final map: landmarks with 3×3 covariances as JSON (.json) or points as PLY (.ply).
    #[arg(long, value_name = "FILE")]
    map: Option<PathBuf>,
    /// PNG figure: trajectory with covariance ellipses and the map (Fig. 4c–f).
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    /// Per-frame CSV: counts (predicted, matched, inliers, …) and timings.
    #[arg(long, value_name = "FILE")]
    report: Option<PathBuf>,
    /// Also write the results as MCAP for ROS 2 tools and Foxglove: a
    /// geometry_msgs/msg/PoseStamped on /steernav/pose per frame (stamped like the frame, in
    /// the `map` frame), then nav_msgs/msg/Path on /steernav/path and the landmarks as
    /// sensor_msgs/msg/PointCloud2 on /steernav/landmarks. The per-frame poses are a stream:
    /// start frames revised later are not sent again; the path at the end has them.
    #[arg(long, value_name = "FILE")]
    mcap: Option<PathBuf>,
    /// Frame rate giving timestamps to a plain folder of frames (default 30) or to a KITTI
    /// folder without times.txt (default 10). Unused, with a warning, where the sequence has
    /// timestamps of its own (rgb.txt, data.csv, times.txt); refused for a ROS 2 bag.
    #[arg(long)]
    fps: Option<f64>,
    /// Process at most this many frames.
    #[arg(long, value_name = "N")]
    max_frames: Option<usize>,
    /// Ground truth to evaluate against at the end (TUM, EuRoC data.csv, or KITTI pose rows,
    /// one per frame); defaults to groundtruth.txt / groundtruth_tum.txt / poses.txt beside
    /// the frames. Read and checked before the run.
    #[arg(long, value_name = "FILE")]
    ground_truth: Option<PathBuf>,
    /// The backend, the settings file ([slam] and [detector] tables) and detector flags;
    /// slam starts from the tracking preset (6 orientations, 3 scales, no descriptor) rather
    /// than detect's defaults, and a [detector] table's keys apply over it.
    #[command(flatten)]
    detector: DetectorArgs,
}

/// How a trajectory is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TrajectoryFormat {
    /// TUM: `t tx ty tz qx qy qz qw`.
    Tum,
    /// KITTI odometry: 12 values of the 3×4 camera-to-world matrix per row.
    Kitti,
}

pub fn run(cmd: SlamCmd) -> anyhow::Result<ExitCode> {
    check_outputs(&cmd)?;
    let input = Input::open(&cmd)?;
    let camera = input.camera(&cmd)?;
    let truth_path = cmd.ground_truth.clone().or(input.ground_truth());
    let truth = match &truth_path {
        Some(p) => Some(input.ground_truth_poses(p)?),
        None => None,
    };
    let mut config = cmd.detector.config.settings()?.slam;
    let track = match (&cmd.odometry, &cmd.odom_topic, &input) {
        (Some(path), _, _) => Some(OdometryTrack::load(path)?),
        (None, Some(topic), Input::Bag(bag, image)) => {
            let frame = bag_frames::frame_id(bag, &image.name)?;
            let poses = steernav::bag::odometry::camera_track(bag, Some(topic), &frame)?;
            Some(OdometryTrack::new(poses))
        }
        (None, Some(_), Input::Folder(_)) => bail!(
            "{}: --odom-topic applies to ROS 2 bags only (--odometry takes a file)",
            cmd.sequence.display()
        ),
        (None, None, _) => None,
    };
    if cmd.wheeled && !matches!(config.motion, MotionModel::Wheeled(_)) {
        config.motion = MotionModel::wheeled();
    }
    if cmd.hand_held && config.motion == MotionModel::default() {
        config.motion = MotionModel::hand_held();
    }
    // Measured motion replaces a model of it.
    if track.is_some() && !matches!(config.motion, MotionModel::Odometry { .. }) {
        config.motion = MotionModel::odometry();
    }
    let mut odometry = track;
    let detector = cmd
        .detector
        .detector_from(steernav::DetectorConfig::tracking())?;
    let mut slam = Slam::new(camera.clone(), config)?;
    let missing = input.missing();
    for path in missing {
        eprintln!("warning: {}: listed but missing; skipped", path.display());
    }
    let max_frames = cmd.max_frames.unwrap_or(usize::MAX);
    let out_err = |p: &Path| format!("{}: cannot write", p.display());
    std::fs::create_dir_all(&cmd.out).with_context(|| out_err(&cmd.out))?;
    let traj_path = cmd.out.join("trajectory.txt");
    let mut traj = create_trajectory(&traj_path, cmd.format)?;
    let mut report = match &cmd.report {
        Some(path) => Some((path.clone(), create_report(path)?)),
        None => None,
    };
    let mut mcap = match &cmd.mcap {
        Some(path) => Some(results_bag(path)?),
        None => None,
    };
    let mut depth_check = match &input {
        Input::Folder(_) => DepthCheck::open(&cmd.sequence, &camera, &cmd.out)?,
        Input::Bag(..) => None,
    };
    let bar = progress(input.len().min(max_frames), "frames");
    let mut estimated: Vec<EstimatedPose> = Vec::new();
    let mut reports: Vec<FrameReport> = Vec::new();
    let mut skipped = 0usize;
    // SIGINT or SIGTERM stops after the current frame; the map, the figure and the
    // evaluation of the frames done are still written.
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    {
        let stop = std::sync::Arc::clone(&stop);
        if let Err(e) =
            ctrlc::set_handler(move || stop.store(true, std::sync::atomic::Ordering::SeqCst))
        {
            log::warn!("cannot catch SIGINT/SIGTERM ({e}); an interrupted run writes no map");
        }
    }
    let mut interrupted = false;
    let mut broken = None;
    for (label, item) in input.frames(cmd.detector.max_pixels).take(max_frames) {
        if stop.load(std::sync::atomic::Ordering::SeqCst) {
            interrupted = true;
            bar.suspend(|| {
                eprintln!(
                    "interrupted after {} frames: writing the map, the figure and the evaluation of what was done",
                    reports.len()
                )
            });
            break;
        }
        bar.inc(1);
        let (timestamp, frame) = match item {
            Ok(f) => f,
            // The bag itself is broken (cut short, corrupt): nothing after this point can be
            // read, so the run ends here and writes what it has before reporting it.
            Err(e @ steernav::Error::Bag { .. }) => {
                bar.suspend(|| eprintln!("error: {e}; writing what was done"));
                broken = Some(e);
                break;
            }
            Err(e) => {
                bar.suspend(|| eprintln!("warning: {e}; frame skipped"));
                skipped += 1;
                continue;
            }
        };
        let step = match odometry.as_mut().map(|track| track.step_to(timestamp)) {
            Some(Ok(step)) => step,
            Some(Err(e)) => {
                bar.suspend(|| eprintln!("warning: {e}; frame skipped"));
                skipped += 1;
                continue;
            }
            None => None,
        };
        let r = match slam.process(&frame, timestamp, step.as_ref(), &detector) {
            Ok(r) => r,
            Err(e) => {
                bar.suspend(|| eprintln!("warning: {label}: {e}; frame skipped"));
                skipped += 1;
                continue;
            }
        };
        let revised = slam.take_revised();
        if !revised.is_empty() {
            // The start placed its wait, or kept the motion it had not reported: those frames
            // are written again.
            let (t, f) = revise(
                revised,
                &mut reports,
                &mut estimated,
                (&traj_path, cmd.format),
                report.as_ref().map(|(path, _)| path.as_path()),
            )?;
            traj = t;
            if let (Some((_, old)), Some(f)) = (&mut report, f) {
                *old = f;
            }
        }
        let estimate = estimated_pose(&r);
        let pose = estimate.pose;
        writeln!(traj, "{}", trajectory_line(cmd.format, &pose))
            .with_context(|| out_err(&traj_path))?;
        traj.flush().with_context(|| out_err(&traj_path))?;
        if let Some(bag) = &mut mcap {
            bag.write(POSE_TOPIC, timestamp, &pose_stamped(&r))?;
            // Flushed every frame, as the trajectory is: a killed run keeps every pose.
            bag.flush()?;
        }
        if let Some((path, f)) = &mut report {
            let row = r.csv_record();
            f.write_record(&row).with_context(|| out_err(path))?;
            // Flushed every frame: a killed run leaves whole rows up to its last frame.
            f.flush().with_context(|| out_err(path))?;
        }
        if let Some(check) = &mut depth_check {
            check.frame(&slam.map(), &r)?;
        }
        if r.lost {
            bar.set_message("tracking lost");
        } else {
            bar.set_message(format!("{} landmarks", r.landmarks));
        }
        estimated.push(estimate);
        reports.push(r);
    }
    bar.finish_and_clear();
    if let Some((path, mut f)) = report {
        f.flush().with_context(|| out_err(&path))?;
    }
    let map = slam.map();
    if let Some(path) = &cmd.map {
        write_map(path, &map)?;
    }
    if let Some(mut bag) = mcap {
        let end = reports.last().map_or(0.0, |r| r.timestamp);
        let poses: Vec<PoseStamped> = reports.iter().map(pose_stamped).collect();
        bag.write(
            PATH_TOPIC,
            end,
            &PathOut {
                header: write::header(end, "map"),
                poses,
            },
        )?;
        let points: Vec<[f64; 3]> = map.iter().map(|m| m.position).collect();
        bag.write(
            LANDMARKS_TOPIC,
            end,
            &PointCloud2::xyz(write::header(end, "map"), &points),
        )?;
        bag.finish()?;
    }
    if reports.is_empty() {
        bail!(
            "{}: no frame was processed ({} skipped, {} missing)",
            cmd.sequence.display(),
            skipped,
            missing.len()
        );
    }
    let n = reports.len() as f64;
    let mean = |f: fn(&FrameReport) -> f64| reports.iter().map(f).sum::<f64>() / n;
    let lost = reports.iter().filter(|r| r.lost).count();
    let relocalised = reports.iter().filter(|r| r.relocalised).count();
    let initialising = reports.iter().filter(|r| r.initialising).count();
    println!(
        "{}: {} frames ({} layout), {} skipped, {} missing; {} frames initialising, tracking lost on {} frames, relocalised {} times",
        cmd.sequence.display(),
        reports.len(),
        input.layout(),
        skipped,
        missing.len(),
        initialising,
        lost,
        relocalised
    );
    let speed = 1e3 / mean(|r| r.timings.total_ms).max(1e-9);
    println!(
        "per frame: detection {:.2} ms, association {:.2} ms, filter {:.2} ms, total {:.2} ms ({:.0} frames/s{}); {} landmarks at the end",
        mean(|r| r.timings.detection_ms),
        mean(|r| r.timings.association_ms),
        mean(|r| r.timings.filter_ms),
        mean(|r| r.timings.total_ms),
        speed,
        against_camera_rate(&reports, speed),
        map.len()
    );
    println!("trajectory: {}", traj_path.display());
    let estimate: Vec<Pose> = estimated.iter().map(|e| e.pose).collect();
    let mut aligned_truth = None;
    let mut fitted_scale = None;
    let arm = slam.filter().arm();
    if let Some((d, sigma)) = arm {
        println!("wheeled model: camera {d:.4} ± {sigma:.4} map units ahead of the turning axis");
    }
    if let (Some(truth), Some(path)) = (&truth, &truth_path) {
        match trajectory::evaluate(&estimate, truth, 0.02) {
            Ok(e) => {
                if let Some((d, sigma)) = arm {
                    println!(
                        "wheeled model: the arm at the fitted scale, {:.3} ± {:.3} m",
                        d * e.scale,
                        sigma * e.scale
                    );
                }
                println!(
                    "against {}: ATE {:.4} m RMSE ({:.2}% of the {:.2} m path), {}, scale {:.4}, {}, {} poses matched",
                    path.display(),
                    e.ate_rmse,
                    100.0 * e.ate_rmse / e.path_length.max(1e-12),
                    e.path_length,
                    e.rpe_text(),
                    e.scale,
                    e.scale_drift_text(),
                    e.matched
                );
                aligned_truth = Some(truth_in_estimate_frame(&estimate, truth));
                fitted_scale = Some(e.scale);
            }
            Err(e) => eprintln!("warning: cannot evaluate against {}: {e}", path.display()),
        }
    }
    if let Some(check) = &depth_check {
        println!("{}", check.summary(fitted_scale));
    }
    if let Some(path) = &cmd.plot {
        slam_figure(path, &estimated, aligned_truth.as_deref(), &map)?;
        println!("figure: {}", path.display());
    }
    if let Some(e) = broken {
        return Err(anyhow::Error::new(e).context(format!(
            "{}: stopped after {} frames; their trajectory, map and report are written",
            cmd.sequence.display(),
            reports.len()
        )));
    }
    // 128 + SIGINT, as a shell reports an interrupted command.
    Ok(if interrupted {
        ExitCode::from(130)
    } else {
        ExitCode::SUCCESS
    })
}

/// Ground truth mapped into the estimate's frame by the inverse of the Sim(3) alignment.
fn truth_in_estimate_frame(estimate: &[Pose], truth: &[Pose]) -> Vec<Pose> {
    let pairs = trajectory::associate(estimate, truth, 0.02);
    let src: Vec<_> = pairs.iter().map(|(_, g)| g.position).collect();
    let dst: Vec<_> = pairs.iter().map(|(e, _)| e.position).collect();
    let (s, r, t) = trajectory::umeyama(&src, &dst, true);
    pairs
        .iter()
        .map(|(_, g)| Pose {
            position: s * r * g.position + t,
            ..*g
        })
        .collect()
}

fn write_map(path: &Path, map: &[steernav::slam::MapPoint]) -> anyhow::Result<()> {
    let text = if path.extension().is_some_and(|e| e == "ply") {
        let mut s = format!(
            "ply\nformat ascii 1.0\ncomment steernav map\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
            map.len()
        );
        for m in map {
            s.push_str(&format!(
                "{} {} {}\n",
                m.position[0], m.position[1], m.position[2]
            ));
        }
        s
    } else {
        serde_json::to_string_pretty(map)?
    };
    steernav::output::write_atomic(path, text.as_bytes())?;
    println!("map: {} ({} landmarks)", path.display(), map.len());
    Ok(())
}

/// Where `slam` reads its frames: a folder layout or a ROS 2 bag's image topic.
enum Input {
    Folder(Sequence),
    Bag(Box<Bag>, Topic),
}

/// One frame to process, or why it cannot be, named by `label` (file, or bag topic and time).
type FrameItem = (String, steernav::Result<(f64, Frame)>);

impl Input {
    fn open(cmd: &SlamCmd) -> anyhow::Result<Self> {
        if steernav::bag::is_bag(&cmd.sequence) {
            if let Some(fps) = cmd.fps {
                bail!(
                    "{}: --fps {fps} does not apply to a ROS 2 bag: its frames are stamped by \
                     their headers",
                    cmd.sequence.display()
                );
            }
            let bag = Bag::open(&cmd.sequence)?;
            let topic = bag_frames::image_topic(&bag, cmd.image_topic.as_deref())?;
            return Ok(Input::Bag(Box::new(bag), topic));
        }
        for (flag, given) in [
            ("--image-topic", cmd.image_topic.is_some()),
            ("--camera-info-topic", cmd.camera_info_topic.is_some()),
        ] {
            if given {
                bail!(
                    "{}: {flag} applies to ROS 2 bags only",
                    cmd.sequence.display()
                );
            }
        }
        let seq = sequence::open(&cmd.sequence, cmd.fps)?;
        if cmd.calib.is_none() && seq.calibration.is_none() {
            bail!(
                "{}: no calibration beside the frames; pass --calib CALIB.toml",
                cmd.sequence.display()
            );
        }
        Ok(Input::Folder(seq))
    }

    /// `--calib`, else the sequence's calibration or the bag's CameraInfo.
    fn camera(&self, cmd: &SlamCmd) -> anyhow::Result<PinholeCamera> {
        Ok(match self {
            Input::Folder(seq) => seq.camera(cmd.calib.as_deref())?,
            Input::Bag(bag, _) => match &cmd.calib {
                Some(path) if path.extension().is_some_and(|e| e == "txt") => bail!(
                    "{}: a KITTI calib.txt needs the frames' size; give a bag a TOML or sensor.yaml calibration",
                    path.display()
                ),
                Some(path) => PinholeCamera::load(path)?,
                None => bag_frames::camera(bag, cmd.camera_info_topic.as_deref())?,
            },
        })
    }

    fn ground_truth(&self) -> Option<PathBuf> {
        match self {
            Input::Folder(seq) => seq.ground_truth.clone(),
            Input::Bag(..) => None,
        }
    }

    fn ground_truth_poses(&self, path: &Path) -> anyhow::Result<Vec<Pose>> {
        Ok(match self {
            Input::Folder(seq) => sequence::read_ground_truth(path, &seq.ground_truth_times())?,
            Input::Bag(..) => {
                if kitti::looks_like_poses(path) {
                    bail!(
                        "{}: KITTI pose rows are matched to frames by number; a bag's ground truth must carry timestamps (TUM)",
                        path.display()
                    );
                }
                sequence::read_ground_truth(path, &[])?
            }
        })
    }

    fn missing(&self) -> &[PathBuf] {
        match self {
            Input::Folder(seq) => &seq.missing,
            Input::Bag(..) => &[],
        }
    }

    fn layout(&self) -> &'static str {
        match self {
            Input::Folder(seq) => seq.layout,
            Input::Bag(..) => "ROS 2 bag",
        }
    }

    /// Frames to come (a bag's from its message count when the summary has one).
    fn len(&self) -> usize {
        match self {
            Input::Folder(seq) => seq.frames.len(),
            Input::Bag(bag, topic) => bag.message_count(&topic.name).unwrap_or(0) as usize,
        }
    }

    fn frames(&self, max_pixels: u64) -> Box<dyn Iterator<Item = FrameItem> + '_> {
        match self {
            Input::Folder(seq) => Box::new(seq.frames.iter().map(move |item| {
                let label = item.path.display().to_string();
                let frame =
                    Frame::load_limited(&item.path, max_pixels).map(|f| (item.timestamp, f));
                (label, frame)
            })),
            Input::Bag(bag, topic) => Box::new(
                bag.messages(std::slice::from_ref(&topic.name))
                    .map(move |m| match m {
                        Ok(m) => (
                            m.describe(&bag.path),
                            bag_frames::decode_frame(&bag.path, &m, max_pixels)
                                .map(|f| (f.timestamp, f.frame)),
                        ),
                        Err(e) => (bag.path.display().to_string(), Err(e)),
                    }),
            ),
        }
    }
}

const POSE_TOPIC: &str = "/steernav/pose";
const PATH_TOPIC: &str = "/steernav/path";
const LANDMARKS_TOPIC: &str = "/steernav/landmarks";

/// The `--mcap` file with its three topics declared.
fn results_bag(path: &Path) -> anyhow::Result<BagWriter> {
    let mut bag = BagWriter::create(path)?;
    bag.add_topic(
        POSE_TOPIC,
        "geometry_msgs/msg/PoseStamped",
        &write::pose_stamped_schema(),
    )?;
    bag.add_topic(PATH_TOPIC, "nav_msgs/msg/Path", &write::path_schema())?;
    bag.add_topic(
        LANDMARKS_TOPIC,
        "sensor_msgs/msg/PointCloud2",
        &write::point_cloud2_schema(),
    )?;
    Ok(bag)
}

/// A frame's camera pose in the `map` frame (ROS quaternions are x, y, z, w).
fn pose_stamped(r: &FrameReport) -> PoseStamped {
    let q = r.orientation;
    PoseStamped {
        header: write::header(r.timestamp, "map"),
        pose: PoseOut {
            position: r.position,
            orientation: [q[1], q[2], q[3], q[0]],
        },
    }
}

/// Every output is checked before any is touched, so a run refused at the start leaves an
/// earlier run's results whole, and a bad `--plot` fails now rather than after the run.
fn check_outputs(cmd: &SlamCmd) -> anyhow::Result<()> {
    if cmd.out.exists() && !cmd.out.is_dir() {
        bail!("{}: --out must be a folder", cmd.out.display());
    }
    let files = [
        ("--report", &cmd.report),
        ("--map", &cmd.map),
        ("--plot", &cmd.plot),
        ("--mcap", &cmd.mcap),
    ];
    for (flag, path) in files {
        let Some(path) = path else { continue };
        if path.is_dir() {
            bail!("{}: {flag} names a folder; give a file", path.display());
        }
        // The run creates --out, so a file inside it is fine.
        let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
        if let Some(parent) = parent {
            if !parent.is_dir() && parent != cmd.out {
                bail!(
                    "{}: {flag}: the folder {} does not exist",
                    path.display(),
                    parent.display()
                );
            }
        }
        if path == &cmd.out.join("trajectory.txt") {
            bail!("{}: {flag} would overwrite the trajectory", path.display());
        }
    }
    if let Some(plot) = &cmd.plot {
        crate::args::check_png_output("--plot", plot)?;
    }
    Ok(())
}

/// How the processing rate `speed` (frames/s) compares with the rate the frames were taken at
/// (from their timestamps): ", real time against the sequence's 30.0" or ", 0.62× the
/// sequence's 30.0: falls behind"; empty for fewer than two frames or equal timestamps.
fn against_camera_rate(reports: &[FrameReport], speed: f64) -> String {
    let (Some(first), Some(last)) = (reports.first(), reports.last()) else {
        return String::new();
    };
    let span = last.timestamp - first.timestamp;
    if reports.len() < 2 || span.is_nan() || span <= 0.0 {
        return String::new();
    }
    let rate = (reports.len() - 1) as f64 / span;
    if speed >= rate {
        format!(", real time against the sequence's {rate:.1}")
    } else {
        format!(
            ", {:.2}× the sequence's {rate:.1}: falls behind",
            speed / rate
        )
    }
}
