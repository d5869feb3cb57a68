//! Matching accuracy on pairs of views with a known homography, as HPatches and the Oxford
//! protocol measure it: mutual nearest neighbours of the descriptors passing Lowe's ratio both
//! ways, then
//! - **MMA(t)**: the fraction of matches whose first point the true map sends within t px of
//!   the second, for t = 1 … 10;
//! - **correct matches** at 3 px;
//! - **homography accuracy**: the homography RANSAC fits to the matches (3 px) moves the four
//!   image corners by a mean of at most 1, 3 or 5 px from where the true map sends them;
//! - **repeatability** at 3 px (eq 11) and under the region-overlap criterion
//!   (`eval::overlap`), which also asks the scales to follow the map.
//!
//! The same code judges steernav and every peer, on the same keypoint count.

use rayon::prelude::*;

use super::homography::{project, Homography};
use super::overlap::{common_region, overlap_repeatability};
use super::recall::KeypointSet;
use super::repeatability::repeatability;
use crate::features::matching::{verify, PointPair, Verification};

/// Thresholds (px) of the MMA curve: 1, 2, … , 10.
pub const MMA_THRESHOLDS: usize = 10;

/// The corner-error thresholds (px) of homography accuracy.
pub const CORNER_THRESHOLDS: [f64; 3] = [1.0, 3.0, 5.0];

/// What matching one pair of views gave.
#[derive(Clone, Debug, PartialEq)]
pub struct PairMatching {
    /// "steernav" or a peer's name.
    pub detector: String,
    /// The pair, as `sequence/imgN`.
    pub image: String,
    /// Keypoints in each view (after the cut to the strongest).
    pub keypoints: (usize, usize),
    /// Mutual ratio-test matches.
    pub matches: usize,
    /// Matches within t + 1 px under the true map, t = 0 … 9.
    pub correct: [usize; MMA_THRESHOLDS],
    /// Mean corner displacement of the RANSAC homography against the true one (px); `None`
    /// when RANSAC found none.
    pub corner_error: Option<f64>,
    /// Repeatability (eq 11) at 3 px.
    pub repeatability_3px: f64,
    /// Repeatability under the region-overlap criterion; `None` without scales.
    pub repeatability_overlap: Option<f64>,
}

impl PairMatching {
    /// MMA at `t` px (1 ≤ t ≤ 10); 0 without matches.
    pub fn mma(&self, t: usize) -> f64 {
        if self.matches == 0 {
            0.0
        } else {
            self.correct[t - 1] as f64 / self.matches as f64
        }
    }

    /// Whether the estimated homography is within `threshold` px at the corners.
    pub fn accurate(&self, threshold: f64) -> bool {
        self.corner_error.is_some_and(|e| e <= threshold)
    }
}

/// Mutual nearest neighbours passing the ratio test in both directions, as (i, j) pairs.
pub fn mutual_ratio_matches(a: &KeypointSet, b: &KeypointSet, ratio: f64) -> Vec<(usize, usize)> {
    let nearest = |from: &KeypointSet, to: &KeypointSet| -> Vec<Option<usize>> {
        (0..from.points.len())
            .into_par_iter()
            .map(|i| {
                from.descriptors
                    .nearest(i, &to.descriptors, 0..to.points.len(), ratio)
            })
            .collect()
    };
    let (forward, backward) = (nearest(a, b), nearest(b, a));
    forward
        .iter()
        .enumerate()
        .filter_map(|(i, f)| {
            let j = (*f)?;
            (backward[j] == Some(i)).then_some((i, j))
        })
        .collect()
}

