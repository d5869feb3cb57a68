//! A synthetic monocular sequence with exact ground truth: a camera moving inside a box whose
//! walls carry seeded procedural textures, with furniture-like clutter in front of them
//! (`scene`), rendered by ray casting through the calibrated (optionally distorted) camera,
//! with optional motion blur, auto-exposure and sensor noise (`degrade`). Four motions
//! (`motion`): a hand-held loop in a room, a car driving down a street-sized box at 10 Hz
//! with turns (scene depths 3–50 m), a person walking through one or two cluttered rooms while
//! looking around (30 Hz), and a wheeled robot that drives and turns in place (15 Hz, camera
//! 0.3 m above the floor). Tests use it to check that the filter converges; `steernav
//! slam-synth` writes it in the TUM RGB-D layout.

mod degrade;
mod motion;
mod scene;

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
use scene::Scene;

/// Motion blur integrates the motion at this many samples per frame interval.
const BLUR_SAMPLES_PER_FRAME: usize = 8;

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
    /// A person carrying the camera `camera_height` above the floor along a seeded loop
    /// through the room (or both rooms, through the doors of the dividing wall), at 0.3–1 m/s
    /// around `speed`, looking around by ±`amplitude` radians over `period` seconds (yaw rate
    /// at most 60°/s), pitch within ±20°, roll within ±5°, with the bounce of the steps.
    Walk,
    /// A wheeled robot, the camera `camera_height` above the floor and 0.1 m ahead of the
    /// turning centre: straight legs at up to `speed` m/s and turns in place at up to
    /// `amplitude` rad/s, the first a half turn.
    Rover,
    /// A camera on a slider: pure translation of `amplitude` metres sideways along its x axis,
    /// starting and stopping smoothly, at `camera_height` above the floor 1 m in front of one
    /// wall of a furnished room, looking across it (seeded yaw within ±0.3 rad, a little
    /// down), no rotation.
    Slider,
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
    /// swing, radians. Walk: amplitude of the look-around, radians. Rover: fastest in-place
    /// turn, rad/s.
    pub amplitude: f64,
    /// Drive: mean forward speed, m/s; it swings by ±30% over 1.5 periods (braking and
    /// accelerating), so a constant step length is not the right answer. Walk: mean walking
    /// speed, m/s. Rover: top speed, m/s.
    pub speed: f64,
    /// Drive, walk and rover: height of the camera above the floor, metres.
    pub camera_height: f64,
    /// Duration of one loop of the trajectory, seconds (independent of `frames`, so a short
    /// sequence is the start of a long one); the walk's look-around period.
    pub period: f64,
    /// Texture resolution, texels per metre.
    pub texels_per_metre: f64,
    /// Seed of the textures, the furniture and the walk's and rover's routes.
    pub seed: u64,
    /// 1, or 2 for a wall across the room at z = 0 with a door wherever the walk's route
    /// crosses it (walk only).
    pub rooms: u32,
    /// Pieces of furniture (boxes, pillars, tables, shelves), at most 200.
    pub clutter: usize,
    /// Share of the furniture left textureless, 0–1.
    pub plain_fraction: f64,
    /// Exposure time of the motion blur, seconds (0: none; at most one frame interval).
    pub exposure: f64,
    /// Standard deviation of the sensor noise, grey levels (0–64).
    pub noise: f64,
    /// Auto-exposure: spread of the gain's log change per frame (0–0.5).
    pub gain_jitter: f64,
    /// Rays per pixel side (1–4): a pixel averages the light of supersample² rays spread
    /// over its area, as a sensor integrates it. One ray per pixel aliases textures finer
    /// than the pixels (a small image of a wall a few metres away), and the aliased pattern
    /// moves against the scene.
    pub supersample: u32,
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
            rooms: 1,
            clutter: 0,
            plain_fraction: 0.2,
            exposure: 0.0,
            noise: 0.0,
            gain_jitter: 0.0,
            supersample: 1,
        }
    }
}

