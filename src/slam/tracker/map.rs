//! Map management (section 2.6): landmarks created from steernav keypoints in image cells
//! without tracked features (eq 13, at the prior depth, at the ground's or the scene's depth
//! while a wheeled vehicle turns in place (`turning.rs`), or at a two-frame depth),
//! inverse-depth landmarks converted to Euclidean by their linearity index, and landmarks
//! deleted when they keep failing or the map is full.

use std::time::Instant;

use nalgebra::{Matrix3, Vector2};

use super::report::MapPoint;
use super::{ms, Slam};
use crate::error::Result;
use crate::features::Detector;
use crate::image::Frame;
use crate::slam::association::{self, Template};
use crate::slam::inverse_depth::{self, Parametrisation};
use crate::slam::klt::{self, Pyramid};
use crate::slam::rotation;
use crate::slam::two_view;

/// What the front end keeps about one landmark beside the filter.
#[derive(Clone, Debug)]
pub(super) struct Track {
    pub template: Template,
    /// Frames it was predicted inside the image (while tracking held).
    pub predicted: usize,
    /// Frames its measurement was used.
    pub matched: usize,
    pub last_seen: usize,
    /// Where it was measured in the previous frame, when it was: the start of its KLT track.
    pub last_pixel: Option<Vector2<f64>>,
}

impl Slam {
    /// Pixels of the landmarks predicted inside the image.
    pub(super) fn visible_pixels(&self) -> Vec<Vector2<f64>> {
        self.visible_landmarks()
            .into_iter()
            .map(|(_, z)| z)
            .collect()
    }

    /// The landmarks predicted inside the image: slot and pixel.
    fn visible_landmarks(&self) -> Vec<(usize, Vector2<f64>)> {
        let cam = self.filter.camera();
        (0..self.filter.slots().len())
            .filter_map(|slot| Some((slot, self.filter.predict_observation(slot)?.pixel)))
            .filter(|(_, z)| cam.contains(z, 0.0))
            .collect()
    }

    /// Detects keypoints when fewer than `target_visible` landmarks are predicted inside the
    /// image, and starts landmarks at the strongest ones in empty grid cells. Returns how many
    /// were created, and the detection and creation times.
    pub(super) fn create_landmarks(
        &mut self,
        frame: &Frame,
        detector: &Detector,
        views: Option<(&Pyramid, &Pyramid)>,
    ) -> Result<(usize, f64, f64)> {
        let in_view = self.visible_landmarks();
        let visible: Vec<Vector2<f64>> = in_view.iter().map(|&(_, z)| z).collect();
        // After a detection that found no free cell, wait before trying again, unless the
        // map is down to less than half its target: then a frame without new landmarks
        // risks losing the track, which costs more than a detection.
        let critical = 2 * visible.len() < self.config.map.target_visible;
        if visible.len() >= self.config.map.target_visible
            || (self.frame_index < self.detect_after && !critical)
        {
            return Ok((0, 0.0, 0.0));
        }
        let t_detect = Instant::now();
        let detection = detector.detect(frame)?;
        let detection_ms = ms(t_detect);
        let t_create = Instant::now();
        let want =
            (self.config.map.target_visible - visible.len()).min(self.config.map.max_new_per_frame);
        let turning = self.turning_prior(&in_view);
        let initial = (
            self.config.filter.initial_inverse_depth,
            self.config.filter.inverse_depth_sigma,
        );
        let priors = detection.keypoints.iter().map(|kp| {
            let z = Vector2::new(kp.x as f64, kp.y as f64);
            let (rho, sigma) = turning.as_ref().map_or(initial, |t| t.at(&z));
            (z, rho, sigma)
        });
        let two_frames = views.filter(|_| self.config.map.two_frame_depth);
        let created = self.add_at_free_cells(frame, &visible, priors, want, |slam, z| {
            two_frames.and_then(|(previous, current)| slam.two_frame_prior(z, previous, current))
        });
        if created == 0 {
            self.detect_after = self.frame_index + self.config.map.redetect_interval;
        }
        Ok((created, detection_ms, ms(t_create)))
    }

