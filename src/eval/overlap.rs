//! Repeatability with the region-overlap criterion of the Oxford protocol (Mikolajczyk et al.,
//! IJCV 2005), beside the pixel criterion of eq 11: each keypoint stands for a disc of radius
//! [`REGION_SIGMAS`] × its scale; the disc of view 1 is mapped into view 2 through the local
//! scale of the true homography, both are rescaled so that it has a radius of
//! [`NORMALISED_RADIUS`] px, and two keypoints correspond when the overlap error
//! 1 − |A ∩ B| / |A ∪ B| is at most [`MAX_OVERLAP_ERROR`]. A keypoint at the wrong scale fails
//! it however close it is, so the figure shows what the pixel criterion cannot: whether the
//! scales follow a zoom.
//!
//! The same discs decide which keypoints eq 11 judges at all ([`common_region`]): only those
//! whose region lies inside both views.
//!
//! Discs stand in for the protocol's ellipses: exact under zoom and rotation, an approximation
//! under the perspective of a viewpoint change.

use super::homography::{invert, project, Homography};
use super::recall::KeypointSet;
use super::repeatability::{correspondences, inside, Repeatability};

/// A keypoint's region is a disc of this many times its scale.
pub const REGION_SIGMAS: f64 = 3.0;
/// The region of view 1 is rescaled to this radius before the overlap is measured.
pub const NORMALISED_RADIUS: f64 = 30.0;
/// Largest overlap error of a correspondence.
pub const MAX_OVERLAP_ERROR: f64 = 0.4;

/// Isotropic local scale √|det J| of `h` at (x, y), J its Jacobian.
fn local_scale(h: &Homography, x: f64, y: f64) -> Option<f64> {
    let e = 0.5;
    let (ax, ay) = project(h, x - e, y)?;
    let (bx, by) = project(h, x + e, y)?;
    let (cx, cy) = project(h, x, y - e)?;
    let (dx, dy) = project(h, x, y + e)?;
    let det = ((bx - ax) * (dy - cy) - (by - ay) * (dx - cx)) / (4.0 * e * e);
    let s = det.abs().sqrt();
    (s.is_finite() && s > 0.0).then_some(s)
}

/// The points of `set` (in a view of `size`) whose region (a disc of `region_sigmas` × the
/// point's scale) lies inside their own view and, mapped by `h` (this view → the other, through
/// its local scale), inside the other view of `other`: the common region of eq 11 for points
/// that stand for regions. A point whose region reaches past a border measures scene that one
/// view does not see (on a rotated view's canvas, the black corners), so its twin cannot be
/// judged; the Oxford protocol likewise keeps only regions inside both images. A set without
/// scales, or `region_sigmas` 0, is returned whole (the centre's `margin` still applies later).
pub fn inside_both_views(
    set: &KeypointSet,
    size: (u32, u32),
    other: (u32, u32),
    h: &Homography,
    region_sigmas: f64,
) -> KeypointSet {
    if region_sigmas <= 0.0 || set.scales.len() != set.points.len() {
        return set.clone();
    }
    let keep: Vec<usize> = (0..set.points.len())
        .filter(|&i| {
            let (x, y) = set.points[i];
            let radius = region_sigmas * set.scales[i];
            let mapped = project(h, x, y).zip(local_scale(h, x, y));
            inside((x, y), size, radius)
                && mapped.is_some_and(|(q, s)| inside(q, other, radius * s))
        })
        .collect();
    set.select(&keep)
}

/// Both views' points cut to those whose regions lie inside both views
/// ([`inside_both_views`]; `h` maps view a to view b). A singular `h` leaves them whole: the
/// correspondences then find no common region and say why.
pub fn common_region(
    a: &KeypointSet,
    sa: (u32, u32),
    b: &KeypointSet,
    sb: (u32, u32),
    h: &Homography,
    region_sigmas: f64,
) -> (KeypointSet, KeypointSet) {
    match invert(h) {
        Some(back) => (
            inside_both_views(a, sa, sb, h, region_sigmas),
            inside_both_views(b, sb, sa, &back, region_sigmas),
        ),
        None => (a.clone(), b.clone()),
    }
}

/// Overlap error 1 − |A ∩ B| / |A ∪ B| of discs of radii `r1`, `r2` whose centres are `d` apart.
pub fn disc_overlap_error(r1: f64, r2: f64, d: f64) -> f64 {
    let (a1, a2) = (
        std::f64::consts::PI * r1 * r1,
        std::f64::consts::PI * r2 * r2,
    );
    let inter = if d >= r1 + r2 {
        0.0
    } else if d <= (r1 - r2).abs() {
        a1.min(a2)
    } else {
        let alpha = ((d * d + r1 * r1 - r2 * r2) / (2.0 * d * r1))
            .clamp(-1.0, 1.0)
            .acos();
        let beta = ((d * d + r2 * r2 - r1 * r1) / (2.0 * d * r2))
            .clamp(-1.0, 1.0)
            .acos();
        r1 * r1 * (alpha - alpha.sin() * alpha.cos()) + r2 * r2 * (beta - beta.sin() * beta.cos())
    };
    1.0 - inter / (a1 + a2 - inter)
}

