//! The plan of the multiscale Harris stage (eqs 5–8) that both backends execute: per scale,
//! the derivative filters D_k at σ_e, the integration window w(σ_I), the sampling grid, and the
//! Harris response R = det − k·tr² (eq 8). Built once per configuration and image size.
//!
//! Why the plan steers gradients and never filtered images: see `features::steerable`.
//!
//! **Octaves.** The derivative filters of a coarse scale run on an image pyramid (each level
//! blurred and decimated by 2), on the coarsest level where σ_e still spans
//! [`LEVEL_MIN_SIGMA`] of its pixels, with the kernel that brings the level's own blur up to
//! σ_e: each octave then costs about a quarter of the one below it, and the response grids
//! (and so every later stage) are those of the full-resolution computation.

use crate::error::Result;
use crate::features::config::{DescriptorKind, DetectorConfig};
use crate::features::steerable::{orientations, steering_coefficients, Kernel1d, Separable};

/// Everything one detection scale needs.
#[derive(Clone, Debug)]
pub struct ScalePlan {
    /// Differentiation scale σ_D.
    pub sigma_d: f32,
    /// Integration scale σ_I.
    pub sigma_i: f32,
    /// The n+2 derivative filters D_k at σ_e, scale-normalised by σ_e^p.
    pub derivatives: Vec<Separable>,
    /// The integration window w(σ_I) (eq 7), used along both axes, in grid units: a Gaussian
    /// of σ_I / step applied to the products sampled on the scale's grid.
    pub window: Kernel1d,
    /// Border margin in pixels: no candidate closer to the border.
    pub margin: u32,
    /// Factor applied to this scale's responses when clusters are ranked:
    /// (σ_e / σ_e of the finest scale)^(4(p_r − p)) (see `rank_normalization`).
    pub rank_weight: f32,
    /// Sampling step of this scale's grid (1, 2, 4 …). The derivative planes are sampled every
    /// `step` pixels and the products, their window blur, the responses and the suppression
    /// all live on that grid: the window integral of eq 7 becomes a sum over the grid's
    /// samples, accurate because the window is wide against the step (step = largest power
    /// of two ≤ σ_I / 1.4: the window passes at most exp(−π²·1.4²/2) ≈ 6e-5 at the grid's
    /// Nyquist frequency).
    pub step: u32,
    /// Pyramid level (image decimated by 2^level) the derivative filters run on.
    pub level: u32,
}

/// Blur of every pyramid level above the base, in that level's own pixels. Before each
/// decimation the level is blurred to twice this, which passes exp(−(2·π/2)²/2) ≈ 0.7% at the
/// decimated grid's Nyquist frequency.
pub const PYRAMID_BLUR: f32 = 1.0;

/// Blur a camera image is taken to carry already, in its pixels (optics, demosaicing; SIFT
/// assumes 0.5). Detection is covariant in the total blur √(σ_D² + b²), not in σ_D: under a
/// zoom of J a corner found at σ_D in one view is found at √(J²(σ_D² + b²) − b²) in the other.
/// On bark, the keypoints' σ_D fall short of the true map's scale by a median 0.36 octave at
/// J ≈ 0.36 and their total scales with b = 0.7 by 0.13 (docs/EVALUATION.md), so keypoint scales
/// and the descriptor's window use the total (see [`total_scale`]). The default of
/// `[detector] image_blur` ([`crate::DetectorConfig::image_blur`]).
pub const IMAGE_BLUR: f32 = 0.7;

/// A keypoint's scale (`Keypoint::scale`) from the σ_D it was detected at on an image that
/// carries a blur of `image_blur` (b, [`IMAGE_BLUR`] by default): the total blur √(σ_D² + b²),
/// which follows zoom between views.
pub fn total_scale(sigma_d: f32, image_blur: f32) -> f32 {
    sigma_d.hypot(image_blur)
}

/// The σ_D a keypoint of total scale `scale` ([`total_scale`]) was detected at.
pub fn detection_scale(scale: f32, image_blur: f32) -> f32 {
    (scale * scale - image_blur * image_blur).max(0.0).sqrt()
}

