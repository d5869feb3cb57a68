//! The SLAM loop for one frame: predict (eqs 15–16), search every visible landmark inside its
//! gated ellipse (eqs 25–27), 1-point RANSAC, update (eqs 22–24), rescue the high-innovation
//! inliers, then manage the map — convert linear landmarks to Euclidean, delete the ones that
//! keep failing, and create new inverse-depth landmarks (eq 13) from steernav keypoints in
//! image cells without tracked features.
//!
//! The rooms: `start` (the two-view start and the start at rest, as a `Phase`), `trial` (the
//! start's second hypothesis, run beside the first for a few frames), `search` (the
//! active search of one landmark), `update` (RANSAC, the update, the rescue, the template
//! refresh), `map` (creation, conversion, deletion, the map output) and `report` (what each
//! frame reports). This file is the per-frame orchestration.

mod keyframes;
mod map;
mod report;
mod search;
mod start;
mod trial;
mod turning;
mod update;

use std::time::Instant;

use nalgebra::Vector3;

use self::map::Track;
pub use self::report::{FrameReport, MapPoint, SlamTimings};
use self::search::LandmarkSearch;
use self::start::Phase;
use self::trial::Trial;
use super::camera::PinholeCamera;
use super::config::SlamConfig;
use super::ekf::{Filter, Observation};
use super::klt::Pyramid;
use super::motion::{MotionModel, OdometryStep};
use super::refine::Window;
use super::rotation::Quat;
use crate::error::{Error, Result};
use crate::features::Detector;
use crate::image::Frame;
use crate::rng::Rng;

/// A monocular EKF SLAM session.
#[derive(Clone, Debug)]
pub struct Slam {
    config: SlamConfig,
    filter: Filter,
    /// One per filter slot, in slot order.
    tracks: Vec<Track>,
    frame_index: usize,
    last_time: Option<f64>,
    lost_streak: usize,
    rng: Rng,
    /// Frame index before which detection is skipped (the last one found no free cell).
    detect_after: usize,
    /// The previous frame's pyramid, the source of the KLT tracks.
    previous: Option<Pyramid>,
    /// The camera pose estimated at the previous frame, for the two-frame depth of new
    /// landmarks.
    previous_pose: Option<(Vector3<f64>, Quat)>,
    phase: Phase,
    /// The keyframes of the local bundle adjustment.
    window: Window,
    /// The start's second hypothesis while both are tried.
    trial: Option<Box<Trial>>,
    /// While a trial runs: the normalised innovations of this hypothesis's matches so far.
    trial_innovation: Option<f64>,
    /// Reports of earlier frames revised since the caller last took them.
    revised: Vec<FrameReport>,
}

impl Slam {
    /// Starts a session at the origin of the world frame.
    pub fn new(camera: PinholeCamera, config: SlamConfig) -> Result<Self> {
        camera.validate()?;
        config.validate()?;
        // Odometry gives the motion and its scale from the first frame; only the
        // constant-velocity model has to learn them from two views.
        let phase = match config.motion {
            MotionModel::Odometry { .. } => Phase::Tracking,
            MotionModel::ConstantVelocity { .. } | MotionModel::Wheeled(_) => Phase::Starting(None),
        };
        let filter = Filter::new(
            camera,
            config.motion.clone(),
            config.filter.pixel_sigma,
            config.filter.velocity_sigma,
            config.filter.angular_velocity_sigma,
        );
        Ok(Self {
            config,
            filter,
            tracks: Vec::new(),
            frame_index: 0,
            last_time: None,
            lost_streak: 0,
            rng: Rng(0x5EED),
            detect_after: 0,
            previous: None,
            previous_pose: None,
            phase,
            window: Window::default(),
            trial: None,
            trial_innovation: None,
            revised: Vec::new(),
        })
    }

    /// The filter (state, covariance, landmarks), read only.
    pub fn filter(&self) -> &Filter {
        &self.filter
    }

    /// Camera position.
    pub fn position(&self) -> Vector3<f64> {
        self.filter.position()
    }

    /// Camera orientation.
    pub fn orientation(&self) -> Quat {
        self.filter.orientation()
    }

    /// Reports of earlier frames that the session has revised since the last call, oldest
    /// first; empty on most frames. Two moments revise: when the start seats, the frames it
    /// reported while it waited for two views get their resected poses; and the start can
    /// try two motions side by side for a few frames (`[slam.start] two_view_search`),
    /// reporting one; when the other wins, the frames of the trial are reported again with
    /// its poses. A caller that keeps a trajectory replaces those frames (same timestamps).
    pub fn take_revised(&mut self) -> Vec<FrameReport> {
        std::mem::take(&mut self.revised)
    }

