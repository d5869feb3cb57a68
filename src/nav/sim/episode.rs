//! One navigation episode in the simulator, driving the [`Controller`] as a robot would: every
//! control period the LIDAR scans, the camera renders, the stimuli of eqs 32–34 (plus the GIST stimulus in fusion mode) drive the field
//! (eqs 28–31) for a few Euler steps, φ_F (eq 29) and the velocity laws (eqs 35–37) command a
//! unicycle, and the motion is integrated in small sub-steps with an exact collision test.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use super::sensors::LidarConfig;
use super::world::{length, segment_distance, World};
use crate::error::{Error, Result};
use crate::moved::{Moved, MovedKeys};
use crate::nav::controller::{Command, Controller, ControllerConfig, LaserScan, Mode};
use crate::nav::dnf::FieldBatch;
use crate::nav::gist::Gist;
use crate::nav::stimulus::angle_diff;
use crate::nav::visual::VisualObstacleModel;
use crate::rng::Rng;

/// Every parameter of an episode (the `[nav]` TOML table): the robot's controller, and what
/// only the simulator has — the LIDAR, the clock, the goal and the integration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(from = "NavTable")]
pub struct EpisodeConfig {
    /// `[nav.controller]`: the robot's controller.
    pub controller: ControllerConfig,
    /// The LIDAR.
    pub lidar: LidarConfig,
    /// Control period, seconds. Default 0.1.
    pub control_period: f32,
    /// Episode time limit, seconds. Default 60.
    pub max_time: f32,
    /// The goal is reached within this distance, metres. Default 0.3.
    pub goal_tolerance: f32,
    /// Integration sub-step, seconds. Default 0.01.
    pub substep: f32,
}

impl Default for EpisodeConfig {
    fn default() -> Self {
        Self {
            controller: ControllerConfig::default(),
            lidar: LidarConfig::default(),
            control_period: 0.1,
            max_time: 60.0,
            goal_tolerance: 0.3,
            substep: 0.01,
        }
    }
}

impl EpisodeConfig {
    /// Checks every value, naming the bad one.
    pub fn validate(&self) -> Result<()> {
        self.controller.validate()?;
        self.lidar.validate()?;
        for (field, v) in [
            ("nav.control_period", self.control_period),
            ("nav.max_time", self.max_time),
            ("nav.goal_tolerance", self.goal_tolerance),
            ("nav.substep", self.substep),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::config(field, v, "must be finite and > 0"));
            }
        }
        Ok(())
    }
}

/// The keys of `[nav]` that belong to the controller now.
struct FlatNav;

impl MovedKeys for FlatNav {
    const TABLE: &'static str = "nav";
    const KEYS: &'static [(&'static str, &'static str)] = &[
        ("field", "nav.controller.field"),
        ("stimulus", "nav.controller.stimulus"),
        ("camera", "nav.controller.camera"),
        ("visual", "nav.controller.visual"),
        ("field_steps", "nav.controller.field_steps"),
        ("turn_gain", "nav.controller.turn_gain"),
        ("max_turn_rate", "nav.controller.max_turn_rate"),
        ("rear_inhibition", "nav.controller.rear_inhibition"),
    ];
    const WHY: &'static str = "the controller's settings are in [nav.controller]";
}

/// The `[nav]` table as read: the episode's keys, and the controller's old ones, which only
/// refuse.
#[derive(Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct NavTable {
    controller: ControllerConfig,
    lidar: LidarConfig,
    control_period: Option<f32>,
    max_time: Option<f32>,
    goal_tolerance: Option<f32>,
    substep: Option<f32>,
    #[serde(rename = "field")]
    _0: Moved<FlatNav, 0>,
    #[serde(rename = "stimulus")]
    _1: Moved<FlatNav, 1>,
    #[serde(rename = "camera")]
    _2: Moved<FlatNav, 2>,
    #[serde(rename = "visual")]
    _3: Moved<FlatNav, 3>,
    #[serde(rename = "field_steps")]
    _4: Moved<FlatNav, 4>,
    #[serde(rename = "turn_gain")]
    _5: Moved<FlatNav, 5>,
    #[serde(rename = "max_turn_rate")]
    _6: Moved<FlatNav, 6>,
    #[serde(rename = "rear_inhibition")]
    _7: Moved<FlatNav, 7>,
}

