//! Pyramidal Lucas–Kanade tracking (Bouguet's formulation) for frame-to-frame data association
//! on real motion. It is not an equation of the paper: the paper's active search (eqs 25–27)
//! needs the prediction to land within a few pixels, which a constant-velocity prior cannot
//! promise at 10 Hz on a car (an unknown start-up speed, 1 m between frames, points 3 m away).
//! The pyramid finds flows of 100 pixels and more without relying on the prediction, and the
//! filter's gate and 1-point RANSAC still decide what is used.

use nalgebra::{Matrix2, Vector2};
use rayon::prelude::*;

/// One level: the smoothed image and its central-difference gradients.
#[derive(Clone, Debug)]
struct Level {
    width: usize,
    height: usize,
    image: Vec<f32>,
    gx: Vec<f32>,
    gy: Vec<f32>,
}

/// An image pyramid, each level half the size of the one below.
#[derive(Clone, Debug)]
pub struct Pyramid {
    levels: Vec<Level>,
}

/// How a track is searched for: `[slam.klt]`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KltParams {
    /// Half side of the integration window, pixels (side = 2·half + 1).
    pub half_window: usize,
    /// Pyramid levels used (1 = full resolution only).
    pub levels: usize,
    /// Gauss–Newton iterations per level.
    pub iterations: usize,
    /// Largest disagreement, pixels, between the start point and the point tracked back from
    /// the result (the forward–backward check).
    pub max_round_trip: f64,
}

impl Default for KltParams {
    fn default() -> Self {
        Self {
            half_window: 7,
            levels: 4,
            iterations: 12,
            max_round_trip: 1.0,
        }
    }
}

impl KltParams {
    /// Checks every value, naming the first bad one.
    pub fn validate(&self) -> crate::error::Result<()> {
        use crate::error::Error;
        if !(1..=32).contains(&self.half_window) {
            return Err(Error::config(
                "slam.klt.half_window",
                self.half_window,
                "must be in 1..=32",
            ));
        }
        if !(1..=8).contains(&self.levels) {
            return Err(Error::config(
                "slam.klt.levels",
                self.levels,
                "must be in 1..=8",
            ));
        }
        if !(1..=100).contains(&self.iterations) {
            return Err(Error::config(
                "slam.klt.iterations",
                self.iterations,
                "must be in 1..=100",
            ));
        }
        Ok(())
    }
}

impl Pyramid {
    /// Builds `levels` levels from a row-major grey plane (coarsest at most ~16 pixels a side).
    pub fn new(gray: &[f32], width: usize, height: usize, levels: usize) -> Self {
        let mut out = vec![Level::new(gray.to_vec(), width, height)];
        while out.len() < levels.max(1) {
            let last = out.last().expect("one level at least");
            let (w, h) = (last.width / 2, last.height / 2);
            if w < 16 || h < 16 {
                break;
            }
            // [1 2 1]/4 smoothing in both directions, sampled at even pixels: the 2×2 box
            // alone aliases fine texture into false structure at the coarse levels.
            let (lw, lh) = (last.width, last.height);
            let src = &last.image;
            let mut image = vec![0.0f32; w * h];
            image.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                let yc = 2 * y;
                let rows = [yc.saturating_sub(1), yc, (yc + 1).min(lh - 1)];
                for (x, v) in row.iter_mut().enumerate() {
                    let xc = 2 * x;
                    let cols = [xc.saturating_sub(1), xc, (xc + 1).min(lw - 1)];
                    let mut acc = 0.0;
                    for (ry, wy) in rows.iter().zip([1.0f32, 2.0, 1.0]) {
                        let base = ry * lw;
                        acc += wy
                            * (src[base + cols[0]]
                                + 2.0 * src[base + cols[1]]
                                + src[base + cols[2]]);
                    }
                    *v = acc / 16.0;
                }
            });
            out.push(Level::new(image, w, h));
        }
        Self { levels: out }
    }

    /// Number of levels actually built.
    pub fn depth(&self) -> usize {
        self.levels.len()
    }
}

impl Level {
    fn new(image: Vec<f32>, width: usize, height: usize) -> Self {
        let mut gx = vec![0.0f32; width * height];
        let mut gy = vec![0.0f32; width * height];
        gx.par_chunks_mut(width)
            .zip(gy.par_chunks_mut(width))
            .enumerate()
            .for_each(|(y, (rx, ry))| {
                let up = y.saturating_sub(1) * width;
                let down = (y + 1).min(height - 1) * width;
                let row = y * width;
                for x in 0..width {
                    let left = x.saturating_sub(1);
                    let right = (x + 1).min(width - 1);
                    rx[x] = 0.5 * (image[row + right] - image[row + left]);
                    ry[x] = 0.5 * (image[down + x] - image[up + x]);
                }
            });
        Self {
            width,
            height,
            image,
            gx,
            gy,
        }
    }

