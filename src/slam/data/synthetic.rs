//! A synthetic monocular sequence with exact ground truth: a camera moving inside a box whose
//! six walls carry seeded procedural textures ([`crate::synth::textured_scene`]), rendered by
//! ray casting through the calibrated (optionally distorted) camera. Two motions: a hand-held
//! loop in a room, and a car driving down a street-sized box at 10 Hz with turns (scene
//! depths 3–50 m). Tests use it to check that the filter converges; `steernav slam-synth`
//! writes it in the TUM RGB-D layout.

use std::f64::consts::TAU;
use std::io::Write;
use std::path::Path;

use nalgebra::{Vector2, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::trajectory::{write_tum, Pose};
use crate::error::{Error, Result};
use crate::image::Frame;
use crate::slam::camera::PinholeCamera;
use crate::slam::rotation;

/// How the synthetic camera moves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SyntheticMotion {
    /// A hand-held loop in a room: sideways sway, yaw and pitch oscillations.
    #[default]
    Room,
    /// A car: forward at about `speed` along +z, heading swinging by ±`amplitude` radians over
    /// `period` seconds, the camera `camera_height` metres above the floor.
    Drive,
}

/// Parameters of a synthetic sequence.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SyntheticConfig {
    /// The trajectory.
    pub motion: SyntheticMotion,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Horizontal field of view, degrees.
    pub fov_deg: f64,
    /// Radial distortion k₁ of the rendered camera.
    pub k1: f64,
    /// Number of frames.
    pub frames: usize,
    /// Frame rate, Hz.
    pub fps: f64,
    /// Half-extent of the room (x, y, z), metres; the camera starts at its centre.
    pub room: [f64; 3],
    /// Room: amplitude of the sideways motion, metres. Drive: amplitude of the heading
    /// swing, radians.
    pub amplitude: f64,
    /// Drive: mean forward speed, m/s; it swings by ±30% over 1.5 periods (braking and
    /// accelerating), so a constant step length is not the right answer.
    pub speed: f64,
    /// Drive: height of the camera above the floor, metres.
    pub camera_height: f64,
    /// Duration of one loop of the trajectory, seconds (independent of `frames`, so a short
    /// sequence is the start of a long one).
    pub period: f64,
    /// Texture resolution, texels per metre.
    pub texels_per_metre: f64,
    /// Seed of the wall textures.
    pub seed: u64,
}

impl Default for SyntheticConfig {
    fn default() -> Self {
        Self {
            width: 320,
            height: 240,
            fov_deg: 70.0,
            k1: -0.05,
            frames: 240,
            fps: 30.0,
            room: [3.0, 1.5, 4.0],
            amplitude: 0.5,
            speed: 10.0,
            camera_height: 1.6,
            period: 8.0,
            texels_per_metre: 160.0,
            seed: 7,
            motion: SyntheticMotion::Room,
        }
    }
}

impl SyntheticConfig {
    /// The defaults of a motion: the room loop ([`Default`]) or a drive — 10 Hz, 10 m/s,
    /// heading ±0.25 rad over 8 s, in a box 16 m wide, 6 m high and 120 m long whose side
    /// walls pass at 3–11 m and whose far wall starts 95 m ahead.
    pub fn for_motion(motion: SyntheticMotion) -> Self {
        match motion {
            SyntheticMotion::Room => Self::default(),
            SyntheticMotion::Drive => Self {
                motion,
                frames: 60,
                fps: 10.0,
                room: [8.0, 3.0, 60.0],
                amplitude: 0.25,
                speed: 10.0,
                camera_height: 1.6,
                period: 8.0,
                texels_per_metre: 24.0,
                ..Self::default()
            },
        }
    }
}

