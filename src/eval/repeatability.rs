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

/// Applies a 3×3 row-major homography.
pub fn project(h: &[f64; 9], x: f64, y: f64) -> Option<(f64, f64)> {
    let w = h[6] * x + h[7] * y + h[8];
    if w.abs() < 1e-12 {
        return None;
    }
    Some((
        (h[0] * x + h[1] * y + h[2]) / w,
        (h[3] * x + h[4] * y + h[5]) / w,
    ))
}

/// Inverse of a 3×3 matrix (None when singular).
pub fn invert(h: &[f64; 9]) -> Option<[f64; 9]> {
    let [a, b, c, d, e, f, g, hh, i] = *h;
    let det = a * (e * i - f * hh) - b * (d * i - f * g) + c * (d * hh - e * g);
    if det.abs() < 1e-15 {
        return None;
    }
    let inv = [
        e * i - f * hh,
        c * hh - b * i,
        b * f - c * e,
        f * g - d * i,
        a * i - c * g,
        c * d - a * f,
        d * hh - e * g,
        b * g - a * hh,
        a * e - b * d,
    ];
    Some(inv.map(|v| v / det))
}

fn inside(p: (f64, f64), size: (u32, u32), margin: f64) -> bool {
    p.0 >= margin
        && p.1 >= margin
        && p.0 <= size.0 as f64 - 1.0 - margin
        && p.1 <= size.1 as f64 - 1.0 - margin
}

/// Repeatability of `p1` (in an image of `size1`) and `p2` (in `size2`) related by the
/// homography `h` (view 1 → view 2), with tolerance `eps` pixels and a border `margin`.
/// Each point set should already be cut to the same number of strongest points.
pub fn repeatability(
    p1: &[(f64, f64)],
    size1: (u32, u32),
    p2: &[(f64, f64)],
    size2: (u32, u32),
    h: &[f64; 9],
    eps: f64,
    margin: f64,
) -> Repeatability {
    let hinv = invert(h).expect("ground-truth homography is invertible");
    let a: Vec<(f64, f64)> = p1
        .iter()
        .filter_map(|&(x, y)| project(h, x, y))
        .filter(|&q| inside(q, size2, margin))
        .collect();
    let b: Vec<(f64, f64)> = p2
        .iter()
        .copied()
        .filter(|&(x, y)| project(&hinv, x, y).is_some_and(|q| inside(q, size1, margin)))
        .collect();
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, pa) in a.iter().enumerate() {
        for (j, pb) in b.iter().enumerate() {
            let d2 = (pa.0 - pb.0).powi(2) + (pa.1 - pb.1).powi(2);
            if d2 <= eps * eps {
                pairs.push((d2, i, j));
            }
        }
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let (mut used_a, mut used_b) = (vec![false; a.len()], vec![false; b.len()]);
    let mut matches = 0;
    for (_, i, j) in pairs {
        if !used_a[i] && !used_b[j] {
            used_a[i] = true;
            used_b[j] = true;
            matches += 1;
        }
    }
    let denom = a.len().min(b.len());
    Repeatability {
        ratio: if denom == 0 {
            0.0
        } else {
            matches as f64 / denom as f64
        },
        matches,
        count1: a.len(),
        count2: b.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
