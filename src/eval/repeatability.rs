//! Repeatability (eq 11): R = |F1 ∩ F2| / min(|F1|, |F2|), where F1 and F2 are the keypoints of
//! two views restricted to the part of the scene both views see, and ∩ is a one-to-one
//! matching of points within ε pixels after mapping view 1 into view 2 with the ground truth.

/// The figures of one comparison; the counts travel with the ratio.
#[derive(Clone, Debug, PartialEq)]
pub struct Repeatability {
    /// |F1 ∩ F2| / min(|F1|, |F2|), 0 when either set is empty.
    pub ratio: f64,
    /// One-to-one correspondences within ε.
    pub matches: usize,
    /// Points of view 1 inside the common region.
    pub count1: usize,
    /// Points of view 2 inside the common region.
    pub count2: usize,
}

use super::homography::{invert, project, Homography};

/// Whether `p` lies at least `margin` inside a view of `size`.
pub(super) fn inside(p: (f64, f64), size: (u32, u32), margin: f64) -> bool {
    p.0 >= margin
        && p.1 >= margin
        && p.0 <= size.0 as f64 - 1.0 - margin
        && p.1 <= size.1 as f64 - 1.0 - margin
}

/// Points of each view inside the region both views see (the point and its ground-truth image
/// each at least `margin` inside their views), and their one-to-one ground-truth
/// correspondences within ε (greedy by distance, so no point is counted twice).
#[derive(Clone, Debug, PartialEq)]
pub struct Correspondences {
    /// Indices into view 1's points of those whose projection lands inside view 2.
    pub inside1: Vec<usize>,
    /// Indices into view 2's points of those whose back-projection lands inside view 1.
    pub inside2: Vec<usize>,
    /// Pairs (index into view 1's points, index into view 2's points).
    pub pairs: Vec<(usize, usize)>,
}

/// Finds the common region's points and the one-to-one correspondences within `eps`. A
/// singular `h` maps no region of view 2 back into view 1: nothing corresponds (and a warning
/// says why), rather than a panic.
pub fn correspondences(
    p1: &[(f64, f64)],
    size1: (u32, u32),
    p2: &[(f64, f64)],
    size2: (u32, u32),
    h: &Homography,
    eps: f64,
    margin: f64,
) -> Correspondences {
    let Some(hinv) = invert(h) else {
        log::warn!("the homography {h:?} is singular: no common region, nothing corresponds");
        return Correspondences {
            inside1: Vec::new(),
            inside2: Vec::new(),
            pairs: Vec::new(),
        };
    };
    let projected: Vec<Option<(f64, f64)>> = p1.iter().map(|&(x, y)| project(h, x, y)).collect();
    // A point counts when it and its ground-truth image both lie at least `margin` inside
    // their views. Checking only the image (as a one-sided test would) keeps view-1 points
    // near view 1's own border whose partners view 2 must leave out, so the region would
    // differ between the views and swapping them would change the figure.
    let inside1: Vec<usize> = (0..p1.len())
        .filter(|&i| {
            inside(p1[i], size1, margin) && projected[i].is_some_and(|q| inside(q, size2, margin))
        })
        .collect();
    let inside2: Vec<usize> = (0..p2.len())
        .filter(|&j| {
            inside(p2[j], size2, margin)
                && project(&hinv, p2[j].0, p2[j].1).is_some_and(|q| inside(q, size1, margin))
        })
        .collect();
    let mut candidates: Vec<(f64, usize, usize)> = Vec::new();
    for &i in &inside1 {
        let a = projected[i].expect("inside points project");
        for &j in &inside2 {
            let b = p2[j];
            let d2 = (a.0 - b.0).powi(2) + (a.1 - b.1).powi(2);
            if d2 <= eps * eps {
                candidates.push((d2, i, j));
            }
        }
    }
    candidates.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let (mut used1, mut used2) = (vec![false; p1.len()], vec![false; p2.len()]);
    let mut pairs = Vec::new();
    for (_, i, j) in candidates {
        if !used1[i] && !used2[j] {
            used1[i] = true;
            used2[j] = true;
            pairs.push((i, j));
        }
    }
    Correspondences {
        inside1,
        inside2,
        pairs,
    }
}

/// Repeatability of `p1` (in an image of `size1`) and `p2` (in `size2`) related by the
/// homography `h` (view 1 → view 2), with tolerance `eps` pixels and a border `margin`.
/// Each point set should already be cut to the same number of strongest points.
pub fn repeatability(
    p1: &[(f64, f64)],
    size1: (u32, u32),
    p2: &[(f64, f64)],
    size2: (u32, u32),
    h: &Homography,
    eps: f64,
    margin: f64,
) -> Repeatability {
    let c = correspondences(p1, size1, p2, size2, h, eps, margin);
    let denom = c.inside1.len().min(c.inside2.len());
    Repeatability {
        ratio: if denom == 0 {
            0.0
        } else {
            c.pairs.len() as f64 / denom as f64
        },
        matches: c.pairs.len(),
        count1: c.inside1.len(),
        count2: c.inside2.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_singular_homography_gives_no_correspondences_not_a_panic() {
        let points = [(10.0, 10.0), (20.0, 30.0)];
        let r = repeatability(&points, (64, 64), &points, (64, 64), &[0.0; 9], 2.0, 0.0);
        assert_eq!((r.ratio, r.matches, r.count1, r.count2), (0.0, 0, 0, 0));
    }

    const ID: [f64; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

    #[test]
    fn identity_is_one_and_matching_is_one_to_one() {
        let p = vec![(10.0, 10.0), (20.0, 20.0), (30.0, 12.0)];
        assert_eq!(
            repeatability(&p, (50, 50), &p, (50, 50), &ID, 2.0, 0.0).ratio,
            1.0
        );
        // Two points of view 1 near one point of view 2: one match only.
        let a = vec![(10.0, 10.0), (10.5, 10.0)];
        let b = vec![(10.2, 10.0)];
        let r = repeatability(&a, (50, 50), &b, (50, 50), &ID, 2.0, 0.0);
        assert_eq!((r.matches, r.ratio), (1, 1.0));
    }

    #[test]
    fn shift_and_overlap() {
        let h = [1.0, 0.0, 5.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let a = vec![(10.0, 10.0), (47.0, 10.0)]; // the second leaves view 2
        let b = vec![(15.0, 10.0), (2.0, 30.0)]; // the second comes from outside view 1
        let r = repeatability(&a, (50, 50), &b, (50, 50), &h, 2.0, 0.0);
        assert_eq!((r.count1, r.count2, r.matches), (1, 1, 1));
    }

    #[test]
    fn the_common_region_is_the_same_from_both_sides() {
        // View 2 is view 1 shifted 20 px right on a wider canvas. The point 3 px from view 1's
        // left border lands well inside view 2, but its partner in view 2 sits 3 px from where
        // view 1's border maps: with a 10-px margin neither may count, whichever view is first.
        let h = [1.0, 0.0, 20.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let hinv = [1.0, 0.0, -20.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let a = vec![(3.0, 25.0), (25.0, 25.0)];
        let b = vec![(23.0, 25.0), (45.0, 25.0)];
        let r = repeatability(&a, (50, 50), &b, (90, 50), &h, 2.0, 10.0);
        assert_eq!((r.count1, r.count2, r.matches), (1, 1, 1));
        let back = repeatability(&b, (90, 50), &a, (50, 50), &hinv, 2.0, 10.0);
        assert_eq!((back.count1, back.count2, back.matches), (1, 1, 1));
    }
}