/// A synthetic sequence: the camera, the ground-truth poses and the scene to render from.
pub struct SyntheticSequence {
    /// Configuration it was built from.
    pub config: SyntheticConfig,
    /// The rendering (and calibration) camera.
    pub camera: PinholeCamera,
    /// Ground-truth camera poses, one per frame.
    pub poses: Vec<Pose>,
    walls: Vec<Frame>,
    rays: Vec<Vector3<f64>>,
}

impl SyntheticSequence {
    /// Builds the scene and the trajectory (a smooth loop with yaw and pitch oscillations,
    /// the first pose at the origin looking along +z).
    pub fn new(config: SyntheticConfig) -> Result<Self> {
        if config.frames == 0
            || config.fps.is_nan()
            || config.fps <= 0.0
            || config.period.is_nan()
            || config.period <= 0.0
            || !(config.fov_deg > 1.0 && config.fov_deg < 170.0)
            || !config
                .room
                .iter()
                .all(|r| r.is_finite() && *r > 0.1 && *r < 1e4)
            || !(config.texels_per_metre > 0.0 && config.texels_per_metre <= 1e4)
            || !(config.k1.is_finite() && config.k1.abs() < 1.0)
            || !(config.amplitude.is_finite() && config.amplitude.abs() < 1e3)
            || !(config.speed.is_finite() && config.speed.abs() < 1e3)
            || !(config.camera_height > 0.0 && config.camera_height < 2.0 * config.room[1])
        {
            return Err(Error::config(
                "synthetic",
                format!(
                    "frames={} fps={} fov={}",
                    config.frames, config.fps, config.fov_deg
                ),
                "needs frames >= 1, fps > 0, period > 0, fov in (1, 170) degrees, room half-extents in (0.1, 1e4) m, texels_per_metre in (0, 1e4], |k1| < 1, |amplitude| and |speed| < 1e3, camera_height inside the room",
            ));
        }
        crate::image::check_size("synthetic", config.width, config.height)?;
        let f = 0.5 * config.width as f64 / (0.5 * config.fov_deg.to_radians()).tan();
        let camera = PinholeCamera {
            k1: config.k1,
            ..PinholeCamera::ideal(
                f,
                f,
                0.5 * (config.width as f64 - 1.0),
                0.5 * (config.height as f64 - 1.0),
                config.width,
                config.height,
            )
        };
        let walls = (0..6u64)
            .into_par_iter()
            .map(|i| {
                let [rx, ry, rz] = config.room;
                let (a, b) = match i / 2 {
                    0 => (ry, rz),
                    1 => (rx, rz),
                    _ => (rx, ry),
                };
                let w = ((2.0 * a * config.texels_per_metre) as u32).clamp(16, 4096);
                let h = ((2.0 * b * config.texels_per_metre) as u32).clamp(16, 4096);
                tiled_texture(w, h, config.seed.wrapping_mul(31).wrapping_add(i))
            })
            .collect();
        let rays = (0..config.width as usize * config.height as usize)
            .map(|i| {
                let z = Vector2::new(
                    (i % config.width as usize) as f64,
                    (i / config.width as usize) as f64,
                );
                camera.back_project(z).0
            })
            .collect();
        let poses = match config.motion {
            SyntheticMotion::Room => room_loop(&config),
            SyntheticMotion::Drive => drive(&config),
        };
        if let Some((k, pose)) = poses
            .iter()
            .enumerate()
            .find(|(_, p)| (0..3).any(|axis| p.position[axis].abs() > config.room[axis] - 0.1))
        {
            return Err(Error::config(
                "synthetic.room",
                format!("{:?}", config.room),
                format!(
                    "frame {k} at {:?} leaves the box; enlarge room or use fewer frames",
                    pose.position.as_slice()
                ),
            ));
        }
        Ok(Self {
            config,
            camera,
            poses,
            walls,
            rays,
        })
    }

