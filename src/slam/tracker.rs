//! The SLAM loop for one frame: predict (eqs 15–16), search every visible landmark inside its
//! gated ellipse (eqs 25–27), 1-point RANSAC, update (eqs 22–24), rescue the high-innovation
//! inliers, then manage the map — convert linear landmarks to Euclidean, delete the ones that
//! keep failing, and create new inverse-depth landmarks (eq 13) from steernav keypoints in
//! image cells without tracked features.

use std::time::Instant;

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use rayon::prelude::*;
use serde::Serialize;

use super::association::{self, Template};
use super::camera::PinholeCamera;
use super::config::SlamConfig;
use super::ekf::{Filter, Observation};
use super::inverse_depth::{self, Parametrisation};
use super::klt::{self, KltParams, Pyramid};
use super::motion::OdometryStep;
use super::rotation::{self, Quat};
use super::two_view;
use crate::error::{Error, Result};
use crate::features::Detector;
use crate::image::Frame;
use crate::rng::Rng;

/// Wall-clock split of one frame, milliseconds.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct SlamTimings {
    /// Keypoint detection (only on frames that need new landmarks).
    pub detection_ms: f64,
    /// Prediction of every landmark, active search, descriptor check and RANSAC.
    pub association_ms: f64,
    /// EKF prediction, updates and map management.
    pub filter_ms: f64,
    /// The whole frame.
    pub total_ms: f64,
}

/// What happened in one frame.
#[derive(Clone, Debug, Serialize)]
pub struct FrameReport {
    /// Timestamp, seconds.
    pub timestamp: f64,
    /// Camera position after the update.
    pub position: [f64; 3],
    /// Camera orientation (w, x, y, z), camera → world.
    pub orientation: [f64; 4],
    /// Covariance of the position.
    pub position_covariance: [[f64; 3]; 3],
    /// Landmarks predicted inside the image.
    pub predicted: usize,
    /// Matches found by the active search (before RANSAC).
    pub matched: usize,
    /// Matches dropped by the descriptor check.
    pub descriptor_rejected: usize,
    /// Low-innovation inliers of 1-point RANSAC.
    pub inliers: usize,
    /// High-innovation inliers rescued by the χ² gate.
    pub rescued: usize,
    /// Landmarks created.
    pub created: usize,
    /// Landmarks deleted.
    pub deleted: usize,
    /// Landmarks converted to Euclidean.
    pub converted: usize,
    /// Landmarks in the state after the frame.
    pub landmarks: usize,
    /// State dimension after the frame.
    pub state_dim: usize,
    /// Fewer than 3 landmarks supported the pose this frame.
    pub lost: bool,
    /// Tracking resumed here against the existing map after being lost for at least
    /// `lost_after` frames.
    pub relocalised: bool,
    /// The filter is waiting for enough parallax to start (the pose is the start pose).
    pub initialising: bool,
    /// Timings.
    pub timings: SlamTimings,
}

#[derive(Clone, Debug)]
struct Track {
    template: Template,
    predicted: usize,
    matched: usize,
    last_seen: usize,
    /// Where it was measured in the previous frame, when it was: the start of its KLT track.
    last_pixel: Option<Vector2<f64>>,
}

/// A monocular EKF SLAM session.
pub struct Slam {
    config: SlamConfig,
    filter: Filter,
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
    /// Points followed from a reference frame until the two views fix the motion.
    bootstrap: Option<Bootstrap>,
    /// The filter holds a map seated from two views (false until the first bootstrap).
    started: bool,
}

/// Points followed by KLT from a reference frame, for the two-view start.
#[derive(Clone, Debug)]
struct Bootstrap {
    /// Timestamp of the reference frame.
    timestamp: f64,
    /// Camera pose at the reference frame.
    position: Vector3<f64>,
    orientation: Quat,
    /// Pixels in the reference frame and where KLT has followed them to.
    start: Vec<Vector2<f64>>,
    current: Vec<Vector2<f64>>,
}

