//! Wheel odometry as the input u_k of the odometry motion model (eq 15): a trajectory of the
//! camera (TUM), interpolated at each frame's time, turned into the motion since the previous
//! frame.

use std::path::Path;

use super::trajectory::{interpolate, read_tum, Pose};
use crate::error::{Error, Result};
use crate::slam::motion::{relative_motion, OdometryStep};

/// Odometry poses and where the last frame was.
#[derive(Clone, Debug)]
pub struct OdometryTrack {
    poses: Vec<Pose>,
    previous: Option<Pose>,
}

impl OdometryTrack {
    /// A track of camera poses in time order.
    pub fn new(poses: Vec<Pose>) -> Self {
        Self {
            poses,
            previous: None,
        }
    }

    /// Reads a TUM trajectory file.
    pub fn load(path: &Path) -> Result<Self> {
        Ok(Self::new(read_tum(path)?))
    }

    /// The motion from the previous frame to the frame at `t` seconds: `None` for the first
    /// frame. A `t` outside the track is an [`Error::Input`]; the frame should be skipped, and
    /// the next step then spans from the last frame the track covered.
    pub fn step_to(&mut self, t: f64) -> Result<Option<OdometryStep>> {
        let now = interpolate(&self.poses, t).ok_or_else(|| {
            Error::input(
                format!("odometry at t={t}"),
                match (self.poses.first(), self.poses.last()) {
                    (Some(a), Some(b)) => {
                        format!("outside the track ({} to {})", a.timestamp, b.timestamp)
                    }
                    _ => "the track is empty".into(),
                },
            )
        })?;
        let step = self.previous.map(|prev| {
            relative_motion(
                &prev.position,
                &prev.orientation,
                &now.position,
                &now.orientation,
            )
        });
        self.previous = Some(now);
        Ok(step)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Vector3, Vector4};

    fn pose(t: f64, x: f64) -> Pose {
        Pose {
            timestamp: t,
            position: Vector3::new(x, 0.0, 0.0),
            orientation: Vector4::new(1.0, 0.0, 0.0, 0.0),
        }
    }

    #[test]
    fn steps_are_the_motion_between_frames_and_gaps_are_named() {
        let mut track = OdometryTrack::new(vec![pose(0.0, 0.0), pose(1.0, 2.0)]);
        assert!(track.step_to(0.0).unwrap().is_none());
        let e = track.step_to(3.0).unwrap_err().to_string();
        assert!(e.contains("t=3") && e.contains("outside"), "{e}");
        let step = track
            .step_to(0.5)
            .unwrap()
            .expect("a second frame has a step");
        assert!(
            (step.translation - Vector3::new(1.0, 0.0, 0.0)).norm() < 1e-12,
            "{step:?}"
        );
    }
}
