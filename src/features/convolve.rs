//! CPU separable convolution with clamp-to-edge borders: the twin of `shaders/harris_convolve.wgsl`.
//! Rows are processed in parallel (rayon); the inner loops run over contiguous memory so the
//! compiler vectorises them. Symmetric and antisymmetric kernels (every Gaussian derivative)
//! are folded: one multiplication per pair of taps. The shader sums taps in plain order, so
//! the two agree to float rounding (see the parity tolerances in tests/gpu_parity.rs).

use rayon::prelude::*;

use super::steerable::{Kernel1d, Separable};
use crate::simd::fold_terms;

/// Symmetry of a kernel about its centre, which halves the multiplications.
#[derive(Clone, Copy, PartialEq)]
enum Parity {
    Even,
    Odd,
    None,
}

fn parity(taps: &[f32]) -> Parity {
    let n = taps.len();
    if (0..n / 2).all(|i| taps[i] == taps[n - 1 - i]) {
        Parity::Even
    } else if (0..n / 2).all(|i| taps[i] == -taps[n - 1 - i]) && taps[n / 2] == 0.0 {
        Parity::Odd
    } else {
        Parity::None
    }
}

/// One output row of a vertical pass: `out = Σ_t taps[t] · row(y + t − r)`, where `row`
/// returns the (already clamped) input row of an index.
#[inline]
pub fn column_at<'a>(
    row: impl Fn(isize) -> &'a [f32],
    y: isize,
    kernel: &Kernel1d,
    out: &mut [f32],
) {
    let r = kernel.radius() as isize;
    let taps = &kernel.taps;
    let row = &row;
    match parity(taps) {
        Parity::None => fold_terms(out, taps.len(), |i| {
            let src = row(y + i as isize - r);
            (src, src, taps[i], 0.0)
        }),
        par => {
            let sign = if par == Parity::Even { 1.0 } else { -1.0 };
            // The centre tap (absent from odd kernels), then taps[r + t], which multiplies row
            // y + t, with taps[r − t] = sign · taps[r + t].
            let first = usize::from(taps[r as usize] == 0.0);
            fold_terms(out, r as usize + 1 - first, |i| {
                let t = (i + first) as isize;
                if t == 0 {
                    (row(y), row(y), taps[r as usize], 0.0)
                } else {
                    (row(y + t), row(y - t), taps[(r + t) as usize], sign)
                }
            })
        }
    }
}

/// Copies `row` into `padded` with `r` clamped samples on each side.
#[inline]
fn pad_row(row: &[f32], r: usize, padded: &mut Vec<f32>) {
    let width = row.len();
    padded.resize(width + 2 * r, 0.0);
    padded[..r].fill(row[0]);
    padded[r..r + width].copy_from_slice(row);
    padded[r + width..].fill(row[width - 1]);
}

/// One row of a horizontal pass evaluated every `step` samples:
/// `out[i] = Σ_t taps[t] · row[clamp(i·step + t − r)]`; `scratch` holds the padded row (and,
/// when subsampling, the full-resolution result: the vectorised row then a pick of every
/// `step`-th sample beats a scalar gather per sample).
#[inline]
pub fn row_at(
    row: &[f32],
    kernel: &Kernel1d,
    step: usize,
    scratch: &mut Vec<f32>,
    out: &mut [f32],
) {
    let r = kernel.radius();
    let width = row.len();
    pad_row(row, r, scratch);
    if step > 1 {
        scratch.resize(2 * width + 2 * r, 0.0);
        let (padded, full) = scratch.split_at_mut(width + 2 * r);
        fold_padded(padded, kernel, full);
        for (o, v) in out.iter_mut().zip(full.iter().step_by(step)) {
            *o = *v;
        }
    } else {
        fold_padded(&scratch[..width + 2 * r], kernel, out);
    }
}

/// `out[x] = Σ_i taps[i] · padded[x + i]`, folded for (anti)symmetric kernels.
#[inline]
fn fold_padded(padded: &[f32], kernel: &Kernel1d, out: &mut [f32]) {
    let r = kernel.radius();
    let width = out.len();
    let taps = &kernel.taps;
    match parity(taps) {
        Parity::None => fold_terms(out, taps.len(), |i| {
            let src = &padded[i..i + width];
            (src, src, taps[i], 0.0)
        }),
        par => {
            let sign = if par == Parity::Even { 1.0 } else { -1.0 };
            let first = usize::from(taps[r] == 0.0);
            fold_terms(out, r + 1 - first, |i| {
                let t = i + first;
                let (right, left) = (&padded[r + t..r + t + width], &padded[r - t..r - t + width]);
                (right, left, taps[r + t], if t == 0 { 0.0 } else { sign })
            })
        }
    }
}

/// Vertical pass: `dst[y][x] = Σ_t taps[t] · src[clamp(y + t)][x]`.
pub fn convolve_columns(
    src: &[f32],
    dst: &mut [f32],
    width: usize,
    height: usize,
    kernel: &Kernel1d,
) {
    let row = |y: isize| {
        let sy = y.clamp(0, height as isize - 1) as usize;
        &src[sy * width..(sy + 1) * width]
    };
    dst.par_chunks_mut(width)
        .take(height)
        .enumerate()
        .for_each(|(y, out)| column_at(row, y as isize, kernel, out));
}

/// Horizontal pass: `dst[y][x] = Σ_t taps[t] · src[y][clamp(x + t)]`.
pub fn convolve_rows(src: &[f32], dst: &mut [f32], width: usize, height: usize, kernel: &Kernel1d) {
    dst.par_chunks_mut(width)
        .take(height)
        .enumerate()
        .for_each_init(Vec::new, |padded, (y, out)| {
            row_at(&src[y * width..(y + 1) * width], kernel, 1, padded, out)
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
    fn folded_kernels_match_plain_sums() {
        let src: Vec<f32> = (0..7 * 5).map(|i| ((i * 37 % 11) as f32).sin()).collect();
        for order in 0..=3 {
            let k = Kernel1d::gaussian_derivative(1.3, order, 3.0);
            let r = k.radius() as isize;
            let (mut rows, mut cols) = (vec![0.0; 35], vec![0.0; 35]);
            convolve_rows(&src, &mut rows, 7, 5, &k);
            convolve_columns(&src, &mut cols, 7, 5, &k);
            for y in 0..5isize {
                for x in 0..7isize {
                    let (mut er, mut ec) = (0.0f32, 0.0f32);
                    for (i, &t) in k.taps.iter().enumerate() {
                        let d = i as isize - r;
                        er += t * src[(y * 7 + (x + d).clamp(0, 6)) as usize];
                        ec += t * src[((y + d).clamp(0, 4) * 7 + x) as usize];
                    }
                    let i = (y * 7 + x) as usize;
                    assert!(
                        (rows[i] - er).abs() < 1e-5 && (cols[i] - ec).abs() < 1e-5,
                        "order {order}"
                    );
                }
            }
        }
    }

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