    /// Renders frame `k`.
    pub fn render(&self, k: usize) -> Frame {
        let pose = &self.poses[k];
        let rot = rotation::matrix(&pose.orientation);
        let (w, h) = (self.config.width as usize, self.config.height as usize);
        let mut rgb = vec![0u8; 3 * w * h];
        rgb.par_chunks_mut(3 * w).enumerate().for_each(|(y, row)| {
            for x in 0..w {
                let c = self.shade(&pose.position, &(rot * self.rays[y * w + x]));
                row[3 * x..3 * x + 3].copy_from_slice(&c);
            }
        });
        Frame::from_rgb(self.config.width, self.config.height, rgb)
            .expect("size checked at construction")
    }

    /// Colour seen from `origin` along `dir` inside the room.
    fn shade(&self, origin: &Vector3<f64>, dir: &Vector3<f64>) -> [u8; 3] {
        let room = self.config.room;
        let mut best = (f64::INFINITY, 0usize);
        for axis in 0..3 {
            if dir[axis].abs() < 1e-12 {
                continue;
            }
            let bound = room[axis] * dir[axis].signum();
            let t = (bound - origin[axis]) / dir[axis];
            if t > 0.0 && t < best.0 {
                best = (t, 2 * axis + usize::from(dir[axis] > 0.0));
            }
        }
        let (t, face) = best;
        let hit = origin + dir * t;
        let axis = face / 2;
        let (u_axis, v_axis) = match axis {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        let wall = &self.walls[face];
        let u = (hit[u_axis] + room[u_axis]) * self.config.texels_per_metre;
        let v = (hit[v_axis] + room[v_axis]) * self.config.texels_per_metre;
        bilinear_rgb(wall, u, v)
    }

    /// Writes the sequence in the TUM RGB-D layout: rgb/NNNNNN.png, rgb.txt,
    /// groundtruth.txt, and calib.toml for the camera.
    pub fn write_tum_layout(&self, dir: &Path, mut progress: impl FnMut(usize)) -> Result<()> {
        let io = |path: &Path| {
            let path = path.to_path_buf();
            move |source| Error::Io { path, source }
        };
        let rgb_dir = dir.join("rgb");
        std::fs::create_dir_all(&rgb_dir).map_err(io(&rgb_dir))?;
        let list_path = dir.join("rgb.txt");
        let mut list = std::fs::File::create(&list_path).map_err(io(&list_path))?;
        writeln!(list, "# synthetic steernav sequence\n# timestamp filename")
            .map_err(io(&list_path))?;
        for (k, pose) in self.poses.iter().enumerate() {
            let frame = self.render(k);
            let name = format!("rgb/{k:06}.png");
            let path = dir.join(&name);
            image::save_buffer(
                &path,
                &frame.rgb,
                frame.width,
                frame.height,
                image::ExtendedColorType::Rgb8,
            )
            .map_err(|e| Error::Io {
                path: path.clone(),
                source: std::io::Error::other(e.to_string()),
            })?;
            writeln!(list, "{:.6} {name}", pose.timestamp).map_err(io(&list_path))?;
            progress(k);
        }
        write_tum(&dir.join("groundtruth.txt"), &self.poses)?;
        let calib = toml::to_string(&CalibrationOut {
            camera: self.camera.clone(),
        })
        .map_err(|e| Error::config("camera", "?", e.to_string()))?;
        let calib_path = dir.join("calib.toml");
        std::fs::write(&calib_path, calib).map_err(io(&calib_path))?;
        Ok(())
    }

    /// Length of the ground-truth path, metres.
    pub fn path_length(&self) -> f64 {
        self.poses
            .windows(2)
            .map(|w| (w[1].position - w[0].position).norm())
            .sum()
    }
}

/// The hand-held loop: sway, yaw and pitch, starting at the origin looking along +z.
fn room_loop(config: &SyntheticConfig) -> Vec<Pose> {
    let period = config.period;
    (0..config.frames)
        .map(|k| {
            let t = k as f64 / config.fps;
            let phase = TAU * t / period;
            let a = config.amplitude;
            let position = Vector3::new(
                a * phase.sin(),
                0.15 * a * (2.0 * phase).sin(),
                0.6 * a * (1.0 - phase.cos()),
            );
            let orientation = rotation::from_rotation_vector(&Vector3::new(
                0.06 * (1.3 * phase).sin(),
                0.3 * phase.sin(),
                0.05 * (0.7 * phase).sin(),
            ));
            Pose {
                timestamp: t,
                position,
                orientation,
            }
        })
        .collect()
}

/// The drive: heading ψ(t) = amplitude · sin(2πt / period) about the vertical (y points
/// down), position integrated from the speed along the heading, starting 25 m into the box.
fn drive(config: &SyntheticConfig) -> Vec<Pose> {
    let heading = |t: f64| config.amplitude * (TAU * t / config.period).sin();
    let height = config.room[1] - config.camera_height;
    let mut position = Vector3::new(0.0, height, 25.0 - config.room[2]);
    let substeps = 50;
    let dt = 1.0 / (config.fps * substeps as f64);
    let mut t = 0.0;
    let mut poses = Vec::with_capacity(config.frames);
    for k in 0..config.frames {
        if k > 0 {
            for _ in 0..substeps {
                let mid = t + 0.5 * dt;
                let psi = heading(mid);
                let speed = config.speed * (1.0 + 0.3 * (TAU * mid / (1.5 * config.period)).sin());
                position += Vector3::new(psi.sin(), 0.0, psi.cos()) * (speed * dt);
                t += dt;
            }
        }
        poses.push(Pose {
            timestamp: k as f64 / config.fps,
            position,
            orientation: rotation::from_rotation_vector(&Vector3::new(0.0, heading(t), 0.0)),
        });
    }
    poses
}

#[derive(Serialize)]
struct CalibrationOut {
    camera: PinholeCamera,
}

/// A wall texture made of independently seeded 256×256 scenes: the cost of
/// [`crate::synth::textured_scene`] grows with the square of the area (more shapes, each tested
/// at every pixel), while tiles keep it linear and never repeat a pattern.
fn tiled_texture(width: u32, height: u32, seed: u64) -> Frame {
    const TILE: u32 = 256;
    let (tx, ty) = (width.div_ceil(TILE), height.div_ceil(TILE));
    let tiles: Vec<Frame> = (0..tx * ty)
        .into_par_iter()
        .map(|i| {
            crate::synth::textured_scene(
                TILE,
                TILE,
                seed.wrapping_mul(1_000_003).wrapping_add(i as u64),
            )
        })
        .collect();
    let (w, h) = (width as usize, height as usize);
    let mut rgb = vec![0u8; 3 * w * h];
    for y in 0..h {
        for x in 0..w {
            let tile = &tiles[(y / TILE as usize) * tx as usize + x / TILE as usize];
            let o = 3 * ((y % TILE as usize) * TILE as usize + x % TILE as usize);
            rgb[3 * (y * w + x)..3 * (y * w + x) + 3].copy_from_slice(&tile.rgb[o..o + 3]);
        }
    }
    Frame::from_rgb(width, height, rgb).expect("texture sizes are small and positive")
}

fn bilinear_rgb(frame: &Frame, u: f64, v: f64) -> [u8; 3] {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let u = u.clamp(0.0, (w - 1) as f64);
    let v = v.clamp(0.0, (h - 1) as f64);
    let (x0, y0) = (u.floor() as usize, v.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (u - x0 as f64, v - y0 as f64);
    let px = |x: usize, y: usize, c: usize| frame.rgb[3 * (y * w + x) + c] as f64;
    let mut out = [0u8; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let top = px(x0, y0, c) * (1.0 - fx) + px(x1, y0, c) * fx;
        let bottom = px(x0, y1, c) * (1.0 - fx) + px(x1, y1, c) * fx;
        *o = (top * (1.0 - fy) + bottom * fy).round().clamp(0.0, 255.0) as u8;
    }
    out
}
