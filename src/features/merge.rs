//! The two-stage merge of section 2.2.2: the detections of all N orientations and S scales are
//! clustered, clusters whose means end up close are merged, and each cluster's mean becomes a
//! keypoint.
//!
//! The default (`covariant`) is built so that a rotated or zoomed image merges into the rotated
//! or zoomed keypoints: stage 1 is k-means seeded deterministically by a radius suppression over
//! the candidates, strongest first, with each mean confined to its neighbourhood (assignment
//! radius 1.5·r); stage 2 merges the means that end up within r of a stronger one. The radius
//! grows with scale (r·σ_D/σ_0, the larger of the two scales) and only adjacent scales meet,
//! so a fine and a coarse keypoint at one place both survive; `pixel` keeps r at every scale
//! and across all scales. `kmeans-pp` is the literal reading (k-means++ random starts over all
//! candidates), kept for comparison. `spread = "anms"` then picks the kept clusters by adaptive
//! non-maximal suppression within an octave instead of by rank.
//!
//! Clusters are ranked (and cut to `max_keypoints`) by their strength: the strongest member
//! response times its scale's `rank_weight`, so ranking across scales has its own
//! normalisation, apart from the one that selected each corner's scale.

use rayon::prelude::*;

use super::config::{MergeMode, Spread};
use super::harris::HarrisPlan;
use super::neighbours::{dist2, ScaleGrids};
use super::Candidate;

/// A merged cluster before its descriptor is computed.
#[derive(Clone, Debug, PartialEq)]
pub struct Cluster {
    /// Response-weighted mean column.
    pub x: f32,
    /// Response-weighted mean row.
    pub y: f32,
    /// Strongest member response.
    pub response: f32,
    /// The ranking key: the strongest member response weighted by its scale's `rank_weight`.
    pub strength: f32,
    /// Scale index with the largest summed member response.
    pub scale_index: usize,
    /// Response-weighted mean sub-scale offset of the members at that scale, in scale steps
    /// within ±0.5: the cluster's characteristic scale is σ_D(scale_index)·scale_step^offset.
    pub scale_offset: f32,
    /// Orientation index with the largest summed member response.
    pub orientation_index: usize,
    /// Number of member candidates.
    pub members: usize,
}

/// Running statistics of a cluster.
#[derive(Clone, Debug)]
struct Stats {
    wsum: f64,
    sx: f64,
    sy: f64,
    max: f32,
    strength: f32,
    count: usize,
    by_scale: Vec<f64>,
    /// Per scale, Σ w·(sub-scale offset) of its members.
    offset_by_scale: Vec<f64>,
    by_orientation: Vec<f64>,
}

impl Stats {
    fn new(scales: usize, orientations: usize) -> Self {
        Self {
            wsum: 0.0,
            sx: 0.0,
            sy: 0.0,
            max: f32::MIN,
            strength: f32::MIN,
            count: 0,
            by_scale: vec![0.0; scales],
            offset_by_scale: vec![0.0; scales],
            by_orientation: vec![0.0; orientations],
        }
    }
    fn add(&mut self, c: &Candidate, plan: &HarrisPlan) {
        let w = c.response.max(1e-20) as f64;
        self.wsum += w;
        self.sx += w * c.x as f64;
        self.sy += w * c.y as f64;
        self.max = self.max.max(c.response);
        self.strength = self
            .strength
            .max(c.response * plan.scales[c.scale_index()].rank_weight);
        self.count += 1;
        self.by_scale[c.scale_index()] += w;
        self.offset_by_scale[c.scale_index()] += w * c.scale_offset() as f64;
        self.by_orientation[c.orientation_index()] += w;
    }
    fn absorb(&mut self, o: &Stats) {
        self.wsum += o.wsum;
        self.sx += o.sx;
        self.sy += o.sy;
        self.max = self.max.max(o.max);
        self.strength = self.strength.max(o.strength);
        self.count += o.count;
        for (a, b) in self.by_scale.iter_mut().zip(&o.by_scale) {
            *a += b;
        }
        for (a, b) in self.offset_by_scale.iter_mut().zip(&o.offset_by_scale) {
            *a += b;
        }

        for (a, b) in self.by_orientation.iter_mut().zip(&o.by_orientation) {
            *a += b;
        }
    }
    /// The response-weighted mean sub-scale offset of the members at scale `s`.
    fn offset_at(&self, s: usize) -> f32 {
        if self.by_scale[s] > 0.0 {
            (self.offset_by_scale[s] / self.by_scale[s]) as f32
        } else {
            0.0
        }
    }
    fn centre(&self) -> (f32, f32) {
        ((self.sx / self.wsum) as f32, (self.sy / self.wsum) as f32)
    }
}

