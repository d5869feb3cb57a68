//! `nav-replay`: drive the stimuli and the field with every scan of a real CARMEN log, taking
//! as target the direction in which the robot really moved over the next second, and report
//! how often the chosen heading is free and how far it deviates from the real motion.
//!
//! Beams are many point obstacles, so each beam's weight c_o is scaled by the angular density
//! (Δφ·√(σ/π)): a wall then inhibits about as strongly as one obstacle of eq 32 would, whatever
//! the scanner's resolution. Headings outside the scanner's 180° field of view are unknown and
//! are inhibited by `rear_inhibition`.
//!
//! Besides the field's figures over every scan with motion, each scan is classed by what the
//! robot did ([`metric::Motion`]), and the forward-driving scans are scored against the free
//! heading nearest to the real motion ([`metric`]).

pub mod metric;

use serde::{Deserialize, Serialize};

use metric::{Deviation, Motion, MotionCounts};

use super::carmen::Scan;
use super::controller::{Controller, LaserScan};
use super::controller::{ControllerConfig, Mode, MAX_FIELD_STEPS};
use super::dnf::FieldConfig;
use super::stimulus::{angle_diff, StimulusConfig};
use crate::error::{Error, Result};

/// Settings of a replay.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReplayConfig {
    /// The field. Default eq 31's kernel on 1° neurons ([`FieldConfig::refined`]`(5)`, 360
    /// neurons): on the controller's 5° lattice a formed peak stays pinned while the target
    /// drifts by less than a few neurons between two scans, and the chosen heading trailed a
    /// free real motion by 5–6° (docs/NAVIGATION.md).
    pub field: FieldConfig,
    /// The stimuli.
    pub stimulus: StimulusConfig,
    /// Euler steps of the field per scan, whatever the time between scans. Default unset: each
    /// scan drives the field for the time until the next scan of the log (up to
    /// `max_field_time`), as a robot's field runs between two scans.
    pub steps_per_scan: Option<usize>,
    /// Longest time a scan drives the field (s), however long the log's gap. Default 5.
    pub max_field_time: f64,
    /// The time each scan drives the field (s) on a log whose timestamps do not resolve the
    /// scans (see `fallback_distance`). Default 1.
    pub untimed_field_time: f64,
    /// The target is where the robot is this many seconds later. Default 1.0.
    pub lookahead: f64,
    /// Scans after which the robot moves less than this (m) in the look-ahead are skipped.
    /// Default 0.1.
    pub min_motion: f64,
    /// A heading is free when every beam within ±`free_halfwidth_deg` reads beyond this (m).
    /// Default 0.5.
    pub safety: f32,
    /// Default 10°.
    pub free_halfwidth_deg: f32,
    /// Stimulus subtracted from headings outside the field of view. Default 4.
    pub rear_inhibition: f32,
    /// When a log's timestamps are too coarse to measure one second (the corrected CSAIL log
    /// prints them with six digits, so consecutive scans share one), the target is the
    /// direction to the first later pose at least this far (m). Default 0.3.
    pub fallback_distance: f64,
    /// A scan after which the robot moves less than `min_motion` but turns at least this
    /// much over the look-ahead (degrees) counts as turning in place. Default 15.
    pub turn_min_deg: f64,
}

impl ReplayConfig {
    /// Checks every value, naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        self.field.validate()?;
        self.stimulus.validate()?;
        let longest = MAX_FIELD_STEPS as f64 * self.field.dt as f64;
        let checks: [(&'static str, f64, f64, f64); 9] = [
            ("lookahead", self.lookahead, 1e-3, 3600.0),
            ("max_field_time", self.max_field_time, 0.0, longest),
            ("untimed_field_time", self.untimed_field_time, 0.0, longest),
            ("min_motion", self.min_motion, 0.0, 1e3),
            ("safety", self.safety as f64, 0.0, 1e3),
            (
                "free_halfwidth_deg",
                self.free_halfwidth_deg as f64,
                0.0,
                90.0,
            ),
            ("rear_inhibition", self.rear_inhibition as f64, 0.0, 1e3),
            ("fallback_distance", self.fallback_distance, 1e-3, 1e3),
            ("turn_min_deg", self.turn_min_deg, 0.0, 360.0),
        ];
        for (field, v, lo, hi) in checks {
            if !(v.is_finite() && v >= lo && v <= hi) {
                return Err(Error::config(field, v, format!("must be in [{lo}, {hi}]")));
            }
        }
        if let Some(steps) = self.steps_per_scan {
            if !(1..=MAX_FIELD_STEPS).contains(&steps) {
                return Err(Error::config(
                    "steps_per_scan",
                    steps,
                    format!("must be in 1..={MAX_FIELD_STEPS}"),
                ));
            }
        }
        Ok(())
    }
}

