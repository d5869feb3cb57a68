//! A bag's wheel odometry as the camera's trajectory, for SLAM's odometry motion model (eq 15):
//! `nav_msgs/msg/Odometry` gives the pose of the robot's base (`child_frame_id`) in the odometry
//! frame, and `/tf_static` (`tf2_msgs/msg/TFMessage`) places the camera's frame on the base;
//! each camera pose is T_odom_base · T_base_camera.

use std::collections::HashMap;

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3, Vector4};
use serde::Deserialize;

use super::laser::ODOMETRY;
use super::messages::{Header, Odometry, Quaternion as RosQuaternion, Vector3 as RosVector3};
use super::Bag;
use crate::error::{Error, Result};
use crate::slam::data::trajectory::Pose;

/// The static transforms' type.
pub const TF_MESSAGE: &str = "tf2_msgs/msg/TFMessage";

/// `geometry_msgs/msg/Transform`.
#[derive(Clone, Debug, Deserialize)]
struct Transform {
    translation: RosVector3,
    rotation: RosQuaternion,
}

/// `geometry_msgs/msg/TransformStamped`.
#[derive(Clone, Debug, Deserialize)]
struct TransformStamped {
    header: Header,
    child_frame_id: String,
    transform: Transform,
}

/// `tf2_msgs/msg/TFMessage`.
#[derive(Clone, Debug, Deserialize)]
struct TfMessage {
    transforms: Vec<TransformStamped>,
}

fn isometry(t: &RosVector3, q: &RosQuaternion, what: &str) -> Result<Isometry3<f64>> {
    let raw = Quaternion::new(q.w, q.x, q.y, q.z);
    let norm = raw.norm();
    if !(norm.is_finite() && norm > 1e-9 && [t.x, t.y, t.z].iter().all(|v| v.is_finite())) {
        return Err(Error::input(
            what,
            "a transform that is not finite, or a zero quaternion",
        ));
    }
    Ok(Isometry3::from_parts(
        Translation3::new(t.x, t.y, t.z),
        UnitQuaternion::from_quaternion(raw),
    ))
}

/// T_base_camera from the static transforms: both frames are walked up to their root, and
/// must share it.
fn base_to_camera(
    parents: &HashMap<String, (String, Isometry3<f64>)>,
    base: &str,
    camera: &str,
    bag: &str,
) -> Result<Isometry3<f64>> {
    // T_root_frame and the root, following child → parent links (bounded by the link count,
    // so a cycle cannot loop).
    let up = |frame: &str| {
        let mut pose = Isometry3::identity();
        let mut at = frame.to_string();
        for _ in 0..=parents.len() {
            match parents.get(&at) {
                Some((parent, t)) => {
                    pose = t * pose;
                    at = parent.clone();
                }
                None => break,
            }
        }
        (at, pose)
    };
    let (root_b, t_root_base) = up(base);
    let (root_c, t_root_camera) = up(camera);
    if root_b != root_c {
        return Err(Error::input(
            bag,
            format!(
                "no /tf_static transforms link the odometry's base frame {base:?} to the camera's frame {camera:?} (give the odometry topic of the camera's own frame, or record tf_static)"
            ),
        ));
    }
    Ok(t_root_base.inverse() * t_root_camera)
}

/// The camera's poses from the bag's odometry on `odom_topic` (or the only Odometry topic),
/// with the camera in `camera_frame` (the images' or CameraInfo's `header.frame_id`).
pub fn camera_track(bag: &Bag, odom_topic: Option<&str>, camera_frame: &str) -> Result<Vec<Pose>> {
    let odom = bag.choose_topic(&[ODOMETRY], odom_topic, "--odom-topic")?;
    let mut topics = vec![odom.name.clone()];
    topics.extend(
        bag.topics_of(&[TF_MESSAGE])
            .iter()
            .filter(|t| t.name.ends_with("tf_static"))
            .map(|t| t.name.clone()),
    );
    let mut parents: HashMap<String, (String, Isometry3<f64>)> = HashMap::new();
    let mut base_poses: Vec<(f64, String, Isometry3<f64>)> = Vec::new();
    for m in bag.messages(&topics) {
        let m = m?;
        let what = m.describe(&bag.path);
        if m.topic == odom.name {
            let o: Odometry = m.decode(&bag.path)?;
            let p = o.pose.pose;
            let t = RosVector3 {
                x: p.position.x,
                y: p.position.y,
                z: p.position.z,
            };
            base_poses.push((
                o.header.stamp.seconds(),
                o.child_frame_id,
                isometry(&t, &p.orientation, &what)?,
            ));
        } else {
            let tf: TfMessage = m.decode(&bag.path)?;
            for t in tf.transforms {
                let iso = isometry(&t.transform.translation, &t.transform.rotation, &what)?;
                parents.insert(t.child_frame_id, (t.header.frame_id, iso));
            }
        }
    }
    let Some(base) = base_poses.first().map(|p| p.1.clone()) else {
        return Err(Error::input(
            bag.path.display().to_string(),
            format!("topic {} has no message", odom.name),
        ));
    };
    let extrinsic = if base == camera_frame || base.is_empty() {
        Isometry3::identity()
    } else {
        base_to_camera(
            &parents,
            &base,
            camera_frame,
            &bag.path.display().to_string(),
        )?
    };
    let mut poses: Vec<Pose> = base_poses
        .into_iter()
        .map(|(timestamp, _, t_odom_base)| {
            let camera = t_odom_base * extrinsic;
            let q = camera.rotation.into_inner();
            Pose {
                timestamp,
                position: Vector3::from(camera.translation.vector),
                orientation: Vector4::new(q.w, q.i, q.j, q.k),
            }
        })
        .collect();
    poses.sort_by(|a, b| a.timestamp.total_cmp(&b.timestamp));
    Ok(poses)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_camera_is_found_through_a_chain_of_static_transforms() {
        let shift = |x: f64, y: f64, z: f64| Isometry3::translation(x, y, z);
        let mut parents = HashMap::new();
        // base_link → mast (0.2 up), mast → camera (0.1 ahead, turned 90° about z).
        parents.insert(
            "mast".to_string(),
            ("base_link".to_string(), shift(0.0, 0.0, 0.2)),
        );
        let turn = Isometry3::from_parts(
            Translation3::new(0.1, 0.0, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2),
        );
        parents.insert("camera".to_string(), ("mast".to_string(), turn));
        let t = base_to_camera(&parents, "base_link", "camera", "b.mcap").unwrap();
        assert!((t.translation.vector - Vector3::new(0.1, 0.0, 0.2)).norm() < 1e-12);
        assert!((t.rotation.angle() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        // Seen from another frame of the same tree, the same camera.
        let from_mast = base_to_camera(&parents, "mast", "camera", "b.mcap").unwrap();
        assert!((from_mast.translation.vector - Vector3::new(0.1, 0.0, 0.0)).norm() < 1e-12);
        let e = base_to_camera(&parents, "base_link", "lidar", "b.mcap")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("b.mcap") && e.contains("\"lidar\"") && e.contains("tf_static"),
            "{e}"
        );
    }
}