    /// Processes one frame taken at `timestamp` seconds (strictly increasing).
    pub fn process(
        &mut self,
        frame: &Frame,
        timestamp: f64,
        odometry: Option<&OdometryStep>,
        detector: &Detector,
    ) -> Result<FrameReport> {
        match self.trial.take() {
            Some(trial) => self.process_in_trial(trial, frame, timestamp, odometry, detector),
            None => self.process_frame(frame, timestamp, odometry, detector),
        }
    }

    /// One frame of one hypothesis.
    fn process_frame(
        &mut self,
        frame: &Frame,
        timestamp: f64,
        odometry: Option<&OdometryStep>,
        detector: &Detector,
    ) -> Result<FrameReport> {
        let start = Instant::now();
        self.predict_to(frame, timestamp, odometry)?;
        let mut timings = SlamTimings {
            filter_ms: ms(start),
            ..Default::default()
        };
        let t_assoc = Instant::now();
        let (width, height) = (frame.width as usize, frame.height as usize);
        let pyramid = Pyramid::new(&frame.gray, width, height, self.config.klt.levels);
        let previous = self.previous.take();
        match self.phase {
            Phase::Starting(_) => {
                let report = self.initialise(
                    frame,
                    timestamp,
                    detector,
                    previous.as_ref(),
                    &pyramid,
                    start,
                );
                self.end_seat_frame(&pyramid, timestamp);
                self.end_frame(pyramid);
                return report;
            }
            Phase::AtRest(_) => {
                if let Some(created) =
                    self.follow_rest_start(frame, timestamp, previous.as_ref(), &pyramid)
                {
                    self.end_seat_frame(&pyramid, timestamp);
                    self.end_frame(pyramid);
                    timings.association_ms = ms(t_assoc);
                    timings.total_ms = ms(start);
                    return Ok(self.report(timestamp, timings, created, false));
                }
            }
            Phase::Tracking => {}
        }

        let searched = self.search_landmarks(frame, previous.as_ref(), &pyramid);
        self.continue_tracks(&searched);
        let candidates: Vec<Observation> = searched
            .iter()
            .filter_map(|s| s.observation.clone())
            .collect();
        if self.lost_streak >= self.config.search.lost_after && !candidates.is_empty() {
            // Relocalising: the blind prediction correlated the camera with the map through
            // a motion that did not happen. Re-measure the pose against the map as it stands
            // instead of letting the correction drag the map along.
            self.filter.decorrelate_camera();
        }
        self.add_trial_innovation(&candidates);
        let inlier_flags = self.one_point_ransac(&candidates);
        timings.association_ms = ms(t_assoc);

        let t_filter = Instant::now();
        let outcome = self.update_with(frame, timestamp, &candidates, &inlier_flags);
        // The wheeled model's step constraint, on the pose the measurements have moved.
        self.filter.close_step();
        self.filter.constrain_ground();
        let (lost, relocalised) = self.judge_tracking(&searched, outcome.supported.len());
        // By landmark id: deletion below moves the slots.
        let measured: Vec<(u64, nalgebra::Vector2<f64>)> = candidates
            .iter()
            .filter(|c| outcome.supported.contains(&c.slot))
            .map(|c| (self.filter.slots()[c.slot].id, c.pixel))
            .collect();
        let converted = self.convert_linear_landmarks();
        let deleted = self.delete_bad_landmarks();
        timings.filter_ms += ms(t_filter);

        // New landmarks where the image has no tracked feature.
        let views = previous.as_ref().map(|from| (from, &pyramid));
        let (created, detection_ms, creation_ms) = self.create_landmarks(frame, detector, views)?;
        timings.detection_ms = detection_ms;
        timings.filter_ms += creation_ms;
        if !lost && matches!(self.phase, Phase::Tracking) {
            let t_refine = Instant::now();
            let first_new = self.filter.slots().len() - created;
            self.refine_keyframes(&measured, first_new);
            timings.filter_ms += ms(t_refine);
        }
        self.end_frame(pyramid);
        timings.total_ms = ms(start);
        Ok(FrameReport {
            predicted: searched.len(),
            matched: candidates.len(),
            descriptor_rejected: searched.iter().filter(|s| s.descriptor_rejected).count(),
            inliers: outcome.inliers,
            rescued: outcome.rescued,
            deleted,
            converted,
            lost,
            relocalised,
            update_rejected: outcome.rejected,
            ..self.report(timestamp, timings, created, false)
        })
    }