/// The blur pyramid level `level` carries in its own pixels, the image's own (`image_blur`)
/// included: what the steered descriptor's smoothing starts from there.
pub fn plane_blur(level: u32, image_blur: f32) -> f32 {
    level_blur(level).hypot(image_blur) / (1u32 << level) as f32
}

/// A scale's derivatives run on the coarsest level where σ_e spans at least this many level
/// pixels: the third-order derivative filters then have σ ≥ √(2² − 1) ≈ 1.7 level pixels,
/// enough to sample them accurately.
pub const LEVEL_MIN_SIGMA: f32 = 2.0;

/// The pyramid level of a scale with effective scale `sigma_e` sampled every `step` pixels:
/// the coarsest whose pixels still divide the step and hold σ_e over [`LEVEL_MIN_SIGMA`] pixels.
pub fn pyramid_level(sigma_e: f32, step: u32) -> u32 {
    let mut level = 0;
    while (2u32 << level) <= step && sigma_e / (2u32 << level) as f32 >= LEVEL_MIN_SIGMA {
        level += 1;
    }
    level
}

/// The steered descriptor of a keypoint is read on the coarsest level where its σ_D spans at
/// least this many level pixels: a cell (5σ_D) then spans 5–10 pixels at any scale, so a
/// coarse keypoint costs what a fine one does.
pub const DESCRIPTOR_MIN_SIGMA: f32 = 1.0;

/// The pyramid level the steered descriptor of a keypoint of scale `sigma_d` is read on.
pub fn descriptor_level(sigma_d: f32) -> u32 {
    let mut level = 0;
    while level < 16 && sigma_d / (2u32 << level) as f32 >= DESCRIPTOR_MIN_SIGMA {
        level += 1;
    }
    level
}

/// The blur a pyramid level already carries, in full-resolution pixels (the base: none).
pub fn level_blur(level: u32) -> f32 {
    if level == 0 {
        0.0
    } else {
        PYRAMID_BLUR * (1u32 << level) as f32
    }
}

/// Size of pyramid level `level` of a `width`×`height` image: pixel i of the level is pixel
/// i·2^level of the image, so the level's size is the image's divided by 2^level, rounded up.
pub fn level_size(width: usize, height: usize, level: u32) -> (usize, usize) {
    let f = 1usize << level;
    (width.div_ceil(f), height.div_ceil(f))
}

impl ScalePlan {
    /// The sampling step of this scale's grid on its pyramid level.
    pub fn level_step(&self) -> u32 {
        self.step >> self.level
    }

    /// Size of the response grid for a `width`×`height` image.
    pub fn grid(&self, width: usize, height: usize) -> (usize, usize) {
        let g = self.step as usize;
        (width.div_ceil(g), height.div_ceil(g))
    }

    /// The border margin in grid cells.
    pub fn grid_margin(&self) -> usize {
        (self.margin.div_ceil(self.step)).max(1) as usize
    }
}

/// A scale's grid step is the largest power of two that leaves at least this many steps in σ_I.
pub const GRID_SIGMAS: f32 = 1.4;

/// The grid step of a scale with integration scale `sigma_i`.
pub fn grid_step(sigma_i: f32) -> u32 {
    let mut step = 1u32;
    while sigma_i / (2 * step) as f32 >= GRID_SIGMAS && step < 64 {
        step *= 2;
    }
    step
}

/// The whole multiscale steered Harris computation, shared by the CPU and GPU backends.
#[derive(Clone, Debug)]
pub struct HarrisPlan {
    /// The configuration it was built from.
    pub config: DetectorConfig,
    /// Steered orientations θ_n.
    pub orientations: Vec<f32>,
    /// One entry per detection scale.
    pub scales: Vec<ScalePlan>,
    /// Index pairs (j, k), j ≤ k, of the products D_j·D_k.
    pub products: Vec<(usize, usize)>,
    /// Per orientation, three rows of `products.len()` weights giving Mxx, Mxy, Myy as dot
    /// products with the blurred products Q (layout `[θ][entry][product]`).
    pub tensor_weights: Vec<f32>,
    /// `pyramid[l]` blurs level l before it is decimated into level l + 1 (levels beyond the
    /// base exist only when a scale runs on them).
    pub pyramid: Vec<Kernel1d>,
}

