//! Correspondences between the keypoints of two images: mutual nearest neighbours of the
//! descriptors with Lowe's ratio test (the matching behind recall, eq 12), verified by a
//! RANSAC homography (planar scenes, pure rotations) or fundamental matrix (general motion),
//! then guided matching: the model found restricts each keypoint's candidates to those it
//! maps within the inlier threshold, where the ratio test needs no global margin (Hartley and
//! Zisserman, *Multiple View Geometry*, §4.8 and §11.9). Beyond the paper, which evaluates
//! descriptors but never matches two images.

use nalgebra::{Matrix3, SMatrix, Vector3};
use rayon::prelude::*;

use crate::features::Keypoint;
use crate::rng::Rng;

/// One correspondence: keypoint `i` of the first image and `j` of the second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Match {
    /// Index into the first image's keypoints.
    pub i: usize,
    /// Index into the second image's keypoints.
    pub j: usize,
    /// Euclidean distance between the two descriptors.
    pub distance: f32,
}

/// Mutual nearest neighbours in descriptor space that pass the ratio test in both
/// directions: each is the other's nearest, and nearer than `ratio` × the second nearest.
/// Descriptors of `frames` frames each (2 for `steered-twin`, else 1) are as near as their
/// nearest pair of frames. Sorted by distance.
pub fn mutual_matches(a: &[Keypoint], b: &[Keypoint], ratio: f32, frames: usize) -> Vec<Match> {
    let forward = nearest(a, b, ratio, frames);
    let backward = nearest(b, a, ratio, frames);
    let mut out: Vec<Match> = forward
        .iter()
        .enumerate()
        .filter_map(|(i, f)| {
            let (j, distance) = (*f)?;
            (backward[j].map(|(back, _)| back) == Some(i)).then_some(Match { i, j, distance })
        })
        .collect();
    out.sort_by(|x, y| x.distance.total_cmp(&y.distance).then(x.i.cmp(&y.i)));
    out
}

/// For each keypoint of `from`, its nearest in `to` and the distance, when that passes the
/// ratio test against the second nearest.
fn nearest(
    from: &[Keypoint],
    to: &[Keypoint],
    ratio: f32,
    frames: usize,
) -> Vec<Option<(usize, f32)>> {
    from.par_iter()
        .map(|p| ratio_nearest(p, to.iter().enumerate(), ratio, frames))
        .collect()
}

/// The nearest of `candidates` (index, keypoint) to `p` in descriptor space and the distance,
/// when that passes the ratio test against the second nearest.
fn ratio_nearest<'a>(
    p: &Keypoint,
    candidates: impl Iterator<Item = (usize, &'a Keypoint)>,
    ratio: f32,
    frames: usize,
) -> Option<(usize, f32)> {
    let (mut best, mut second) = ((usize::MAX, f32::INFINITY), f32::INFINITY);
    for (j, q) in candidates {
        let d2 = crate::features::steered::squared_distance(&p.descriptor, &q.descriptor, frames);
        if d2 < best.1 {
            second = best.1;
            best = (j, d2);
        } else if d2 < second {
            second = d2;
        }
    }
    // Squared distances: the ratio applies squared.
    (best.0 != usize::MAX && best.1 < ratio * ratio * second).then(|| (best.0, best.1.sqrt()))
}

/// The geometric model that verifies matches.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Verification {
    /// A plane-to-plane map x₂ ~ H·x₁ (4-point DLT); error: distance in the second image.
    Homography,
    /// The epipolar constraint x₂ᵀ·F·x₁ = 0 (8-point); error: Sampson distance in pixels.
    Fundamental,
    /// No verification: every match counts as an inlier.
    None,
}

named_variants!(Verification { Homography => "homography", Fundamental => "fundamental", None => "none" });

