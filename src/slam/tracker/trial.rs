//! The start's second hypothesis. Not an equation of the paper (its filter starts at rest).
//!
//! Two views alone do not always tell a sideways walk that turns from a forward motion with
//! a little more turn (the bas-relief ambiguity): the eight-point direction leans towards the
//! optical axis, and the Sampson cost can score a wrong basin lower (docs/SLAM.md, "Hand-held
//! starts"). The frames that follow tell them apart: the filter seated on the wrong motion
//! predicts its landmarks farther from where they are found, measured against its own
//! innovation covariance (eq 26's Mahalanobis distance). So when the multi-start search lands
//! on another motion, the session is seated on both and runs both, side by side, for
//! `[slam.start] trial_frames` frames; each frame adds the mean normalised innovation of a
//! hypothesis's matches, and the searched motion replaces the eight-point one only when its
//! total is below [`REPLACE_BELOW`] of the eight-point's. The eight-point motion is right for
//! the forward starts of vehicles, where the two totals come out alike. Meanwhile each frame
//! reports the eight-point hypothesis, with the time of both. The ratio separates the
//! measured starts only narrowly, and misses the generated sliders, where the searched
//! motion is right (docs/SLAM.md, "The start's trial" and "The wait placed").

use super::report::{FrameReport, SlamTimings};
use super::Slam;
use crate::error::Result;
use crate::features::Detector;
use crate::image::Frame;
use crate::slam::ekf::Observation;
use crate::slam::klt::Pyramid;
use crate::slam::motion::OdometryStep;

/// The searched motion wins when its normalised innovations total less than this fraction
/// of the eight-point one's.
const REPLACE_BELOW: f64 = 0.85;

/// A session seated on the searched two-view motion, run beside this one.
#[derive(Clone, Debug)]
pub(super) struct Trial {
    rival: Box<Slam>,
    frames_left: usize,
    /// The rival's reports of the trial's frames, from the one it seated on.
    reports: Vec<FrameReport>,
}

impl Slam {
    /// Runs `rival` (seated on the searched motion) beside this session from the next frame.
    pub(super) fn start_trial(&mut self, mut rival: Slam) {
        self.trial_innovation = Some(0.0);
        rival.trial_innovation = Some(0.0);
        self.trial = Some(Box::new(Trial {
            rival: Box::new(rival),
            frames_left: self.config.start.trial_frames,
            reports: Vec::new(),
        }));
    }

    /// At the end of a frame that may have seated both hypotheses: the rival ends the frame
    /// too (it keeps the pyramid for KLT) and keeps its report of it.
    pub(super) fn end_seat_frame(&mut self, pyramid: &Pyramid, timestamp: f64) {
        let Some(trial) = self.trial.as_mut() else {
            return;
        };
        if !trial.reports.is_empty() {
            return;
        }
        let created = trial.rival.filter.slots().len();
        let report = trial
            .rival
            .report(timestamp, SlamTimings::default(), created, false);
        trial.reports.push(report);
        trial.rival.end_frame(pyramid.clone());
    }

    /// One frame of the trial: both sessions process it and this one reports; on the trial's
    /// last frame the hypothesis kept becomes this session.
    pub(super) fn process_in_trial(
        &mut self,
        mut trial: Box<Trial>,
        frame: &Frame,
        timestamp: f64,
        odometry: Option<&OdometryStep>,
        detector: &Detector,
    ) -> Result<FrameReport> {
        let ours = match self.process_frame(frame, timestamp, odometry, detector) {
            Ok(report) => report,
            Err(e) => {
                // A frame refused (size, timestamp) is refused to both: the trial goes on.
                self.trial = Some(trial);
                return Err(e);
            }
        };
        let theirs = match trial
            .rival
            .process_frame(frame, timestamp, odometry, detector)
        {
            Ok(report) => report,
            Err(e) => {
                log::warn!("start trial: the searched motion failed at t={timestamp} ({e})");
                self.trial_innovation = None;
                return Ok(ours);
            }
        };
        let timings = SlamTimings {
            detection_ms: ours.timings.detection_ms + theirs.timings.detection_ms,
            association_ms: ours.timings.association_ms + theirs.timings.association_ms,
            filter_ms: ours.timings.filter_ms + theirs.timings.filter_ms,
            total_ms: ours.timings.total_ms + theirs.timings.total_ms,
        };
        trial.frames_left -= 1;
        if trial.frames_left > 0 {
            trial.reports.push(theirs);
            self.trial = Some(trial);
            return Ok(FrameReport { timings, ..ours });
        }
        let own = self.trial_innovation.take().unwrap_or(f64::INFINITY);
        let searched = trial.rival.trial_innovation.take().unwrap_or(f64::INFINITY);
        let replace = searched < REPLACE_BELOW * own;
        log::info!(
            "start trial ends at t={timestamp}: normalised innovations {own:.2} (eight-point) \
             against {searched:.2} (searched); keeping the {}",
            if replace { "searched" } else { "eight-point" }
        );
        if replace {
            *self = *trial.rival;
            // The rival's placing of the frames before the seat, then the trial's frames.
            self.revised.extend(trial.reports);
            return Ok(FrameReport { timings, ..theirs });
        }
        Ok(FrameReport { timings, ..ours })
    }

    /// Adds this frame's mean normalised innovation over `matches` (before the update) to
    /// the trial's total, when a trial runs. Each distance² is capped at twice the rescue
    /// gate, so a few gross mismatches do not decide.
    pub(super) fn add_trial_innovation(&mut self, matches: &[Observation]) {
        let Some(total) = self.trial_innovation else {
            return;
        };
        if matches.is_empty() {
            return;
        }
        let cap = 2.0 * self.config.ransac.rescue_gate;
        let sum: f64 = matches
            .iter()
            .map(|obs| {
                let s = self.filter.innovation_covariance(obs.slot, &obs.prediction);
                let nu = obs.pixel - obs.prediction.pixel;
                s.try_inverse()
                    .map_or(cap, |inverse| nu.dot(&(inverse * nu)).min(cap))
            })
            .sum();
        self.trial_innovation = Some(total + sum / matches.len() as f64);
    }
}
