//! The navigation controller a robot calls once per control cycle (paper §3): a laser scan,
//! the pose, the goal and optionally a camera frame in; the field's stimulus (eqs 32–34 and
//! the GIST stimulus of eqs 38–45), the field (eqs 28–31), and the velocities (eqs 35–37) out.
//!
//! It knows nothing of the simulator: the simulator, `nav-replay` and `nav-eval` all drive it,
//! the last one with many robots sharing one batched field through [`Controller::stimulus`]
//! and [`Controller::command`]. Its settings are [`ControllerConfig`]; the camera's GIST comes
//! from either backend through [`Gist`].

use std::f32::consts::{FRAC_PI_2, TAU};

use serde::{Deserialize, Serialize};

use super::camera::CameraConfig;
use super::dnf::{heading as neuron_heading, FieldBatch, FieldConfig};
use super::gist::Gist;
use super::stimulus::{
    angle_diff, combined, field_of_view, in_view, obstacle_stimulus, obstacle_velocity,
    target_stimulus, target_velocity, velocity, StimulusConfig,
};
use super::visual::{sector_features, visual_stimulus, VisualConfig, VisualObstacleModel};
use crate::error::{Error, Result};
use crate::image::Frame;

/// Which sensors drive the field.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// LIDAR range/bearing stimulus only.
    Laser,
    /// LIDAR plus the learned GIST stimulus of the camera.
    Fusion,
}

named_variants!(Mode { Laser => "laser", Fusion => "fusion" });

/// Every parameter of the controller, with documented defaults (the `[nav.controller]` TOML
/// table).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ControllerConfig {
    /// The field (eqs 28–31).
    pub field: FieldConfig,
    /// Stimuli and velocity laws, eqs 32–37 (default c_o = 30, σ = 10; the rest as
    /// [`StimulusConfig`]).
    pub stimulus: StimulusConfig,
    /// The camera's geometry, for the GIST sectors.
    pub camera: CameraConfig,
    /// The GIST stimulus and its learning.
    pub visual: VisualConfig,
    /// Euler steps of the field per control cycle. Default 10.
    pub field_steps: usize,
    /// Turn rate per radian of heading error, 1/s. Default 2.5.
    pub turn_gain: f32,
    /// Largest turn rate, rad/s. Default 2.0.
    pub max_turn_rate: f32,
    /// Stimulus subtracted from headings behind the robot. Default 4.
    pub rear_inhibition: f32,
}

impl Default for ControllerConfig {
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
            camera: CameraConfig::default(),
            visual: VisualConfig::default(),
            field_steps: 10,
            turn_gain: 2.5,
            max_turn_rate: 2.0,
            rear_inhibition: 4.0,
        }
    }
}

impl ControllerConfig {
    /// Checks every value, naming the bad one.
    pub fn validate(&self) -> Result<()> {
        self.field.validate()?;
        self.stimulus.validate()?;
        self.camera.validate()?;
        self.visual.validate()?;
        for (field, v) in [
            ("nav.controller.turn_gain", self.turn_gain),
            ("nav.controller.max_turn_rate", self.max_turn_rate),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::config(field, v, "must be finite and > 0"));
            }
        }
        if !self.rear_inhibition.is_finite() {
            return Err(Error::config(
                "nav.controller.rear_inhibition",
                self.rear_inhibition,
                "must be finite",
            ));
        }
        if self.field_steps == 0 || self.field_steps > MAX_FIELD_STEPS {
            return Err(Error::config(
                "nav.controller.field_steps",
                self.field_steps,
                format!("must be in 1..={MAX_FIELD_STEPS}"),
            ));
        }
        Ok(())
    }
}

/// One laser scan in the robot frame.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserScan {
    /// Ranges in metres; beams at or beyond `range_max` (or ≤ 0) saw nothing.
    pub ranges: Vec<f32>,
    /// Bearing of each beam, radians, 0 ahead, positive to the left.
    pub bearings: Vec<f32>,
    /// Angle between neighbouring beams, radians: each beam's weight in eq 32 is scaled by it,
    /// so that a wall inhibits alike whatever the scanner's resolution.
    pub angle_increment: f32,
    /// The scanner's largest range, metres.
    pub range_max: f32,
}

impl LaserScan {
    /// A scan in the ROS convention: beam i at `angle_min + i · angle_increment`.
    pub fn new(ranges: Vec<f32>, angle_min: f32, angle_increment: f32, range_max: f32) -> Self {
        let bearings = (0..ranges.len())
            .map(|i| angle_min + i as f32 * angle_increment)
            .collect();
        Self {
            ranges,
            bearings,
            angle_increment,
            range_max,
        }
    }