impl Verification {
    /// Correspondences one model needs: 4 for a homography, 8 for a fundamental matrix.
    pub fn sample_size(self) -> usize {
        match self {
            Verification::Homography => 4,
            Verification::Fundamental => 8,
            Verification::None => 0,
        }
    }

    /// Why no model came out of `matches` correspondences, when none did: too few to fit
    /// one, or none that RANSAC could agree on.
    pub fn failure(self, matches: usize, model: Option<&[f64; 9]>) -> Option<String> {
        if self == Verification::None || model.is_some() {
            return None;
        }
        let need = self.sample_size();
        let model_name = match self {
            Verification::Fundamental => "a fundamental matrix",
            _ => "a homography",
        };
        Some(if matches < need {
            format!(
                "{} verification impossible: {matches} matches, {model_name} needs {need}; every match is counted an outlier",
                self.as_str()
            )
        } else {
            format!(
                "{} verification found no model among {matches} matches; every match is counted an outlier",
                self.as_str()
            )
        })
    }
}

/// The outcome of RANSAC: the model (row-major 3×3) refitted on its inliers, and which
/// correspondences are inliers.
#[derive(Clone, Debug, PartialEq)]
pub struct Verified {
    /// H or F, row-major; `None` when too few correspondences or no model was found.
    pub model: Option<[f64; 9]>,
    /// One flag per correspondence.
    pub inliers: Vec<bool>,
}

/// How two keypoint sets are matched and verified: mutual nearest neighbours passing Lowe's
/// ratio test both ways, then RANSAC, then guided matching. The CLI's `match` and the Python
/// `match` take these.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MatchSettings {
    /// Lowe's ratio, in (0, 1]: a match's distance must be below ratio × the second nearest's.
    pub ratio: f32,
    /// The geometric check.
    pub verification: Verification,
    /// RANSAC inlier threshold, pixels (transfer error, or Sampson distance).
    pub inlier_threshold: f64,
    /// Most RANSAC iterations, 1 to 1 000 000 (fewer when 99.9% confidence allows).
    pub iterations: usize,
    /// Seed of RANSAC's draws.
    pub seed: u64,
    /// Guided matching after verification: with the model RANSAC found (from at least
    /// [`GUIDED_MIN_INLIERS`] inliers), match again among the keypoints the model maps within
    /// `inlier_threshold` of each other (ratio test among those candidates, mutual), and
    /// verify again, up to [`GUIDED_ROUNDS`] times while the inliers grow. Default true.
    pub guided: bool,
    /// Frames each descriptor holds, 1 to 16 ([`crate::features::DescriptorKind::frames`]: 2
    /// for `steered-twin`): two descriptors are as near as their nearest pair of frames.
    /// Default 1.
    pub frames: usize,
}

/// Guided matching starts from a model with at least this many inliers per correspondence
/// the model needs (4 for a homography, 8 for a fundamental matrix): fewer say little about
/// whether the model is the scene's, and guiding by a wrong one would dress it in inliers.
pub const GUIDED_MIN_INLIERS: usize = 3;
/// Most rounds of guided matching and verification.
pub const GUIDED_ROUNDS: usize = 3;

impl Default for MatchSettings {
    fn default() -> Self {
        Self {
            ratio: 0.8,
            verification: Verification::Homography,
            inlier_threshold: 3.0,
            iterations: 10_000,
            seed: 1,
            guided: true,
            frames: 1,
        }
    }
}

/// Matches of two keypoint sets and their verification, one inlier flag per match.
#[derive(Clone, Debug, PartialEq)]
pub struct Matched {
    /// Sorted by descriptor distance.
    pub matches: Vec<Match>,
    /// The fitted model and the inlier flags, in the order of `matches`.
    pub verified: Verified,
}