fn argmax(v: &[f64]) -> usize {
    v.iter()
        .enumerate()
        .fold(
            (0, f64::MIN),
            |best, (i, &x)| if x > best.1 { (i, x) } else { best },
        )
        .0
}

/// Merges candidates (sorted strongest first) into clusters, strongest first, at most
/// `max_keypoints` of them.
pub fn merge(candidates: &[Candidate], plan: &HarrisPlan) -> Vec<Cluster> {
    if candidates.is_empty() {
        return Vec::new();
    }
    let cfg = &plan.config;
    let stats = match cfg.merge {
        MergeMode::Covariant | MergeMode::Pixel => covariant_stage1(candidates, plan),
        MergeMode::KmeansPp => kmeans_pp_stage1(candidates, plan),
    };
    match cfg.spread {
        Spread::Strongest => merge_close(stats, plan, cfg.max_keypoints),
        Spread::Anms => {
            let all = merge_close(stats, plan, usize::MAX);
            spread_out(all, plan)
        }
    }
}

/// Fraction of a cluster's strength another must exceed to suppress it in [`spread_out`].
const ANMS_ROBUSTNESS: f32 = 0.9;

/// Adaptive non-maximal suppression within an octave ([`Spread::Anms`]): of `clusters`
/// (strongest first), the `max_keypoints` with the largest suppression radii, still in rank
/// order.
fn spread_out(clusters: Vec<Cluster>, plan: &HarrisPlan) -> Vec<Cluster> {
    let limit = plan.config.max_keypoints;
    if clusters.len() <= limit {
        return clusters;
    }
    let octave = |a: usize, b: usize| {
        let ratio = plan.scales[a].sigma_d / plan.scales[b].sigma_d;
        (0.5..=2.0).contains(&ratio)
    };
    let radii: Vec<f32> = (0..clusters.len())
        .into_par_iter()
        .map(|i| {
            let c = &clusters[i];
            clusters[..i]
                .iter()
                .filter(|o| {
                    c.strength < ANMS_ROBUSTNESS * o.strength
                        && octave(c.scale_index, o.scale_index)
                })
                .map(|o| dist2((c.x, c.y), (o.x, o.y)))
                .fold(f32::INFINITY, f32::min)
        })
        .collect();
    let mut order: Vec<usize> = (0..clusters.len()).collect();
    order.sort_by(|&a, &b| radii[b].total_cmp(&radii[a]).then(a.cmp(&b)));
    let mut keep = vec![false; clusters.len()];
    for &i in &order[..limit] {
        keep[i] = true;
    }
    clusters
        .into_iter()
        .zip(keep)
        .filter_map(|(c, k)| k.then_some(c))
        .collect()
}

/// The merge's radius multiplier at each scale: σ_D(s) / σ_D(0), or 1 for the pixel merge.
fn radius_factors(plan: &HarrisPlan) -> Vec<f32> {
    let s0 = plan.scales[0].sigma_d;
    match plan.config.merge {
        MergeMode::Pixel => vec![1.0; plan.scales.len()],
        _ => plan.scales.iter().map(|s| s.sigma_d / s0).collect(),
    }
}