/// One tile of a frame: its pixels in the image, and the core whose candidates it reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Tile {
    /// First pixel (x, y) in the image; a multiple of every scale's step.
    pub origin: (u32, u32),
    /// Size in pixels (core plus halo, cut by the image).
    pub size: (u32, u32),
    /// The core (x0, y0, x1, y1) in the tile's pixels.
    pub core: [u32; 4],
}

impl HarrisPlan {
    /// Builds the kernels and weights of a validated configuration.
    pub fn new(config: &DetectorConfig) -> Self {
        let n = config.basis.order();
        let m = n + 1; // derivative order of the D_k
        let count = m + 1;
        let products: Vec<(usize, usize)> = (0..count)
            .flat_map(|j| (j..count).map(move |k| (j, k)))
            .collect();
        let index = |j: usize, k: usize| {
            let (j, k) = if j <= k { (j, k) } else { (k, j) };
            products
                .iter()
                .position(|&p| p == (j, k))
                .expect("pair exists")
        };
        let orientations = orientations(config.orientations);
        let p = products.len();
        let mut tensor_weights = vec![0.0f32; orientations.len() * 3 * p];
        for (t, &theta) in orientations.iter().enumerate() {
            let c = steering_coefficients(n, theta);
            let base = t * 3 * p;
            for i in 0..=n {
                for j in 0..=n {
                    let w = c[i] * c[j];
                    tensor_weights[base + index(i, j)] += w;
                    tensor_weights[base + p + index(i, j + 1)] += w;
                    tensor_weights[base + 2 * p + index(i + 1, j + 1)] += w;
                }
            }
        }
        let scales: Vec<ScalePlan> = (0..config.scales)
            .map(|s| {
                let sigma_d = config.sigma_d(s);
                let sigma_e = config.sigma_e(s);
                let step = grid_step(config.sigma_i(s));
                let level = pyramid_level(sigma_e, step);
                let factor = (1u32 << level) as f32;
                // The kernel in level pixels that brings the level's blur up to σ_e; a
                // derivative of order m in level pixels is factor^m times one in image pixels.
                let sigma = (sigma_e * sigma_e - level_blur(level).powi(2)).sqrt() / factor;
                let norm = sigma_e.powf(config.scale_normalization) / factor.powi(m as i32);
                let derivatives = (0..count)
                    .map(|k| Separable {
                        column: Kernel1d::gaussian_derivative(sigma, k, config.truncate),
                        row: Kernel1d::gaussian_derivative(sigma, m - k, config.truncate)
                            .scaled(norm),
                    })
                    .collect();
                ScalePlan {
                    sigma_d,
                    sigma_i: config.sigma_i(s),
                    derivatives,
                    window: Kernel1d::gaussian_derivative(
                        config.sigma_i(s) / grid_step(config.sigma_i(s)) as f32,
                        0,
                        config.truncate,
                    ),
                    margin: config.margin(s),
                    rank_weight: (sigma_e / config.sigma_e(0))
                        .powf(4.0 * (config.rank_normalization - config.scale_normalization)),
                    step,
                    level,
                }
            })
            .collect();
        let descriptor_levels = match config.descriptor {
            DescriptorKind::Steered | DescriptorKind::SteeredTwin => scales
                .iter()
                .map(|s| descriptor_level(s.sigma_d))
                .max()
                .unwrap_or(0),
            DescriptorKind::Entropy | DescriptorKind::None => 0,
        };
        let levels = scales
            .iter()
            .map(|s| s.level)
            .max()
            .unwrap_or(0)
            .max(descriptor_levels);
        let pyramid = (0..levels)
            .map(|l| {
                // From the level's own blur to twice PYRAMID_BLUR, in the level's pixels.
                let own = if l == 0 { 0.0 } else { PYRAMID_BLUR };
                let sigma = ((2.0 * PYRAMID_BLUR).powi(2) - own * own).sqrt();
                Kernel1d::gaussian_derivative(sigma, 0, config.truncate)
            })
            .collect();
        Self {
            config: config.clone(),
            orientations,
            scales,
            products,
            tensor_weights,
            pyramid,
        }
    }

