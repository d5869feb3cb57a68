//! The image pyramid the detector's octaves run on (see [`crate::features::harris::plan`]):
//! each level is the one below blurred by the plan's pyramid kernel and decimated by 2, pixel
//! i of level l being pixel i·2^l of the image. CPU twin of the pyramid passes in
//! [`crate::features::harris::gpu`] (`shaders/harris_convolve.wgsl` with step 2): the same
//! taps, the same clamped borders, columns first.

use rayon::prelude::*;

use super::convolve::{column_at, row_at};
use super::harris::plan::level_size;
use super::steerable::Kernel1d;

/// A luminance plane and the levels above it.
pub struct Pyramid<'a> {
    base: &'a [f32],
    width: usize,
    height: usize,
    /// Levels 1, 2, … (the base is borrowed).
    upper: Vec<Vec<f32>>,
}

impl<'a> Pyramid<'a> {
    /// Builds one level above `gray` per kernel in `kernels` (`kernels[l]` blurs level l
    /// before its decimation).
    pub fn new(gray: &'a [f32], width: usize, height: usize, kernels: &[Kernel1d]) -> Self {
        let mut upper: Vec<Vec<f32>> = Vec::with_capacity(kernels.len());
        for (l, kernel) in kernels.iter().enumerate() {
            let (w, h) = level_size(width, height, l as u32);
            let below: &[f32] = if l == 0 { gray } else { &upper[l - 1] };
            let next = decimate(below, w, h, kernel);
            upper.push(next);
        }
        Self {
            base: gray,
            width,
            height,
            upper,
        }
    }

    /// Level `level`'s pixels and size.
    pub fn level(&self, level: u32) -> (&[f32], usize, usize) {
        let (w, h) = level_size(self.width, self.height, level);
        let data = if level == 0 {
            self.base
        } else {
            &self.upper[level as usize - 1]
        };
        (data, w, h)
    }

    /// Number of levels, the base included.
    pub fn levels(&self) -> usize {
        self.upper.len() + 1
    }
}

/// `src` (`width`×`height`) blurred with `kernel` along columns then rows, keeping every
/// second row and column.
pub fn decimate(src: &[f32], width: usize, height: usize, kernel: &Kernel1d) -> Vec<f32> {
    let (dw, dh) = (width.div_ceil(2), height.div_ceil(2));
    let mut out = vec![0.0f32; dw * dh];
    let row = |y: isize| {
        let sy = y.clamp(0, height as isize - 1) as usize;
        &src[sy * width..(sy + 1) * width]
    };
    out.par_chunks_mut(dw).enumerate().for_each_init(
        || (vec![0.0f32; width], Vec::new()),
        |(column, scratch), (j, dst)| {
            column_at(row, (2 * j) as isize, kernel, column);
            row_at(column, kernel, 2, scratch, dst);
        },
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_halve_the_size_rounding_up_and_keep_a_constant() {
        let (w, h) = (37, 20);
        let gray = vec![0.25f32; w * h];
        let k = Kernel1d::gaussian_derivative(2.0, 0, 4.0);
        let p = Pyramid::new(&gray, w, h, &[k.clone(), k]);
        assert_eq!(p.levels(), 3);
        let (l2, w2, h2) = p.level(2);
        assert_eq!((w2, h2, l2.len()), (10, 5, 50));
        assert!(l2.iter().all(|v| (v - 0.25).abs() < 1e-6));
    }
}