    /// Refuses a scan the controller cannot read: NaN ranges or bearings, mismatched lengths,
    /// fewer than two beams, or a range_max that is not positive.
    pub fn validate(&self) -> Result<()> {
        if self.ranges.len() != self.bearings.len() || self.ranges.len() < 2 {
            return Err(Error::input(
                format!("scan.ranges ({} beams)", self.ranges.len()),
                format!(
                    "needs ≥ 2 beams, one bearing each ({} bearings)",
                    self.bearings.len()
                ),
            ));
        }
        if let Some(i) = self.ranges.iter().position(|r| r.is_nan()) {
            return Err(Error::input(
                format!("scan.ranges[{i}] = NaN"),
                "must be a number",
            ));
        }
        if let Some(i) = self.bearings.iter().position(|b| !b.is_finite()) {
            return Err(Error::input(
                format!("scan.bearings[{i}] = {}", self.bearings[i]),
                "must be finite",
            ));
        }
        if !(self.angle_increment.is_finite() && self.angle_increment != 0.0) {
            return Err(Error::input(
                format!("scan.angle_increment = {}", self.angle_increment),
                "must be finite and non-zero",
            ));
        }
        if self.range_max.is_nan() || self.range_max <= 0.0 {
            return Err(Error::input(
                format!("scan.range_max = {}", self.range_max),
                "must be > 0",
            ));
        }
        Ok(())
    }

    fn spacing(&self) -> f32 {
        self.angle_increment.abs()
    }
}

/// What the controller asks of the robot for the next control period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Command {
    /// Forward speed, m/s (eqs 35–37).
    pub v: f32,
    /// Turn rate, rad/s (positive to the left).
    pub omega: f32,
    /// The heading the field chose (φ_F, eq 29), relative to where the robot points.
    pub heading: f32,
}

/// Most Euler steps of the field in one control cycle: bounds the work of one call, whatever
/// a setting or a log's gap between scans asks.
pub const MAX_FIELD_STEPS: usize = 10_000;

/// The field-based navigation controller of one robot.
pub struct Controller {
    cfg: ControllerConfig,
    mode: Mode,
    model: VisualObstacleModel,
    field: FieldBatch,
    /// The camera's GIST blocks as (centre bearing, half width), robot frame.
    sectors: Vec<(f32, f32)>,
    /// The distance the bottom row of a block sees: a beam closer than this blocks the sector.
    near: f32,
}

impl Controller {
    /// A controller with its own field. In [`Mode::Fusion`] `model` is its visual model,
    /// trained further online from the LIDAR.
    pub fn new(cfg: ControllerConfig, mode: Mode, model: VisualObstacleModel) -> Result<Self> {
        cfg.validate()?;
        let blocks = cfg.visual.gist.blocks;
        let sector_width = cfg.camera.fov_deg.to_radians() / blocks as f32;
        let sectors = (0..blocks)
            .map(|c| {
                let centre = cfg
                    .camera
                    .column_bearing((c as f32 + 0.5) * cfg.camera.width as f32 / blocks as f32);
                (centre, 0.5 * sector_width)
            })
            .collect();
        Ok(Self {
            field: FieldBatch::new(cfg.field.clone(), 1)?,
            near: cfg.camera.near_distance(1.0 / blocks as f32),
            sectors,
            model,
            mode,
            cfg,
        })
    }

    /// The mode it runs in.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The configuration.
    pub fn config(&self) -> &ControllerConfig {
        &self.cfg
    }

    /// The field's activations after the last [`Controller::step`].
    pub fn field(&self) -> &[f32] {
        self.field.field(0)
    }

    /// The visual model as learned so far.
    pub fn into_model(self) -> VisualObstacleModel {
        self.model
    }

    /// One control cycle towards the goal point (x, y) from `pose` (x, y, θ): the stimulus,
    /// `field_steps` Euler steps of the field, and the command. `camera` is the current frame
    /// with a GIST engine (either backend), needed in fusion mode.
    pub fn step(
        &mut self,
        scan: &LaserScan,
        pose: [f32; 3],
        goal: [f32; 2],
        camera: Option<(&Frame, &Gist)>,
    ) -> Result<Command> {
        let target = (goal[1] - pose[1]).atan2(goal[0] - pose[0]);
        let distance = (goal[0] - pose[0]).hypot(goal[1] - pose[1]);
        self.step_towards(scan, pose, target, distance, camera)
    }

