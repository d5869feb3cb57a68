//! The update of one frame: 1-point RANSAC over the matches, the EKF update with the
//! low-innovation inliers (eqs 22–24), the rescue of high-innovation inliers through the χ²
//! gate (eq 26), and the refresh of the templates of the landmarks the update accepted.

use nalgebra::{DVector, Vector3};

use super::Slam;
use crate::image::Frame;
use crate::slam::association::{self, Template};
use crate::slam::ekf::Observation;
use crate::slam::inverse_depth;
use crate::slam::rotation::Quat;

/// What the update of one frame did.
#[derive(Clone, Debug, Default)]
pub(super) struct UpdateOutcome {
    /// Low-innovation inliers used (0 when their update was refused).
    pub inliers: usize,
    /// High-innovation inliers rescued and used.
    pub rescued: usize,
    /// Slots of the landmarks whose measurement the filter took.
    pub supported: Vec<usize>,
    /// The filter refused an update (the inliers' or the rescued ones').
    pub rejected: bool,
}

impl Slam {
    /// RANSAC over `candidates`, then the update with the inliers and the rescued ones;
    /// the accepted landmarks are counted as matched and their templates refreshed.
    pub(super) fn update_with(
        &mut self,
        frame: &Frame,
        timestamp: f64,
        candidates: &[Observation],
        inlier_flags: &[bool],
    ) -> UpdateOutcome {
        let inliers: Vec<Observation> = candidates
            .iter()
            .zip(inlier_flags)
            .filter(|(_, &ok)| ok)
            .map(|(o, _)| o.clone())
            .collect();
        let mut outcome = UpdateOutcome {
            inliers: inliers.len(),
            supported: inliers.iter().map(|o| o.slot).collect(),
            ..Default::default()
        };
        if let Err(e) = self.filter.update(&inliers) {
            log::warn!(
                "frame at t={timestamp}: the update with {} inliers was refused ({e})",
                inliers.len()
            );
            outcome.inliers = 0;
            outcome.supported.clear();
            outcome.rejected = true;
        }
        let outliers = candidates.iter().zip(inlier_flags).filter(|(_, &ok)| !ok);
        let mut rescued = Vec::new();
        for (obs, _) in outliers {
            let Some(prediction) = self.filter.predict_observation(obs.slot) else {
                continue;
            };
            let s = self.filter.innovation_covariance(obs.slot, &prediction);
            let nu = obs.pixel - prediction.pixel;
            let d2 = s
                .try_inverse()
                .map_or(f64::INFINITY, |si| nu.dot(&(si * nu)));
            if d2 < self.config.ransac.rescue_gate {
                rescued.push(Observation {
                    slot: obs.slot,
                    pixel: obs.pixel,
                    prediction,
                });
            }
        }
        if !rescued.is_empty() {
            match self.filter.update(&rescued) {
                Ok(()) => outcome.supported.extend(rescued.iter().map(|o| o.slot)),
                Err(e) => {
                    log::warn!(
                        "frame at t={timestamp}: the update with {} rescued matches was refused ({e})",
                        rescued.len()
                    );
                    outcome.rejected = true;
                    rescued.clear();
                }
            }
        }
        outcome.rescued = rescued.len();
        self.refresh_templates(frame, inliers.iter().chain(&rescued), &outcome.supported);
        for &slot in &outcome.supported {
            self.tracks[slot].matched += 1;
            self.tracks[slot].last_seen = self.frame_index;
        }
        outcome
    }

    /// Refreshes the template once the view has moved far from where it was cut: the warp
    /// through a plane facing the first camera fails on the oblique walls and roads of
    /// forward motion. Only pixels the update accepted refresh it.
    fn refresh_templates<'a>(
        &mut self,
        frame: &Frame,
        used: impl Iterator<Item = &'a Observation>,
        supported: &[usize],
    ) {
        let (r, q) = (self.filter.position(), self.filter.orientation());
        for obs in used {
            if !supported.contains(&obs.slot) {
                continue;
            }
            self.tracks[obs.slot].last_pixel = Some(obs.pixel);
            let Some(point) = self.filter.landmark_point(obs.slot) else {
                continue;
            };
            let template = &self.tracks[obs.slot].template;
            let depth = (point - r).norm();
            if depth > 1e-9
                && (r - template.position).norm() > self.config.search.template_refresh * depth
            {
                let radius = template.radius;
                let fresh = Template::capture(frame, obs.pixel, radius, r, q);
                if association::normalised(&fresh.patch).is_some() {
                    self.tracks[obs.slot].template = fresh;
                }
            }
        }
    }

    /// 1-point RANSAC: each hypothesis is the state updated with one match; the hypothesis
    /// that brings most matches within `ransac_threshold` pixels wins. Every match is tried
    /// when there are few; otherwise matches are drawn at random until the adaptive count of
    /// hypotheses is reached.
    pub(super) fn one_point_ransac(&mut self, candidates: &[Observation]) -> Vec<bool> {
        let n = candidates.len();
        if n == 0 {
            return Vec::new();
        }
        let cam = self.filter.camera();
        let evaluate = |state: &DVector<f64>| -> Vec<bool> {
            let r = Vector3::new(state[0], state[1], state[2]);
            let q = Quat::new(state[3], state[4], state[5], state[6]);
            candidates
                .iter()
                .map(|obs| {
                    let s = self.filter.slots()[obs.slot];
                    let y = &state.as_slice()[s.offset..s.offset + s.kind.dim()];
                    inverse_depth::predict(cam, s.kind, y, &r, &q).is_some_and(|p| {
                        (p.pixel - obs.pixel).norm() < self.config.ransac.threshold
                    })
                })
                .collect()
        };
        let mut needed = self.config.ransac.max_hypotheses;
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
                    self.config.ransac.confidence,
                    count as f64 / n as f64,
                ));
            }
        }
        best
    }
}