impl From<NavTable> for EpisodeConfig {
    fn from(t: NavTable) -> Self {
        let d = EpisodeConfig::default();
        Self {
            controller: t.controller,
            lidar: t.lidar,
            control_period: t.control_period.unwrap_or(d.control_period),
            max_time: t.max_time.unwrap_or(d.max_time),
            goal_tolerance: t.goal_tolerance.unwrap_or(d.goal_tolerance),
            substep: t.substep.unwrap_or(d.substep),
        }
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

/// One episode advanced step by step, so that many episodes can share one batched field:
/// [`Robot::sense`] scans (and looks) and asks its [`Controller`] for the field's stimulus, the
/// caller steps the field (alone or batched, CPU or GPU), and [`Robot::act`] asks the
/// controller for a command from φ_F and moves.
pub struct Robot<'a> {
    world: &'a World,
    cfg: &'a EpisodeConfig,
    mode: Mode,
    controller: Controller,
    rng: Rng,
    pose: [f32; 3],
    scan: LaserScan,
    trajectory: Vec<[f32; 3]>,
    fields: Vec<Vec<f32>>,
    record_field: bool,
    time: f32,
    length: f32,
    outcome: Option<Outcome>,
}

impl<'a> Robot<'a> {
    /// A robot at the world's start; `seed` drives the sensor noise; `model` is its visual
    /// model (trained further online in fusion mode).
    pub fn new(
        world: &'a World,
        cfg: &'a EpisodeConfig,
        mode: Mode,
        model: VisualObstacleModel,
        seed: u64,
        record_field: bool,
    ) -> Result<Self> {
        let pose = [world.start[0], world.start[1], world.start[2].to_radians()];
        let lidar = &cfg.lidar;
        let scan = LaserScan {
            ranges: Vec::new(),
            bearings: (0..lidar.beams).map(|i| lidar.bearing(i)).collect(),
            angle_increment: lidar.fov_deg.to_radians() / (lidar.beams - 1) as f32,
            range_max: lidar.max_range,
        };
        Ok(Self {
            world,
            cfg,
            mode,
            controller: Controller::new(cfg.controller.clone(), mode, model)?,
            rng: Rng(seed),
            pose,
            scan,
            trajectory: vec![pose],
            fields: Vec::new(),
            record_field,
            time: 0.0,
            length: 0.0,
            outcome: None,
        })
    }

    /// Whether the episode has ended (goal, collision or time limit).
    pub fn done(&mut self) -> bool {
        if self.outcome.is_none() {
            if self.distance_to_goal() < self.cfg.goal_tolerance {
                self.outcome = Some(Outcome::Reached);
            } else if self.time >= self.cfg.max_time {
                self.outcome = Some(Outcome::Timeout);
            }
        }
        self.outcome.is_some()
    }

    fn distance_to_goal(&self) -> f32 {
        length(Vec2::from(self.world.goal) - Vec2::new(self.pose[0], self.pose[1]))
    }

    /// Scans (and in fusion mode looks), and returns the controller's stimulus for the field.
    pub fn sense(&mut self, gist: Option<&Gist>) -> Result<Vec<f32>> {
        let (cfg, world, pose) = (self.cfg, self.world, self.pose);
        self.scan.ranges = cfg.lidar.scan(world, pose, &mut self.rng);
        let view = match (self.mode, gist) {
            (Mode::Fusion, Some(engine)) => {
                Some((cfg.controller.camera.render(world, pose), engine))
            }
            _ => None,
        };
        let target = (world.goal[1] - pose[1]).atan2(world.goal[0] - pose[0]);
        self.controller.stimulus(
            &self.scan,
            pose,
            target,
            view.as_ref().map(|(frame, engine)| (frame, *engine)),
        )
    }

    /// Asks the controller for a command from the field's activations (eqs 29, 35–37) and
    /// integrates the unicycle over one control period with an exact collision test.
    pub fn act(&mut self, field: &[f32]) {
        let cfg = self.cfg;
        if self.record_field {
            self.fields.push(field.to_vec());
        }
        let Command { v, omega, .. } =
            self.controller
                .command(field, &self.scan, self.pose, self.distance_to_goal());
        let substeps = (cfg.control_period / cfg.substep).ceil().max(1.0) as usize;
        let h = cfg.control_period / substeps as f32;
        let pose = &mut self.pose;
        for _ in 0..substeps {
            let before = Vec2::new(pose[0], pose[1]);
            pose[0] += v * pose[2].cos() * h;
            pose[1] += v * pose[2].sin() * h;
            pose[2] = angle_diff(pose[2] + omega * h, 0.0);
            self.length += length(Vec2::new(pose[0], pose[1]) - before);
            if self.world.collides([pose[0], pose[1]]) {
                self.outcome = Some(Outcome::Collision);
                break;
            }
        }
        self.time += cfg.control_period;
        self.trajectory.push(*pose);
    }

