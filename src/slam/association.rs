//! Data association (eqs 25–27): active search for each landmark inside the ellipse its
//! innovation covariance S predicts, by normalised cross-correlation of the patch stored when
//! the landmark was created — warped to the predicted view — confirmed by the entropy
//! descriptor of section 2.3; then 1-point RANSAC (Civera et al., 2010) separates the
//! matches consistent with one motion from the outliers, and a Mahalanobis χ² gate (eq 26)
//! rescues the high-innovation inliers after the first update.

use nalgebra::{Matrix2, Vector2, Vector3};

use super::camera::PinholeCamera;
use super::rotation::{self, Quat};
use crate::image::Frame;

/// The appearance of a landmark, captured in the frame where it was created.
#[derive(Clone, Debug)]
pub struct Template {
    /// Square grey patch of side `2 * radius + 1`, centred on the first observation.
    pub patch: Vec<f32>,
    /// Half side of `patch`.
    pub radius: usize,
    /// Pixel of the first observation.
    pub pixel: Vector2<f64>,
    /// Camera position at the first observation.
    pub position: Vector3<f64>,
    /// Camera orientation at the first observation.
    pub orientation: Quat,
    /// Entropy descriptor (eq 10) at the first observation.
    pub descriptor: [f32; 5],
}

/// Bilinear sample of a grey plane with border clamping.
pub fn sample(gray: &[f32], width: usize, height: usize, x: f64, y: f64) -> f32 {
    let x = x.clamp(0.0, (width - 1) as f64);
    let y = y.clamp(0.0, (height - 1) as f64);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(width - 1), (y0 + 1).min(height - 1));
    let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
    let row0 = gray[y0 * width + x0] * (1.0 - fx) + gray[y0 * width + x1] * fx;
    let row1 = gray[y1 * width + x0] * (1.0 - fx) + gray[y1 * width + x1] * fx;
    row0 * (1.0 - fy) + row1 * fy
}

impl Template {
    /// Captures the patch of half side `radius` around `pixel`.
    pub fn capture(
        frame: &Frame,
        pixel: Vector2<f64>,
        radius: usize,
        position: Vector3<f64>,
        orientation: Quat,
    ) -> Self {
        let (w, h) = (frame.width as usize, frame.height as usize);
        let side = 2 * radius + 1;
        let mut patch = Vec::with_capacity(side * side);
        for dy in 0..side {
            for dx in 0..side {
                patch.push(sample(
                    &frame.gray,
                    w,
                    h,
                    pixel.x + dx as f64 - radius as f64,
                    pixel.y + dy as f64 - radius as f64,
                ));
            }
        }
        Self {
            patch,
            radius,
            pixel,
            position,
            orientation,
            descriptor: crate::features::descriptor::describe(
                frame,
                pixel.x as f32,
                pixel.y as f32,
            ),
        }
    }

    /// The 2×2 map from pixel offsets in the first view to offsets in the current predicted
    /// view (r, q), through the plane at `point` facing the first camera. `None` when the
    /// geometry is degenerate (point behind a camera).
    pub fn view_warp(
        &self,
        camera: &PinholeCamera,
        point: &Vector3<f64>,
        r: &Vector3<f64>,
        q: &Quat,
    ) -> Option<Matrix2<f64>> {
        let normal = point - self.position;
        let depth = normal.norm();
        if depth < 1e-9 {
            return None;
        }
        let normal = normal / depth;
        let rot0 = rotation::matrix(&self.orientation);
        let rot_t = rotation::matrix(q).transpose();
        let project_now = |world: Vector3<f64>| camera.project(&(rot_t * (world - r)));
        let centre = project_now(*point)?;
        let mut a = Matrix2::zeros();
        for (c, offset) in [Vector2::new(1.0, 0.0), Vector2::new(0.0, 1.0)]
            .iter()
            .enumerate()
        {
            let (ray, _) = camera.back_project(self.pixel + offset);
            let ray = rot0 * ray;
            let along = ray.dot(&normal);
            if along <= 1e-9 {
                return None;
            }
            let world = self.position + ray * (depth / along);
            a.set_column(c, &(project_now(world)? - centre));
        }
        Some(a)
    }

