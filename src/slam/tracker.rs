//! The SLAM loop for one frame: predict (eqs 15–16), search every visible landmark inside its
//! gated ellipse (eqs 25–27), 1-point RANSAC, update (eqs 22–24), rescue the high-innovation
//! inliers, then manage the map — convert linear landmarks to Euclidean, delete the ones that
//! keep failing, and create new inverse-depth landmarks (eq 13) from steernav keypoints in
//! image cells without tracked features.

use std::time::Instant;

use nalgebra::{Matrix3, Vector2, Vector3};
use rayon::prelude::*;
use serde::Serialize;

use super::association::{self, Template};
use super::camera::PinholeCamera;
use super::config::SlamConfig;
use super::ekf::{Filter, Observation};
use super::inverse_depth::{self, Parametrisation};
use super::motion::OdometryStep;
use super::rotation::Quat;
use crate::error::{Error, Result};
use crate::features::Detector;
use crate::image::Frame;
use crate::synth::Rng;

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
    /// Tracking had been lost for `lost_after` frames and the map was restarted here.
    pub reinitialised: bool,
    /// Timings.
    pub timings: SlamTimings,
}

#[derive(Clone, Debug)]
struct Track {
    template: Template,
    predicted: usize,
    matched: usize,
    last_seen: usize,
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
}

impl Slam {
    /// Starts a session at the origin of the world frame.
    pub fn new(camera: PinholeCamera, config: SlamConfig) -> Result<Self> {
        camera.validate()?;
        config.validate()?;
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
            self.filter.predict(dt, odometry);
        }
        self.last_time = Some(timestamp);
        let mut timings = SlamTimings {
            filter_ms: ms(start),
            ..Default::default()
        };

