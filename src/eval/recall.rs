//! Recall of descriptor matching (eq 12): recall = TP / (TP + FN). Every point of view 1 in the
//! common region is matched to its nearest neighbour in view 2 by descriptor distance, kept when
//! it passes the ratio test; a kept match is a true positive when the ground truth puts the two
//! points within ε. FN counts the ground-truth correspondences (one-to-one, within ε) whose view-1
//! point found no true match.

use super::homography::{project, Homography};
use super::repeatability::correspondences;

/// Descriptors of a keypoint set, one per point.
#[derive(Clone, Debug, PartialEq)]
pub enum Descriptors {
    /// Real-valued descriptors compared by Euclidean distance (steernav's entropies, SIFT, KAZE).
    Float(Vec<Vec<f32>>),
    /// Binary descriptors compared by Hamming distance (ORB, BRISK, AKAZE).
    Binary(Vec<Vec<u8>>),
    /// Real-valued descriptors of several equal frames each, as near as their nearest pair of
    /// frames (steernav's `steered-twin`: 2 frames).
    Framed(Vec<Vec<f32>>, usize),
}

impl Descriptors {
    /// Number of descriptors.
    pub fn len(&self) -> usize {
        match self {
            Descriptors::Float(v) | Descriptors::Framed(v, _) => v.len(),
            Descriptors::Binary(v) => v.len(),
        }
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The first `n`.
    pub fn truncated(&self, n: usize) -> Self {
        match self {
            Descriptors::Float(v) => Descriptors::Float(v.iter().take(n).cloned().collect()),
            Descriptors::Framed(v, f) => {
                Descriptors::Framed(v.iter().take(n).cloned().collect(), *f)
            }
            Descriptors::Binary(v) => Descriptors::Binary(v.iter().take(n).cloned().collect()),
        }
    }

    /// The nearest of `candidates` (indices into `other`) to descriptor `i` of `self`, when it
    /// passes Lowe's ratio test against the second nearest (a lone candidate passes).
    pub fn nearest(
        &self,
        i: usize,
        other: &Self,
        candidates: impl IntoIterator<Item = usize>,
        ratio: f64,
    ) -> Option<usize> {
        let (mut best, mut second) = ((f64::INFINITY, usize::MAX), f64::INFINITY);
        for j in candidates {
            let d = self.distance(i, other, j);
            if d < best.0 {
                second = best.0;
                best = (d, j);
            } else if d < second {
                second = d;
            }
        }
        (best.1 != usize::MAX && (best.0 < ratio * second || second == f64::INFINITY))
            .then_some(best.1)
    }

    /// Distance between descriptor `i` of `self` and descriptor `j` of `other` (same kind).
    pub fn distance(&self, i: usize, other: &Self, j: usize) -> f64 {
        match (self, other) {
            (Descriptors::Framed(a, f), Descriptors::Framed(b, _)) => {
                (crate::features::steered::squared_distance(&a[i], &b[j], *f) as f64).sqrt()
            }
            (Descriptors::Float(a), Descriptors::Float(b)) => a[i]
                .iter()
                .zip(&b[j])
                .map(|(x, y)| ((x - y) as f64).powi(2))
                .sum::<f64>()
                .sqrt(),
            (Descriptors::Binary(a), Descriptors::Binary(b)) => a[i]
                .iter()
                .zip(&b[j])
                .map(|(x, y)| (x ^ y).count_ones() as f64)
                .sum(),
            _ => f64::INFINITY,
        }
    }
}

/// Keypoints of one view, strongest first, with their descriptors.
#[derive(Clone, Debug, PartialEq)]
pub struct KeypointSet {
    /// Positions (x, y) in pixels.
    pub points: Vec<(f64, f64)>,
    /// One descriptor per point.
    pub descriptors: Descriptors,
    /// The scale of each point in pixels (steernav's σ_D, half an OpenCV keypoint's size), for
    /// the region-overlap criterion; empty when unknown.
    pub scales: Vec<f64>,
}

impl KeypointSet {
    /// The points at `keep` (indices in order), with their descriptors and scales.
    pub fn select(&self, keep: &[usize]) -> Self {
        let descriptors = match &self.descriptors {
            Descriptors::Float(v) => {
                Descriptors::Float(keep.iter().map(|&i| v[i].clone()).collect())
            }
            Descriptors::Framed(v, f) => {
                Descriptors::Framed(keep.iter().map(|&i| v[i].clone()).collect(), *f)
            }
            Descriptors::Binary(v) => {
                Descriptors::Binary(keep.iter().map(|&i| v[i].clone()).collect())
            }
        };
        Self {
            points: keep.iter().map(|&i| self.points[i]).collect(),
            descriptors,
            scales: if self.scales.len() == self.points.len() {
                keep.iter().map(|&i| self.scales[i]).collect()
            } else {
                Vec::new()
            },
        }
    }