    /// Bilinear sample of `plane` with the border replicated: coarse levels of points near
    /// the border still track, and only the result at full resolution must lie inside.
    fn sample(&self, plane: &[f32], x: f64, y: f64) -> f32 {
        let x = x.clamp(0.0, (self.width - 1) as f64);
        let y = y.clamp(0.0, (self.height - 1) as f64);
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
        let (r0, r1) = (y0 * self.width, y1 * self.width);
        let top = plane[r0 + x0] * (1.0 - fx) + plane[r0 + x1] * fx;
        let bottom = plane[r1 + x0] * (1.0 - fx) + plane[r1 + x1] * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

/// Corners good for tracking (Shi and Tomasi, 1994): the smaller eigenvalue of the
/// structure tensor over a 5×5 window at full resolution, kept on a `cells`-wide grid so that
/// every part of the image contributes, at most `per_cell` per cell, strongest first, and
/// only above 1% of the strongest corner.
pub fn good_features(
    pyramid: &Pyramid,
    cells: [usize; 2],
    per_cell: usize,
    margin: usize,
) -> Vec<Vector2<f64>> {
    let level = &pyramid.levels[0];
    let (w, h) = (level.width, level.height);
    let r = 2usize;
    let start = margin.max(r + 1);
    if w <= 2 * start || h <= 2 * start {
        return Vec::new();
    }
    // Score every pixel (rows in parallel), then keep 3×3 local maxima.
    let mut score = vec![0.0f32; w * h];
    score
        .par_chunks_mut(w)
        .enumerate()
        .skip(start)
        .take(h - 2 * start)
        .for_each(|(y, row)| {
            for (x, out) in row.iter_mut().enumerate().skip(start).take(w - 2 * start) {
                let (mut xx, mut xy, mut yy) = (0.0f32, 0.0f32, 0.0f32);
                for yy_ in y - r..=y + r {
                    let base = yy_ * w;
                    for xx_ in x - r..=x + r {
                        let (gx, gy) = (level.gx[base + xx_], level.gy[base + xx_]);
                        xx += gx * gx;
                        xy += gx * gy;
                        yy += gy * gy;
                    }
                }
                let tr = xx + yy;
                *out = 0.5 * (tr - ((xx - yy) * (xx - yy) + 4.0 * xy * xy).sqrt());
            }
        });
    let strongest = score.iter().cloned().fold(0.0f32, f32::max);
    if strongest <= 0.0 {
        return Vec::new();
    }
    let floor = 0.01 * strongest;
    let [gx, gy] = cells;
    let mut per: Vec<Vec<(f32, usize)>> = vec![Vec::new(); gx * gy];
    for y in start..h - start {
        for x in start..w - start {
            let v = score[y * w + x];
            if v < floor {
                continue;
            }
            let is_max = (y - 1..=y + 1)
                .all(|j| (x - 1..=x + 1).all(|i| (i == x && j == y) || score[j * w + i] < v));
            if is_max {
                let c = (y * gy / h) * gx + x * gx / w;
                per[c].push((v, y * w + x));
            }
        }
    }
    let mut out = Vec::new();
    for cell in &mut per {
        cell.sort_by(|a, b| b.0.total_cmp(&a.0));
        out.extend(
            cell.iter()
                .take(per_cell)
                .map(|&(_, i)| Vector2::new((i % w) as f64, (i / w) as f64)),
        );
    }
    out
}

/// Tracks `point` of `from` into `to`, starting the search at `guess` (a pixel of `to`, for
/// example the filter's prediction). Returns the tracked pixel, or `None` when the window
/// leaves the image, the texture is too weak to fix both axes, or the forward–backward check
/// fails.
pub fn track(
    from: &Pyramid,
    to: &Pyramid,
    point: Vector2<f64>,
    guess: Vector2<f64>,
    params: &KltParams,
) -> Option<Vector2<f64>> {
    let forward = track_one_way(from, to, point, guess, params)?;
    let back = track_one_way(to, from, forward, point, params)?;
    ((back - point).norm() <= params.max_round_trip).then_some(forward)
}

fn track_one_way(
    from: &Pyramid,
    to: &Pyramid,
    point: Vector2<f64>,
    guess: Vector2<f64>,
    params: &KltParams,
) -> Option<Vector2<f64>> {
    let levels = params.levels.clamp(1, from.depth().min(to.depth()));
    let half = params.half_window as i64;
    let side = (2 * half + 1) as usize;
    let mut template = vec![0.0f32; side * side];
    let mut grad = vec![(0.0f32, 0.0f32); side * side];
    // The flow at the coarsest level starts from the guess.
    let top = (levels - 1) as i32;
    let mut flow = (guess - point) / 2f64.powi(top);
    for level in (0..levels).rev() {
        let scale = 2f64.powi(level as i32);
        let (a, b) = (&from.levels[level], &to.levels[level]);
        let p = point / scale;
        let mut g = Matrix2::<f64>::zeros();
        let mut k = 0;
        for dy in -half..=half {
            for dx in -half..=half {
                let (x, y) = (p.x + dx as f64, p.y + dy as f64);
                let (t, ix, iy) = (
                    a.sample(&a.image, x, y),
                    a.sample(&a.gx, x, y),
                    a.sample(&a.gy, x, y),
                );
                template[k] = t;
                grad[k] = (ix, iy);
                g[(0, 0)] += (ix * ix) as f64;
                g[(0, 1)] += (ix * iy) as f64;
                g[(1, 1)] += (iy * iy) as f64;
                k += 1;
            }
        }
        g[(1, 0)] = g[(0, 1)];
        // The smaller eigenvalue, per window pixel: both axes need texture.
        let (tr, det) = (g.trace(), g.determinant());
        let min_eigen = 0.5 * (tr - (tr * tr - 4.0 * det).max(0.0).sqrt());
        if min_eigen / (side * side) as f64 <= 1e-7 {
            return None;
        }
        let g_inv = g.try_inverse()?;
        for _ in 0..params.iterations {
            let mut e = Vector2::<f64>::zeros();
            let mut k = 0;
            for dy in -half..=half {
                for dx in -half..=half {
                    let (x, y) = (p.x + flow.x + dx as f64, p.y + flow.y + dy as f64);
                    let i = b.sample(&b.image, x, y);
                    let diff = (template[k] - i) as f64;
                    e.x += diff * grad[k].0 as f64;
                    e.y += diff * grad[k].1 as f64;
                    k += 1;
                }
            }
            let step = g_inv * e;
            flow += step;
            if !flow.iter().all(|v| v.is_finite()) {
                return None;
            }
            if step.norm_squared() < 1e-4 {
                break;
            }
        }
        if level > 0 {
            flow *= 2.0;
        }
    }
    let out = point + flow;
    let base = &to.levels[0];
    let margin = 1.0;
    let inside = |p: Vector2<f64>, w: usize, h: usize| {
        p.x >= margin
            && p.y >= margin
            && p.x <= w as f64 - 1.0 - margin
            && p.y <= h as f64 - 1.0 - margin
    };
    (inside(point, from.levels[0].width, from.levels[0].height)
        && inside(out, base.width, base.height))
    .then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(x: f64, y: f64) -> f32 {
        // Structure at every scale, as in a real image: each pyramid level sees some.
        (0.5 + 0.1 * (x * 0.21).sin() * (y * 0.17).cos()
            + 0.15 * (0.05 * x + 0.09 * y).sin()
            + 0.2 * (x * 0.031).sin() * (y * 0.027).cos()) as f32
    }

    fn plane(w: usize, h: usize, shift: Vector2<f64>) -> Vec<f32> {
        (0..w * h)
            .map(|i| texture((i % w) as f64 - shift.x, (i / w) as f64 - shift.y))
            .collect()
    }

    #[test]
    fn large_shift_is_recovered_through_the_pyramid() {
        let (w, h) = (320, 240);
        let shift = Vector2::new(23.4, -17.7);
        let a = Pyramid::new(&plane(w, h, Vector2::zeros()), w, h, 4);
        let b = Pyramid::new(&plane(w, h, shift), w, h, 4);
        let p = Vector2::new(150.0, 130.0);
        let found = track(&a, &b, p, p, &KltParams::default()).expect("tracked");
        assert!(
            (found - (p + shift)).norm() < 0.1,
            "{found} vs {}",
            p + shift
        );
    }

    #[test]
    fn flat_windows_and_points_outside_are_refused() {
        let (w, h) = (128, 96);
        let flat = Pyramid::new(&vec![0.5; w * h], w, h, 3);
        let p = Vector2::new(60.0, 40.0);
        assert!(track(&flat, &flat, p, p, &KltParams::default()).is_none());
        let a = Pyramid::new(&plane(w, h, Vector2::zeros()), w, h, 3);
        let edge = Vector2::new(0.5, 0.5);
        assert!(track(&a, &a, edge, edge, &KltParams::default()).is_none());
    }
}