impl Slam {
    /// Starts a session at the origin of the world frame.
    pub fn new(camera: PinholeCamera, config: SlamConfig) -> Result<Self> {
        camera.validate()?;
        config.validate()?;
        // Odometry gives the motion and its scale from the first frame; only the
        // constant-velocity model has to learn them from two views.
        let started = matches!(config.motion, super::motion::MotionModel::Odometry { .. });
        let filter = Filter::new(
            camera,
            config.motion.clone(),
            config.pixel_sigma,
            config.velocity_sigma,
            config.angular_velocity_sigma,
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
            bootstrap: None,
            started,
        })
    }

    /// The filter (state, covariance, landmarks).
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

    /// Processes one frame taken at `timestamp` seconds (strictly increasing).
    pub fn process(
        &mut self,
        frame: &Frame,
        timestamp: f64,
        odometry: Option<&OdometryStep>,
        detector: &Detector,
    ) -> Result<FrameReport> {
        let start = Instant::now();
        let cam = self.filter.camera.clone();
        if frame.width != cam.width || frame.height != cam.height {
            return Err(Error::ImageSize {
                input: format!("frame at t={timestamp}"),
                width: frame.width,
                height: frame.height,
                reason: format!("the calibration is for {}x{}", cam.width, cam.height),
            });
        }
        if !timestamp.is_finite() {
            return Err(Error::config("timestamp", timestamp, "must be finite"));
        }
        if let Some(prev) = self.last_time {
            let dt = timestamp - prev;
            if dt <= 0.0 {
                return Err(Error::config(
                    "timestamp",
                    timestamp,
                    format!("must increase (previous frame at {prev})"),
                ));
            }
            if self.started {
                self.filter.predict(dt, odometry);
            }
        }
        self.last_time = Some(timestamp);
        let mut timings = SlamTimings {
            filter_ms: ms(start),
            ..Default::default()
        };

        // Active search, in parallel over landmarks.
        let t_assoc = Instant::now();
        let pyramid = Pyramid::new(
            &frame.gray,
            frame.width as usize,
            frame.height as usize,
            KltParams::default().levels,
        );
        let previous = self.previous.take();
        let lost_streak = self.lost_streak;
        if !self.started {
            let report = self.initialise(
                frame,
                timestamp,
                detector,
                previous.as_ref(),
                &pyramid,
                start,
            );
            self.end_frame(pyramid);
            return report;
        }
        if self.bootstrap.is_some() {
            let t = Instant::now();
            if let Some(created) =
                self.follow_rest_start(frame, timestamp, previous.as_ref(), &pyramid)
            {
                self.end_frame(pyramid);
                let timings = SlamTimings {
                    association_ms: ms(t),
                    total_ms: ms(start),
                    ..timings
                };
                return Ok(self.report(timestamp, timings, created, false));
            }
        }
        let half = self.config.template_half;
        let (r, q) = (self.filter.position(), self.filter.orientation());
        let filter = &self.filter;
        let tracks = &self.tracks;
        let config = &self.config;
        let searched: Vec<Searched> = (0..filter.slots.len())
            .into_par_iter()
            .filter_map(|slot| {
                let prediction = filter.predict_observation(slot)?;
                if !cam.contains(&prediction.pixel, (half + 1) as f64) {
                    return None;
                }
                let s = filter.innovation_covariance(slot, &prediction);
                let template = &tracks[slot].template;
                let warp = filter
                    .landmark_point(slot)
                    .and_then(|point| template.view_warp(&cam, &point, &r, &q));
                let Some(t) = association::normalised(&template.warped(warp, half)) else {
                    return Some((slot, None, false, None));
                };
                // Seen in the previous frame: follow it with KLT, then let the template
                // confirm (and anchor, against drift) the tracked pixel.
                let tracked =
                    previous
                        .as_ref()
                        .zip(tracks[slot].last_pixel)
                        .and_then(|(from, last)| {
                            let guess = if cam.contains(&prediction.pixel, 0.0) {
                                prediction.pixel
                            } else {
                                last
                            };
                            klt::track(from, &pyramid, last, guess, &KltParams::default())
                        });
                let region = match tracked {
                    Some(z) => association::SearchRegion {
                        predicted: z,
                        covariance: Matrix2::identity() * 0.5,
                        gate: config.search_gate,
                        max_extent: 2.0,
                    },
                    None => association::SearchRegion {
                        predicted: prediction.pixel,
                        covariance: s,
                        gate: config.search_gate,
                        max_extent: config.max_search_extent * (1 + lost_streak.min(4)) as f64,
                    },
                };
                let found = association::search(
                    &frame.gray,
                    frame.width as usize,
                    frame.height as usize,
                    &t,
                    half,
                    &region,
                );
                let threshold = if tracked.is_some() {
                    config.min_tracked_correlation
                } else {
                    config.min_correlation
                };
                let found = found.map(|best| {
                    if best.1 >= threshold {
                        best
                    } else {
                        association::rescore_at_scales(
                            frame,
                            template,
                            warp,
                            half,
                            &config.template_scales,
                            best,
                        )
                    }
                });
                match found {
                    Some((z, score)) if score >= threshold => {
                        let d =
                            crate::features::descriptor::describe(frame, z.x as f32, z.y as f32);
                        if association::descriptor_distance(&d, &template.descriptor)
                            > config.descriptor_tolerance
                        {
                            return Some((slot, None, true, tracked));
                        }
                        // A tracked landmark is measured where KLT put it: the template
                        // only confirms the pixel. Its correlation peak sits off the true
                        // position wherever the warp misjudges the view (oblique surfaces,
                        // young depths), while the frame-to-frame track is sub-pixel.
                        Some((
                            slot,
                            Some(Observation {
                                slot,
                                pixel: tracked.unwrap_or(z),
                                prediction,
                            }),
                            false,
                            tracked,
                        ))
                    }
                    _ => Some((slot, None, false, tracked)),
                }
            })
            .collect();
        let predicted = searched.len();
        let searched_slots: Vec<usize> = searched.iter().map(|s| s.0).collect();
        let descriptor_rejected = searched.iter().filter(|s| s.2).count();
        // A KLT track continues whether or not its landmark is used this frame: rejection is
        // often the landmark's estimate being wrong, not the pixel, and deletion (by match
        // ratio) retires landmarks that keep failing.
        for track in &mut self.tracks {
            track.last_pixel = None;
        }
        for s in &searched {
            self.tracks[s.0].last_pixel = s.3;
        }
        let candidates: Vec<Observation> = searched.into_iter().filter_map(|s| s.1).collect();
        if self.lost_streak >= self.config.lost_after && !candidates.is_empty() {
            // Relocalising: the blind prediction correlated the camera with the map through
            // a motion that did not happen. Re-measure the pose against the map as it stands
            // instead of letting the correction drag the map along.
            self.decorrelate_camera();
        }
        let inlier_flags = self.one_point_ransac(&candidates);
        timings.association_ms = ms(t_assoc);

        // Update with the low-innovation inliers, then rescue the rest through the χ² gate.
        let t_filter = Instant::now();
        let inliers: Vec<Observation> = candidates
            .iter()
            .zip(&inlier_flags)
            .filter(|(_, &ok)| ok)
            .map(|(o, _)| o.clone())
            .collect();
        let mut supported: Vec<usize> = inliers.iter().map(|o| o.slot).collect();
        let mut inlier_count = inliers.len();
        if self.filter.update(&inliers).is_err() {
            inlier_count = 0;
            supported.clear();
        }
        let mut rescued = Vec::new();
        for (obs, _) in candidates.iter().zip(&inlier_flags).filter(|(_, &ok)| !ok) {
            let Some(prediction) = self.filter.predict_observation(obs.slot) else {
                continue;
            };
            let s = self.filter.innovation_covariance(obs.slot, &prediction);
            let nu = obs.pixel - prediction.pixel;
            let d2 = s
                .try_inverse()
                .map_or(f64::INFINITY, |si| nu.dot(&(si * nu)));
            if d2 < self.config.rescue_gate {
                rescued.push(Observation {
                    slot: obs.slot,
                    pixel: obs.pixel,
                    prediction,
                });
            }
        }
        if !rescued.is_empty() && self.filter.update(&rescued).is_ok() {
            supported.extend(rescued.iter().map(|o| o.slot));
        } else {
            rescued.clear();
        }
        let (r, q) = (self.filter.position(), self.filter.orientation());
        for obs in inliers.iter().chain(&rescued) {
            if !supported.contains(&obs.slot) {
                continue;
            }
            self.tracks[obs.slot].last_pixel = Some(obs.pixel);
            // Refresh the template once the view has moved far from where it was cut: the
            // warp through a plane facing the first camera fails on the oblique walls and
            // roads of forward motion. Only pixels the update accepted refresh it.
            let Some(point) = self.filter.landmark_point(obs.slot) else {
                continue;
            };
            let template = &self.tracks[obs.slot].template;
            let depth = (point - r).norm();
            if depth > 1e-9 && (r - template.position).norm() > self.config.template_refresh * depth
            {
                let radius = template.radius;
                let fresh = Template::capture(frame, obs.pixel, radius, r, q);
                if association::normalised(&fresh.patch).is_some() {
                    self.tracks[obs.slot].template = fresh;
                }
            }
        }
        for &slot in &supported {
            self.tracks[slot].matched += 1;
            self.tracks[slot].last_seen = self.frame_index;
        }

        // Tracking lost: report it and keep the map. The filter goes on predicting, its
        // covariance (and so every search region) grows, and the search cap widens with the
        // streak, until the old landmarks are found again: relocalisation against the map,
        // with the trajectory continuous. Frames without support are not held against the
        // landmarks (a blank or blurred frame says nothing about them).
        let lost = predicted > 0 && supported.len() < 3
            || self.filter.slots.is_empty() && self.frame_index > 0;
        let relocalised = !lost && self.lost_streak >= self.config.lost_after;
        self.lost_streak = if lost { self.lost_streak + 1 } else { 0 };
        if !lost {
            for s in &searched_slots {
                self.tracks[*s].predicted += 1;
            }
        }
        let mut deleted = 0;

        let converted = self.convert_linear_landmarks();
        deleted += self.delete_bad_landmarks();
        timings.filter_ms += ms(t_filter);

        // New landmarks where the image has no tracked feature.
        let views = previous.as_ref().map(|from| (from, &pyramid));
        let (created, detection_ms, creation_ms) = self.create_landmarks(frame, detector, views)?;
        timings.detection_ms = detection_ms;
        timings.filter_ms += creation_ms;
        self.end_frame(pyramid);
        timings.total_ms = ms(start);
        Ok(FrameReport {
            predicted,
            matched: candidates.len(),
            descriptor_rejected,
            inliers: inlier_count,
            rescued: rescued.len(),
            deleted,
            converted,
            lost,
            relocalised,
            ..self.report(timestamp, timings, created, false)
        })
    }

    /// Start-up: follows keypoints from a reference frame until the two views determine the
    /// motion, then seats the filter there — pose, velocity, angular velocity, and landmarks
    /// at their triangulated depths.
    fn initialise(
        &mut self,
        frame: &Frame,
        timestamp: f64,
        detector: &Detector,
        previous: Option<&Pyramid>,
        pyramid: &Pyramid,
        start: Instant,
    ) -> Result<FrameReport> {
        let mut timings = SlamTimings::default();
        let mut created = 0;
        let t = Instant::now();
        let (followed, _) = self.follow_bootstrap(previous, pyramid);
        timings.association_ms = ms(t);
        if followed >= MIN_BOOTSTRAP_POINTS {
            let t = Instant::now();
            created = self.try_seat(frame, timestamp);
            timings.filter_ms = ms(t);
        }
        let waited = self
            .bootstrap
            .as_ref()
            .map_or(0.0, |b| timestamp - b.timestamp);
        if !self.started && followed >= MIN_BOOTSTRAP_POINTS && waited >= STATIONARY_START_AFTER {
            // The points stay put: the camera is (nearly) at rest, which is the paper's own
            // start — the filter at rest, landmarks at the inverse-depth prior. The points
            // stay followed, to seat the filter again once it moves (`follow_rest_start`).
            self.started = true;
            let (n, detection_ms, creation_ms) = self.create_landmarks(frame, detector, None)?;
            created = n;
            timings.detection_ms = detection_ms;
            timings.filter_ms += creation_ms;
        }
        if !self.started && followed < MIN_BOOTSTRAP_POINTS {
            let t = Instant::now();
            self.restart_bootstrap(pyramid, timestamp);
            timings.detection_ms = ms(t);
        }
        timings.total_ms = ms(start);
        Ok(self.report(timestamp, timings, created, !self.started))
    }

    /// Starts the two-view reference at this frame: Shi–Tomasi corners of `pyramid`, at the
    /// filter's current pose.
    fn restart_bootstrap(&mut self, pyramid: &Pyramid, timestamp: f64) {
        let margin = KltParams::default().half_window + 2;
        let points = klt::good_features(pyramid, [16, 12], 2, margin);
        self.bootstrap = Some(Bootstrap {
            timestamp,
            position: self.filter.position(),
            orientation: self.filter.orientation(),
            start: points.clone(),
            current: points,
        });
    }

    /// Keeps this frame's pyramid and pose as the next frame's previous ones.
    fn end_frame(&mut self, pyramid: Pyramid) {
        self.previous = Some(pyramid);
        self.previous_pose = Some((self.filter.position(), self.filter.orientation()));
        self.frame_index += 1;
    }

    /// Follows the start-up points from `previous` into `current` by KLT, dropping those it
    /// loses. Returns how many are left and their median displacement in pixels.
    fn follow_bootstrap(&mut self, previous: Option<&Pyramid>, current: &Pyramid) -> (usize, f64) {
        let (Some(b), Some(from)) = (self.bootstrap.as_mut(), previous) else {
            return (0, 0.0);
        };
        let params = KltParams::default();
        let moved: Vec<Option<Vector2<f64>>> = b
            .current
            .par_iter()
            .map(|&z| klt::track(from, current, z, z, &params))
            .collect();
        let mut kept = 0;
        let mut displacements = Vec::with_capacity(moved.len());
        for (i, m) in moved.into_iter().enumerate() {
            if let Some(z) = m {
                displacements.push((z - b.current[i]).norm());
                b.start[kept] = b.start[i];
                b.current[kept] = z;
                kept += 1;
            }
        }
        b.start.truncate(kept);
        b.current.truncate(kept);
        displacements.sort_by(f64::total_cmp);
        (kept, displacements.get(kept / 2).copied().unwrap_or(0.0))
    }

    /// After a start at rest the map has bearings but no depths. The start-up points keep
    /// being followed from the last frame at rest; once the camera has moved enough for two
    /// views, the filter is seated again there as if it had started moving — the trajectory
    /// continues from the pose at rest, and the depthless map is replaced. Returns the
    /// landmarks created when it seated.
    fn follow_rest_start(
        &mut self,
        frame: &Frame,
        timestamp: f64,
        previous: Option<&Pyramid>,
        current: &Pyramid,
    ) -> Option<usize> {
        let (followed, median_step) = self.follow_bootstrap(previous, current);
        if followed < MIN_BOOTSTRAP_POINTS {
            self.restart_bootstrap(current, timestamp);
            return None;
        }
        let (r, q) = (self.filter.position(), self.filter.orientation());
        let b = self.bootstrap.as_mut()?;
        if median_step < REST_STEP_PIXELS {
            // Still at rest: the motion, when it comes, starts from here.
            b.start.clone_from(&b.current);
            b.timestamp = timestamp;
            b.position = r;
            b.orientation = q;
            return None;
        }
        let created = self.try_seat(frame, timestamp);
        (created > 0).then_some(created)
    }

    /// Tries the two-view estimate on the followed points; when it is well determined, seats
    /// the filter and returns the number of landmarks created.
    fn try_seat(&mut self, frame: &Frame, timestamp: f64) -> usize {
        let Some(b) = self.bootstrap.clone() else {
            return 0;
        };
        let cam = self.filter.camera.clone();
        let normalised = |z: &Vector2<f64>| {
            let (ray, _) = cam.back_project(*z);
            ray / ray.z
        };
        let pairs: Vec<(Vector3<f64>, Vector3<f64>)> = b
            .start
            .iter()
            .zip(&b.current)
            .map(|(a, c)| (normalised(a), normalised(c)))
            .collect();
        let threshold = self.config.ransac_threshold / cam.fx.max(cam.fy);
        let Some(pose) = two_view::relative_pose(&pairs, threshold, 2000, &mut self.rng) else {
            return 0;
        };
        let inlier_count = pose.inliers.iter().filter(|&&i| i).count();
        let mut parallax: Vec<f64> = pose
            .parallax
            .iter()
            .zip(&pose.inliers)
            .filter(|(_, &i)| i)
            .map(|(p, _)| *p)
            .collect();
        if inlier_count < MIN_BOOTSTRAP_POINTS || 2 * inlier_count < pairs.len() {
            return 0;
        }
        parallax.sort_by(f64::total_cmp);
        if parallax[3 * parallax.len() / 4] < MIN_BOOTSTRAP_PARALLAX {
            return 0;
        }
        let elapsed = (timestamp - b.timestamp).max(1e-9);
        let mut inverse_depths: Vec<f64> = pose
            .depths
            .iter()
            .zip(&pose.inliers)
            .filter(|(_, &i)| i)
            .map(|(d, _)| 1.0 / d)
            .collect();
        inverse_depths.sort_by(f64::total_cmp);
        let median_rho = inverse_depths[inverse_depths.len() / 2];
        // Map units per unit of two-view translation: the median landmark lands at the
        // inverse-depth prior ρ₀, as a landmark started from one view would.
        let scale = median_rho / self.config.initial_inverse_depth.max(1e-6);
        let rot0 = rotation::matrix(&b.orientation);
        // Camera 1 in camera 0's frame: centre −Rᵀt, orientation Rᵀ.
        let centre = -(pose.rotation.transpose() * pose.translation) * scale;
        let r = b.position + rot0 * centre;
        let q = rotation::multiply(
            &b.orientation,
            &rotation::from_matrix(&pose.rotation.transpose()),
        );
        let velocity = (r - b.position) / elapsed;
        let omega =
            rotation::to_rotation_vector(&rotation::from_matrix(&pose.rotation.transpose()))
                / elapsed;
        if self.started {
            // Re-seating after a start at rest: the old landmarks carry no depth.
            let all: Vec<usize> = (0..self.filter.slots.len()).collect();
            self.remove(&all);
        }
        let c = self.filter.motion.camera_dim();
        self.filter.x.as_mut_slice()[0..3].copy_from_slice(r.as_slice());
        self.filter.x.as_mut_slice()[3..7].copy_from_slice(q.as_slice());
        let n = self.filter.dim();
        // The old map's correlations with the camera no longer hold: the pose is re-measured.
        self.filter.p.view_mut((0, 0), (c, n)).fill(0.0);
        self.filter.p.view_mut((0, 0), (n, c)).fill(0.0);
        let baseline = (r - b.position).norm();
        for i in 0..3 {
            self.filter.p[(i, i)] = (0.05 * baseline).powi(2) + 1e-12;
        }
        for i in 3..7 {
            self.filter.p[(i, i)] = 1e-6;
        }
        if c == 13 {
            self.filter.x.as_mut_slice()[7..10].copy_from_slice(velocity.as_slice());
            self.filter.x.as_mut_slice()[10..13].copy_from_slice(omega.as_slice());
            for i in 7..10 {
                self.filter.p[(i, i)] =
                    (0.1 * velocity.norm()).powi(2) + self.config.velocity_sigma.powi(2);
                self.filter.p[(i + 3, i + 3)] = self.config.angular_velocity_sigma.powi(2);
            }
        }
        // Landmarks at the triangulated inliers, spread over the grid.
        let inliers: Vec<(Vector2<f64>, f64, f64)> = (0..pairs.len())
            .filter(|&i| pose.inliers[i])
            .map(|i| {
                let rho = 1.0 / (pose.depths[i] * scale);
                // Depth from parallax α with one pixel of noise: σ_ρ/ρ ≈ (σ/f)/α.
                let relative = (self.config.pixel_sigma / cam.fx) / pose.parallax[i].max(1e-6);
                let sigma = (rho * relative.max(0.1)).min(self.config.inverse_depth_sigma.max(rho));
                (b.current[i], rho, sigma)
            })
            .collect();
        self.bootstrap = None;
        self.started = true;
        let visible = self.visible_pixels();
        let limit = (2 * self.config.target_visible).saturating_sub(visible.len());
        self.add_at_free_cells(frame, &visible, inliers, limit, |_, _| None)
    }

    /// The inverse depth ρ and σ_ρ of a new landmark at pixel `z` from two frames: KLT
    /// follows `z` back into the previous frame, and the two rays from the poses the filter
    /// estimated meet at the point. `None` (the caller keeps the prior ρ₀ ± σ) when the track
    /// fails, the rays do not meet in front of both cameras, or the parallax is too small for
    /// the result to say more than the prior.
    fn two_frame_prior(
        &self,
        z: &Vector2<f64>,
        previous: &Pyramid,
        current: &Pyramid,
    ) -> Option<(f64, f64)> {
        let (r0, q0) = self.previous_pose?;
        let (r1, q1) = (self.filter.position(), self.filter.orientation());
        let cam = &self.filter.camera;
        let (rot0, rot1) = (rotation::matrix(&q0), rotation::matrix(&q1));
        let direction1 = (rot1 * cam.back_project(*z).0).normalize();
        // Start KLT where the point would be if it were at infinity: the rotation between
        // the frames is then already accounted for.
        let guess = cam.project(&(rot0.transpose() * direction1)).unwrap_or(*z);
        let z0 = klt::track(current, previous, *z, guess, &KltParams::default())?;
        let direction0 = (rot0 * cam.back_project(z0).0).normalize();
        let (distance, parallax) = two_view::closest_approach(&r1, &direction1, &r0, &direction0)?;
        let rho = 1.0 / distance;
        // σ_ρ/ρ ≈ (σ/f)/α for one pixel of noise, with a floor for the uncertainty of the
        // baseline itself (the motion between the frames is an estimate).
        let relative = (self.config.pixel_sigma / cam.fx.max(cam.fy)) / parallax;
        let sigma = rho * relative.max(self.config.two_frame_depth_floor);
        (sigma < self.config.inverse_depth_sigma).then_some((rho, sigma))
    }

    /// Pixels of the landmarks predicted inside the image.
    fn visible_pixels(&self) -> Vec<Vector2<f64>> {
        let cam = &self.filter.camera;
        (0..self.filter.slots.len())
            .filter_map(|slot| self.filter.predict_observation(slot))
            .map(|p| p.pixel)
            .filter(|z| cam.contains(z, 0.0))
            .collect()
    }

    /// Starts landmarks at `priors` (pixel, ρ, σ_ρ), best first, at most one per grid cell
    /// free of `visible` landmarks and at most `limit` of them. Landmarks start at the pixel
    /// centre, where the template is cut without resampling (the rounding is far inside the
    /// 1-pixel measurement noise). Returns how many were added.
    fn add_at_free_cells(
        &mut self,
        frame: &Frame,
        visible: &[Vector2<f64>],
        priors: impl IntoIterator<Item = (Vector2<f64>, f64, f64)>,
        limit: usize,
        depth: impl Fn(&Self, &Vector2<f64>) -> Option<(f64, f64)>,
    ) -> usize {
        let cam = self.filter.camera.clone();
        let margin = (2 * self.config.template_half + 2) as f64;
        let [gx, gy] = self.config.grid;
        let cell = |z: &Vector2<f64>| -> usize {
            let cx = ((z.x / cam.width as f64) * gx as f64).clamp(0.0, gx as f64 - 1.0) as usize;
            let cy = ((z.y / cam.height as f64) * gy as f64).clamp(0.0, gy as f64 - 1.0) as usize;
            cy * gx + cx
        };
        let mut occupied = vec![false; gx * gy];
        for z in visible {
            occupied[cell(z)] = true;
        }
        let mut chosen = Vec::new();
        for (z, rho, sigma) in priors {
            if chosen.len() >= limit {
                break;
            }
            let z = Vector2::new(z.x.round(), z.y.round());
            if !cam.contains(&z, margin) || occupied[cell(&z)] {
                continue;
            }
            let template = Template::capture(
                frame,
                z,
                2 * self.config.template_half,
                self.filter.position(),
                self.filter.orientation(),
            );
            if association::normalised(&template.patch).is_none() {
                continue;
            }
            occupied[cell(&z)] = true;
            let (rho, sigma) = depth(self, &z).unwrap_or((rho, sigma));
            chosen.push((z, rho, sigma));
            self.tracks.push(Track {
                template,
                predicted: 0,
                matched: 0,
                last_seen: self.frame_index,
                last_pixel: Some(z),
            });
        }
        self.filter.add_landmarks_with_depth(&chosen);
        chosen.len()
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
            landmarks: self.filter.slots.len(),
            state_dim: self.filter.dim(),
            lost: false,
            relocalised: false,
            initialising,
            timings,
        }
    }

    /// 1-point RANSAC: each hypothesis is the state updated with one match; the hypothesis
    /// that brings most matches within `ransac_threshold` pixels wins. Every match is tried
    /// when there are few; otherwise matches are drawn at random until the adaptive count of
    /// hypotheses is reached.
    fn one_point_ransac(&mut self, candidates: &[Observation]) -> Vec<bool> {
        let n = candidates.len();
        if n == 0 {
            return Vec::new();
        }
        let cam = &self.filter.camera;
        let evaluate = |state: &nalgebra::DVector<f64>| -> Vec<bool> {
            let r = Vector3::new(state[0], state[1], state[2]);
            let q = Quat::new(state[3], state[4], state[5], state[6]);
            candidates
                .iter()
                .map(|obs| {
                    let s = self.filter.slots[obs.slot];
                    let y = &state.as_slice()[s.offset..s.offset + s.kind.dim()];
                    inverse_depth::predict(cam, s.kind, y, &r, &q).is_some_and(|p| {
                        (p.pixel - obs.pixel).norm() < self.config.ransac_threshold
                    })
                })
                .collect()
        };
        let mut needed = self.config.max_hypotheses;
        let exhaustive = n <= needed;
        let order: Vec<usize> = if exhaustive {
            (0..n).collect()
        } else {
            (0..needed)
                .map(|_| (self.rng.next_u64() % n as u64) as usize)
                .collect()
        };
        let mut best: Vec<bool> = vec![false; n];
        let mut best_count = 0;
        for (tried, &i) in order.iter().enumerate() {
            if !exhaustive && tried >= needed {
                break;
            }
            let Some(state) = self.filter.single_observation_state(&candidates[i]) else {
                continue;
            };
            let support = evaluate(&state);
            let count = support.iter().filter(|&&b| b).count();
            if count > best_count {
                best_count = count;
                best = support;
                needed = needed.min(association::hypotheses_needed(
                    self.config.ransac_confidence,
                    count as f64 / n as f64,
                ));
            }
        }
        best
    }

    fn remove(&mut self, slots: &[usize]) {
        self.filter.remove_landmarks(slots);
        let mut index = 0;
        self.tracks.retain(|_| {
            let keep = !slots.contains(&index);
            index += 1;
            keep
        });
    }

    fn decorrelate_camera(&mut self) {
        let c = self.filter.motion.camera_dim();
        let n = self.filter.dim();
        if n > c {
            self.filter.p.view_mut((0, c), (c, n - c)).fill(0.0);
            self.filter.p.view_mut((c, 0), (n - c, c)).fill(0.0);
        }
    }

    fn convert_linear_landmarks(&mut self) -> usize {
        let r = self.filter.position();
        let mut converted = 0;
        for slot in 0..self.filter.slots.len() {
            if self.filter.slots[slot].kind != Parametrisation::InverseDepth {
                continue;
            }
            let index = inverse_depth::linearity_index(
                self.filter.landmark(slot),
                self.filter.rho_variance(slot),
                &r,
            );
            if index < self.config.linearity_threshold {
                self.filter.convert_to_euclidean(slot);
                converted += 1;
            }
        }
        converted
    }

    fn delete_bad_landmarks(&mut self) -> usize {
        let c = &self.config;
        let mut doomed: Vec<usize> = self
            .tracks
            .iter()
            .enumerate()
            .filter(|(_, t)| {
                t.predicted >= c.min_predicted_for_deletion
                    && (t.matched as f64) < c.min_match_ratio * t.predicted as f64
            })
            .map(|(i, _)| i)
            .collect();
        let excess = self
            .tracks
            .len()
            .saturating_sub(doomed.len() + c.max_landmarks);
        if excess > 0 {
            let mut by_age: Vec<usize> = (0..self.tracks.len())
                .filter(|i| !doomed.contains(i))
                .collect();
            by_age.sort_by_key(|&i| self.tracks[i].last_seen);
            doomed.extend(by_age.into_iter().take(excess));
        }
        let count = doomed.len();
        self.remove(&doomed);
        count
    }

    /// Detects keypoints when fewer than `target_visible` landmarks are predicted inside the
    /// image, and starts landmarks at the strongest ones in empty grid cells.
    fn create_landmarks(
        &mut self,
        frame: &Frame,
        detector: &Detector,
        views: Option<(&Pyramid, &Pyramid)>,
    ) -> Result<(usize, f64, f64)> {
        let visible = self.visible_pixels();
        // After a detection that found no free cell, wait before trying again, unless the
        // map is down to less than half its target: then a frame without new landmarks
        // risks losing the track, which costs more than a detection.
        let critical = 2 * visible.len() < self.config.target_visible;
        if visible.len() >= self.config.target_visible
            || (self.frame_index < self.detect_after && !critical)
        {
            return Ok((0, 0.0, 0.0));
        }
        let t_detect = Instant::now();
        let detection = detector.detect(frame)?;
        let detection_ms = ms(t_detect);
        let t_create = Instant::now();
        let want = (self.config.target_visible - visible.len()).min(self.config.max_new_per_frame);
        let (rho, sigma) = (
            self.config.initial_inverse_depth,
            self.config.inverse_depth_sigma,
        );
        let priors = detection
            .keypoints
            .iter()
            .map(|kp| (Vector2::new(kp.x as f64, kp.y as f64), rho, sigma));
        let two_frames = views.filter(|_| self.config.two_frame_depth);
        let created = self.add_at_free_cells(frame, &visible, priors, want, |slam, z| {
            two_frames.and_then(|(previous, current)| slam.two_frame_prior(z, previous, current))
        });
        if created == 0 {
            self.detect_after = self.frame_index + self.config.redetect_interval;
        }
        Ok((created, detection_ms, ms(t_create)))
    }

    /// Landmarks as Euclidean points with their 3×3 covariances (inverse-depth landmarks at
    /// infinity are left out).
    pub fn map(&self) -> Vec<MapPoint> {
        (0..self.filter.slots.len())
            .filter_map(|slot| {
                let point = self.filter.landmark_point(slot)?;
                let cov: Matrix3<f64> = self.filter.landmark_covariance(slot)?;
                Some(MapPoint {
                    id: self.filter.slots[slot].id,
                    parametrisation: self.filter.slots[slot].kind,
                    position: [point.x, point.y, point.z],
                    covariance: [
                        [cov[(0, 0)], cov[(0, 1)], cov[(0, 2)]],
                        [cov[(1, 0)], cov[(1, 1)], cov[(1, 2)]],
                        [cov[(2, 0)], cov[(2, 1)], cov[(2, 2)]],
                    ],
                    observations: self.tracks[slot].matched,
                })
            })
            .collect()
    }
}

