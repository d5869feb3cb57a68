//! CPU separable convolution with clamp-to-edge borders: the twin of `shaders/convolve.wgsl`.
//! Rows are processed in parallel (rayon); the inner loops run over contiguous memory so the
//! compiler vectorises them. Taps are summed in ascending order, as the shader does.

use rayon::prelude::*;

use super::steerable::{Kernel1d, Separable};

/// Vertical pass: `dst[y][x] = Σ_t taps[t] · src[clamp(y + t)][x]`.
pub fn convolve_columns(
    src: &[f32],
    dst: &mut [f32],
    width: usize,
    height: usize,
    kernel: &Kernel1d,
) {
    let r = kernel.radius() as isize;
    dst.par_chunks_mut(width)
        .take(height)
        .enumerate()
        .for_each(|(y, out)| {
            out.fill(0.0);
            for (i, &k) in kernel.taps.iter().enumerate() {
                let sy = (y as isize + i as isize - r).clamp(0, height as isize - 1) as usize;
                let row = &src[sy * width..(sy + 1) * width];
                for (o, &v) in out.iter_mut().zip(row) {
                    *o += k * v;
                }
            }
        });
}

/// Horizontal pass: `dst[y][x] = Σ_t taps[t] · src[y][clamp(x + t)]`.
pub fn convolve_rows(src: &[f32], dst: &mut [f32], width: usize, height: usize, kernel: &Kernel1d) {
    let r = kernel.radius();
    dst.par_chunks_mut(width)
        .take(height)
        .enumerate()
        .for_each_init(Vec::new, |padded, (y, out)| {
            let row = &src[y * width..(y + 1) * width];
            padded.clear();
            padded.extend(
                (0..width + 2 * r)
                    .map(|i| row[(i as isize - r as isize).clamp(0, width as isize - 1) as usize]),
            );
            out.fill(0.0);
            for (i, &k) in kernel.taps.iter().enumerate() {
                for (o, &v) in out.iter_mut().zip(&padded[i..i + width]) {
                    *o += k * v;
                }
            }
        });
}

/// Applies a separable filter, using `scratch` (same size as the image) for the column pass.
pub fn convolve_separable(
    src: &[f32],
    dst: &mut [f32],
    scratch: &mut [f32],
    width: usize,
    height: usize,
    filter: &Separable,
) {
    convolve_columns(src, scratch, width, height, &filter.column);
    convolve_rows(scratch, dst, width, height, &filter.row);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_kernel_clamps_at_borders() {
        let k = Kernel1d {
            taps: vec![1.0, 1.0, 1.0],
        };
        let src = vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let mut dst = vec![0.0; 6];
        convolve_rows(&src, &mut dst, 3, 2, &k);
        assert_eq!(dst, vec![4.0, 6.0, 8.0, 13.0, 15.0, 17.0]);
        convolve_columns(&src, &mut dst, 3, 2, &k);
        assert_eq!(dst, vec![6.0, 9.0, 12.0, 9.0, 12.0, 15.0]);
    }
}
