//! One navigation episode in the simulator: every control period the LIDAR scans, the camera
//! renders, the stimuli of eqs 32–34 (plus the GIST stimulus in fusion mode) drive the field
//! (eqs 28–31) for a few Euler steps, φ_F (eq 29) and the velocity laws (eqs 35–37) command a
//! unicycle, and the motion is integrated in small sub-steps with an exact collision test.

use serde::{Deserialize, Serialize};

use super::sensors::{CameraConfig, LidarConfig};
use super::visual::{sector_features, visual_stimulus, VisualConfig, VisualObstacleModel};
use super::world::World;
use crate::error::{Error, Result};
use crate::nav::dnf::{FieldBatch, FieldConfig};
use crate::nav::gist::GistEngine;
use crate::nav::stimulus::{
    angle_diff, combined, obstacle_stimulus, obstacle_velocity, target_stimulus, target_velocity,
    velocity, StimulusConfig,
};
use crate::synth::Rng;

/// Which sensors drive the field.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// LIDAR range/bearing stimulus only.
    Laser,
    /// LIDAR plus the learned GIST stimulus of the camera.
    Fusion,
}

/// Every parameter of an episode, with documented defaults (the `[nav]` TOML table).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NavConfig {
    /// The field.
    pub field: FieldConfig,
    /// Stimuli and velocity laws (default c_o = 30, σ = 10; the rest as [`StimulusConfig`]).
    pub stimulus: StimulusConfig,
    /// The LIDAR.
    pub lidar: LidarConfig,
    /// The camera.
    pub camera: CameraConfig,
    /// The GIST stimulus and its learning.
    pub visual: VisualConfig,
    /// Control period, seconds. Default 0.1.
    pub control_period: f32,
    /// Euler steps of the field per control period. Default 10.
    pub field_steps: usize,
    /// Episode time limit, seconds. Default 60.
    pub max_time: f32,
    /// The goal is reached within this distance, metres. Default 0.3.
    pub goal_tolerance: f32,
    /// Turn rate per radian of heading error, 1/s. Default 2.5.
    pub turn_gain: f32,
    /// Largest turn rate, rad/s. Default 2.0.
    pub max_turn_rate: f32,
    /// Stimulus subtracted from headings behind the robot. Default 4.
    pub rear_inhibition: f32,
    /// Integration sub-step, seconds. Default 0.01.
    pub substep: f32,
}

impl Default for NavConfig {
    fn default() -> Self {
        Self {
            field: FieldConfig::default(),
            // Measured on 40 random worlds without LIDAR-invisible obstacles: eq 32's c_o = 2
            // (the replay's default) lets the robot reach 7 goals; c_o = 30 with σ = 10
            // reaches 36, with 2 collisions.
            stimulus: StimulusConfig {
                c_o: 30.0,
                sigma: 10.0,
                ..StimulusConfig::default()
            },
            lidar: LidarConfig::default(),
            camera: CameraConfig::default(),
            visual: VisualConfig::default(),
            control_period: 0.1,
            field_steps: 10,
            max_time: 60.0,
            goal_tolerance: 0.3,
            turn_gain: 2.5,
            max_turn_rate: 2.0,
            rear_inhibition: 4.0,
            substep: 0.01,
        }
    }
}

impl NavConfig {
    /// Checks every value, naming the bad one.
    pub fn validate(&self) -> Result<()> {
        self.field.validate()?;
        self.stimulus.validate()?;
        self.lidar.validate()?;
        self.camera.validate()?;
        self.visual.validate()?;
        for (field, v) in [
            ("nav.control_period", self.control_period),
            ("nav.max_time", self.max_time),
            ("nav.goal_tolerance", self.goal_tolerance),
            ("nav.turn_gain", self.turn_gain),
            ("nav.max_turn_rate", self.max_turn_rate),
            ("nav.substep", self.substep),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::config(field, v, "must be finite and > 0"));
            }
        }
        if self.field_steps == 0 {
            return Err(Error::config("nav.field_steps", 0, "must be >= 1"));
        }
        Ok(())
    }
}

