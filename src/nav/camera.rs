//! The robot's forward camera as the controller sees it: its geometry, which maps GIST blocks
//! to sectors of bearing (section 3.2.2) and tells how far the floor under the bottom row of
//! blocks lies. The simulator renders through it (`sim::sensors`).

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Camera parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraConfig {
    /// Image width, pixels. Default 128.
    pub width: u32,
    /// Image height, pixels. Default 96.
    pub height: u32,
    /// Horizontal field of view, degrees. Default 90.
    pub fov_deg: f32,
    /// Height of the optical centre above the floor, metres. Default 0.5.
    pub mount_height: f32,
    /// Nothing is drawn beyond this distance, metres. Default 10.
    pub max_range: f32,
}

impl Default for CameraConfig {
    fn default() -> Self {
        Self {
            width: 128,
            height: 96,
            fov_deg: 90.0,
            mount_height: 0.5,
            max_range: 10.0,
        }
    }
}

impl CameraConfig {
    /// Checks the values, naming the bad one.
    pub fn validate(&self) -> Result<()> {
        crate::image::check_size("camera", self.width, self.height)?;
        if !(self.fov_deg.is_finite() && self.fov_deg > 1.0 && self.fov_deg < 179.0) {
            return Err(Error::config(
                "camera.fov_deg",
                self.fov_deg,
                "must be in (1, 179)",
            ));
        }
        for (field, v) in [
            ("camera.mount_height", self.mount_height),
            ("camera.max_range", self.max_range),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::config(field, v, "must be finite and > 0"));
            }
        }
        Ok(())
    }

    /// Focal length in pixels.
    pub fn focal(&self) -> f32 {
        0.5 * self.width as f32 / (0.5 * self.fov_deg.to_radians()).tan()
    }

    /// Bearing of image column `c` (robot frame; column 0 on the left).
    pub fn column_bearing(&self, c: f32) -> f32 {
        ((0.5 * self.width as f32 - c) / self.focal()).atan()
    }

    /// The distance under which an obstacle's foot shows in the bottom `fraction` (< 0.5) of
    /// the image: its foot projects to row h/2 + f·mount_height/d.
    pub fn near_distance(&self, fraction: f32) -> f32 {
        self.focal() * self.mount_height / (self.height as f32 * (0.5 - fraction)).max(1e-3)
    }
}
