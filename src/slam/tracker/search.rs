//! The active search of every visible landmark (eqs 25–27): its predicted pixel and gated
//! ellipse, a KLT track from the previous frame where it was seen there, the warped template's
//! correlation (at other scales when the warp's scale is in doubt), and the descriptor check.

use nalgebra::{Matrix2, Vector2};
use rayon::prelude::*;

use super::Slam;
use crate::image::Frame;
use crate::slam::association;
use crate::slam::ekf::Observation;
use crate::slam::klt::{self, Pyramid};

/// One landmark's search.
#[derive(Clone, Debug)]
pub(super) struct LandmarkSearch {
    /// The landmark searched.
    pub slot: usize,
    /// The measurement, when the landmark was found and its descriptor agreed.
    pub observation: Option<Observation>,
    /// Found, but its descriptor differed from the landmark's.
    pub descriptor_rejected: bool,
    /// Where KLT followed it to from the previous frame.
    pub tracked: Option<Vector2<f64>>,
}

impl Slam {
    /// Searches every landmark predicted inside the image, in parallel; the ones predicted
    /// outside are left out.
    pub(super) fn search_landmarks(
        &self,
        frame: &Frame,
        previous: Option<&Pyramid>,
        pyramid: &Pyramid,
    ) -> Vec<LandmarkSearch> {
        (0..self.filter.slots().len())
            .into_par_iter()
            .filter_map(|slot| self.search_landmark(slot, frame, previous, pyramid))
            .collect()
    }

    fn search_landmark(
        &self,
        slot: usize,
        frame: &Frame,
        previous: Option<&Pyramid>,
        pyramid: &Pyramid,
    ) -> Option<LandmarkSearch> {
        let (filter, config) = (&self.filter, &self.config);
        let cam = filter.camera();
        let half = config.search.template_half;
        let prediction = filter.predict_observation(slot)?;
        if !cam.contains(&prediction.pixel, (half + 1) as f64) {
            return None;
        }
        let missed = |descriptor_rejected, tracked| LandmarkSearch {
            slot,
            observation: None,
            descriptor_rejected,
            tracked,
        };
        let s = filter.innovation_covariance(slot, &prediction);
        let template = &self.tracks[slot].template;
        let (r, q) = (filter.position(), filter.orientation());
        let warp = filter
            .landmark_point(slot)
            .and_then(|point| template.view_warp(cam, &point, &r, &q));
        let Some(t) = association::normalised(&template.warped(warp, half)) else {
            return Some(missed(false, None));
        };
        // Seen in the previous frame: follow it with KLT, then let the template confirm (and
        // anchor, against drift) the tracked pixel.
        let tracked = previous
            .zip(self.tracks[slot].last_pixel)
            .and_then(|(from, last)| {
                let guess = if cam.contains(&prediction.pixel, 0.0) {
                    prediction.pixel
                } else {
                    last
                };
                klt::track(from, pyramid, last, guess, &self.config.klt)
            });
        let region = match tracked {
            Some(z) => association::SearchRegion {
                predicted: z,
                covariance: Matrix2::identity() * config.search.tracked_variance,
                gate: config.search.gate,
                max_extent: config.search.tracked_extent,
            },
            None => association::SearchRegion {
                predicted: prediction.pixel,
                covariance: s,
                gate: config.search.gate,
                max_extent: config.search.max_extent
                    * (1 + self.lost_streak.min(config.search.max_widening)) as f64,
            },
        };
        let (width, height) = (frame.width as usize, frame.height as usize);
        let found = association::search(&frame.gray, width, height, &t, half, &region);
        let threshold = if tracked.is_some() {
            config.search.min_tracked_correlation
        } else {
            config.search.min_correlation
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
                    &config.search.template_scales,
                    best,
                )
            }
        });
        let Some((z, _)) = found.filter(|(_, score)| *score >= threshold) else {
            return Some(missed(false, tracked));
        };
        let d = crate::features::descriptor::describe(frame, z.x as f32, z.y as f32);
        if association::descriptor_distance(&d, &template.descriptor)
            > config.search.descriptor_tolerance
        {
            return Some(missed(true, tracked));
        }
        // A tracked landmark is measured where KLT put it: the template only confirms the
        // pixel. Its correlation peak sits off the true position wherever the warp misjudges
        // the view (oblique surfaces, young depths), while the frame-to-frame track is
        // sub-pixel.
        Some(LandmarkSearch {
            slot,
            observation: Some(Observation {
                slot,
                pixel: tracked.unwrap_or(z),
                prediction,
            }),
            descriptor_rejected: false,
            tracked,
        })
    }
}