/// How an episode ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Outcome {
    /// Within the goal tolerance.
    Reached,
    /// The robot's disc touched an obstacle or a wall.
    Collision,
    /// Time ran out.
    Timeout,
}

/// The record of one episode.
#[derive(Clone, Debug, Serialize)]
pub struct Episode {
    /// How it ended.
    pub outcome: Outcome,
    /// Seconds simulated.
    pub time: f32,
    /// Distance driven, metres.
    pub path_length: f32,
    /// Standard deviation of the distance to the reference path (the straight segment from
    /// start to goal), metres.
    pub position_error_std: f32,
    /// Poses (x, y, θ) at every control period.
    pub trajectory: Vec<[f32; 3]>,
    /// Field activations at every control period (when recorded).
    pub field: Vec<Vec<f32>>,
}

/// Runs one episode. In fusion mode `model` is used and trained online (pass the same model
/// to later episodes to keep what was learned). `seed` drives the sensor noise.
pub fn run(
    world: &World,
    cfg: &NavConfig,
    mode: Mode,
    model: &mut VisualObstacleModel,
    gist: Option<&GistEngine>,
    seed: u64,
    record_field: bool,
) -> Result<Episode> {
    let n = cfg.field.neurons;
    let mut field = FieldBatch::new(cfg.field.clone(), 1)?;
    let mut rng = Rng(seed);
    let mut pose = [world.start[0], world.start[1], world.start[2].to_radians()];
    let spacing = cfg.lidar.fov_deg.to_radians() / (cfg.lidar.beams - 1) as f32;
    let beam_cfg = cfg.stimulus.per_beam(spacing);
    let bearings: Vec<f32> = (0..cfg.lidar.beams).map(|i| cfg.lidar.bearing(i)).collect();
    let blocks = cfg.visual.gist.blocks;
    let sector_width = cfg.camera.fov_deg.to_radians() / blocks as f32;
    let sectors: Vec<(f32, f32)> = (0..blocks)
        .map(|c| {
            let centre = cfg
                .camera
                .column_bearing((c as f32 + 0.5) * cfg.camera.width as f32 / blocks as f32);
            (centre, 0.5 * sector_width)
        })
        .collect();
    let near = cfg.camera.near_distance(1.0 / blocks as f32);
    let mut trajectory = vec![pose];
    let mut fields = Vec::new();
    let (mut time, mut length) = (0.0f32, 0.0f32);
    let outcome = loop {
        let to_goal = [world.goal[0] - pose[0], world.goal[1] - pose[1]];
        let distance = to_goal[0].hypot(to_goal[1]);
        if distance < cfg.goal_tolerance {
            break Outcome::Reached;
        }
        if time >= cfg.max_time {
            break Outcome::Timeout;
        }
        let ranges = cfg.lidar.scan(world, pose, &mut rng);
        let (near_ranges, near_bearings): (Vec<f32>, Vec<f32>) = ranges
            .iter()
            .zip(&bearings)
            .filter(|(r, _)| **r < cfg.lidar.max_range)
            .map(|(r, b)| (*r, *b))
            .unzip();
        // The field is allocentric — neuron i is the world heading 2πi/N — so a peak stays put
        // while the robot turns toward it; sensor bearings are rotated into the world frame.
        let world_bearings: Vec<f32> = near_bearings.iter().map(|b| b + pose[2]).collect();
        let mut obstacle = obstacle_stimulus(&near_ranges, &world_bearings, &beam_cfg, n)?;
        if mode == Mode::Fusion {
            let engine =
                gist.ok_or_else(|| Error::config("mode", "fusion", "needs a GIST engine"))?;
            let view = cfg.camera.render(world, pose);
            let features = sector_features(&engine.describe(&view)?, blocks);
            let likelihood = model.predict(&features, &cfg.visual);
            let world_sectors: Vec<(f32, f32)> =
                sectors.iter().map(|&(c, h)| (c + pose[2], h)).collect();
            let visual = visual_stimulus(&likelihood, &world_sectors, cfg.visual.gain, n);
            // Fusion by the larger inhibition, not the sum: where the LIDAR already sees an
            // obstacle the camera adds nothing, so fusion cannot make the robot shy of what
            // LIDAR alone handles.
            for (o, v) in obstacle.iter_mut().zip(&visual) {
                *o = o.max(*v);
            }
            // The LIDAR teaches: is a beam inside the sector closer than the bottom row's reach?
            let blocked: Vec<bool> = sectors
                .iter()
                .map(|&(c, half)| {
                    ranges
                        .iter()
                        .zip(&bearings)
                        .any(|(r, b)| angle_diff(*b, c).abs() <= half && *r < near)
                })
                .collect();
            model.learn(&features, &blocked, cfg.visual.learning_rate);
        }
        let target = to_goal[1].atan2(to_goal[0]);
        let mut s = combined(&target_stimulus(target, &cfg.stimulus, n), &obstacle);
        for (i, si) in s.iter_mut().enumerate() {
            let h = angle_diff(i as f32 * std::f32::consts::TAU / n as f32, pose[2]);
            if h.abs() > std::f32::consts::FRAC_PI_2 {
                *si -= cfg.rear_inhibition;
            }
        }
        field.step(&s, cfg.field_steps)?;
        let (peak_index, heading) = field.peak(0);
        // φ_F relative to where the robot points.
        let heading = angle_diff(heading, pose[2]);
        if record_field {
            fields.push(field.field(0).to_vec());
        }
        let (nearest, nearest_bearing) =
            ranges
                .iter()
                .zip(&bearings)
                .fold((f32::INFINITY, 0.0), |best, (r, b)| {
                    if *r < best.0 {
                        (*r, *b)
                    } else {
                        best
                    }
                });
        let v = velocity(
            target_velocity(distance, &cfg.stimulus),
            obstacle_velocity(heading, nearest, nearest_bearing, &cfg.stimulus),
            field.field(0)[peak_index],
        ) * heading.cos().max(0.0);
        let omega = (cfg.turn_gain * heading).clamp(-cfg.max_turn_rate, cfg.max_turn_rate);
        // Unicycle, integrated in sub-steps; the collision test is exact at each.
        let substeps = (cfg.control_period / cfg.substep).ceil().max(1.0) as usize;
        let h = cfg.control_period / substeps as f32;
        let mut collided = false;
        for _ in 0..substeps {
            let before = [pose[0], pose[1]];
            pose[0] += v * pose[2].cos() * h;
            pose[1] += v * pose[2].sin() * h;
            pose[2] = angle_diff(pose[2] + omega * h, 0.0);
            length += (pose[0] - before[0]).hypot(pose[1] - before[1]);
            if world.collides([pose[0], pose[1]]) {
                collided = true;
                break;
            }
        }
        time += cfg.control_period;
        trajectory.push(pose);
        if collided {
            break Outcome::Collision;
        }
    };
    Ok(Episode {
        outcome,
        time,
        path_length: length,
        position_error_std: deviation_std(world, &trajectory),
        trajectory,
        field: fields,
    })
}

/// Standard deviation of the distance from each pose to the start–goal segment.
fn deviation_std(world: &World, trajectory: &[[f32; 3]]) -> f32 {
    let (a, b) = ([world.start[0], world.start[1]], world.goal);
    let ab = [b[0] - a[0], b[1] - a[1]];
    let len2 = (ab[0] * ab[0] + ab[1] * ab[1]).max(1e-12);
    let d: Vec<f32> = trajectory
        .iter()
        .map(|p| {
            let t = (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / len2).clamp(0.0, 1.0);
            (p[0] - a[0] - t * ab[0]).hypot(p[1] - a[1] - t * ab[1])
        })
        .collect();
    let mean = d.iter().sum::<f32>() / d.len() as f32;
    (d.iter().map(|x| (x - mean) * (x - mean)).sum::<f32>() / d.len() as f32).sqrt()
}