impl MatchSettings {
    /// Checks every value, naming the bad one.
    pub fn validate(&self) -> crate::error::Result<()> {
        use crate::error::Error;
        if !(self.ratio > 0.0 && self.ratio <= 1.0) {
            return Err(Error::config("ratio", self.ratio, "must be in (0, 1]"));
        }
        if !(self.inlier_threshold.is_finite() && self.inlier_threshold > 0.0) {
            return Err(Error::config(
                "inlier_threshold",
                self.inlier_threshold,
                "must be a positive number of pixels",
            ));
        }
        if !(1..=16).contains(&self.frames) {
            return Err(Error::config("frames", self.frames, "must be 1 to 16"));
        }
        if !(1..=1_000_000).contains(&self.iterations) {
            return Err(Error::config(
                "iterations",
                self.iterations,
                "must be in 1..=1000000",
            ));
        }
        Ok(())
    }

    /// Matches `a` to `b` and verifies the matches. Both sets must carry descriptors of one
    /// length; sets without descriptors are refused, since nothing could match.
    pub fn run(&self, a: &[Keypoint], b: &[Keypoint]) -> crate::error::Result<Matched> {
        use crate::error::Error;
        self.validate()?;
        if let (Some(p), Some(q)) = (a.first(), b.first()) {
            if p.descriptor.len() != q.descriptor.len() {
                return Err(Error::input(
                    format!(
                        "descriptors of {} and {} values",
                        p.descriptor.len(),
                        q.descriptor.len()
                    ),
                    "both sets must be described the same way",
                ));
            }
            if p.descriptor.is_empty() {
                return Err(Error::input(
                    "keypoints without descriptors (descriptor = \"none\")",
                    "nothing to match on",
                ));
            }
        }
        let mut best = self.verified(a, b, mutual_matches(a, b, self.ratio, self.frames));
        if !self.guided {
            return Ok(best);
        }
        for _ in 0..GUIDED_ROUNDS {
            let Some(model) = best.verified.model else {
                break;
            };
            let inliers = best.verified.inliers.iter().filter(|&&f| f).count();
            if inliers < GUIDED_MIN_INLIERS * self.verification.sample_size() {
                break;
            }
            let guided = guided_matches(
                a,
                b,
                self.verification,
                &model,
                self.inlier_threshold,
                self.ratio,
                self.frames,
            );
            let next = self.verified(a, b, guided);
            if next.verified.inliers.iter().filter(|&&f| f).count() <= inliers {
                break;
            }
            best = next;
        }
        Ok(best)
    }

    /// `matches` between `a` and `b` with their RANSAC verification.
    fn verified(&self, a: &[Keypoint], b: &[Keypoint], matches: Vec<Match>) -> Matched {
        let point = |k: &Keypoint| (k.x as f64, k.y as f64);
        let pairs: Vec<PointPair> = matches
            .iter()
            .map(|m| (point(&a[m.i]), point(&b[m.j])))
            .collect();
        let verified = verify(
            &pairs,
            self.verification,
            self.inlier_threshold,
            self.iterations,
            self.seed,
        );
        Matched { matches, verified }
    }
}

