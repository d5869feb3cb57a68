//! `steernav nav-replay`: the neural field on every scan of a CARMEN laser log or of a ROS 2
//! bag's LaserScan topic.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use steernav::bag::write::{self, BagWriter, TwistOut};

use crate::args::ConfigArg;

const CMD_VEL: &str = "/steernav/cmd_vel";
const HEADING: &str = "/steernav/heading";

#[derive(Args)]
pub struct NavReplayCmd {
    /// CARMEN log (.log or .log.gz), or a ROS 2 bag (rosbag2 folder or .mcap file) with a
    /// sensor_msgs/msg/LaserScan topic and the robot's nav_msgs/msg/Odometry.
    log: PathBuf,
    /// The bag's LaserScan topic, when it has several.
    #[arg(long, value_name = "TOPIC")]
    scan_topic: Option<String>,
    /// The bag's Odometry topic, when it has several.
    #[arg(long, value_name = "TOPIC")]
    odom_topic: Option<String>,
    #[command(flatten)]
    config: ConfigArg,
    /// Print the figures as JSON: "scans", "free_fraction", "mean_abs_deviation_deg" over
    /// every scan with motion; "motion" (scans driving forward, turning in place, reversing,
    /// standing); "forward" and "reference" ({"scans", "mean_deg", "median_deg", "p90_deg"}:
    /// the chosen heading's and the nearest free heading's deviation over the forward-driving
    /// scans); "forward_free_fraction"; "reference_missing" (forward scans with no free
    /// heading). docs/NAVIGATION.md explains the classes.
    #[arg(long)]
    json: bool,
    /// Also write, per evaluated scan and stamped with it, the command as
    /// geometry_msgs/msg/Twist on /steernav/cmd_vel (linear.x the speed, angular.z the turn
    /// rate) and the chosen heading (rad, robot frame) as std_msgs/msg/Float64 on
    /// /steernav/heading, as MCAP for ROS 2 tools and Foxglove.
    #[arg(long, value_name = "FILE")]
    mcap: Option<PathBuf>,
}

pub fn run(cmd: NavReplayCmd) -> anyhow::Result<ExitCode> {
    let cfg = cmd.config.settings()?.replay;
    let scans = if steernav::bag::is_bag(&cmd.log) {
        let bag = steernav::bag::Bag::open(&cmd.log)?;
        steernav::bag::laser::scans(&bag, cmd.scan_topic.as_deref(), cmd.odom_topic.as_deref())?
    } else {
        if cmd.scan_topic.is_some() || cmd.odom_topic.is_some() {
            anyhow::bail!(
                "{}: --scan-topic and --odom-topic apply to ROS 2 bags only",
                cmd.log.display()
            );
        }
        steernav::nav::carmen::read_log(&cmd.log)?
    };
    let r = match &cmd.mcap {
        None => steernav::nav::replay::replay(&scans, &cfg)?,
        Some(path) => {
            let mut bag = BagWriter::create(path)?;
            bag.add_topic(CMD_VEL, "geometry_msgs/msg/Twist", &write::twist_schema())?;
            bag.add_topic(HEADING, "std_msgs/msg/Float64", &write::float64_schema())?;
            let mut since_flush = 0;
            let r = steernav::nav::replay::replay_with(&scans, &cfg, |step| {
                let c = step.command;
                bag.write(
                    CMD_VEL,
                    step.time,
                    &TwistOut {
                        linear: [c.v as f64, 0.0, 0.0],
                        angular: [0.0, 0.0, c.omega as f64],
                    },
                )?;
                bag.write(HEADING, step.time, &(c.heading as f64))?;
                since_flush += 1;
                if since_flush == 100 {
                    since_flush = 0;
                    bag.flush()?;
                }
                Ok(())
            })?;
            bag.finish()?;
            r
        }
    };
    if cmd.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!(
            "{}: {} scans with motion; chosen heading free on {:.1}%; mean |deviation| from the real motion {:.1}°",
            cmd.log.display(),
            r.scans,
            100.0 * r.free_fraction,
            r.mean_abs_deviation_deg
        );
        let m = &r.motion;
        println!(
            "  scans: {} forward, {} turning in place, {} reversing, {} standing",
            m.forward, m.turning_in_place, m.reversing, m.standing
        );
        let (f, g) = (&r.forward, &r.reference);
        println!(
            "  forward: deviation mean {:.1}°, median {:.1}°, 90% {:.1}°, free {:.1}%; nearest free heading: mean {:.1}°, median {:.1}°, 90% {:.1}°{}",
            f.mean_deg,
            f.median_deg,
            f.p90_deg,
            100.0 * r.forward_free_fraction,
            g.mean_deg,
            g.median_deg,
            g.p90_deg,
            if r.reference_missing > 0 {
                format!(" ({} scans with no free heading)", r.reference_missing)
            } else {
                String::new()
            }
        );
    }
    Ok(ExitCode::SUCCESS)
}