        // Active search, in parallel over landmarks.
        let t_assoc = Instant::now();
        let half = self.config.template_half;
        let (r, q) = (self.filter.position(), self.filter.orientation());
        let filter = &self.filter;
        let tracks = &self.tracks;
        let config = &self.config;
        let searched: Vec<(usize, Option<Observation>, bool)> = (0..filter.slots.len())
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
                    return Some((slot, None, false));
                };
                let found = association::search(
                    &frame.gray,
                    frame.width as usize,
                    frame.height as usize,
                    &t,
                    half,
                    &association::SearchRegion {
                        predicted: prediction.pixel,
                        covariance: s,
                        gate: config.search_gate,
                        max_extent: config.max_search_extent,
                    },
                );
                match found {
                    Some((z, score)) if score >= config.min_correlation => {
                        let d =
                            crate::features::descriptor::describe(frame, z.x as f32, z.y as f32);
                        if association::descriptor_distance(&d, &template.descriptor)
                            > config.descriptor_tolerance
                        {
                            return Some((slot, None, true));
                        }
                        Some((
                            slot,
                            Some(Observation {
                                slot,
                                pixel: z,
                                prediction,
                            }),
                            false,
                        ))
                    }
                    _ => Some((slot, None, false)),
                }
            })
            .collect();
        let predicted = searched.len();
        let descriptor_rejected = searched.iter().filter(|s| s.2).count();
        for (slot, _, _) in &searched {
            self.tracks[*slot].predicted += 1;
        }
        let candidates: Vec<Observation> = searched.into_iter().filter_map(|s| s.1).collect();
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
        for &slot in &supported {
            self.tracks[slot].matched += 1;
            self.tracks[slot].last_seen = self.frame_index;
        }

        // Tracking lost: report it, and restart the map when it lasts.
        let lost = predicted > 0 && supported.len() < 3
            || self.filter.slots.is_empty() && self.frame_index > 0;
        self.lost_streak = if lost { self.lost_streak + 1 } else { 0 };
        let mut reinitialised = false;
        let mut deleted = 0;
        if self.lost_streak >= self.config.lost_after {
            deleted += self.filter.slots.len();
            let all: Vec<usize> = (0..self.filter.slots.len()).collect();
            self.remove(&all);
            self.restart_at_current_pose();
            self.lost_streak = 0;
            reinitialised = true;
        }

        let converted = self.convert_linear_landmarks();
        deleted += self.delete_bad_landmarks();
        timings.filter_ms += ms(t_filter);

        // New landmarks where the image has no tracked feature.
        let (created, detection_ms, creation_ms) = self.create_landmarks(frame, detector)?;
        timings.detection_ms = detection_ms;
        timings.filter_ms += creation_ms;
        self.frame_index += 1;
        timings.total_ms = ms(start);
        let cov = self.filter.position_covariance();
        let qn = self.filter.orientation();
        let p = self.filter.position();
        Ok(FrameReport {
            timestamp,
            position: [p.x, p.y, p.z],
            orientation: [qn[0], qn[1], qn[2], qn[3]],
            position_covariance: [
                [cov[(0, 0)], cov[(0, 1)], cov[(0, 2)]],
                [cov[(1, 0)], cov[(1, 1)], cov[(1, 2)]],
                [cov[(2, 0)], cov[(2, 1)], cov[(2, 2)]],
            ],
            predicted,
            matched: candidates.len(),
            descriptor_rejected,
            inliers: inlier_count,
            rescued: rescued.len(),
            created,
            deleted,
            converted,
            landmarks: self.filter.slots.len(),
            state_dim: self.filter.dim(),
            lost,
            reinitialised,
            timings,
        })
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

    /// A restart begins a new map anchored at the current pose estimate, as at start-up: the
    /// pose covariance goes back to (almost) zero — nothing in the new map can be tied to the
    /// old one — and the velocity keeps its estimate (the camera rarely stops when tracking
    /// fails) with the prior's uncertainty.
    fn restart_at_current_pose(&mut self) {
        let c = self.filter.motion.camera_dim();
        let mut p = nalgebra::DMatrix::zeros(c, c);
        for i in 0..super::ekf::POSE {
            p[(i, i)] = 1e-12;
        }
        if c == 13 {
            for i in 7..10 {
                p[(i, i)] = self.config.velocity_sigma.powi(2);
                p[(i + 3, i + 3)] = self.config.angular_velocity_sigma.powi(2);
            }
        }
        self.filter.p = p;
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
    ) -> Result<(usize, f64, f64)> {
        let cam = self.filter.camera.clone();
        let margin = (2 * self.config.template_half + 2) as f64;
        let visible: Vec<Vector2<f64>> = (0..self.filter.slots.len())
            .filter_map(|slot| self.filter.predict_observation(slot))
            .map(|p| p.pixel)
            .filter(|z| cam.contains(z, 0.0))
            .collect();
        if visible.len() >= self.config.target_visible || self.frame_index < self.detect_after {
            return Ok((0, 0.0, 0.0));
        }
        let t_detect = Instant::now();
        let detection = detector.detect(frame)?;
        let detection_ms = ms(t_detect);
        let t_create = Instant::now();
        let [gx, gy] = self.config.grid;
        let cell = |z: &Vector2<f64>| -> usize {
            let cx = ((z.x / cam.width as f64) * gx as f64).clamp(0.0, gx as f64 - 1.0) as usize;
            let cy = ((z.y / cam.height as f64) * gy as f64).clamp(0.0, gy as f64 - 1.0) as usize;
            cy * gx + cx
        };
        let mut occupied = vec![false; gx * gy];
        for z in &visible {
            occupied[cell(z)] = true;
        }
        let want = (self.config.target_visible - visible.len()).min(self.config.max_new_per_frame);
        let mut pixels = Vec::new();
        for kp in &detection.keypoints {
            if pixels.len() >= want {
                break;
            }
            // Landmarks start at the keypoint's pixel centre, where the template is cut
            // without resampling (the rounding is far inside the 1-pixel measurement noise).
            let z = Vector2::new(kp.x.round() as f64, kp.y.round() as f64);
            if !cam.contains(&z, margin) {
                continue;
            }
            let c = cell(&z);
            if occupied[c] {
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
            occupied[c] = true;
            pixels.push(z);
            self.tracks.push(Track {
                template,
                predicted: 0,
                matched: 0,
                last_seen: self.frame_index,
            });
        }
        if pixels.is_empty() {
            self.detect_after = self.frame_index + self.config.redetect_interval;
        }
        self.filter.add_landmarks(
            &pixels,
            self.config.initial_inverse_depth,
            self.config.inverse_depth_sigma,
        );
        Ok((pixels.len(), detection_ms, ms(t_create)))
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

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}