    /// The record of the finished (or abandoned) episode, and the visual model as it ends.
    pub fn finish(self) -> (Episode, VisualObstacleModel) {
        let episode = Episode {
            outcome: self.outcome.unwrap_or(Outcome::Timeout),
            time: self.time,
            path_length: self.length,
            position_error_std: deviation_std(self.world, &self.trajectory),
            trajectory: self.trajectory,
            field: self.fields,
        };
        (episode, self.controller.into_model())
    }
}

/// Runs one episode with its own field. In fusion mode `model` is used and trained online
/// (pass the same model to later episodes to keep what was learned). `seed` drives the
/// sensor noise.
pub fn run(
    world: &World,
    cfg: &EpisodeConfig,
    mode: Mode,
    model: &mut VisualObstacleModel,
    gist: Option<&Gist>,
    seed: u64,
    record_field: bool,
) -> Result<Episode> {
    let mut field = FieldBatch::new(cfg.controller.field.clone(), 1)?;
    let mut robot = Robot::new(world, cfg, mode, std::mem::take(model), seed, record_field)?;
    while !robot.done() {
        let s = robot.sense(gist)?;
        field.step(&s, cfg.controller.field_steps)?;
        robot.act(field.field(0));
    }
    let (episode, learned) = robot.finish();
    *model = learned;
    Ok(episode)
}

/// Where a batch of episodes keeps its fields.
pub enum Fields {
    /// [`FieldBatch`] on CPU threads.
    Cpu(FieldBatch),
    /// [`crate::nav::dnf::GpuFieldBatch`]: one dispatch steps every episode's field.
    Gpu(crate::nav::dnf::GpuFieldBatch),
}

/// Runs many episodes in lockstep: every control period, all robots sense in parallel, one
/// batched call steps all their fields (B = robots, one GPU dispatch chain on the GPU), and
/// all act. Finished robots' fields idle at rest (zero stimulus is refused by nothing and
/// costs the same as any). Returns the episodes in order.
pub fn run_lockstep(
    mut robots: Vec<Robot<'_>>,
    fields: &mut Fields,
    gist: Option<&Gist>,
    progress: impl Fn() + Sync,
) -> Result<Vec<Episode>> {
    use rayon::prelude::*;
    let Some(first) = robots.first() else {
        return Ok(Vec::new());
    };
    let (n, steps) = (
        first.cfg.controller.field.neurons,
        first.cfg.controller.field_steps,
    );
    let b = robots.len();
    let mut stimulus = vec![0.0f32; b * n];
    let mut finished = vec![false; b];
    loop {
        let active: Vec<bool> = robots.iter_mut().map(|r| !r.done()).collect();
        for (i, &a) in active.iter().enumerate() {
            if !a && !finished[i] {
                finished[i] = true;
                progress();
            }
        }
        if !active.iter().any(|&a| a) {
            break;
        }
        robots
            .par_iter_mut()
            .zip(stimulus.par_chunks_mut(n))
            .zip(active.par_iter())
            .try_for_each(|((robot, s), &a)| -> Result<()> {
                if a {
                    s.copy_from_slice(&robot.sense(gist)?);
                } else {
                    s.fill(0.0);
                }
                Ok(())
            })?;
        // The CPU fields are read in place; the GPU's come back in one readback.
        let read_back;
        let activations: &[f32] = match fields {
            Fields::Cpu(f) => {
                f.step(&stimulus, steps)?;
                &f.u
            }
            Fields::Gpu(f) => {
                f.step(&stimulus, steps)?;
                read_back = f.read()?;
                &read_back
            }
        };
        robots
            .par_iter_mut()
            .zip(activations.par_chunks(n))
            .zip(active.par_iter())
            .for_each(|((robot, u), &a)| {
                if a {
                    robot.act(u);
                }
            });
    }
    Ok(robots.into_iter().map(|r| r.finish().0).collect())
}

/// Standard deviation of the distance from each pose to the start–goal segment.
fn deviation_std(world: &World, trajectory: &[[f32; 3]]) -> f32 {
    let (a, b) = (
        Vec2::new(world.start[0], world.start[1]),
        Vec2::from(world.goal),
    );
    let d: Vec<f32> = trajectory
        .iter()
        .map(|p| segment_distance(Vec2::new(p[0], p[1]), a, b))
        .collect();
    let mean = d.iter().sum::<f32>() / d.len() as f32;
    (d.iter().map(|x| (x - mean) * (x - mean)).sum::<f32>() / d.len() as f32).sqrt()
}
