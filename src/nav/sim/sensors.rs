//! The robot's sensors: a planar LIDAR by exact ray casting (range limit, Gaussian noise, only
//! what stands in its scan plane — eqs 42–45 give range and bearing), and a forward camera
//! that renders the robot's view column by column (every obstacle, textured, at its true
//! height), the input of the GIST stimulus.

use serde::{Deserialize, Serialize};

use super::world::World;
use crate::error::{Error, Result};
use crate::image::Frame;
use crate::nav::camera::CameraConfig;
use crate::rng::Rng;

/// LIDAR parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LidarConfig {
    /// Number of beams. Default 181.
    pub beams: usize,
    /// Field of view, degrees, centred straight ahead. Default 180.
    pub fov_deg: f32,
    /// Range limit, metres: beams that hit nothing read this. Default 4.
    pub max_range: f32,
    /// Standard deviation of the range noise, metres. Default 0.01.
    pub noise: f32,
}

impl Default for LidarConfig {
    fn default() -> Self {
        Self {
            beams: 181,
            fov_deg: 180.0,
            max_range: 4.0,
            noise: 0.01,
        }
    }
}

impl LidarConfig {
    /// Checks the values, naming the bad one.
    pub fn validate(&self) -> Result<()> {
        if self.beams < 2 || self.beams > 100_000 {
            return Err(Error::config(
                "lidar.beams",
                self.beams,
                "must be in 2..=100000",
            ));
        }
        for (field, v) in [
            ("lidar.fov_deg", self.fov_deg),
            ("lidar.max_range", self.max_range),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::config(field, v, "must be finite and > 0"));
            }
        }
        if !(self.noise.is_finite() && self.noise >= 0.0) {
            return Err(Error::config(
                "lidar.noise",
                self.noise,
                "must be finite and >= 0",
            ));
        }
        Ok(())
    }

    /// Bearing of beam `i`, radians, robot frame (0 ahead, positive to the left).
    pub fn bearing(&self, i: usize) -> f32 {
        let fov = self.fov_deg.to_radians();
        -0.5 * fov + fov * i as f32 / (self.beams - 1) as f32
    }

    /// One scan from pose (x, y, θ): ranges in metres, beam by beam.
    pub fn scan(&self, world: &World, pose: [f32; 3], rng: &mut Rng) -> Vec<f32> {
        (0..self.beams)
            .map(|i| {
                let angle = pose[2] + self.bearing(i);
                let d = world
                    .cast([pose[0], pose[1]], angle, self.max_range, true)
                    .map_or(self.max_range, |h| h.distance);
                if d >= self.max_range {
                    return self.max_range;
                }
                (d + self.noise * gaussian(rng)).clamp(0.0, self.max_range)
            })
            .collect()
    }
}

/// A standard normal sample (Box–Muller).
pub fn gaussian(rng: &mut Rng) -> f32 {
    let u1 = rng.unit_f64().max(1e-12);
    let u2 = rng.unit_f64();
    ((-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32
}

/// The simulator's renderer of the robot's camera.
impl CameraConfig {
    /// Renders the robot's view from pose (x, y, θ): plain sky and floor, walls with brick
    /// courses, obstacles with checkers in their own colour — low ones too, which is what
    /// lets a camera learn them from the LIDAR's lessons on tall ones.
    pub fn render(&self, world: &World, pose: [f32; 3]) -> Frame {
        let (w, h) = (self.width as usize, self.height as usize);
        let f = self.focal();
        let horizon = 0.5 * h as f32;
        let mut rgb = vec![0u8; 3 * w * h];
        for y in 0..h {
            let sky = y as f32 + 0.5 < horizon;
            let c: [u8; 3] = if sky {
                [200, 210, 225]
            } else {
                [120, 115, 105]
            };
            for x in 0..w {
                rgb[3 * (y * w + x)..3 * (y * w + x) + 3].copy_from_slice(&c);
            }
        }
        for x in 0..w {
            let rel = self.column_bearing(x as f32 + 0.5);
            let hits = world.cast_all([pose[0], pose[1]], pose[2] + rel, self.max_range, false);
            // Back to front, so nearer surfaces cover farther ones.
            for hit in hits.iter().rev() {
                let depth = (hit.distance * rel.cos()).max(1e-3);
                let top_z = hit.obstacle.map_or(2.0, |i| world.obstacles[i].height);
                let top = horizon - f * (top_z - self.mount_height) / depth;
                let bottom = horizon + f * self.mount_height / depth;
                let (y0, y1) = (
                    top.max(0.0) as usize,
                    (bottom.min(h as f32)).max(0.0) as usize,
                );
                for y in y0..y1 {
                    let z = self.mount_height + (horizon - (y as f32 + 0.5)) * depth / f;
                    let shade = (1.0 - 0.06 * hit.distance).clamp(0.35, 1.0);
                    let c = surface_colour(hit.obstacle, hit.surface, z, shade);
                    rgb[3 * (y * w + x)..3 * (y * w + x) + 3].copy_from_slice(&c);
                }
            }
        }
        Frame::from_rgb(self.width, self.height, rgb).expect("size validated")
    }
}

fn surface_colour(obstacle: Option<usize>, u: f32, z: f32, shade: f32) -> [u8; 3] {
    let (base, pattern) = match obstacle {
        None => {
            // Bricks: 0.25 m courses, staggered 0.5 m bricks.
            let course = (z / 0.25).floor() as i32;
            let offset = if course % 2 == 0 { 0.0 } else { 0.25 };
            let mortar = (z / 0.25).fract() < 0.08 || ((u + offset) / 0.5).fract() < 0.04;
            ([170.0, 90.0, 70.0], if mortar { 0.55 } else { 1.0 })
        }
        Some(i) => {
            let hue = [
                [60.0, 120.0, 200.0],
                [200.0, 170.0, 40.0],
                [70.0, 160.0, 80.0],
                [180.0, 70.0, 160.0],
            ][i % 4];
            let checker = ((u / 0.1).floor() as i32 + (z / 0.1).floor() as i32).rem_euclid(2) == 0;
            (hue, if checker { 1.0 } else { 0.35 })
        }
    };
    let k = pattern * shade;
    [
        (base[0] * k) as u8,
        (base[1] * k) as u8,
        (base[2] * k) as u8,
    ]
}
