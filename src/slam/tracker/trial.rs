//! The start's second hypothesis. Not an equation of the paper (its filter starts at rest).
//!
//! Two views alone do not always tell a sideways walk that turns from a forward motion with
//! a little more turn (the bas-relief ambiguity): the eight-point direction leans towards the
//! optical axis, and the Sampson cost can score a wrong basin lower (docs/SLAM.md, "Hand-held
//! starts"). The frames that follow tell them apart. So when the multi-start search lands on
//! another motion, the session is seated on both and runs both, side by side, for
//! `[slam.start] trial_frames` frames, reporting the eight-point hypothesis (with the time of
//! both). Two witnesses decide at the trial's end:
//!
//! 1. **The whole baseline.** The start's points keep being followed by KLT from its
//!    reference frame through the trial (until fewer than `[slam.start] min_points` are
//!    left). Each hypothesis's motion from the reference frame to that last frame, now
//!    several times the two views' baseline, is scored by MSAC on them (Sampson distances
//!    truncated at the RANSAC threshold): the motion whose epipolar geometry explains the
//!    points is the right one. A score below [`REPLACE_BELOW`] of the other's decides.
//! 2. **The innovations**, when the scores are close: each frame adds the mean normalised
//!    innovation of a hypothesis's matches (eq 26's Mahalanobis distance against its own S),
//!    and the searched motion replaces the eight-point one when its total is below
//!    [`REPLACE_BELOW`] of the eight-point's.
//!
//! The eight-point motion is right for the forward starts of vehicles, where both witnesses
//! come out alike. Measured in docs/SLAM.md, "The start's trial" and "The whole baseline".

use std::time::Instant;

use nalgebra::{Vector2, Vector3};
use rayon::prelude::*;

use super::report::{FrameReport, SlamTimings};
use super::start::{normalised_pairs, Bootstrap};
use super::{ms, Slam};
use crate::error::Result;
use crate::features::Detector;
use crate::image::Frame;
use crate::slam::ekf::Observation;
use crate::slam::klt::{self, KltParams, Pyramid};
use crate::slam::motion::OdometryStep;
use crate::slam::rotation::{self, Quat};
use crate::slam::two_view_refine::msac_score;

/// A hypothesis wins when its score (MSAC over the whole baseline, or else its normalised
/// innovations) is below this fraction of the other's.
const REPLACE_BELOW: f64 = 0.85;

/// Points in the start's reference frame and where KLT has followed them to.
type Followed = (Vec<Vector2<f64>>, Vec<Vector2<f64>>);

/// A session seated on the searched two-view motion, run beside this one.
#[derive(Clone, Debug)]
pub(super) struct Trial {
    rival: Box<Slam>,
    frames_left: usize,
    /// The rival's reports of the trial's frames, from the one it seated on.
    reports: Vec<FrameReport>,
    /// The start's points in its reference frame and where KLT has followed them through the
    /// trial: a baseline of the whole trial at its end.
    reference: Vec<Vector2<f64>>,
    followed: Vec<Vector2<f64>>,
    /// The camera's pose at the start's reference frame (both hypotheses share it).
    reference_pose: (Vector3<f64>, Quat),
    /// Each hypothesis's pose (eight-point, searched) at the frame of `followed`; `None`
    /// before the first trial frame. Following stops at the frame that would leave fewer
    /// than `[slam.start] min_points`.
    followed_poses: Option<[(Vector3<f64>, Quat); 2]>,
    /// Whether the points are still followed (false once too few were left).
    following: bool,
}

impl Trial {
    /// The start's points followed from `from` into `to` by KLT: those kept, with their
    /// pixels in the reference frame.
    fn follow(&self, from: &Pyramid, to: &Pyramid, params: &KltParams) -> Followed {
        let moved: Vec<Option<Vector2<f64>>> = self
            .followed
            .par_iter()
            .map(|&z| klt::track(from, to, z, z, params))
            .collect();
        self.reference
            .iter()
            .zip(moved)
            .filter_map(|(&a, m)| m.map(|z| (a, z)))
            .unzip()
    }

    /// Keeps `followed` and the hypotheses' `poses` at its frame; stops following for good,
    /// keeping the last frame's, when fewer than `min_points` are left.
    fn keep(&mut self, followed: Followed, min_points: usize, poses: [(Vector3<f64>, Quat); 2]) {
        if followed.1.len() < min_points {
            self.following = false;
            return;
        }
        (self.reference, self.followed) = followed;
        self.followed_poses = Some(poses);
    }
}