/// A landmark of the map output.
#[derive(Clone, Debug, Serialize)]
pub struct MapPoint {
    /// Stable landmark id.
    pub id: u64,
    /// How it is held in the state.
    pub parametrisation: Parametrisation,
    /// Euclidean position, world frame.
    pub position: [f64; 3],
    /// 3×3 covariance of the position (first order for inverse-depth landmarks).
    pub covariance: [[f64; 3]; 3],
    /// Frames in which it was matched and used.
    pub observations: usize,
}

/// One landmark's search: slot, the observation when matched, whether the descriptor
/// rejected it, and the KLT-tracked pixel.
type Searched = (usize, Option<Observation>, bool, Option<Vector2<f64>>);

/// Seconds without enough parallax after which the camera is taken to be at rest and the
/// filter starts there, as in the paper.
const STATIONARY_START_AFTER: f64 = 1.0;
/// Median step of the start-up points between two frames, pixels, under which a camera that
/// started at rest is taken to be still at rest.
const REST_STEP_PIXELS: f64 = 0.5;
/// Fewest points (followed, then inliers) for a two-view estimate.
const MIN_BOOTSTRAP_POINTS: usize = 20;
/// Parallax, radians, that a quarter of the inliers must reach for the two views to fix the
/// depths (about 1°).
const MIN_BOOTSTRAP_PARALLAX: f64 = 0.017;

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}