    /// [`Controller::step`] towards a world heading `target` (radians) at `distance` metres.
    pub fn step_towards(
        &mut self,
        scan: &LaserScan,
        pose: [f32; 3],
        target: f32,
        distance: f32,
        camera: Option<(&Frame, &Gist)>,
    ) -> Result<Command> {
        self.advance(scan, pose, target, distance, camera, self.cfg.field_steps)
    }

    /// [`Controller::step_towards`] with the field integrated over `seconds` (whole Euler
    /// steps of `field.dt`, at least one) instead of `field_steps` steps: for scans that arrive
    /// at irregular intervals, each held until the next. At most 10 000 steps.
    pub fn step_towards_over(
        &mut self,
        scan: &LaserScan,
        pose: [f32; 3],
        target: f32,
        distance: f32,
        camera: Option<(&Frame, &Gist)>,
        seconds: f32,
    ) -> Result<Command> {
        let steps = seconds / self.cfg.field.dt;
        if !(seconds.is_finite() && seconds >= 0.0 && steps.round() <= MAX_FIELD_STEPS as f32) {
            return Err(Error::input(
                format!("field time {seconds} s"),
                format!(
                    "must be in [0, {}] ({MAX_FIELD_STEPS} Euler steps of {} s)",
                    MAX_FIELD_STEPS as f32 * self.cfg.field.dt,
                    self.cfg.field.dt
                ),
            ));
        }
        let steps = (steps.round() as usize).max(1);
        self.advance(scan, pose, target, distance, camera, steps)
    }

    fn advance(
        &mut self,
        scan: &LaserScan,
        pose: [f32; 3],
        target: f32,
        distance: f32,
        camera: Option<(&Frame, &Gist)>,
        steps: usize,
    ) -> Result<Command> {
        let s = self.stimulus(scan, pose, target, camera)?;
        self.field.step(&s, steps)?;
        Ok(self.command(self.field.field(0), scan, pose, distance))
    }

    /// The field's stimulus S on the allocentric ring (neuron i is the world heading 2πi/N, so
    /// a peak stays put while the robot turns toward it): the goal's attraction (eq 33), each
    /// beam as an obstacle (eq 32, weighted by the beams' angular density), in fusion mode the
    /// camera's GIST stimulus, and an inhibition of the headings behind the robot. In fusion
    /// mode the LIDAR also teaches the visual model which camera sectors are blocked.
    pub fn stimulus(
        &mut self,
        scan: &LaserScan,
        pose: [f32; 3],
        target: f32,
        camera: Option<(&Frame, &Gist)>,
    ) -> Result<Vec<f32>> {
        scan.validate()?;
        let cfg = &self.cfg;
        let n = cfg.field.neurons;
        let beam_cfg = cfg.stimulus.per_beam(scan.spacing());
        let (near_ranges, world_bearings): (Vec<f32>, Vec<f32>) = scan
            .ranges
            .iter()
            .zip(&scan.bearings)
            .filter(|(r, _)| **r > 0.0 && **r < scan.range_max)
            .map(|(r, b)| (*r, b + pose[2]))
            .unzip();
        let mut obstacle = obstacle_stimulus(&near_ranges, &world_bearings, &beam_cfg, n)?;
        if self.mode == Mode::Fusion {
            let (view, engine) = camera.ok_or_else(|| {
                Error::input(
                    "camera (none given)",
                    "fusion mode needs a camera frame and a GIST engine",
                )
            })?;
            let blocks = cfg.visual.gist.blocks;
            let features = sector_features(&engine.describe(view)?, blocks);
            let likelihood = self.model.predict(&features, &cfg.visual);
            let world_sectors: Vec<(f32, f32)> = self
                .sectors
                .iter()
                .map(|&(c, h)| (c + pose[2], h))
                .collect();
            let visual = visual_stimulus(&likelihood, &world_sectors, cfg.visual.gain, n);
            // Fusion by the larger inhibition, not the sum: where the LIDAR already sees an
            // obstacle the camera adds nothing, so fusion cannot make the robot shy of what
            // LIDAR alone handles.
            for (o, v) in obstacle.iter_mut().zip(&visual) {
                *o = o.max(*v);
            }
            let blocked: Vec<bool> = self
                .sectors
                .iter()
                .map(|&(c, half)| {
                    scan.ranges
                        .iter()
                        .zip(&scan.bearings)
                        .any(|(r, b)| angle_diff(*b, c).abs() <= half && *r < self.near)
                })
                .collect();
            self.model
                .learn(&features, &blocked, cfg.visual.learning_rate);
        }
        let mut s = combined(&target_stimulus(target, &cfg.stimulus, n), &obstacle);
        // Behind, and outside the scanner's view (a scanner narrower than 180°): headings the
        // robot should not take, or knows nothing of.
        let view = field_of_view(&scan.bearings, scan.spacing()).unwrap_or((0.0, 0.0));
        for (i, si) in s.iter_mut().enumerate() {
            let h = angle_diff(i as f32 * TAU / n as f32, pose[2]);
            if h.abs() > FRAC_PI_2 || !in_view(h, view) {
                *si -= cfg.rear_inhibition;
            }
        }
        Ok(s)
    }