impl Default for ReplayConfig {
    fn default() -> Self {
        Self {
            field: FieldConfig::refined(5),
            stimulus: StimulusConfig::default(),
            steps_per_scan: None,
            max_field_time: 5.0,
            untimed_field_time: 1.0,
            lookahead: 1.0,
            min_motion: 0.1,
            safety: 0.5,
            free_halfwidth_deg: 10.0,
            rear_inhibition: 4.0,
            fallback_distance: 0.3,
            turn_min_deg: 15.0,
        }
    }
}

/// Whether the log's timestamps resolve the look-ahead (most consecutive scans differ in time).
pub fn timestamps_usable(scans: &[Scan]) -> bool {
    let distinct = scans.windows(2).filter(|w| w[1].time > w[0].time).count();
    distinct * 2 > scans.len().saturating_sub(1)
}

/// The later scan that defines the target of scan `k`: one look-ahead later in time, or, when
/// the timestamps are too coarse, the first pose `fallback_distance` away.
fn later<'a>(scans: &'a [Scan], k: usize, cfg: &ReplayConfig, by_time: bool) -> Option<&'a Scan> {
    let s = &scans[k];
    if by_time {
        scans[k..].iter().find(|l| l.time >= s.time + cfg.lookahead)
    } else {
        scans[k..]
            .iter()
            .find(|l| (l.x - s.x).hypot(l.y - s.y) >= cfg.fallback_distance)
    }
}

/// Offset between the log's pose heading and the scanner's forward axis, estimated from the
/// motion and rounded to a multiple of 90° (a frame convention, not a per-scan fit): the
/// corrected CSAIL log's θ points 90° away from the direction the robot drives.
pub fn frame_offset(scans: &[Scan], cfg: &ReplayConfig) -> f64 {
    let (mut sx, mut sy) = (0.0f64, 0.0f64);
    let by_time = timestamps_usable(scans);
    for (k, scan) in scans.iter().enumerate() {
        let Some(later) = later(scans, k, cfg, by_time) else {
            break;
        };
        let (dx, dy) = (later.x - scan.x, later.y - scan.y);
        if dx.hypot(dy) >= cfg.min_motion {
            let a = dy.atan2(dx) - scan.theta;
            sx += a.cos();
            sy += a.sin();
        }
    }
    let quarter = std::f64::consts::FRAC_PI_2;
    (sy.atan2(sx) / quarter).round() * quarter
}

/// The figures of a replay.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReplayResult {
    /// Scans evaluated: those after which the robot moved at least `min_motion` (forward or
    /// reversing).
    pub scans: usize,
    /// Fraction of them whose chosen heading is free.
    pub free_fraction: f64,
    /// Mean |chosen heading − real motion| in degrees, over the same scans.
    pub mean_abs_deviation_deg: f64,
    /// Every scan with a look-ahead, by what the robot did over it.
    pub motion: MotionCounts,
    /// |chosen heading − real motion| over the forward-driving scans.
    pub forward: Deviation,
    /// Fraction of the forward-driving scans whose chosen heading is free.
    pub forward_free_fraction: f64,
    /// |nearest free heading − real motion| over the forward-driving scans that have a free
    /// heading: how far any free choice had to be from the real motion.
    pub reference: Deviation,
    /// Forward-driving scans on which no heading in view is free.
    pub reference_missing: usize,
}

/// Whether `heading` (robot frame) is free in `scan`.
pub fn is_free(scan: &Scan, heading: f32, safety: f32, halfwidth: f32) -> bool {
    let mut seen = false;
    for (&r, &b) in scan.ranges.iter().zip(&scan.bearings) {
        if angle_diff(b, heading).abs() <= halfwidth {
            seen = true;
            if r.is_nan() || r <= safety {
                return false;
            }
        }
    }
    seen
}

/// Replays a log.
pub fn replay(scans: &[Scan], cfg: &ReplayConfig) -> Result<ReplayResult> {
    replay_with(scans, cfg, |_| Ok(()))
}

/// What the field did on one evaluated scan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReplayStep {
    /// The scan's time (s).
    pub time: f64,
    /// The controller's command: speed, turn rate and the chosen heading (robot frame).
    pub command: super::controller::Command,
    /// Direction of the real motion over the look-ahead (robot frame, rad).
    pub target: f32,
    /// Whether the chosen heading is free.
    pub free: bool,
}