/// Matches guided by `model`: each keypoint of `a` against the keypoints of `b` that the
/// model puts within `threshold` pixels of it (transfer distance for a homography, Sampson
/// distance for a fundamental matrix), the nearest descriptor passing the ratio test among
/// those candidates when there are several; then only mutual pairs (each `b` keypoint keeps
/// its nearest `a`). Sorted by distance, as [`mutual_matches`].
pub fn guided_matches(
    a: &[Keypoint],
    b: &[Keypoint],
    verification: Verification,
    model: &[f64; 9],
    threshold: f64,
    ratio: f32,
    frames: usize,
) -> Vec<Match> {
    let error: ErrorFn = match verification {
        Verification::Homography => homography_error,
        Verification::Fundamental => sampson_error,
        Verification::None => return Vec::new(),
    };
    let m = Matrix3::from_row_slice(model);
    // The errors are squared, as RANSAC compares them.
    let t2 = threshold * threshold;
    let forward: Vec<Option<(usize, f32)>> = a
        .par_iter()
        .map(|p| {
            let x = (p.x as f64, p.y as f64);
            // A NaN error (a degenerate model) is no candidate either.
            let near = b
                .iter()
                .enumerate()
                .filter(|(_, q)| error(&m, &(x, (q.x as f64, q.y as f64))) < t2);
            ratio_nearest(p, near, ratio, frames)
        })
        .collect();
    let mut nearest_a = vec![(usize::MAX, f32::INFINITY); b.len()];
    for (i, f) in forward.iter().enumerate() {
        if let Some((j, d)) = *f {
            if d < nearest_a[j].1 {
                nearest_a[j] = (i, d);
            }
        }
    }
    let mut out: Vec<Match> = forward
        .iter()
        .enumerate()
        .filter_map(|(i, f)| {
            let (j, distance) = (*f)?;
            (nearest_a[j].0 == i).then_some(Match { i, j, distance })
        })
        .collect();
    out.sort_by(|x, y| x.distance.total_cmp(&y.distance).then(x.i.cmp(&y.i)));
    out
}

/// Pixel correspondences (x₁, y₁) → (x₂, y₂).
pub type PointPair = ((f64, f64), (f64, f64));

/// RANSAC with the adaptive number of iterations for 99.9% confidence (at most
/// `max_iterations`), `threshold` pixels, then two refits on all inliers. Seeded, so a run
/// is reproducible.
pub fn verify(
    pairs: &[PointPair],
    model: Verification,
    threshold: f64,
    max_iterations: usize,
    seed: u64,
) -> Verified {
    let (sample_size, fit, error): (usize, FitFn, ErrorFn) = match model {
        Verification::None => {
            return Verified {
                model: None,
                inliers: vec![true; pairs.len()],
            }
        }
        Verification::Homography => (model.sample_size(), fit_homography, homography_error),
        Verification::Fundamental => (model.sample_size(), fit_fundamental, sampson_error),
    };
    let none = Verified {
        model: None,
        inliers: vec![false; pairs.len()],
    };
    let n = pairs.len();
    if n < sample_size {
        return none;
    }
    let t2 = threshold * threshold;
    let inliers_of =
        |m: &Matrix3<f64>| -> Vec<bool> { pairs.iter().map(|p| error(m, p) < t2).collect() };
    let mut rng = Rng(seed);
    let mut best: Option<(usize, Vec<bool>)> = None;
    let mut needed = max_iterations;
    let mut done = 0;
    let mut sample = vec![0usize; sample_size];
    while done < needed {
        done += 1;
        let mut k = 0;
        while k < sample_size {
            let i = (rng.next_u64() % n as u64) as usize;
            if !sample[..k].contains(&i) {
                sample[k] = i;
                k += 1;
            }
        }
        let Some(m) = fit(pairs, &sample) else {
            continue;
        };
        let inliers = inliers_of(&m);
        let count = inliers.iter().filter(|&&b| b).count();
        if best.as_ref().is_none_or(|(c, _)| count > *c) {
            let w = (count as f64 / n as f64).powi(sample_size as i32);
            if w > 0.0 {
                let adaptive = ((0.001f64).ln() / (1.0 - w).ln().min(-1e-12)).ceil();
                needed = needed.min(adaptive.max(1.0) as usize);
            }
            best = Some((count, inliers));
        }
    }
    let Some((_, mut inliers)) = best else {
        return none;
    };
    let mut model = None;
    for _ in 0..2 {
        let chosen: Vec<usize> = (0..n).filter(|&i| inliers[i]).collect();
        let Some(m) = fit(pairs, &chosen) else { break };
        inliers = inliers_of(&m);
        model = Some(m);
    }
    Verified {
        model: model.map(|m| std::array::from_fn(|k| m[(k / 3, k % 3)])),
        inliers,
    }
}

type FitFn = fn(&[PointPair], &[usize]) -> Option<Matrix3<f64>>;
type ErrorFn = fn(&Matrix3<f64>, &PointPair) -> f64;