    /// Number of pyramid levels, the base included.
    pub fn levels(&self) -> usize {
        self.pyramid.len() + 1
    }

    /// How far (image pixels) a pixel of level `level` reaches into the image through the
    /// blurs that built it.
    pub fn level_reach(&self, level: u32) -> u32 {
        self.pyramid
            .iter()
            .take(level as usize)
            .enumerate()
            .map(|(l, k)| (k.radius() as u32) << l)
            .sum()
    }

    /// The response grid (columns, rows) of every scale for a `width`×`height` image.
    pub fn grids(&self, width: usize, height: usize) -> Vec<(usize, usize)> {
        self.scales
            .iter()
            .map(|sc| sc.grid(width, height))
            .collect()
    }

    /// The coarsest grid step: bands and tiles start on multiples of it, so every grid stays
    /// aligned.
    pub fn max_step(&self) -> u32 {
        self.scales.iter().map(|s| s.step).max().unwrap_or(1)
    }

    /// Rows or columns of halo a tile needs around its core so that the responses and the
    /// suppression of the core's samples see exactly the pixels they would in the whole
    /// image: the derivative filters' and the window's reach at each scale, plus the
    /// neighbouring samples the suppression reads (±1 of its scale, ±1.5 steps of the
    /// adjacent ones). A multiple of the coarsest step, so tiles keep every grid aligned.
    pub fn tile_halo(&self) -> u32 {
        let max_step = self.max_step();
        let reach = self
            .scales
            .iter()
            .map(|sc| {
                // The derivative filters reach their radius in level pixels, and each level
                // pixel the blurs that built it.
                let filter = sc
                    .derivatives
                    .iter()
                    .map(|f| f.column.radius().max(f.row.radius()))
                    .max()
                    .unwrap_or(0) as u32;
                let filter = (filter << sc.level) + self.level_reach(sc.level);
                filter + sc.window.radius() as u32 * sc.step + sc.margin
            })
            .max()
            .unwrap_or(0);
        (reach + 2 * max_step).next_multiple_of(max_step)
    }

    /// The tiles of a `width`×`height` frame: the whole frame when `fits` accepts it and no
    /// tile size is configured; otherwise square cores of `gpu_tile_size` (or the largest
    /// whose core plus halos is at most `largest` pixels a side), each with its halo, cut by
    /// the image. Cores are multiples of the coarsest step and partition the frame. An error
    /// from `fits` (which names the device's limit) when not even a tile fits.
    pub(crate) fn tiles(
        &self,
        width: u32,
        height: u32,
        largest: u32,
        fits: impl Fn(u32, u32) -> Result<()>,
    ) -> Result<Vec<Tile>> {
        let whole = Tile {
            origin: (0, 0),
            size: (width, height),
            core: [0, 0, width, height],
        };
        let configured = self.config.gpu_tile_size;
        let halo = self.tile_halo();
        let max_step = self.max_step();
        let side = if configured > 0 {
            configured
        } else if fits(width, height).is_ok() {
            return Ok(vec![whole]);
        } else {
            let core = largest.saturating_sub(2 * halo) / max_step * max_step;
            if core == 0 {
                return fits(width, height).map(|_| vec![whole]);
            }
            core
        };
        let side = side.next_multiple_of(max_step);
        if side >= width && side >= height {
            return Ok(vec![whole]);
        }
        let mut tiles = Vec::new();
        for y0 in (0..height).step_by(side as usize) {
            for x0 in (0..width).step_by(side as usize) {
                let (x1, y1) = ((x0 + side).min(width), (y0 + side).min(height));
                let origin = (x0.saturating_sub(halo), y0.saturating_sub(halo));
                let end = ((x1 + halo).min(width), (y1 + halo).min(height));
                let tile = Tile {
                    origin,
                    size: (end.0 - origin.0, end.1 - origin.1),
                    core: [x0 - origin.0, y0 - origin.1, x1 - origin.0, y1 - origin.1],
                };
                fits(tile.size.0, tile.size.1)?;
                tiles.push(tile);
            }
        }
        Ok(tiles)
    }

