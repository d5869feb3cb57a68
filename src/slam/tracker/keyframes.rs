//! The keyframes of the local bundle adjustment (`slam::refine`): which frames become one,
//! what each keeps, and how the refined pose goes back into the filter — as a measurement of
//! the camera's pose, so that the map follows it through its correlations.

use std::collections::HashMap;

use nalgebra::{Vector2, Vector3};

use super::Slam;
use crate::slam::refine::Keyframe;

impl Slam {
    /// Records this frame as a keyframe when it has turned or moved enough since the last
    /// one, then refines the window and updates the filter with the refined current pose.
    /// `measured` holds the landmarks (by id) the update took, with their pixels; the
    /// landmarks created in this frame, from slot `first_new` on, are seen where they were
    /// created.
    pub(super) fn refine_keyframes(&mut self, measured: &[(u64, Vector2<f64>)], first_new: usize) {
        let config = &self.config.refine;
        if config.keyframes == 0 {
            return;
        }
        let (r, q) = (self.filter.position(), self.filter.orientation());
        let slots = self.filter.slots();
        let mut depths: Vec<f64> = measured
            .iter()
            .filter_map(|(id, _)| slots.iter().position(|s| s.id == *id))
            .filter_map(|slot| self.filter.landmark_point(slot))
            .map(|p| (p - r).norm())
            .collect();
        if depths.is_empty() {
            return;
        }
        depths.sort_by(f64::total_cmp);
        let median_depth = depths[depths.len() / 2];
        if !self.window.wants(&r, &q, median_depth, config) {
            return;
        }
        let mut observations = measured.to_vec();
        for (slot, s) in slots.iter().enumerate().skip(first_new) {
            if let Some(p) = self.filter.predict_observation(slot) {
                observations.push((s.id, p.pixel));
            }
        }
        self.window.push(
            Keyframe {
                position: r,
                orientation: q,
                observations,
            },
            config,
        );
        let slot_of: HashMap<u64, usize> =
            slots.iter().enumerate().map(|(i, s)| (s.id, i)).collect();
        let mut points: HashMap<u64, Vector3<f64>> = slot_of
            .iter()
            .filter_map(|(&id, &slot)| Some((id, self.filter.landmark_point(slot)?)))
            .collect();
        let Some(refined) =
            self.window
                .adjust(self.filter.camera(), &mut points, &self.config.refine)
        else {
            return;
        };
        log::debug!(
            "frame {}: {} points refined over the keyframes, RMS {:.2} → {:.2} px",
            self.frame_index,
            refined.points,
            refined.rms_before,
            refined.rms_after
        );
        let (Some((r, q)), Some(covariance)) = (self.window.newest(), refined.newest_covariance)
        else {
            return;
        };
        let inflation = self.config.refine.measurement_inflation;
        if let Err(e) = self.filter.update_pose(&r, &q, &(covariance * inflation)) {
            log::debug!(
                "frame {}: the filter refused the refined pose ({e})",
                self.frame_index
            );
        }
    }
}