/// Repeatability under the overlap criterion of two keypoint sets (each already cut to the
/// same number of strongest points) in views of `size1` and `size2` related by `h`, in the
/// common region of eq 11 with a border `margin`. `None` when either set has no scales.
pub fn overlap_repeatability(
    a: &KeypointSet,
    size1: (u32, u32),
    b: &KeypointSet,
    size2: (u32, u32),
    h: &Homography,
    margin: f64,
) -> Option<Repeatability> {
    if a.scales.len() != a.points.len() || b.scales.len() != b.points.len() {
        return None;
    }
    let region = correspondences(&a.points, size1, &b.points, size2, h, 0.0, margin);
    let mut candidates: Vec<(f64, usize, usize)> = Vec::new();
    for &i in &region.inside1 {
        let (x, y) = a.points[i];
        let (Some((u, v)), Some(s)) = (project(h, x, y), local_scale(h, x, y)) else {
            continue;
        };
        let r1 = REGION_SIGMAS * a.scales[i] * s;
        if r1 <= 0.0 {
            continue;
        }
        let k = NORMALISED_RADIUS / r1;
        for &j in &region.inside2 {
            let (p, q) = b.points[j];
            let r2 = REGION_SIGMAS * b.scales[j];
            let d = (u - p).hypot(v - q);
            if d >= r1 + r2 {
                continue;
            }
            let error = disc_overlap_error(NORMALISED_RADIUS, r2 * k, d * k);
            if error <= MAX_OVERLAP_ERROR {
                candidates.push((error, i, j));
            }
        }
    }
    candidates.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let (mut used1, mut used2) = (vec![false; a.points.len()], vec![false; b.points.len()]);
    let mut matches = 0;
    for (_, i, j) in candidates {
        if !used1[i] && !used2[j] {
            used1[i] = true;
            used2[j] = true;
            matches += 1;
        }
    }
    let denom = region.inside1.len().min(region.inside2.len());
    Some(Repeatability {
        ratio: if denom == 0 {
            0.0
        } else {
            matches as f64 / denom as f64
        },
        matches,
        count1: region.inside1.len(),
        count2: region.inside2.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::recall::Descriptors;

    #[test]
    fn disc_overlap_is_zero_for_equal_discs_and_one_when_apart() {
        assert!(disc_overlap_error(3.0, 3.0, 0.0).abs() < 1e-12);
        assert_eq!(disc_overlap_error(3.0, 3.0, 6.0), 1.0);
        // A disc inside one of twice its radius: intersection ¼ of the union.
        assert!((disc_overlap_error(1.0, 2.0, 0.5) - 0.75).abs() < 1e-12);
    }

    #[test]
    fn the_right_place_at_the_wrong_scale_fails_the_overlap_test() {
        let set = |scales: Vec<f64>| KeypointSet {
            points: vec![(50.0, 50.0), (120.0, 80.0)],
            descriptors: Descriptors::Float(vec![vec![0.0]; 2]),
            scales,
        };
        // A zoom ×2 about the origin: the points move, their scales must double.
        let h = [2.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 1.0];
        let a = set(vec![2.0, 4.0]);
        let mut b = set(vec![4.0, 8.0]);
        b.points = vec![(100.0, 100.0), (240.0, 160.0)];
        let r = overlap_repeatability(&a, (200, 150), &b, (400, 300), &h, 0.0).unwrap();
        assert_eq!((r.matches, r.ratio), (2, 1.0));
        let same_scale = KeypointSet {
            scales: vec![2.0, 4.0],
            ..b.clone()
        };
        let r = overlap_repeatability(&a, (200, 150), &same_scale, (400, 300), &h, 0.0).unwrap();
        assert_eq!(r.matches, 0);
        let unknown = KeypointSet {
            scales: Vec::new(),
            ..b
        };
        assert!(overlap_repeatability(&a, (200, 150), &unknown, (400, 300), &h, 0.0).is_none());
    }

    #[test]
    fn a_region_past_either_border_leaves_the_common_region() {
        let set = |points: Vec<(f64, f64)>, scales: Vec<f64>| KeypointSet {
            descriptors: Descriptors::Float(vec![vec![0.0]; points.len()]),
            points,
            scales,
        };
        // View 2 is view 1 shifted 100 px right on a canvas 200 px wider, and zoomed ×2.
        let h = [2.0, 0.0, 100.0, 0.0, 2.0, 0.0, 0.0, 0.0, 1.0];
        let a = set(
            vec![(20.0, 50.0), (20.0, 50.0), (90.0, 50.0), (180.0, 50.0)],
            vec![2.0, 10.0, 10.0, 10.0],
        );
        // 20 px from view 1's left border: a scale of 2 (region 6 px) stays, a scale of 10
        // (region 30 px) goes; at x = 180, 19 px from the right border, scale 10 goes too.
        let kept = inside_both_views(&a, (200, 100), (600, 200), &h, 3.0);
        assert_eq!(kept.points, vec![(20.0, 50.0), (90.0, 50.0)]);
        assert_eq!(kept.scales, vec![2.0, 10.0]);
        // Mapped into view 2, (90, 50) lands at (280, 100) with a region of 60 px: inside
        // a 600×200 view, not a 600×150 one.
        let kept = inside_both_views(&a, (200, 100), (600, 150), &h, 3.0);
        assert_eq!(kept.points, vec![(20.0, 50.0)]);
        // Centres only with 0, and for a set without scales.
        assert_eq!(inside_both_views(&a, (200, 100), (600, 150), &h, 0.0), a);
        let bare = set(a.points.clone(), Vec::new());
        assert_eq!(
            inside_both_views(&bare, (200, 100), (600, 150), &h, 3.0),
            bare
        );
    }
}