/// Stage 1, covariant: radius-suppression seeds, then confined Lloyd iterations, both with
/// radii proportional to scale and only between adjacent scales, so a fine and a coarse
/// detection at the same place stay two keypoints.
fn covariant_stage1(candidates: &[Candidate], plan: &HarrisPlan) -> Vec<Stats> {
    let r = plan.config.merge_radius;
    let factor = radius_factors(plan);
    let ns = plan.scales.len();
    // A query of scale s ± 1 reaches r·factor(s ± 1) ≤ r·factor(s)·step around scale s.
    let spread = plan.config.scale_step;
    let points: Vec<(f32, f32)> = candidates.iter().map(|c| (c.x, c.y)).collect();
    let scale_of: Vec<usize> = candidates.iter().map(Candidate::scale_index).collect();
    let pair_radius = |a: usize, b: usize| r * factor[a].max(factor[b]);
    // Radius suppression, strongest first: a candidate becomes a seed unless a seed of an
    // adjacent scale lies within the pair's radius.
    let grids = ScaleGrids::new(&points, &scale_of, plan, |s| r * factor[s] * spread);
    // Only the strongest clusters are kept (stage 2 stops at max_keypoints, and a cluster is
    // led by its seed), so seeds far down the list and the candidates out of reach of the
    // strongest seeds cannot reach the output: drop them before the Lloyd iterations. The
    // suppression itself stops one seed past the limit: the later seeds would be dropped, and
    // which candidates are kept depends on the first `limit` alone.
    let limit = 4 * plan.config.max_keypoints;
    let mut is_seed = vec![false; points.len()];
    let mut seeds: Vec<usize> = Vec::new();
    for (i, &p) in points.iter().enumerate() {
        let s = scale_of[i];
        if !grids.any_near(p, s, |j| {
            let rr = pair_radius(s, scale_of[j]);
            is_seed[j] && dist2(points[j], p) <= rr * rr
        }) {
            is_seed[i] = true;
            seeds.push(i);
            if seeds.len() > limit {
                break;
            }
        }
    }
    let reach = 1.5;
    let kept: Vec<usize> = if seeds.len() > limit {
        seeds.truncate(limit);
        let seed_points: Vec<(f32, f32)> = seeds.iter().map(|&i| points[i]).collect();
        let seed_scales: Vec<usize> = seeds.iter().map(|&i| scale_of[i]).collect();
        let seed_grids = ScaleGrids::new(&seed_points, &seed_scales, plan, |s| {
            2.0 * reach * r * factor[s] * spread
        });
        (0..points.len())
            .into_par_iter()
            .filter(|&i| {
                seed_grids.any_near(points[i], scale_of[i], |k| {
                    let rr = 2.0 * reach * pair_radius(scale_of[i], seed_scales[k]);
                    dist2(seed_points[k], points[i]) <= rr * rr
                })
            })
            .collect()
    } else {
        (0..points.len()).collect()
    };
    let candidates: Vec<Candidate> = kept.iter().map(|&i| candidates[i]).collect();
    let points: Vec<(f32, f32)> = kept.iter().map(|&i| points[i]).collect();
    let scale_of: Vec<usize> = kept.iter().map(|&i| scale_of[i]).collect();
    // Every seed is within reach of itself, so it is kept; each centre keeps its seed's scale.
    let seed_at: Vec<usize> = seeds
        .iter()
        .map(|i| kept.binary_search(i).expect("seeds are kept"))
        .collect();
    let mut centre_scales: Vec<usize> = seed_at.iter().map(|&k| scale_of[k]).collect();
    let mut centres: Vec<(f32, f32)> = seed_at.iter().map(|&k| points[k]).collect();
    let mut assignment: Vec<Option<usize>> = Vec::new();
    for iteration in 0..3 {
        let grid = ScaleGrids::new(&centres, &centre_scales, plan, |s| {
            reach * r * factor[s] * spread
        });
        assignment = points
            .par_iter()
            .zip(&scale_of)
            .map(|(&p, &s)| {
                // The centre nearest in units of the pair's radius, ties to the lower index.
                let mut best: Option<(f32, usize)> = None;
                grid.for_each_near(p, s, |i| {
                    let rr = reach * pair_radius(s, centre_scales[i]);
                    let d = dist2(centres[i], p);
                    if d <= rr * rr {
                        let q = (d / (rr * rr), i);
                        if best.is_none_or(|b| q.0.total_cmp(&b.0).then(q.1.cmp(&b.1)).is_lt()) {
                            best = Some(q);
                        }
                    }
                });
                best.map(|(_, i)| i)
            })
            .collect();
        if iteration == 2 {
            break;
        }
        // Response-weighted means of the members (positions only: the full statistics are
        // gathered once, after the last assignment).
        let mut sums = vec![(0.0f64, 0.0f64, 0.0f64); centres.len()];
        for (c, a) in candidates.iter().zip(&assignment) {
            if let Some(i) = *a {
                let w = c.response.max(1e-20) as f64;
                sums[i].0 += w;
                sums[i].1 += w * c.x as f64;
                sums[i].2 += w * c.y as f64;
            }
        }
        let moved: Vec<Option<(f32, f32)>> = sums
            .iter()
            .map(|&(w, sx, sy)| (w > 0.0).then(|| ((sx / w) as f32, (sy / w) as f32)))
            .collect();
        let settled = moved
            .iter()
            .zip(&centres)
            .all(|(m, c)| m.is_some_and(|m| dist2(m, *c) < 1e-6));
        if settled {
            break;
        }
        // Empty clusters disappear; renumbering keeps the order (and so the tie-breaks).
        centre_scales = moved
            .iter()
            .zip(&centre_scales)
            .filter_map(|(m, &s)| m.map(|_| s))
            .collect();
        centres = moved.into_iter().flatten().collect();
    }
    let no = plan.orientations.len();
    let mut stats = vec![Stats::new(ns, no); centres.len()];
    for (c, a) in candidates.iter().zip(&assignment) {
        if let Some(i) = *a {
            stats[i].add(c, plan);
        }
    }
    stats.retain(|s| s.count > 0);
    stats
}

