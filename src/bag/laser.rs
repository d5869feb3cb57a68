//! Laser topics of a bag as the replay's scans: `sensor_msgs/msg/LaserScan` (beam i at
//! angle_min + i·angle_increment; ranges outside [range_min, range_max], and NaN or infinite
//! ones, discarded as ROS specifies) with the robot's pose from `nav_msgs/msg/Odometry`,
//! interpolated at each scan's stamp. The same data as a CARMEN log gives the same scans.

use super::messages::{LaserScan, Odometry};
use super::Bag;
use crate::error::{Error, Result};
use crate::nav::carmen::Scan;

/// The laser type.
pub const LASER_SCAN: &str = "sensor_msgs/msg/LaserScan";
/// The odometry type.
pub const ODOMETRY: &str = "nav_msgs/msg/Odometry";

/// A planar pose at a time.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Pose2 {
    time: f64,
    x: f64,
    y: f64,
    theta: f64,
}

/// Every scan of the bag's laser topic with its odometry pose, in the bag's order. Scans
/// outside the odometry's time span have no pose and are left out (logged).
pub fn scans(bag: &Bag, scan_topic: Option<&str>, odom_topic: Option<&str>) -> Result<Vec<Scan>> {
    let scan_topic = bag.choose_topic(&[LASER_SCAN], scan_topic, "--scan-topic")?;
    let odom_topic = bag.choose_topic(&[ODOMETRY], odom_topic, "--odom-topic")?;
    let topics = [scan_topic.name.clone(), odom_topic.name.clone()];
    // Per scan: stamp, beams, and the pose of an odometry message with the same stamp that
    // came just before it (logs with coarse stamps repeat one stamp over several poses).
    type Raw = (f64, Vec<f32>, Vec<f32>, f32, Option<Pose2>);
    let mut raw: Vec<Raw> = Vec::new();
    let mut poses: Vec<Pose2> = Vec::new();
    for m in bag.messages(&topics) {
        let m = m?;
        if m.topic == odom_topic.name {
            let o: Odometry = m.decode(&bag.path)?;
            let q = o.pose.pose.orientation;
            let theta = (2.0 * (q.w * q.z + q.x * q.y)).atan2(1.0 - 2.0 * (q.y * q.y + q.z * q.z));
            let p = o.pose.pose.position;
            if ![p.x, p.y, theta].iter().all(|v| v.is_finite()) {
                return Err(Error::input(
                    m.describe(&bag.path),
                    "a non-finite odometry pose",
                ));
            }
            poses.push(Pose2 {
                time: o.header.stamp.seconds(),
                x: p.x,
                y: p.y,
                theta,
            });
        } else {
            let s: LaserScan = m.decode(&bag.path)?;
            let what = m.describe(&bag.path);
            let (ranges, bearings) = beams(&s, &what)?;
            let time = s.header.stamp.seconds();
            let same = poses.last().copied().filter(|p| p.time == time);
            raw.push((time, ranges, bearings, s.angle_increment.abs(), same));
        }
    }
    // Scans stay in the bag's order, as a log's do; the poses are sorted for interpolation.
    poses.sort_by(|a, b| a.time.total_cmp(&b.time));
    let mut out = Vec::with_capacity(raw.len());
    let mut outside = 0;
    for (time, ranges, bearings, angle_increment, same) in raw {
        match same.or_else(|| pose_at(&poses, time)) {
            Some(p) => out.push(Scan {
                ranges,
                bearings,
                angle_increment,
                x: p.x,
                y: p.y,
                theta: p.theta,
                time,
            }),
            None => outside += 1,
        }
    }
    if outside > 0 {
        log::warn!(
            "{}: {outside} scans lie outside the odometry's time span and have no pose; left out",
            bag.path.display()
        );
    }
    Ok(out)
}

/// The valid beams of a scan: ranges and bearings.
fn beams(s: &LaserScan, what: &str) -> Result<(Vec<f32>, Vec<f32>)> {
    if !(s.angle_min.is_finite() && s.angle_increment.is_finite() && s.angle_increment != 0.0) {
        return Err(Error::input(
            what,
            format!(
                "angle_min {} and angle_increment {} do not place the beams",
                s.angle_min, s.angle_increment
            ),
        ));
    }
    let (lo, hi) = (s.range_min, s.range_max);
    let mut ranges = Vec::with_capacity(s.ranges.len());
    let mut bearings = Vec::with_capacity(s.ranges.len());
    for (i, &r) in s.ranges.iter().enumerate() {
        if r.is_finite() && r >= lo && r <= hi {
            ranges.push(r);
            bearings.push((s.angle_min as f64 + i as f64 * s.angle_increment as f64) as f32);
        }
    }
    Ok((ranges, bearings))
}

/// The odometry pose at `t`, linear between the two poses around it (the heading along the
/// shorter turn); `None` outside their span.
fn pose_at(poses: &[Pose2], t: f64) -> Option<Pose2> {
    let i = poses.partition_point(|p| p.time < t);
    if i < poses.len() && poses[i].time == t {
        return Some(poses[i]);
    }
    if i == 0 || i == poses.len() {
        return None;
    }
    let (a, b) = (poses[i - 1], poses[i]);
    let f = (t - a.time) / (b.time - a.time);
    let turn = (b.theta - a.theta + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
        - std::f64::consts::PI;
    Some(Pose2 {
        time: t,
        x: a.x + f * (b.x - a.x),
        y: a.y + f * (b.y - a.y),
        theta: a.theta + f * turn,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poses_interpolate_across_the_half_turn() {
        let p = |time, theta| Pose2 {
            time,
            x: time,
            y: 0.0,
            theta,
        };
        let poses = [p(0.0, 3.0), p(1.0, -3.0)];
        let mid = pose_at(&poses, 0.5).unwrap();
        assert!((mid.x - 0.5).abs() < 1e-12);
        // 3 rad to −3 rad is a turn of 2π − 6 through π, not of −6 through 0.
        assert!((mid.theta - (3.0 + (std::f64::consts::TAU - 6.0) / 2.0)).abs() < 1e-12);
        assert_eq!(pose_at(&poses, 1.0).unwrap().theta, -3.0);
        assert!(pose_at(&poses, 1.5).is_none() && pose_at(&poses, -0.1).is_none());
    }
}