    /// Number of derivative images per scale (n + 2).
    pub fn derivative_count(&self) -> usize {
        self.config.basis.order() + 2
    }
}

/// Harris response of eq 8 from the structure tensor entries.
#[inline]
pub fn harris_response(mxx: f32, mxy: f32, myy: f32, k: f32) -> f32 {
    let tr = mxx + myy;
    mxx * myy - mxy * mxy - k * tr * tr
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;

    fn plan(tile: u32) -> HarrisPlan {
        HarrisPlan::new(&DetectorConfig {
            gpu_tile_size: tile,
            ..DetectorConfig::default()
        })
    }

    /// Every pixel of the frame in exactly one core; every tile inside the frame, its core
    /// inside it, its origin on every grid, and its halo complete where the frame allows.
    fn assert_partition(plan: &HarrisPlan, tiles: &[Tile], width: u32, height: u32) {
        let mut covered = vec![0u8; (width * height) as usize];
        let (halo, step) = (plan.tile_halo(), plan.max_step());
        for t in tiles {
            assert_eq!((t.origin.0 % step, t.origin.1 % step), (0, 0), "{t:?}");
            assert!(t.origin.0 + t.size.0 <= width && t.origin.1 + t.size.1 <= height);
            let [x0, y0, x1, y1] = t.core;
            assert!(
                x0 < x1 && x1 <= t.size.0 && y0 < y1 && y1 <= t.size.1,
                "{t:?}"
            );
            assert!(x0 >= halo.min(t.origin.0 + x0) && y0 >= halo.min(t.origin.1 + y0));
            assert!(t.size.0 - x1 >= halo.min(width - t.origin.0 - x1), "{t:?}");
            for y in y0..y1 {
                for x in x0..x1 {
                    covered[((t.origin.1 + y) * width + t.origin.0 + x) as usize] += 1;
                }
            }
        }
        assert!(
            covered.iter().all(|&c| c == 1),
            "cores must partition the frame"
        );
    }

    #[test]
    fn a_frame_that_fits_is_one_tile_and_a_configured_size_tiles_it() {
        let whole = plan(0).tiles(640, 480, 4096, |_, _| Ok(())).unwrap();
        assert_eq!(whole.len(), 1);
        assert_eq!(whole[0].core, [0, 0, 640, 480]);
        let p = plan(128);
        let tiles = p.tiles(640, 480, 4096, |_, _| Ok(())).unwrap();
        assert!(tiles.len() > 1);
        assert_partition(&p, &tiles, 640, 480);
    }

    #[test]
    fn a_frame_past_the_limits_gets_the_largest_tiles_that_fit() {
        let p = plan(0);
        let largest = 2 * p.tile_halo() + 3 * p.max_step();
        let fits = |w: u32, h: u32| {
            if w.max(h) <= largest {
                Ok(())
            } else {
                Err(Error::GpuLimit(format!("{w}x{h}")))
            }
        };
        let tiles = p.tiles(2000, 1500, largest, fits).unwrap();
        assert!(tiles
            .iter()
            .all(|t| t.size.0 <= largest && t.size.1 <= largest));
        assert_partition(&p, &tiles, 2000, 1500);
        // Not even a core of one step fits: the device's own error.
        let e = p.tiles(2000, 1500, p.tile_halo(), fits).unwrap_err();
        assert!(e.to_string().contains("2000x1500"), "{e}");
    }
}