/// Hartley's normalisation of the chosen points of one image: centroid at the origin, mean
/// distance √2. Returns the transform.
fn normaliser(points: impl Iterator<Item = (f64, f64)> + Clone) -> Matrix3<f64> {
    let n = points.clone().count().max(1) as f64;
    let (mx, my) = points
        .clone()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let mean = points
        .map(|(x, y)| ((x - mx).powi(2) + (y - my).powi(2)).sqrt())
        .sum::<f64>()
        / n;
    let s = if mean > 0.0 {
        std::f64::consts::SQRT_2 / mean
    } else {
        1.0
    };
    Matrix3::new(s, 0.0, -s * mx, 0.0, s, -s * my, 0.0, 0.0, 1.0)
}

/// The null vector of the stacked constraint rows (least squares for more rows than needed).
fn null_vector(rows: &[[f64; 9]]) -> Option<SMatrix<f64, 9, 1>> {
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    for r in rows {
        let v = SMatrix::<f64, 9, 1>::from_row_slice(r);
        ata += v * v.transpose();
    }
    let eigen = nalgebra::SymmetricEigen::new(ata);
    let v = eigen
        .eigenvectors
        .column(eigen.eigenvalues.imin())
        .into_owned();
    v.iter().all(|x| x.is_finite()).then_some(v)
}

fn normalised(
    pairs: &[PointPair],
    chosen: &[usize],
) -> (Matrix3<f64>, Matrix3<f64>, Vec<PointPair>) {
    let t1 = normaliser(chosen.iter().map(|&i| pairs[i].0));
    let t2 = normaliser(chosen.iter().map(|&i| pairs[i].1));
    let apply = |t: &Matrix3<f64>, (x, y): (f64, f64)| {
        (t[(0, 0)] * x + t[(0, 2)], t[(1, 1)] * y + t[(1, 2)])
    };
    let pts = chosen
        .iter()
        .map(|&i| (apply(&t1, pairs[i].0), apply(&t2, pairs[i].1)))
        .collect();
    (t1, t2, pts)
}

fn fit_homography(pairs: &[PointPair], chosen: &[usize]) -> Option<Matrix3<f64>> {
    let (t1, t2, pts) = normalised(pairs, chosen);
    let rows: Vec<[f64; 9]> = pts
        .iter()
        .flat_map(|&((x, y), (u, v))| {
            [
                [-x, -y, -1.0, 0.0, 0.0, 0.0, u * x, u * y, u],
                [0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v],
            ]
        })
        .collect();
    let h = null_vector(&rows)?;
    let h = Matrix3::from_row_slice(h.as_slice());
    let h = t2.try_inverse()? * h * t1;
    (h[(2, 2)].abs() > 1e-12).then(|| h / h[(2, 2)])
}

fn homography_error(h: &Matrix3<f64>, &((x, y), (u, v)): &PointPair) -> f64 {
    let p = h * Vector3::new(x, y, 1.0);
    if p.z.abs() < 1e-12 {
        return f64::INFINITY;
    }
    (p.x / p.z - u).powi(2) + (p.y / p.z - v).powi(2)
}

fn fit_fundamental(pairs: &[PointPair], chosen: &[usize]) -> Option<Matrix3<f64>> {
    let (t1, t2, pts) = normalised(pairs, chosen);
    let rows: Vec<[f64; 9]> = pts
        .iter()
        .map(|&((x, y), (u, v))| [u * x, u * y, u, v * x, v * y, v, x, y, 1.0])
        .collect();
    let f = null_vector(&rows)?;
    let f = Matrix3::from_row_slice(f.as_slice());
    // Rank 2: the smallest singular value set to zero.
    let svd = f.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut s = svd.singular_values;
    s[2] = 0.0;
    let f = u * Matrix3::from_diagonal(&s) * v_t;
    Some(t2.transpose() * f * t1)
}