/// Matches two views (`a` in the view of size `size_a`, `b` in `size_b`) and judges the
/// matches and the keypoints against the true map `h` (view a → view b); `margin` is the
/// border the repeatabilities leave out, and `region_sigmas` the region each keypoint must have
/// inside both views to count in them ([`super::overlap::inside_both_views`]); the matches are
/// judged on every keypoint.
#[allow(clippy::too_many_arguments)]
pub fn judge_pair(
    detector: &str,
    image: &str,
    a: &KeypointSet,
    size_a: (u32, u32),
    b: &KeypointSet,
    size_b: (u32, u32),
    h: &Homography,
    (ratio, margin, region_sigmas): (f64, f64, f64),
) -> PairMatching {
    let matches = mutual_ratio_matches(a, b, ratio);
    let mut correct = [0usize; MMA_THRESHOLDS];
    for &(i, j) in &matches {
        let (x, y) = a.points[i];
        let Some((u, v)) = project(h, x, y) else {
            continue;
        };
        let (p, q) = b.points[j];
        let d = (u - p).hypot(v - q);
        for (t, c) in correct.iter_mut().enumerate() {
            if d <= (t + 1) as f64 {
                *c += 1;
            }
        }
    }
    let pairs: Vec<PointPair> = matches
        .iter()
        .map(|&(i, j)| (a.points[i], b.points[j]))
        .collect();
    let fitted = verify(&pairs, Verification::Homography, 3.0, 10_000, 7).model;
    let corner_error = fitted.and_then(|m| corner_error(&m, h, size_a));
    let (ra, rb) = common_region(a, size_a, b, size_b, h, region_sigmas);
    PairMatching {
        detector: detector.to_string(),
        image: image.to_string(),
        keypoints: (a.points.len(), b.points.len()),
        matches: matches.len(),
        correct,
        corner_error,
        repeatability_3px: repeatability(&ra.points, size_a, &rb.points, size_b, h, 3.0, margin)
            .ratio,
        repeatability_overlap: overlap_repeatability(&ra, size_a, &rb, size_b, h, margin)
            .map(|r| r.ratio),
    }
}

/// Mean distance between where `estimated` and `truth` send the corners of a `w`×`h` view.
pub fn corner_error(estimated: &Homography, truth: &Homography, (w, h): (u32, u32)) -> Option<f64> {
    let (w, h) = (w as f64 - 1.0, h as f64 - 1.0);
    let corners = [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)];
    let mut sum = 0.0;
    for (x, y) in corners {
        let (a, b) = (project(estimated, x, y)?, project(truth, x, y)?);
        sum += (a.0 - b.0).hypot(a.1 - b.1);
    }
    let mean = sum / 4.0;
    mean.is_finite().then_some(mean)
}

/// The CSV header of [`to_csv`].
pub const CSV_HEADER: &str = "detector,image,keypoints1,keypoints2,matches,correct_1px,correct_2px,correct_3px,correct_4px,correct_5px,correct_6px,correct_7px,correct_8px,correct_9px,correct_10px,corner_error,repeatability_3px,repeatability_overlap";

/// One CSV line per pair.
pub fn to_csv(rows: &[PairMatching]) -> String {
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for r in rows {
        let correct: Vec<String> = r.correct.iter().map(|c| c.to_string()).collect();
        let corner = r.corner_error.map_or(String::new(), |e| format!("{e:.3}"));
        let overlap = r
            .repeatability_overlap
            .map_or(String::new(), |v| format!("{v:.4}"));
        out.push_str(&format!(
            "{},{},{},{},{},{},{},{:.4},{}\n",
            r.detector,
            r.image,
            r.keypoints.0,
            r.keypoints.1,
            r.matches,
            correct.join(","),
            corner,
            r.repeatability_3px,
            overlap
        ));
    }
    out
}

/// Per detector, over all its pairs: the figures of the summary table.
#[derive(Clone, Debug, PartialEq)]
pub struct MatchingSummary {
    /// Detector name.
    pub detector: String,
    /// Pairs judged.
    pub pairs: usize,
    /// Correct matches at 3 px, summed over pairs.
    pub correct_3px: usize,
    /// Mean over pairs of MMA at 1 … 10 px.
    pub mma: [f64; MMA_THRESHOLDS],
    /// Pairs whose homography is accurate at each of [`CORNER_THRESHOLDS`].
    pub accurate: [usize; 3],
    /// Mean repeatability at 3 px.
    pub repeatability_3px: f64,
    /// Mean repeatability under the overlap criterion (over the pairs that have it).
    pub repeatability_overlap: Option<f64>,
}