    /// Reads φ_F (eq 29) from a field's activations and sets the velocities (eqs 35–37):
    /// slower near the goal and near obstacles, not forward at all when φ_F points behind.
    pub fn command(
        &self,
        field: &[f32],
        scan: &LaserScan,
        pose: [f32; 3],
        distance: f32,
    ) -> Command {
        let cfg = &self.cfg;
        let n = field.len();
        let peak = (0..n).fold(0, |best, i| if field[i] > field[best] { i } else { best });
        let heading = angle_diff(neuron_heading(peak, n), pose[2]);
        let (nearest, nearest_bearing) =
            scan.ranges
                .iter()
                .zip(&scan.bearings)
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
            field[peak],
        ) * heading.cos().max(0.0);
        let omega = (cfg.turn_gain * heading).clamp(-cfg.max_turn_rate, cfg.max_turn_rate);
        Command { v, omega, heading }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan_with_wall_ahead(range: f32) -> LaserScan {
        let n = 181;
        let inc = std::f32::consts::PI / (n - 1) as f32;
        let mut scan = LaserScan::new(vec![8.0; n], -FRAC_PI_2, inc, 8.0);
        for (r, b) in scan.ranges.iter_mut().zip(&scan.bearings) {
            if b.abs() < 0.35 {
                *r = range;
            }
        }
        scan
    }

    #[test]
    fn heads_for_the_goal_when_free_and_around_an_obstacle_in_the_way() {
        let mut free =
            Controller::new(ControllerConfig::default(), Mode::Laser, Default::default()).unwrap();
        let open = LaserScan::new(
            vec![8.0; 181],
            -FRAC_PI_2,
            std::f32::consts::PI / 180.0,
            8.0,
        );
        let mut cmd = free.step(&open, [0.0, 0.0, 0.0], [5.0, 0.0], None).unwrap();
        for _ in 0..5 {
            cmd = free.step(&open, [0.0, 0.0, 0.0], [5.0, 0.0], None).unwrap();
        }
        assert!(cmd.heading.abs() < 0.1, "{cmd:?}");
        assert!(cmd.v > 0.0 && cmd.omega.abs() < 0.3, "{cmd:?}");

        let mut blocked =
            Controller::new(ControllerConfig::default(), Mode::Laser, Default::default()).unwrap();
        let wall = scan_with_wall_ahead(0.8);
        for _ in 0..6 {
            cmd = blocked
                .step(&wall, [0.0, 0.0, 0.0], [5.0, 0.0], None)
                .unwrap();
        }
        assert!(cmd.heading.abs() > 0.3, "turns away from the wall: {cmd:?}");
        assert_eq!(
            blocked.field().len(),
            ControllerConfig::default().field.neurons
        );
    }

    #[test]
    fn bad_scans_are_refused_by_name() {
        let mut c =
            Controller::new(ControllerConfig::default(), Mode::Laser, Default::default()).unwrap();
        let mut scan = scan_with_wall_ahead(1.0);
        scan.ranges[3] = f32::NAN;
        let e = c
            .step(&scan, [0.0; 3], [1.0, 0.0], None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("scan.ranges") && e.contains("NaN"), "{e}");
        let short = LaserScan::new(vec![1.0], 0.0, 0.1, 8.0);
        assert!(c.step(&short, [0.0; 3], [1.0, 0.0], None).is_err());
        let e = Controller::new(
            ControllerConfig::default(),
            Mode::Fusion,
            Default::default(),
        )
        .unwrap()
        .step(&scan_with_wall_ahead(1.0), [0.0; 3], [1.0, 0.0], None)
        .unwrap_err()
        .to_string();
        assert!(e.contains("camera"), "{e}");
    }
}