    /// The patch as the current camera should see it: half side `half`, sampled through the
    /// inverse of `warp` (identity when `None`).
    pub fn warped(&self, warp: Option<Matrix2<f64>>, half: usize) -> Vec<f32> {
        let side_in = 2 * self.radius + 1;
        let inverse = warp
            .and_then(|a| a.try_inverse())
            .filter(|inv| inv.iter().all(|v| v.is_finite()) && inv.amax() < 8.0)
            .unwrap_or_else(Matrix2::identity);
        let side = 2 * half + 1;
        let mut out = Vec::with_capacity(side * side);
        // Close to the first view, crop instead of resampling: bilinear resampling blurs the
        // template and costs correlation on sharp edges.
        if (inverse - Matrix2::identity()).amax() < 0.08 {
            let side_in = 2 * self.radius + 1;
            let start = self.radius - half;
            for dy in 0..side {
                let row = (start + dy) * side_in + start;
                out.extend_from_slice(&self.patch[row..row + side]);
            }
            return out;
        }
        for dy in 0..side {
            for dx in 0..side {
                let d = Vector2::new(dx as f64 - half as f64, dy as f64 - half as f64);
                let s = inverse * d;
                out.push(sample(
                    &self.patch,
                    side_in,
                    side_in,
                    s.x + self.radius as f64,
                    s.y + self.radius as f64,
                ));
            }
        }
        out
    }
}

/// Zero-mean, unit-norm copy of a patch; `None` for a flat patch (no texture to correlate).
pub fn normalised(patch: &[f32]) -> Option<Vec<f32>> {
    let n = patch.len() as f32;
    let mean = patch.iter().sum::<f32>() / n;
    let norm = patch
        .iter()
        .map(|v| (v - mean) * (v - mean))
        .sum::<f32>()
        .sqrt();
    if norm < 1e-3 {
        return None;
    }
    Some(patch.iter().map(|v| (v - mean) / norm).collect())
}

/// Where to search: the ellipse (z − ẑ)ᵀ S⁻¹ (z − ẑ) ≤ `gate` around `predicted`, cut to
/// `max_extent` pixels from it along each axis.
#[derive(Clone, Copy, Debug)]
pub struct SearchRegion {
    /// Predicted pixel ẑ.
    pub predicted: Vector2<f64>,
    /// Innovation covariance S (eq 27).
    pub covariance: Matrix2<f64>,
    /// χ² bound of the ellipse.
    pub gate: f64,
    /// Largest half-extent along each axis, pixels.
    pub max_extent: f64,
}

/// The best NCC match of `template` (normalised, side `2*half+1`) in the `width`×`height`
/// grey plane `gray`, inside `region`. Returns the sub-pixel position and the score.
pub fn search(
    gray: &[f32],
    width: usize,
    height: usize,
    template: &[f32],
    half: usize,
    region: &SearchRegion,
) -> Option<(Vector2<f64>, f32)> {
    let (predicted, s, gate, max_extent) = (
        region.predicted,
        &region.covariance,
        region.gate,
        region.max_extent,
    );
    let s_inv = s.try_inverse()?;
    let ex = (gate * s[(0, 0)]).sqrt().min(max_extent);
    let ey = (gate * s[(1, 1)]).sqrt().min(max_extent);
    let h = half as i64;
    let x0 = ((predicted.x - ex).floor() as i64).max(h);
    let x1 = ((predicted.x + ex).ceil() as i64).min(width as i64 - 1 - h);
    let y0 = ((predicted.y - ey).floor() as i64).max(h);
    let y1 = ((predicted.y + ey).ceil() as i64).min(height as i64 - 1 - h);
    if x0 > x1 || y0 > y1 {
        return None;
    }
    let side = 2 * half + 1;
    let n = (side * side) as f32;
    let (cols, rows) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
    let mut scores = vec![f32::NEG_INFINITY; cols * rows];
    let mut best = (f32::NEG_INFINITY, 0usize, 0usize);
    for (j, y) in (y0..=y1).enumerate() {
        for (i, x) in (x0..=x1).enumerate() {
            let d = Vector2::new(x as f64 - predicted.x, y as f64 - predicted.y);
            if d.dot(&(s_inv * d)) > gate {
                continue;
            }
            let (mut sum, mut sum2, mut dot) = (0.0f32, 0.0f32, 0.0f32);
            for ty in 0..side {
                let row = ((y - h) as usize + ty) * width + (x - h) as usize;
                let window = &gray[row..row + side];
                let t = &template[ty * side..(ty + 1) * side];
                for (a, b) in window.iter().zip(t) {
                    sum += a;
                    sum2 += a * a;
                    dot += a * b;
                }
            }
            // The template is zero-mean, so Σ(w − w̄)t = Σ w t.
            let var = (sum2 - sum * sum / n).max(0.0);
            if var < 1e-6 {
                continue;
            }
            let score = dot / var.sqrt();
            scores[j * cols + i] = score;
            if score > best.0 {
                best = (score, i, j);
            }
        }
    }
    if !best.0.is_finite() {
        return None;
    }
    let (score, i, j) = best;
    let at = |i: usize, j: usize| scores[j * cols + i];
    let refine = |minus: f32, centre: f32, plus: f32| -> f64 {
        if !(minus.is_finite() && plus.is_finite()) {
            return 0.0;
        }
        let denom = minus - 2.0 * centre + plus;
        if denom >= 0.0 {
            return 0.0;
        }
        (0.5 * (minus - plus) / denom).clamp(-0.5, 0.5) as f64
    };
    let dx = if i > 0 && i + 1 < cols {
        refine(at(i - 1, j), score, at(i + 1, j))
    } else {
        0.0
    };
    let dy = if j > 0 && j + 1 < rows {
        refine(at(i, j - 1), score, at(i, j + 1))
    } else {
        0.0
    };
    Some((
        Vector2::new((x0 + i as i64) as f64 + dx, (y0 + j as i64) as f64 + dy),
        score,
    ))
}