/// Squared Sampson distance, pixels².
fn sampson_error(f: &Matrix3<f64>, &((x, y), (u, v)): &PointPair) -> f64 {
    let (a, b) = (Vector3::new(x, y, 1.0), Vector3::new(u, v, 1.0));
    let fa = f * a;
    let ftb = f.transpose() * b;
    let r = b.dot(&fa);
    let den = fa.x * fa.x + fa.y * fa.y + ftb.x * ftb.x + ftb.y * ftb.y;
    if den <= 0.0 {
        return f64::INFINITY;
    }
    r * r / den
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keypoint(x: f32, descriptor: Vec<f32>) -> Keypoint {
        Keypoint {
            x,
            y: 0.0,
            scale: 1.0,
            angle: 0.0,
            response: 1.0,
            descriptor,
        }
    }

    #[test]
    fn match_settings_refuse_bad_values_and_sets_that_cannot_match() {
        let bad = MatchSettings {
            ratio: 0.0,
            ..MatchSettings::default()
        };
        assert!(bad.validate().unwrap_err().to_string().contains("ratio"));
        let bad = MatchSettings {
            iterations: 0,
            ..MatchSettings::default()
        };
        assert!(bad
            .validate()
            .unwrap_err()
            .to_string()
            .contains("iterations"));
        let settings = MatchSettings {
            verification: Verification::None,
            ..MatchSettings::default()
        };
        let a = vec![keypoint(0.0, vec![0.0, 1.0]), keypoint(5.0, vec![1.0, 0.0])];
        let matched = settings.run(&a, &a).unwrap();
        assert_eq!(matched.matches.len(), 2);
        assert_eq!(matched.verified.inliers, vec![true, true]);
        let short = vec![keypoint(0.0, vec![0.0])];
        let e = settings.run(&a, &short).unwrap_err().to_string();
        assert!(e.contains("described the same way"), "{e}");
        let bare = vec![keypoint(0.0, Vec::new())];
        let e = settings.run(&bare, &bare).unwrap_err().to_string();
        assert!(e.contains("nothing to match on"), "{e}");
    }

    #[test]
    fn ransac_finds_a_homography_and_a_fundamental_matrix_among_outliers() {
        let h = Matrix3::new(0.9, -0.2, 30.0, 0.25, 1.1, -12.0, 1e-4, -2e-4, 1.0);
        let mut rng = Rng(3);
        let mut pairs: Vec<PointPair> = (0..80)
            .map(|_| {
                let (x, y) = (rng.range(0.0, 640.0) as f64, rng.range(0.0, 480.0) as f64);
                let p = h * Vector3::new(x, y, 1.0);
                ((x, y), (p.x / p.z, p.y / p.z))
            })
            .collect();
        for _ in 0..40 {
            let a = (rng.range(0.0, 640.0) as f64, rng.range(0.0, 480.0) as f64);
            let b = (rng.range(0.0, 640.0) as f64, rng.range(0.0, 480.0) as f64);
            pairs.push((a, b));
        }
        let v = verify(&pairs, Verification::Homography, 2.0, 2000, 1);
        assert!(v.inliers[..80].iter().all(|&b| b));
        assert!(v.inliers[80..].iter().filter(|&&b| b).count() <= 2);
        let m = v.model.unwrap();
        assert!(
            (m[2] - 30.0).abs() < 1e-3 && (m[4] - 1.1).abs() < 1e-6,
            "{m:?}"
        );
        // A homography satisfies the epipolar constraint of some F: the inliers stay inliers.
        let f = verify(&pairs, Verification::Fundamental, 1.0, 4000, 1);
        assert!(f.inliers[..80].iter().filter(|&&b| b).count() >= 78);
        assert_eq!(
            verify(&pairs[..3], Verification::Homography, 2.0, 100, 1).model,
            None
        );
    }
}