    /// Starts landmarks at `priors` (pixel, ρ, σ_ρ), best first, at most one per grid cell
    /// free of `visible` landmarks and at most `limit` of them. Landmarks start at the pixel
    /// centre, where the template is cut without resampling (the rounding is far inside the
    /// 1-pixel measurement noise). `depth` may replace a prior. Returns how many were added.
    pub(super) fn add_at_free_cells(
        &mut self,
        frame: &Frame,
        visible: &[Vector2<f64>],
        priors: impl IntoIterator<Item = (Vector2<f64>, f64, f64)>,
        limit: usize,
        depth: impl Fn(&Self, &Vector2<f64>) -> Option<(f64, f64)>,
    ) -> usize {
        let cam = self.filter.camera().clone();
        let margin = (2 * self.config.search.template_half + 2) as f64;
        let [gx, gy] = self.config.map.grid;
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
                2 * self.config.search.template_half,
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
        let cam = self.filter.camera();
        let (rot0, rot1) = (rotation::matrix(&q0), rotation::matrix(&q1));
        let direction1 = (rot1 * cam.back_project(*z).0).normalize();
        // Start KLT where the point would be if it were at infinity: the rotation between
        // the frames is then already accounted for.
        let guess = cam.project(&(rot0.transpose() * direction1)).unwrap_or(*z);
        let z0 = klt::track(current, previous, *z, guess, &self.config.klt)?;
        let direction0 = (rot0 * cam.back_project(z0).0).normalize();
        let (distance, parallax) = two_view::closest_approach(&r1, &direction1, &r0, &direction0)?;
        let rho = 1.0 / distance;
        // σ_ρ/ρ ≈ (σ/f)/α for one pixel of noise, with a floor for the uncertainty of the
        // baseline itself (the motion between the frames is an estimate).
        let relative = (self.config.filter.pixel_sigma / cam.fx.max(cam.fy)) / parallax;
        let sigma = rho * relative.max(self.config.map.two_frame_depth_floor);
        (sigma < self.config.filter.inverse_depth_sigma).then_some((rho, sigma))
    }

    /// Removes landmarks from the filter and their tracks.
    pub(super) fn remove(&mut self, slots: &[usize]) {
        self.filter.remove_landmarks(slots);
        let mut index = 0;
        self.tracks.retain(|_| {
            let keep = !slots.contains(&index);
            index += 1;
            keep
        });
    }

    /// Converts the inverse-depth landmarks whose linearity index is under the threshold to
    /// Euclidean points. Returns how many were.
    pub(super) fn convert_linear_landmarks(&mut self) -> usize {
        let r = self.filter.position();
        let mut converted = 0;
        for slot in 0..self.filter.slots().len() {
            if self.filter.slots()[slot].kind != Parametrisation::InverseDepth {
                continue;
            }
            let index = inverse_depth::linearity_index(
                self.filter.landmark(slot),
                self.filter.rho_variance(slot),
                &r,
            );
            if index < self.config.filter.linearity_threshold {
                self.filter.convert_to_euclidean(slot);
                converted += 1;
            }
        }
        converted
    }

    /// Deletes the landmarks matched in too few of the frames they were predicted in, then
    /// the ones unseen longest while the map holds more than `max_landmarks`. Returns how
    /// many went.
    pub(super) fn delete_bad_landmarks(&mut self) -> usize {
        let c = &self.config.map;
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

    /// Landmarks as Euclidean points with their 3×3 covariances (inverse-depth landmarks at
    /// infinity are left out).
    pub fn map(&self) -> Vec<MapPoint> {
        let slots = self.filter.slots();
        (0..slots.len())
            .filter_map(|slot| {
                let point = self.filter.landmark_point(slot)?;
                let cov: Matrix3<f64> = self.filter.landmark_covariance(slot)?;
                Some(MapPoint {
                    id: slots[slot].id,
                    parametrisation: slots[slot].kind,
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