/// Summaries in the order detectors first appear.
pub fn summarize(rows: &[PairMatching]) -> Vec<MatchingSummary> {
    let mut names: Vec<&str> = Vec::new();
    for r in rows {
        if !names.contains(&r.detector.as_str()) {
            names.push(&r.detector);
        }
    }
    names
        .into_iter()
        .map(|name| {
            let mine: Vec<&PairMatching> = rows.iter().filter(|r| r.detector == name).collect();
            let n = mine.len().max(1) as f64;
            MatchingSummary {
                detector: name.to_string(),
                pairs: mine.len(),
                correct_3px: mine.iter().map(|r| r.correct[2]).sum(),
                mma: std::array::from_fn(|t| mine.iter().map(|r| r.mma(t + 1)).sum::<f64>() / n),
                accurate: CORNER_THRESHOLDS.map(|t| mine.iter().filter(|r| r.accurate(t)).count()),
                repeatability_3px: mine.iter().map(|r| r.repeatability_3px).sum::<f64>() / n,
                repeatability_overlap: {
                    let known: Vec<f64> = mine
                        .iter()
                        .filter_map(|r| r.repeatability_overlap)
                        .collect();
                    (!known.is_empty()).then(|| known.iter().sum::<f64>() / known.len() as f64)
                },
            }
        })
        .collect()
}

/// The summary as a Markdown table.
pub fn summary_table(summaries: &[MatchingSummary]) -> String {
    let mut out = String::from(
        "| detector | correct @3px | MMA @1 | MMA @3 | MMA @5 | MMA @10 | H acc @1 | H acc @3 | H acc @5 | rep. @3px | rep. overlap |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for s in summaries {
        out.push_str(&format!(
            "| {} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {}/{} | {}/{} | {}/{} | {:.3} | {} |\n",
            s.detector,
            s.correct_3px,
            s.mma[0],
            s.mma[2],
            s.mma[4],
            s.mma[9],
            s.accurate[0],
            s.pairs,
            s.accurate[1],
            s.pairs,
            s.accurate[2],
            s.pairs,
            s.repeatability_3px,
            s.repeatability_overlap
                .map_or("n/a".to_string(), |v| format!("{v:.3}"))
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::recall::Descriptors;

    #[test]
    fn a_shifted_set_matches_fully_and_its_homography_is_exact() {
        let mut rng = crate::rng::Rng(5);
        let points: Vec<(f64, f64)> = (0..60)
            .map(|_| (rng.range(0.0, 300.0) as f64, rng.range(0.0, 200.0) as f64))
            .collect();
        let descriptors: Vec<Vec<f32>> = (0..60)
            .map(|_| (0..16).map(|_| rng.range(0.0, 1.0)).collect())
            .collect();
        let a = KeypointSet {
            points: points.clone(),
            descriptors: Descriptors::Float(descriptors.clone()),
            scales: vec![2.0; 60],
        };
        let h = [1.0, 0.0, 5.0, 0.0, 1.0, -3.0, 0.0, 0.0, 1.0];
        let b = KeypointSet {
            points: points.iter().map(|&(x, y)| (x + 5.0, y - 3.0)).collect(),
            descriptors: Descriptors::Float(descriptors),
            scales: vec![2.0; 60],
        };
        let judge = |h: &Homography| {
            judge_pair(
                "t",
                "p",
                &a,
                (300, 200),
                &b,
                (300, 200),
                h,
                (0.8, 10.0, 3.0),
            )
        };
        let r = judge(&h);
        assert_eq!((r.matches, r.correct[0]), (60, 60));
        assert!(r.repeatability_3px == 1.0 && r.repeatability_overlap == Some(1.0));
        assert!(r.corner_error.unwrap() < 1e-6 && r.accurate(1.0));
        // The same points judged against a wrong map: matched, never correct.
        let wrong = [1.0, 0.0, 40.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let r = judge(&wrong);
        assert_eq!((r.matches, r.correct[9]), (60, 0));
        assert!(!r.accurate(5.0) && r.mma(10) == 0.0);
    }
}