    /// Checks the frame against the calibration and the timestamp against the previous one,
    /// then predicts the filter to `timestamp` (once it has started).
    fn predict_to(
        &mut self,
        frame: &Frame,
        timestamp: f64,
        odometry: Option<&OdometryStep>,
    ) -> Result<()> {
        let cam = self.filter.camera();
        if frame.width != cam.width || frame.height != cam.height {
            return Err(Error::ImageSize {
                input: format!("frame at t={timestamp}"),
                width: frame.width,
                height: frame.height,
                reason: format!("the calibration is for {}x{}", cam.width, cam.height),
            });
        }
        if !timestamp.is_finite() {
            return Err(Error::input(
                format!("timestamp {timestamp}"),
                "must be finite",
            ));
        }
        if let Some(prev) = self.last_time {
            let dt = timestamp - prev;
            if dt <= 0.0 {
                return Err(Error::input(
                    format!("timestamp {timestamp}"),
                    format!("must increase (previous frame at {prev})"),
                ));
            }
            if !matches!(self.phase, Phase::Starting(_)) {
                self.filter.predict(dt, odometry);
            }
        }
        self.last_time = Some(timestamp);
        Ok(())
    }

    /// A KLT track continues whether or not its landmark is used this frame: rejection is
    /// often the landmark's estimate being wrong, not the pixel, and deletion (by match
    /// ratio) retires landmarks that keep failing.
    fn continue_tracks(&mut self, searched: &[LandmarkSearch]) {
        for track in &mut self.tracks {
            track.last_pixel = None;
        }
        for s in searched {
            self.tracks[s.slot].last_pixel = s.tracked;
        }
    }

    /// Whether tracking is lost this frame, and whether it was just found again.
    ///
    /// Tracking lost is reported and the map kept. The filter goes on predicting, its
    /// covariance (and so every search region) grows, and the search cap widens with the
    /// streak, until the old landmarks are found again: relocalisation against the map,
    /// with the trajectory continuous. Frames without support are not held against the
    /// landmarks (a blank or blurred frame says nothing about them).
    fn judge_tracking(&mut self, searched: &[LandmarkSearch], supported: usize) -> (bool, bool) {
        let lost = !searched.is_empty() && supported < 3
            || self.filter.slots().is_empty() && self.frame_index > 0;
        let relocalised = !lost && self.lost_streak >= self.config.search.lost_after;
        self.lost_streak = if lost { self.lost_streak + 1 } else { 0 };
        if !lost {
            for s in searched {
                self.tracks[s.slot].predicted += 1;
            }
        }
        (lost, relocalised)
    }

    /// Keeps this frame's pyramid and pose as the next frame's previous ones.
    fn end_frame(&mut self, pyramid: Pyramid) {
        self.previous = Some(pyramid);
        self.previous_pose = Some((self.filter.position(), self.filter.orientation()));
        self.frame_index += 1;
    }

    /// A frame report with the filter's current pose and landmark counts; the association
    /// counts are zero (the caller fills them in when there was an association).
    fn report(
        &self,
        timestamp: f64,
        timings: SlamTimings,
        created: usize,
        initialising: bool,
    ) -> FrameReport {
        let cov = self.filter.position_covariance();
        let qn = self.filter.orientation();
        let p = self.filter.position();
        FrameReport {
            timestamp,
            position: [p.x, p.y, p.z],
            orientation: [qn[0], qn[1], qn[2], qn[3]],
            position_covariance: [
                [cov[(0, 0)], cov[(0, 1)], cov[(0, 2)]],
                [cov[(1, 0)], cov[(1, 1)], cov[(1, 2)]],
                [cov[(2, 0)], cov[(2, 1)], cov[(2, 2)]],
            ],
            predicted: 0,
            matched: 0,
            descriptor_rejected: 0,
            inliers: 0,
            rescued: 0,
            created,
            deleted: 0,
            converted: 0,
            landmarks: self.filter.slots().len(),
            state_dim: self.filter.dim(),
            lost: false,
            relocalised: false,
            initialising,
            update_rejected: false,
            timings,
        }
    }
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}