impl Slam {
    /// Runs `rival` (seated on the searched motion) beside this session from the next frame.
    pub(super) fn start_trial(&mut self, mut rival: Slam, start: &Bootstrap) {
        self.trial_innovation = Some(0.0);
        rival.trial_innovation = Some(0.0);
        self.trial = Some(Box::new(Trial {
            rival: Box::new(rival),
            frames_left: self.config.start.trial_frames,
            reports: Vec::new(),
            reference: start.start.clone(),
            followed: start.current.clone(),
            reference_pose: (start.position, start.orientation),
            followed_poses: None,
            following: true,
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
        // The start's points, followed while enough are left: the rival still holds the
        // previous frame's pyramid, this session now this frame's.
        let t_follow = Instant::now();
        let followed = match (&trial.rival.previous, &self.previous) {
            (Some(from), Some(to)) if trial.following => {
                Some(trial.follow(from, to, &self.config.klt))
            }
            _ => None,
        };
        let follow_ms = ms(t_follow);
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
        let mut timings = SlamTimings {
            detection_ms: ours.timings.detection_ms + theirs.timings.detection_ms,
            association_ms: ours.timings.association_ms + theirs.timings.association_ms,
            filter_ms: ours.timings.filter_ms + theirs.timings.filter_ms,
            total_ms: ours.timings.total_ms + theirs.timings.total_ms,
        };
        if let Some(followed) = followed {
            let poses = [
                (self.filter.position(), self.filter.orientation()),
                (
                    trial.rival.filter.position(),
                    trial.rival.filter.orientation(),
                ),
            ];
            trial.keep(followed, self.config.start.min_points, poses);
            timings.association_ms += follow_ms;
            timings.total_ms += follow_ms;
        }
        trial.frames_left -= 1;
        if trial.frames_left > 0 {
            trial.reports.push(theirs);
            self.trial = Some(trial);
            return Ok(FrameReport { timings, ..ours });
        }
        let own = self.trial_innovation.take().unwrap_or(f64::INFINITY);
        let searched = trial.rival.trial_innovation.take().unwrap_or(f64::INFINITY);
        let replace = self
            .wide_baseline_choice(&trial)
            .unwrap_or(searched < REPLACE_BELOW * own);
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

    /// The hypothesis the trial's whole baseline prefers, when it prefers one clearly: each
    /// one's motion from the start's reference frame to the last frame the start's points
    /// were followed to, scored by MSAC on those points (squared Sampson distances truncated
    /// at the RANSAC threshold). `Some(true)` when the searched motion scores below
    /// [`REPLACE_BELOW`] of the eight-point one's, `Some(false)` when the eight-point one
    /// scores below that fraction of the searched one's, `None` otherwise (or when no frame
    /// kept `[slam.start] min_points` of them, or a hypothesis did not move).
    fn wide_baseline_choice(&self, trial: &Trial) -> Option<bool> {
        let [eight_point, searched] = trial.followed_poses?;
        let cam = self.filter.camera();
        let pairs = normalised_pairs(cam, &trial.reference, &trial.followed);
        let threshold = self.config.ransac.threshold / cam.fx.max(cam.fy);
        let (r0, q0) = trial.reference_pose;
        let rot0 = rotation::matrix(&q0);
        // X₁ = R·X₀ + t from the reference camera to the hypothesis's camera.
        let score = |(r1, q1): (Vector3<f64>, Quat)| {
            let rot1 = rotation::matrix(&q1);
            let t = rot1.transpose() * (r0 - r1);
            let n = t.norm();
            (n > 1e-12).then(|| msac_score(&pairs, &(rot1.transpose() * rot0), &(t / n), threshold))
        };
        let (ours, theirs) = (score(eight_point)?, score(searched)?);
        let choice = if theirs < REPLACE_BELOW * ours {
            Some(true)
        } else if ours < REPLACE_BELOW * theirs {
            Some(false)
        } else {
            None
        };
        log::info!(
            "start trial, whole baseline ({} points followed): MSAC {ours:.3e} (eight-point) \
             against {theirs:.3e} (searched){}",
            pairs.len(),
            if choice.is_none() {
                ", no clear choice"
            } else {
                ""
            }
        );
        choice
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