/// Stage 1, literal: k-means++ over all candidates with k = max_keypoints, 10 Lloyd iterations.
fn kmeans_pp_stage1(candidates: &[Candidate], plan: &HarrisPlan) -> Vec<Stats> {
    let points: Vec<(f32, f32)> = candidates.iter().map(|c| (c.x, c.y)).collect();
    let k = plan.config.max_keypoints.min(points.len());
    let mut rng = crate::rng::Rng(plan.config.seed);
    let mut centres = vec![points[(rng.unit_f64() * points.len() as f64) as usize % points.len()]];
    let mut d2: Vec<f32> = points.iter().map(|&p| dist2(p, centres[0])).collect();
    while centres.len() < k {
        let total: f64 = d2.iter().map(|&d| d as f64).sum();
        if total <= 0.0 {
            break;
        }
        let mut target = rng.unit_f64() * total;
        let mut pick = points.len() - 1;
        for (i, &d) in d2.iter().enumerate() {
            target -= d as f64;
            if target <= 0.0 {
                pick = i;
                break;
            }
        }
        let c = points[pick];
        centres.push(c);
        d2.par_iter_mut()
            .zip(&points)
            .for_each(|(d, &p)| *d = d.min(dist2(p, c)));
    }
    let (ns, no) = (plan.scales.len(), plan.orientations.len());
    let mut stats = Vec::new();
    for _ in 0..10 {
        let assignment: Vec<usize> = points
            .par_iter()
            .map(|&p| {
                centres
                    .iter()
                    .enumerate()
                    .map(|(i, &c)| (dist2(c, p), i))
                    .min_by(|a, b| a.0.total_cmp(&b.0))
                    .map_or(0, |(_, i)| i)
            })
            .collect();
        stats = vec![Stats::new(ns, no); centres.len()];
        let mut plain = vec![(0.0f64, 0.0f64, 0usize); centres.len()];
        for ((c, &a), p) in candidates.iter().zip(&assignment).zip(&points) {
            stats[a].add(c, plan);
            plain[a].0 += p.0 as f64;
            plain[a].1 += p.1 as f64;
            plain[a].2 += 1;
        }
        // Plain (unweighted) means, as k-means is usually run.
        centres = plain
            .iter()
            .zip(&centres)
            .map(|(&(sx, sy, n), &c)| {
                if n > 0 {
                    ((sx / n as f64) as f32, (sy / n as f64) as f32)
                } else {
                    c
                }
            })
            .collect();
    }
    stats.retain(|s| s.count > 0);
    stats
}