/// Scores `template` again at each of `scales` times the predicted `warp`, within 1.5 px of
/// `best` (the position and score of the search at the predicted warp), and returns the best
/// position and score of all. The position comes from the predicted warp's search, so a scale
/// can only confirm a peak, not move the match elsewhere.
pub fn rescore_at_scales(
    frame: &Frame,
    template: &Template,
    warp: Option<Matrix2<f64>>,
    half: usize,
    scales: &[f64],
    best: (Vector2<f64>, f32),
) -> (Vector2<f64>, f32) {
    let nominal = warp.unwrap_or_else(Matrix2::identity);
    let reach = 1.5;
    let around = SearchRegion {
        predicted: best.0,
        covariance: Matrix2::identity(),
        // The whole square of half side `reach`, corners included.
        gate: 2.0 * reach * reach,
        max_extent: reach,
    };
    let (width, height) = (frame.width as usize, frame.height as usize);
    scales
        .iter()
        .filter_map(|&s| normalised(&template.warped(Some(nominal * s), half)))
        .filter_map(|t| search(&frame.gray, width, height, &t, half, &around))
        .fold(best, |a, b| if b.1 > a.1 { b } else { a })
}

/// Largest absolute difference between two entropy descriptors, in bits.
pub fn descriptor_distance(a: &[f32; 5], b: &[f32; 5]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

/// Number of RANSAC hypotheses for confidence `p` when a fraction `inliers` are inliers and
/// one match makes a hypothesis.
pub fn hypotheses_needed(p: f64, inliers: f64) -> usize {
    if inliers >= 1.0 {
        return 1;
    }
    if inliers <= 0.0 {
        return usize::MAX;
    }
    ((1.0 - p).ln() / (1.0 - inliers).ln()).ceil().max(1.0) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn search_finds_a_shifted_patch_with_sub_pixel_accuracy() {
        let (w, h) = (80usize, 60usize);
        let f = |x: f64, y: f64| {
            ((x * 0.37).sin() * (y * 0.23).cos() + (0.19 * x + 0.31 * y).sin() * 0.3) as f32
        };
        let gray: Vec<f32> = (0..w * h)
            .map(|i| f((i % w) as f64, (i / w) as f64))
            .collect();
        // The template is the image around (40.3, 30.6).
        let half = 5;
        let side = 2 * half + 1;
        let patch: Vec<f32> = (0..side * side)
            .map(|i| {
                f(
                    40.3 + (i % side) as f64 - 5.0,
                    30.6 + (i / side) as f64 - 5.0,
                )
            })
            .collect();
        let t = normalised(&patch).unwrap();
        let s = Matrix2::new(16.0, 0.0, 0.0, 16.0);
        let (z, score) = search(
            &gray,
            w,
            h,
            &t,
            half,
            &SearchRegion {
                predicted: Vector2::new(37.0, 33.0),
                covariance: s,
                gate: 9.21,
                max_extent: 30.0,
            },
        )
        .unwrap();
        assert!(score > 0.95, "{score}");
        assert!((z - Vector2::new(40.3, 30.6)).norm() < 0.25, "{z}");
        // Outside the gate it is not found.
        let tight = Matrix2::new(0.5, 0.0, 0.0, 0.5);
        let far = search(
            &gray,
            w,
            h,
            &t,
            half,
            &SearchRegion {
                predicted: Vector2::new(20.0, 20.0),
                covariance: tight,
                gate: 9.21,
                max_extent: 30.0,
            },
        );
        assert!(far.is_none_or(|(z, _)| (z - Vector2::new(40.3, 30.6)).norm() > 5.0));
    }

    #[test]
    fn hypothesis_count_follows_the_ransac_formula() {
        assert_eq!(hypotheses_needed(0.99, 0.5), 7);
        assert_eq!(hypotheses_needed(0.99, 1.0), 1);
        assert!(hypotheses_needed(0.99, 0.1) > 40);
    }
}