/// [`replay`], handing every evaluated scan's [`ReplayStep`] to `each` as it is computed (for
/// writing them out); an error from `each` stops the replay.
pub fn replay_with(
    scans: &[Scan],
    cfg: &ReplayConfig,
    mut each: impl FnMut(&ReplayStep) -> Result<()>,
) -> Result<ReplayResult> {
    cfg.validate()?;
    // The robot-frame controller of a robot at the origin facing +x: the log's own poses
    // only give the target, so the ring is the scanner's frame.
    let mut controller = Controller::new(
        ControllerConfig {
            field: cfg.field.clone(),
            stimulus: cfg.stimulus.clone(),
            rear_inhibition: cfg.rear_inhibition,
            ..ControllerConfig::default()
        },
        Mode::Laser,
        Default::default(),
    )?;
    let (mut evaluated, mut free, mut deviation) = (0usize, 0usize, 0.0f64);
    let mut motion = MotionCounts::default();
    let (mut forward, mut forward_free, mut reference, mut reference_missing) =
        (Vec::new(), 0usize, Vec::new(), 0usize);
    let halfwidth = cfg.free_halfwidth_deg.to_radians();
    let offset = frame_offset(scans, cfg);
    let by_time = timestamps_usable(scans);
    for (k, scan) in scans.iter().enumerate() {
        let Some(later) = later(scans, k, cfg, by_time) else {
            break;
        };
        let (dx, dy) = (later.x - scan.x, later.y - scan.y);
        let target = angle_diff((dy.atan2(dx) - scan.theta - offset) as f32, 0.0);
        let class = metric::classify(
            dx.hypot(dy),
            target,
            (later.theta - scan.theta)
                .sin()
                .atan2((later.theta - scan.theta).cos()),
            metric::view_of(scan),
            cfg.min_motion,
            cfg.turn_min_deg.to_radians(),
        );
        motion.add(class);
        if matches!(class, Motion::TurningInPlace | Motion::Standing) {
            continue;
        }
        // Every reading is an obstacle (the scanner's no-return value too, far and weak), each
        // weighted by the beams' angular density (see the module docs).
        let laser = LaserScan {
            ranges: scan.ranges.clone(),
            bearings: scan.bearings.clone(),
            angle_increment: scan.angle_increment,
            range_max: f32::INFINITY,
        };
        // The time this scan drives the field; a log whose time steps back gives it one step.
        let held = match (cfg.steps_per_scan, by_time, scans.get(k + 1)) {
            (Some(steps), _, _) => steps as f64 * cfg.field.dt as f64,
            (None, true, Some(next)) => (next.time - scan.time).clamp(0.0, cfg.max_field_time),
            (None, true, None) => 0.0,
            (None, false, _) => cfg.untimed_field_time,
        };
        let command =
            controller.step_towards_over(&laser, [0.0; 3], target, 1.0, None, held as f32)?;
        let heading = command.heading;
        let is = is_free(scan, heading, cfg.safety, halfwidth);
        each(&ReplayStep {
            time: scan.time,
            command,
            target,
            free: is,
        })?;
        evaluated += 1;
        free += is as usize;
        let off = angle_diff(heading, target).abs().to_degrees() as f64;
        deviation += off;
        if class == Motion::Forward {
            forward.push(off);
            forward_free += is as usize;
            let free_at = |h: f32| is_free(scan, h, cfg.safety, halfwidth);
            match metric::nearest_free(scan, target, free_at) {
                Some(h) => reference.push(angle_diff(h, target).abs().to_degrees() as f64),
                None => reference_missing += 1,
            }
        }
    }
    if evaluated == 0 {
        return Err(Error::input(
            format!("{} scans", scans.len()),
            format!(
                "no scan has a later pose at least min_motion = {} m away: nothing to evaluate",
                cfg.min_motion
            ),
        ));
    }
    Ok(ReplayResult {
        scans: evaluated,
        free_fraction: if evaluated == 0 {
            0.0
        } else {
            free as f64 / evaluated as f64
        },
        mean_abs_deviation_deg: if evaluated == 0 {
            0.0
        } else {
            deviation / evaluated as f64
        },
        forward_free_fraction: if forward.is_empty() {
            0.0
        } else {
            forward_free as f64 / forward.len() as f64
        },
        motion,
        forward: Deviation::of(forward),
        reference: Deviation::of(reference),
        reference_missing,
    })
}