    /// The `n` strongest.
    pub fn top(&self, n: usize) -> Self {
        Self {
            points: self.points.iter().take(n).copied().collect(),
            descriptors: self.descriptors.truncated(n),
            scales: self.scales.iter().take(n).copied().collect(),
        }
    }
}

/// The figures of one recall measurement.
#[derive(Clone, Debug, PartialEq)]
pub struct Recall {
    /// TP / (TP + FN); 0 when there is no ground-truth correspondence.
    pub recall: f64,
    /// Correct matches.
    pub true_positives: usize,
    /// Ground-truth correspondences whose view-1 point has no correct match.
    pub false_negatives: usize,
}

/// Recall of nearest-neighbour matching with Lowe's ratio test (`ratio`, e.g. 0.8).
#[allow(clippy::too_many_arguments)]
pub fn recall(
    a: &KeypointSet,
    size1: (u32, u32),
    b: &KeypointSet,
    size2: (u32, u32),
    h: &Homography,
    eps: f64,
    margin: f64,
    ratio: f64,
) -> Recall {
    let c = correspondences(&a.points, size1, &b.points, size2, h, eps, margin);
    let mut correct = vec![false; a.points.len()];
    let mut tp = 0;
    for &i in &c.inside1 {
        let Some(j) = a
            .descriptors
            .nearest(i, &b.descriptors, c.inside2.iter().copied(), ratio)
        else {
            continue;
        };
        let q = project(h, a.points[i].0, a.points[i].1).expect("inside points project");
        let p = b.points[j];
        if (q.0 - p.0).powi(2) + (q.1 - p.1).powi(2) <= eps * eps {
            tp += 1;
            correct[i] = true;
        }
    }
    let fneg = c.pairs.iter().filter(|&&(i, _)| !correct[i]).count();
    Recall {
        recall: if tp + fneg == 0 {
            0.0
        } else {
            tp as f64 / (tp + fneg) as f64
        },
        true_positives: tp,
        false_negatives: fneg,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::homography::IDENTITY;

    fn set(points: Vec<(f64, f64)>, d: Vec<Vec<f32>>) -> KeypointSet {
        KeypointSet {
            points,
            descriptors: Descriptors::Float(d),
            scales: Vec::new(),
        }
    }

    #[test]
    fn distinct_descriptors_match_perfectly() {
        let a = set(
            vec![(10.0, 10.0), (30.0, 30.0)],
            vec![vec![0.0, 1.0], vec![5.0, 5.0]],
        );
        let r = recall(&a, (50, 50), &a, (50, 50), &IDENTITY, 2.0, 0.0, 0.8);
        assert_eq!((r.recall, r.true_positives, r.false_negatives), (1.0, 2, 0));
    }

    #[test]
    fn swapped_descriptors_give_false_negatives() {
        let a = set(vec![(10.0, 10.0), (30.0, 30.0)], vec![vec![0.0], vec![9.0]]);
        let b = set(vec![(10.0, 10.0), (30.0, 30.0)], vec![vec![9.0], vec![0.0]]);
        let r = recall(&a, (50, 50), &b, (50, 50), &IDENTITY, 2.0, 0.0, 0.8);
        assert_eq!((r.recall, r.true_positives, r.false_negatives), (0.0, 0, 2));
    }

    #[test]
    fn ambiguous_matches_fail_the_ratio_test_and_hamming_counts_bits() {
        let a = KeypointSet {
            points: vec![(10.0, 10.0)],
            descriptors: Descriptors::Binary(vec![vec![0b1111_0000]]),
            scales: Vec::new(),
        };
        let b = KeypointSet {
            points: vec![(10.0, 10.0), (40.0, 40.0)],
            descriptors: Descriptors::Binary(vec![vec![0b1111_0001], vec![0b1111_0010]]),
            scales: Vec::new(),
        };
        let r = recall(&a, (50, 50), &b, (50, 50), &IDENTITY, 2.0, 0.0, 0.8);
        assert_eq!((r.true_positives, r.false_negatives), (0, 1));
        let b2 = KeypointSet {
            points: b.points.clone(),
            descriptors: Descriptors::Binary(vec![vec![0b1111_0000], vec![0b0000_1111]]),
            scales: Vec::new(),
        };
        assert_eq!(
            recall(&a, (50, 50), &b2, (50, 50), &IDENTITY, 2.0, 0.0, 0.8).recall,
            1.0
        );
    }
}