impl SyntheticConfig {
    /// The defaults of a motion:
    /// - room: [`Default`], a bare box;
    /// - drive: 10 Hz, 10 m/s, heading ±0.25 rad over 8 s, in a box 16 m wide, 6 m high and
    ///   120 m long whose side walls pass at 3–11 m and whose far wall starts 95 m ahead;
    /// - walk: 640×480 at 30 Hz, 12 s (about 8 m) at 0.65 m/s through two rooms of 6 × 5 m,
    ///   2.8 m high, with 16 pieces of furniture, the camera 1.5 m high, looking around by
    ///   ±1.2 rad over 10 s, 8 ms exposure, noise of 2 grey levels, auto-exposure 0.03;
    /// - rover: 640×480 at 15 Hz, 24 s at up to 0.4 m/s, turning at up to 0.8 rad/s, in a
    ///   room of 6 × 8 m with 12 pieces of furniture, the camera 0.3 m high, 10 ms exposure,
    ///   the same noise and auto-exposure;
    /// - slider: 240×180 with barrel distortion (k1 = −0.15) at 30 Hz, 87 frames, 1 m of
    ///   sideways travel in a room of 6 × 6 m with 12 pieces of furniture, the camera 1 m
    ///   high, 4 ms exposure, the same noise and auto-exposure.
    pub fn for_motion(motion: SyntheticMotion) -> Self {
        let indoors = Self {
            motion,
            width: 640,
            height: 480,
            exposure: 0.008,
            noise: 2.0,
            gain_jitter: 0.03,
            frames: 360,
            ..Self::default()
        };
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
            SyntheticMotion::Walk => Self {
                fps: 30.0,
                room: [3.0, 1.4, 5.0],
                rooms: 2,
                clutter: 16,
                amplitude: 1.2,
                speed: 0.65,
                camera_height: 1.5,
                period: 10.0,
                ..indoors
            },
            SyntheticMotion::Slider => Self {
                width: 240,
                height: 180,
                k1: -0.15,
                frames: 87,
                fps: 30.0,
                room: [3.0, 1.4, 3.0],
                clutter: 12,
                amplitude: 1.0,
                speed: 0.0,
                camera_height: 1.0,
                exposure: 0.004,
                ..indoors
            },
            SyntheticMotion::Rover => Self {
                fps: 15.0,
                room: [3.0, 1.3, 4.0],
                clutter: 12,
                amplitude: 0.8,
                speed: 0.4,
                camera_height: 0.3,
                exposure: 0.01,
                ..indoors
            },
        }
    }

    /// Refuses settings outside the ranges that bound the work and keep the scene sound.
    fn validate(&self) -> Result<()> {
        let walks = matches!(self.motion, SyntheticMotion::Walk | SyntheticMotion::Rover);
        let checks: [(bool, &'static str, String, &str); 13] = [
            (
                self.frames >= 1 && self.fps > 0.0 && self.fps.is_finite(),
                "synthetic.frames",
                format!("frames={} fps={}", self.frames, self.fps),
                "needs frames >= 1 and a finite fps > 0",
            ),
            (
                self.period > 0.0 && self.period.is_finite(),
                "synthetic.period",
                self.period.to_string(),
                "needs a finite period > 0",
            ),
            (
                self.fov_deg > 1.0 && self.fov_deg < 170.0,
                "synthetic.fov_deg",
                self.fov_deg.to_string(),
                "needs a field of view in (1, 170) degrees",
            ),
            (
                self.room.iter().all(|r| r.is_finite() && *r > 0.1 && *r < 1e4)
                    && (!walks || (self.room[0] >= 1.5 && self.room[2] >= 1.5)),
                "synthetic.room",
                format!("{:?}", self.room),
                "needs half-extents in (0.1, 1e4) m, and at least 1.5 m across the floor for walk and rover",
            ),
            (
                self.texels_per_metre > 0.0 && self.texels_per_metre <= 1e4,
                "synthetic.texels_per_metre",
                self.texels_per_metre.to_string(),
                "needs texels_per_metre in (0, 1e4]",
            ),
            (
                self.k1.is_finite() && self.k1.abs() < 1.0,
                "synthetic.k1",
                self.k1.to_string(),
                "needs |k1| < 1",
            ),
            (
                self.amplitude.is_finite()
                    && self.amplitude.abs() < 1e3
                    && self.speed.is_finite()
                    && self.speed.abs() < 1e3
                    && (!walks || (self.speed > 0.0 && self.amplitude > 0.0)),
                "synthetic.speed",
                format!("speed={} amplitude={}", self.speed, self.amplitude),
                "needs |amplitude| and |speed| < 1e3, both > 0 for walk and rover",
            ),
            (
                self.camera_height > 0.0 && self.camera_height < 2.0 * self.room[1],
                "synthetic.camera_height",
                self.camera_height.to_string(),
                "needs camera_height inside the room",
            ),
            (
                self.rooms == 1 || (self.rooms == 2 && self.motion == SyntheticMotion::Walk),
                "synthetic.rooms",
                self.rooms.to_string(),
                "needs 1, or 2 with motion = walk (the doors go where its route crosses the wall)",
            ),
            (
                self.clutter <= 200 && (0.0..=1.0).contains(&self.plain_fraction),
                "synthetic.clutter",
                format!("clutter={} plain_fraction={}", self.clutter, self.plain_fraction),
                "needs at most 200 pieces of furniture and plain_fraction in [0, 1]",
            ),
            (
                self.exposure >= 0.0 && self.exposure <= 1.0 / self.fps,
                "synthetic.exposure",
                self.exposure.to_string(),
                "needs an exposure from 0 to one frame interval (1 / fps) seconds",
            ),
            (
                (0.0..=64.0).contains(&self.noise) && (0.0..=0.5).contains(&self.gain_jitter),
                "synthetic.noise",
                format!("noise={} gain_jitter={}", self.noise, self.gain_jitter),
                "needs noise in [0, 64] grey levels and gain_jitter in [0, 0.5]",
            ),
            (
                (1..=4).contains(&self.supersample),
                "synthetic.supersample",
                self.supersample.to_string(),
                "needs 1 to 4 rays per pixel side",
            ),
        ];
        for (ok, field, value, reason) in checks {
            if !ok {
                return Err(Error::config(field, value, reason));
            }
        }
        crate::image::check_size("synthetic", self.width, self.height)
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
    scene: Scene,
    /// Each pixel's centre ray (depth and the tests).
    rays: Vec<Vector3<f64>>,
    /// Each pixel's supersample² rays, pixel after pixel.
    pixel_rays: Vec<Vector3<f64>>,
    /// Per frame, the poses averaged over the exposure (empty without motion blur).
    exposures: Vec<Vec<Pose>>,
    gains: Vec<f64>,
}

impl SyntheticSequence {
    /// Builds the scene and the trajectory (the room loop's first pose at the origin looking
    /// along +z).
    pub fn new(config: SyntheticConfig) -> Result<Self> {
        config.validate()?;
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
        let pixels = config.width as usize * config.height as usize;
        let centre = |i: usize| {
            Vector2::new(
                (i % config.width as usize) as f64,
                (i / config.width as usize) as f64,
            )
        };
        let rays = (0..pixels)
            .map(|i| camera.back_project(centre(i)).0)
            .collect();
        let side = config.supersample as usize;
        let offset = |k: usize| (k as f64 + 0.5) / side as f64 - 0.5;
        let pixel_rays = (0..pixels)
            .flat_map(|i| {
                (0..side * side)
                    .map(move |k| centre(i) + Vector2::new(offset(k % side), offset(k / side)))
            })
            .map(|z| camera.back_project(z).0)
            .collect();
        let poses = motion::trajectory(&config, config.fps, config.frames);
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
        let doors = if config.rooms == 2 {
            motion::Route::walk(&config).crossings(0.0)
        } else {
            Vec::new()
        };
        let path: Vec<Vector3<f64>> = poses.iter().map(|p| p.position).collect();
        // A person keeps 0.6 m from furniture with the camera; a robot base 0.5 m.
        let clearance = if config.motion == SyntheticMotion::Rover {
            0.5
        } else {
            0.6
        };
        let scene = Scene::build(&config, &path, &doors, clearance);
        log::debug!(
            "synthetic: {} solids, doors at {doors:?}",
            scene.solid_count()
        );
        let exposures = exposure_poses(&config);
        let gains = degrade::exposure_gains(config.frames, config.gain_jitter, config.seed);
        Ok(Self {
            config,
            camera,
            poses,
            scene,
            rays,
            pixel_rays,
            exposures,
            gains,
        })
    }

    /// Renders frame `k`: the average of the renders over its exposure, times the frame's
    /// auto-exposure gain, plus sensor noise.
    pub fn render(&self, k: usize) -> Frame {
        let single = [self.poses[k]];
        let views: Vec<(Vector3<f64>, nalgebra::Matrix3<f64>)> = match self.exposures.get(k) {
            Some(poses) if !poses.is_empty() => poses.as_slice(),
            _ => &single,
        }
        .iter()
        .map(|p| (p.position, rotation::matrix(&p.orientation)))
        .collect();
        let (w, h) = (self.config.width as usize, self.config.height as usize);
        let mut rgb = vec![0u8; 3 * w * h];
        let per_pixel = (self.config.supersample * self.config.supersample) as usize;
        let weight = 1.0 / (views.len() * per_pixel) as f64;
        let frame_seed = self
            .config
            .seed
            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .wrapping_add(k as u64);
        rgb.par_chunks_mut(3 * w).enumerate().for_each(|(y, row)| {
            let mut light = vec![0.0f64; 3 * w];
            for (position, rot) in &views {
                for x in 0..w {
                    let first = (y * w + x) * per_pixel;
                    for ray in &self.pixel_rays[first..first + per_pixel] {
                        let c = self.scene.shade(position, &(rot * ray));
                        for (l, c) in light[3 * x..3 * x + 3].iter_mut().zip(c) {
                            *l += c * weight;
                        }
                    }
                }
            }
            let row_seed = frame_seed.wrapping_mul(0xBF58_476D_1CE4_E5B9) ^ y as u64;
            degrade::quantise(&light, self.gains[k], self.config.noise, row_seed, row);
        });
        Frame::from_rgb(self.config.width, self.config.height, rgb)
            .expect("size checked at construction")
    }

    /// The true depth of frame `k` (the camera's z of the first surface seen through each
    /// pixel, metres, row by row), at the frame's own pose: what an RGB-D sensor registered
    /// to the colour camera would measure.
    pub fn depth(&self, k: usize) -> Vec<f32> {
        let pose = &self.poses[k];
        let rot = rotation::matrix(&pose.orientation);
        self.rays
            .par_iter()
            .map(|ray| {
                // Rays are (x, y, 1): the z of a point t along the unit ray is t / |ray|.
                let length = ray.norm();
                (self.scene.depth(&pose.position, &(rot * ray / length)) / length) as f32
            })
            .collect()
    }

    /// Writes the true depth of every frame as the TUM RGB-D benchmark stores it:
    /// depth/NNNNNN.png (16-bit, 5000 per metre, 0 where there is none or beyond 13.1 m) listed
    /// in depth.txt with the colour frames' timestamps. `steernav slam` then measures the map's
    /// depths against them.
    pub fn write_tum_depth(&self, dir: &Path, progress: impl FnMut(usize)) -> Result<()> {
        let (w, h) = (self.config.width, self.config.height);
        self.write_listed(
            dir,
            "depth",
            "synthetic steernav depth",
            progress,
            |k, path| super::depth::write_depth_png(path, w, h, &self.depth(k)),
        )
    }

    /// Writes the sequence in the TUM RGB-D layout: rgb/NNNNNN.png, rgb.txt,
    /// groundtruth.txt, and calib.toml for the camera.
    pub fn write_tum_layout(&self, dir: &Path, progress: impl FnMut(usize)) -> Result<()> {
        self.write_listed(
            dir,
            "rgb",
            "synthetic steernav sequence",
            progress,
            |k, path| {
                let frame = self.render(k);
                image::save_buffer(
                    path,
                    &frame.rgb,
                    frame.width,
                    frame.height,
                    image::ExtendedColorType::Rgb8,
                )
                .map_err(|e| Error::Io {
                    path: path.to_path_buf(),
                    source: std::io::Error::other(e.to_string()),
                })
            },
        )?;
        write_tum(&dir.join("groundtruth.txt"), &self.poses)?;
        let calib = toml::to_string(&CalibrationOut {
            camera: self.camera.clone(),
        })
        .map_err(|e| Error::config("camera", "?", e.to_string()))?;
        let calib_path = dir.join("calib.toml");
        std::fs::write(&calib_path, calib).map_err(|source| Error::Io {
            path: calib_path.clone(),
            source,
        })
    }

    /// One image per frame, `folder`/NNNNNN.png written by `write`, listed with the frames'
    /// timestamps in `folder`.txt as TUM RGB-D lists them. Frames are made and encoded a few at
    /// a time in parallel (PNG encoding is serial within a frame), then listed in order.
    fn write_listed(
        &self,
        dir: &Path,
        folder: &str,
        title: &str,
        mut progress: impl FnMut(usize),
        write: impl Fn(usize, &Path) -> Result<()> + Sync,
    ) -> Result<()> {
        let io = |path: &Path| {
            let path = path.to_path_buf();
            move |source| Error::Io { path, source }
        };
        let images = dir.join(folder);
        std::fs::create_dir_all(&images).map_err(io(&images))?;
        let list_path = dir.join(format!("{folder}.txt"));
        let mut list = std::fs::File::create(&list_path).map_err(io(&list_path))?;
        writeln!(list, "# {title}\n# timestamp filename").map_err(io(&list_path))?;
        let indices: Vec<usize> = (0..self.poses.len()).collect();
        for chunk in indices.chunks(2 * rayon::current_num_threads().max(1)) {
            let written: Vec<Result<String>> = chunk
                .par_iter()
                .map(|&k| {
                    let name = format!("{folder}/{k:06}.png");
                    write(k, &dir.join(&name))?;
                    Ok(name)
                })
                .collect();
            for (&k, name) in chunk.iter().zip(written) {
                writeln!(list, "{:.6} {}", self.poses[k].timestamp, name?)
                    .map_err(io(&list_path))?;
                progress(k);
            }
        }
        Ok(())
    }

    /// Length of the ground-truth path, metres.
    pub fn path_length(&self) -> f64 {
        self.poses
            .windows(2)
            .map(|w| (w[1].position - w[0].position).norm())
            .sum::<f64>()
            // An empty sum is −0.
            + 0.0
    }
}

/// Per frame, the poses over its exposure centred on the frame time (none when the exposure is
/// zero): the motion sampled at 8 times the frame rate.
fn exposure_poses(config: &SyntheticConfig) -> Vec<Vec<Pose>> {
    let half =
        (0.5 * config.exposure * config.fps * BLUR_SAMPLES_PER_FRAME as f64).round() as usize;
    if half == 0 {
        return Vec::new();
    }
    let fine = motion::trajectory(
        config,
        config.fps * BLUR_SAMPLES_PER_FRAME as f64,
        config.frames * BLUR_SAMPLES_PER_FRAME + half + 1,
    );
    (0..config.frames)
        .map(|k| {
            let centre = k * BLUR_SAMPLES_PER_FRAME;
            (centre.saturating_sub(half)..=centre + half)
                .map(|i| fine[i])
                .collect()
        })
        .collect()
}

#[derive(Serialize)]
struct CalibrationOut {
    camera: PinholeCamera,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small(motion: SyntheticMotion) -> SyntheticConfig {
        SyntheticConfig {
            width: 96,
            height: 72,
            frames: 12,
            texels_per_metre: 40.0,
            ..SyntheticConfig::for_motion(motion)
        }
    }

    fn mean_level(frame: &Frame) -> f64 {
        frame.rgb.iter().map(|&v| v as f64).sum::<f64>() / frame.rgb.len() as f64
    }

    #[test]
    fn the_walk_furnishes_two_rooms_and_keeps_the_furniture_off_its_path() {
        let seq = SyntheticSequence::new(small(SyntheticMotion::Walk)).unwrap();
        // The dividing wall and every piece of furniture asked for.
        assert_eq!(seq.scene.solid_count(), 1 + seq.config.clutter);
        let doors = motion::Route::walk(&seq.config).crossings(0.0);
        assert_eq!(
            doors.len(),
            2,
            "the loop passes through the wall twice: {doors:?}"
        );
        // Looking from each pose, nothing is nearer than the clearance along the optical axis.
        for pose in &seq.poses {
            let axis = rotation::matrix(&pose.orientation) * Vector3::new(0.0, 0.0, 1.0);
            let depth = seq.scene.depth(&pose.position, &axis);
            assert!(depth > 0.3, "something {depth} m in front of the camera");
        }
    }

    #[test]
    fn furniture_stands_in_front_of_the_walls_and_hides_them() {
        let bare = SyntheticSequence::new(SyntheticConfig {
            clutter: 0,
            ..small(SyntheticMotion::Rover)
        })
        .unwrap();
        let furnished = SyntheticSequence::new(small(SyntheticMotion::Rover)).unwrap();
        let (mut nearer, mut total) = (0usize, 0usize);
        for (k, pose) in furnished.poses.iter().enumerate().step_by(3) {
            let rot = rotation::matrix(&pose.orientation);
            for ray in furnished.rays.iter().step_by(7) {
                let dir = rot * ray;
                let (a, b) = (
                    bare.scene.depth(&pose.position, &dir),
                    furnished.scene.depth(&pose.position, &dir),
                );
                assert!(b <= a + 1e-9, "frame {k}: furniture behind a wall");
                nearer += usize::from(b < a - 1e-6);
                total += 1;
            }
        }
        let share = nearer as f64 / total as f64;
        assert!(
            (0.05..0.9).contains(&share),
            "furniture covers {share} of the view"
        );
    }

    #[test]
    fn supersampling_integrates_each_pixel_and_refuses_more_than_four_rays_a_side() {
        // The room at 160×120: about four texels a pixel on the far wall, where one ray a
        // pixel aliases. Integration keeps the mean and takes out the aliased detail.
        let config = |supersample| SyntheticConfig {
            width: 160,
            height: 120,
            frames: 1,
            supersample,
            ..SyntheticConfig::default()
        };
        let gray = |supersample| {
            SyntheticSequence::new(config(supersample))
                .unwrap()
                .render(0)
                .gray
        };
        let (one, three) = (gray(1), gray(3));
        let mean = |g: &[f32]| g.iter().sum::<f32>() / g.len() as f32;
        let detail =
            |g: &[f32]| g.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f32>() / g.len() as f32;
        assert!(
            (mean(&one) - mean(&three)).abs() < 0.02,
            "{} {}",
            mean(&one),
            mean(&three)
        );
        assert!(
            detail(&three) < 0.7 * detail(&one),
            "{} {}",
            detail(&three),
            detail(&one)
        );
        for bad in [0, 5] {
            let e = SyntheticSequence::new(config(bad))
                .err()
                .expect("refused")
                .to_string();
            assert!(e.contains("synthetic.supersample"), "{e}");
        }
    }

    #[test]
    fn degradations_blur_brighten_and_add_noise_without_moving_the_mean_much() {
        let clean_config = SyntheticConfig {
            exposure: 0.0,
            noise: 0.0,
            gain_jitter: 0.0,
            ..small(SyntheticMotion::Walk)
        };
        let clean = SyntheticSequence::new(clean_config.clone()).unwrap();
        let blurred = SyntheticSequence::new(SyntheticConfig {
            exposure: 1.0 / 30.0,
            ..clean_config.clone()
        })
        .unwrap();
        let noisy = SyntheticSequence::new(SyntheticConfig {
            noise: 8.0,
            ..clean_config.clone()
        })
        .unwrap();
        let k = 6;
        let (c, b, n) = (clean.render(k), blurred.render(k), noisy.render(k));
        // Blur smooths: neighbouring pixels differ less.
        let roughness = |f: &Frame| {
            f.rgb
                .windows(4)
                .step_by(3)
                .map(|w| (w[0] as f64 - w[3] as f64).abs())
                .sum::<f64>()
        };
        assert!(roughness(&b) < 0.9 * roughness(&c));
        assert!((mean_level(&b) - mean_level(&c)).abs() < 3.0);
        let spread = c
            .rgb
            .iter()
            .zip(&n.rgb)
            .map(|(&a, &b)| (a as f64 - b as f64).powi(2))
            .sum::<f64>()
            / c.rgb.len() as f64;
        assert!(
            (6.0..9.0).contains(&spread.sqrt()),
            "noise {}",
            spread.sqrt()
        );
        // The same sequence renders the same frame twice (seeded noise).
        assert_eq!(noisy.render(k).rgb, n.rgb);
        let gained = SyntheticSequence::new(SyntheticConfig {
            gain_jitter: 0.2,
            ..clean_config
        })
        .unwrap();
        let levels: Vec<f64> = (0..12).map(|k| mean_level(&gained.render(k))).collect();
        let (lo, hi) = levels
            .iter()
            .fold((f64::MAX, 0.0f64), |(a, b), &l| (a.min(l), b.max(l)));
        assert!(
            hi / lo > 1.05,
            "auto-exposure changes the level: {levels:?}"
        );
    }
}