/// Stage 2: strongest first, each cluster absorbs the weaker ones of an adjacent scale whose
/// means lie within r times the larger scale factor. Clusters come out strongest first (an
/// absorbed cluster is weaker than its absorber), so the loop stops at `limit`.
fn merge_close(mut stats: Vec<Stats>, plan: &HarrisPlan, limit: usize) -> Vec<Cluster> {
    let r = plan.config.merge_radius;
    let factor = radius_factors(plan);
    stats.sort_by(|a, b| {
        let (ca, cb) = (a.centre(), b.centre());
        b.strength
            .total_cmp(&a.strength)
            .then(ca.1.total_cmp(&cb.1))
            .then(ca.0.total_cmp(&cb.0))
    });
    let centres: Vec<(f32, f32)> = stats.iter().map(Stats::centre).collect();
    let scales: Vec<usize> = stats.iter().map(|s| argmax(&s.by_scale)).collect();
    let spread = plan.config.scale_step;
    let grid = ScaleGrids::new(&centres, &scales, plan, |s| r * factor[s] * spread);
    let mut absorbed = vec![false; stats.len()];
    let mut out = Vec::new();
    for i in 0..stats.len() {
        if out.len() == limit {
            break;
        }
        if absorbed[i] {
            continue;
        }
        let mut total = stats[i].clone();
        let mut near: Vec<usize> = Vec::new();
        grid.for_each_near(centres[i], scales[i], |j| {
            let rr = r * factor[scales[i]].max(factor[scales[j]]);
            if j > i && !absorbed[j] && dist2(centres[i], centres[j]) <= rr * rr {
                near.push(j);
            }
        });
        near.sort_unstable();
        for j in near {
            absorbed[j] = true;
            total.absorb(&stats[j]);
        }
        let scale_index = argmax(&total.by_scale);
        let (x, y) = total.centre();
        out.push(Cluster {
            x,
            y,
            response: total.max,
            strength: total.strength,
            scale_index,
            scale_offset: total.offset_at(scale_index),
            orientation_index: argmax(&total.by_orientation),
            members: total.count,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::{DetectorConfig, MergeMode};

    fn cand(x: f32, y: f32, r: f32, s: usize, t: usize) -> Candidate {
        Candidate {
            x,
            y,
            response: r,
            packed: Candidate::pack(s, t),
        }
    }

    #[test]
    fn nearby_detections_merge_into_one_weighted_mean() {
        let plan = HarrisPlan::new(&DetectorConfig::default());
        let mut c = vec![
            cand(10.0, 10.0, 3.0, 0, 2),
            cand(11.0, 10.0, 1.0, 1, 2),
            cand(30.0, 30.0, 2.0, 2, 5),
        ];
        crate::features::sort_candidates(&mut c);
        let m = merge(&c, &plan);
        assert_eq!(m.len(), 2);
        assert!((m[0].x - 10.25).abs() < 1e-5 && m[0].y == 10.0);
        assert_eq!(
            (m[0].scale_index, m[0].orientation_index, m[0].members),
            (0, 2, 2)
        );
        assert_eq!(
            (m[1].x, m[1].scale_index, m[1].orientation_index),
            (30.0, 2, 5)
        );
    }

    #[test]
    fn ranking_uses_its_own_scale_normalisation() {
        // A coarse corner with the larger scale-normalised response and a fine one.
        let mut c = vec![cand(10.0, 10.0, 2.0, 2, 0), cand(40.0, 40.0, 1.5, 0, 0)];
        crate::features::sort_candidates(&mut c);
        let mut cfg = DetectorConfig {
            scale_normalization: 2.0,
            rank_normalization: 0.5,
            ..DetectorConfig::default()
        };
        let m = merge(&c, &HarrisPlan::new(&cfg));
        // p_r = 0.5 < p = 2: the coarse response is weighted by (σ_e2/σ_e0)^(−6) < 0.75.
        assert_eq!((m[0].x, m[0].response), (40.0, 1.5));
        assert_eq!((m[1].x, m[1].response), (10.0, 2.0));
        assert!(m[1].strength < 0.75 * m[1].response && m[0].strength == 1.5);
        // Ranking with the selection's own normalisation restores the raw order.
        cfg.rank_normalization = cfg.scale_normalization;
        let m = merge(&c, &HarrisPlan::new(&cfg));
        assert_eq!((m[0].x, m[1].x), (10.0, 40.0));
    }

    #[test]
    fn the_merge_radius_follows_the_scale_and_far_scales_stay_apart() {
        let plan = HarrisPlan::new(&DetectorConfig::default());
        let r = plan.config.merge_radius;
        let s8 = plan.scales.iter().position(|s| s.sigma_d >= 7.9).unwrap();
        // Three orientations of a coarse corner spread over 3r (σ_D = 8: radius 8r) become
        // one keypoint; the same spread at σ_D = 1 stays three.
        let spread = |s: usize| {
            let mut c = vec![
                cand(100.0, 100.0, 3.0, s, 0),
                cand(100.0 + 1.5 * r, 100.0, 2.0, s, 3),
                cand(100.0, 100.0 + 1.5 * r, 1.0, s, 6),
            ];
            crate::features::sort_candidates(&mut c);
            merge(&c, &plan).len()
        };
        assert_eq!((spread(s8), spread(0)), (1, 3));
        // A fine corner on top of a coarse one, two scales apart: both survive.
        let mut c = vec![cand(50.0, 50.0, 2.0, 0, 0), cand(50.5, 50.0, 1.0, 2, 0)];
        crate::features::sort_candidates(&mut c);
        let m = merge(&c, &plan);
        assert_eq!(m.len(), 2);
        assert_eq!((m[0].scale_index, m[1].scale_index), (0, 2));
        // Adjacent scales at the same place merge.
        let mut c = vec![cand(50.0, 50.0, 2.0, 0, 0), cand(50.5, 50.0, 1.0, 1, 0)];
        crate::features::sort_candidates(&mut c);
        assert_eq!(merge(&c, &plan).len(), 1);
    }

    #[test]
    fn the_pixel_merge_joins_every_scale_within_its_radius_and_no_farther() {
        let plan = HarrisPlan::new(&DetectorConfig {
            merge: MergeMode::Pixel,
            ..DetectorConfig::default()
        });
        let r = plan.config.merge_radius;
        let last = plan.scales.len() - 1;
        // The finest and the coarsest scale at one place are one keypoint; a detection at
        // 3r from them, at any scale, is another.
        let mut c = vec![
            cand(50.0, 50.0, 3.0, 0, 0),
            cand(50.5, 50.0, 2.0, last, 2),
            cand(50.0 + 3.0 * r, 50.0, 1.0, last, 4),
        ];
        crate::features::sort_candidates(&mut c);
        let m = merge(&c, &plan);
        assert_eq!(m.len(), 2);
        assert_eq!((m[0].members, m[1].members), (2, 1));
    }

    #[test]
    fn anms_spreads_the_keypoints_over_the_image() {
        // A tight block of strong corners on the left, weaker ones spread on the right.
        let mut c: Vec<Candidate> = (0..40)
            .map(|i| {
                cand(
                    10.0 + (i % 8) as f32 * 5.0,
                    10.0 + (i / 8) as f32 * 5.0,
                    10.0 + i as f32,
                    0,
                    0,
                )
            })
            .chain(
                (0..10).map(|i| cand(200.0 + i as f32 * 30.0, 100.0, 1.0 + i as f32 * 0.01, 0, 0)),
            )
            .collect();
        crate::features::sort_candidates(&mut c);
        let mut cfg = DetectorConfig {
            max_keypoints: 20,
            ..DetectorConfig::default()
        };
        let right = |m: &[Cluster]| m.iter().filter(|k| k.x >= 200.0).count();
        let strongest = merge(&c, &HarrisPlan::new(&cfg));
        assert_eq!((strongest.len(), right(&strongest)), (20, 0));
        cfg.spread = Spread::Anms;
        let spread = merge(&c, &HarrisPlan::new(&cfg));
        assert_eq!(spread.len(), 20);
        assert!(right(&spread) >= 9, "{}", right(&spread));
        // Still in rank order.
        assert!(spread.windows(2).all(|w| w[0].strength >= w[1].strength));
    }

    #[test]
    fn merge_is_covariant_with_translation_and_kmeans_pp_is_deterministic() {
        let mut cfg = DetectorConfig::default();
        let pts: Vec<Candidate> = (0..200)
            .map(|i| {
                cand(
                    (i * 37 % 101) as f32 * 1.3,
                    (i * 53 % 97) as f32 * 1.1,
                    1.0 + (i % 7) as f32,
                    0,
                    0,
                )
            })
            .collect();
        let shifted: Vec<Candidate> = pts
            .iter()
            .map(|c| cand(c.x + 40.0, c.y + 25.0, c.response, 0, 0))
            .collect();
        let (mut a, mut b) = (pts.clone(), shifted);
        crate::features::sort_candidates(&mut a);
        crate::features::sort_candidates(&mut b);
        let plan = HarrisPlan::new(&cfg);
        let (ma, mb) = (merge(&a, &plan), merge(&b, &plan));
        assert_eq!(ma.len(), mb.len());
        for (p, q) in ma.iter().zip(&mb) {
            assert!((p.x + 40.0 - q.x).abs() < 1e-3 && (p.y + 25.0 - q.y).abs() < 1e-3);
        }
        cfg.merge = MergeMode::KmeansPp;
        cfg.max_keypoints = 50;
        let plan = HarrisPlan::new(&cfg);
        assert_eq!(merge(&a, &plan), merge(&a, &plan));
        assert!(merge(&a, &plan).len() <= 50);
    }
}
