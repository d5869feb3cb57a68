//! Homography sequences generated from one photo, in the Oxford layout (img1..img6 and
//! H1to2p..H1to6p), for the changes the shared sequences do not hold on their own: blur,
//! JPEG compression and zoom without rotation. `steernav eval homography` then judges them
//! like any other sequence (repeatability, eq 11; recall, eq 12; the matching metrics).
//!
//! Each kind has five fixed levels, so that figures compare across photos and sessions:
//! - **blur**: a Gaussian of σ = 0.6, 1, 1.5, 2 and 3 px on every channel (the Oxford *bikes*
//!   and *trees* sequences defocus a real lens instead); the map is the identity;
//! - **jpeg**: JPEG at quality 40, 20, 10, 5 and 2 (the Oxford *ubc* sequence's 60–98%
//!   compression), decoded again; the identity;
//! - **zoom**: the photo shrunk by 1.25, 1.6, 2, 2.5 and 3, each output pixel the mean of the
//!   source area it covers (a camera farther away integrates more of the scene per pixel);
//!   the map scales about the pixel grid's origin.

use std::path::Path;

use image::codecs::jpeg::JpegEncoder;
use rayon::prelude::*;

use super::homography::{Homography, IDENTITY};
use crate::error::{Error, Result};
use crate::features::steerable::Kernel1d;
use crate::image::Frame;
use crate::output::write_atomic;

/// What changes between img1 and the generated views.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Change {
    /// Gaussian blur of growing σ.
    Blur,
    /// JPEG compression of falling quality.
    Jpeg,
    /// Shrinking by growing factors (zoom out), without rotation.
    Zoom,
}

/// Gaussian σ of the blurred views, in pixels.
pub const BLUR_SIGMAS: [f32; 5] = [0.6, 1.0, 1.5, 2.0, 3.0];
/// JPEG quality of the compressed views.
pub const JPEG_QUALITIES: [u8; 5] = [40, 20, 10, 5, 2];
/// Shrink factors of the zoomed views.
pub const ZOOM_FACTORS: [f64; 5] = [1.25, 1.6, 2.0, 2.5, 3.0];

impl Change {
    /// The five views beside img1 (`frame` itself) and their maps from img1.
    pub fn views(self, frame: &Frame) -> Result<Vec<(Frame, Homography)>> {
        match self {
            Change::Blur => BLUR_SIGMAS
                .iter()
                .map(|&s| Ok((blur(frame, s)?, IDENTITY)))
                .collect(),
            Change::Jpeg => JPEG_QUALITIES
                .iter()
                .map(|&q| Ok((jpeg(frame, q)?, IDENTITY)))
                .collect(),
            Change::Zoom => ZOOM_FACTORS.iter().map(|&z| shrink(frame, z)).collect(),
        }
    }
}

/// Writes `frame` as img1.png and its generated views as img2.png..img6.png with their maps
/// H1to2p..H1to6p into `dir` (created if needed).
pub fn write_sequence(dir: &Path, frame: &Frame, change: Change) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|source| Error::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    write_png(&dir.join("img1.png"), frame)?;
    for (k, (view, h)) in change.views(frame)?.iter().enumerate() {
        write_png(&dir.join(format!("img{}.png", k + 2)), view)?;
        let text: String = h
            .chunks(3)
            .map(|r| format!("{:e} {:e} {:e}\n", r[0], r[1], r[2]))
            .collect();
        write_atomic(&dir.join(format!("H1to{}p", k + 2)), text.as_bytes())?;
    }
    Ok(())
}

/// `frame` as a PNG at `path`, written atomically.
pub(crate) fn write_png(path: &Path, frame: &Frame) -> Result<()> {
    let mut bytes = Vec::new();
    image::RgbImage::from_raw(frame.width, frame.height, frame.rgb.clone())
        .expect("a frame holds its pixels")
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|e| Error::Io {
            path: path.to_path_buf(),
            source: std::io::Error::other(e.to_string()),
        })?;
    write_atomic(path, &bytes)
}

/// Refuses a generator's setting outside `range`, naming it.
fn check(field: &'static str, value: f64, range: std::ops::RangeInclusive<f64>) -> Result<()> {
    if value.is_finite() && range.contains(&value) {
        return Ok(());
    }
    Err(Error::Config {
        field,
        value: value.to_string(),
        reason: format!("must be finite, in [{}, {}]", range.start(), range.end()),
    })
}

/// Every channel blurred by a Gaussian of `sigma` px (0.1–50; truncated at 4σ, borders
/// clamped).
pub fn blur(frame: &Frame, sigma: f32) -> Result<Frame> {
    check("sigma", sigma as f64, 0.1..=50.0)?;
    let taps = Kernel1d::gaussian_derivative(sigma, 0, 4.0).taps;
    let (w, h) = (frame.width as usize, frame.height as usize);
    let src: Vec<f32> = frame.rgb.iter().map(|&v| v as f32).collect();
    let rows = blur_axis(&src, w, h, &taps, true);
    let cols = blur_axis(&rows, w, h, &taps, false);
    let rgb = cols
        .iter()
        .map(|v| v.round().clamp(0.0, 255.0) as u8)
        .collect();
    Frame::from_rgb(frame.width, frame.height, rgb)
}

/// `taps` applied to interleaved RGB (`w`×`h`) along its rows or its columns, borders clamped.
fn blur_axis(src: &[f32], w: usize, h: usize, taps: &[f32], along_rows: bool) -> Vec<f32> {
    let radius = (taps.len() / 2) as i64;
    // Values between neighbours along the axis, and samples along it.
    let (stride, len) = if along_rows { (3, w) } else { (3 * w, h) };
    let mut out = vec![0f32; src.len()];
    out.par_chunks_mut(3 * w).enumerate().for_each(|(y, row)| {
        for (i, v) in row.iter_mut().enumerate() {
            let at = 3 * w * y + i;
            // Position of this value along the axis.
            let pos = if along_rows { (i / 3) as i64 } else { y as i64 };
            *v = taps
                .iter()
                .enumerate()
                .map(|(k, t)| {
                    let p = (pos + k as i64 - radius).clamp(0, len as i64 - 1);
                    t * src[(at as i64 + (p - pos) * stride as i64) as usize]
                })
                .sum();
        }
    });
    out
}

/// The frame compressed as JPEG at `quality` (1–100) and decoded again.
pub fn jpeg(frame: &Frame, quality: u8) -> Result<Frame> {
    check("quality", quality as f64, 1.0..=100.0)?;
    let fail = |e: image::ImageError| Error::Io {
        path: format!("<JPEG at quality {quality}>").into(),
        source: std::io::Error::other(e.to_string()),
    };
    let mut bytes = Vec::new();
    JpegEncoder::new_with_quality(&mut bytes, quality)
        .encode(
            &frame.rgb,
            frame.width,
            frame.height,
            image::ExtendedColorType::Rgb8,
        )
        .map_err(fail)?;
    let decoded = image::load_from_memory_with_format(&bytes, image::ImageFormat::Jpeg)
        .map_err(fail)?
        .to_rgb8();
    Frame::from_rgb(decoded.width(), decoded.height(), decoded.into_raw())
}

/// The frame shrunk by `factor` (1–100): output pixel u covers source pixels [u·f, (u+1)·f)
/// on each axis and takes their area-weighted mean. The map sends source pixel centre x to
/// (x + ½)/f − ½.
pub fn shrink(frame: &Frame, factor: f64) -> Result<(Frame, Homography)> {
    check("factor", factor, 1.0..=100.0)?;
    let (w, h) = (frame.width as usize, frame.height as usize);
    let (ow, oh) = (
        ((w as f64 / factor).floor() as usize).max(1),
        ((h as f64 / factor).floor() as usize).max(1),
    );
    // Per output index, the source indices it covers and their weights (summing to 1).
    let spans = |n_out: usize, n_src: usize| -> Vec<Vec<(usize, f64)>> {
        (0..n_out)
            .map(|u| {
                let (a, b) = (u as f64 * factor, (u + 1) as f64 * factor);
                let span: Vec<(usize, f64)> = (a.floor() as usize..(b.ceil() as usize).min(n_src))
                    .map(|i| (i, (b.min(i as f64 + 1.0) - a.max(i as f64)) / factor))
                    .filter(|&(_, wt)| wt > 0.0)
                    .collect();
                span
            })
            .collect()
    };
    let (xs, ys) = (spans(ow, w), spans(oh, h));
    let mut rgb = vec![0u8; 3 * ow * oh];
    rgb.par_chunks_mut(3 * ow).enumerate().for_each(|(v, out)| {
        for (u, xspan) in xs.iter().enumerate() {
            for c in 0..3 {
                let mut acc = 0.0;
                for &(j, wy) in &ys[v] {
                    for &(i, wx) in xspan {
                        acc += wx * wy * frame.rgb[3 * (j * w + i) + c] as f64;
                    }
                }
                out[3 * u + c] = acc.round().clamp(0.0, 255.0) as u8;
            }
        }
    });
    let s = 1.0 / factor;
    let t = 0.5 * s - 0.5;
    let map = [s, 0.0, t, 0.0, s, t, 0.0, 0.0, 1.0];
    Ok((Frame::from_rgb(ow as u32, oh as u32, rgb)?, map))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::homography::project;

    /// A frame with one bright square on black, `size` px a side, its top-left at `at`.
    fn square(w: u32, h: u32, at: (u32, u32), size: u32) -> Frame {
        let mut rgb = vec![0u8; (3 * w * h) as usize];
        for y in at.1..at.1 + size {
            for x in at.0..at.0 + size {
                let i = 3 * (y * w + x) as usize;
                rgb[i..i + 3].copy_from_slice(&[200, 200, 200]);
            }
        }
        Frame::from_rgb(w, h, rgb).unwrap()
    }

    /// Intensity-weighted centroid of channel 0.
    fn centroid(f: &Frame) -> (f64, f64) {
        let (mut s, mut sx, mut sy) = (0.0, 0.0, 0.0);
        for y in 0..f.height as usize {
            for x in 0..f.width as usize {
                let v = f.rgb[3 * (y * f.width as usize + x)] as f64;
                s += v;
                sx += v * x as f64;
                sy += v * y as f64;
            }
        }
        (sx / s, sy / s)
    }

    #[test]
    fn the_shrunk_view_keeps_the_mass_where_the_map_sends_it() {
        let f = square(120, 90, (41, 23), 18);
        let (c1x, c1y) = centroid(&f);
        for &z in &ZOOM_FACTORS {
            let (g, map) = shrink(&f, z).unwrap();
            assert_eq!(g.width, (120.0 / z).floor() as u32);
            let (ex, ey) = project(&map, c1x, c1y).unwrap();
            let (cx, cy) = centroid(&g);
            assert!(
                (cx - ex).abs() < 0.05 && (cy - ey).abs() < 0.05,
                "{z}: {cx},{cy} against {ex},{ey}"
            );
            // The area mean keeps the total brightness in proportion to the area.
            let sum = |f: &Frame| f.rgb.iter().step_by(3).map(|&v| v as f64).sum::<f64>();
            let ratio = sum(&g) * z * z / sum(&f);
            assert!((ratio - 1.0).abs() < 0.02, "{z}: brightness ratio {ratio}");
        }
    }

    #[test]
    fn blur_spreads_an_edge_by_its_sigma_and_keeps_its_place() {
        let f = square(80, 80, (20, 20), 40);
        for &s in &BLUR_SIGMAS {
            let g = blur(&f, s).unwrap();
            let (cx, cy) = centroid(&g);
            assert!((cx - 39.5).abs() < 0.05 && (cy - 39.5).abs() < 0.05);
            // Across the edge at x = 19.5, the profile is the Gaussian's integral: 50% at the
            // edge, about 84% one σ inside.
            let row = |x: usize| g.rgb[3 * (40 * 80 + x)] as f32 / 200.0;
            let inside = row((19.5 + s).round() as usize);
            assert!(inside > 0.6 && inside < 1.0, "σ {s}: {inside}");
            assert!((row(20) + row(19) - 1.0).abs() < 0.05);
        }
    }

    #[test]
    fn jpeg_views_degrade_with_the_quality_and_keep_the_size() {
        let f = blur(&square(64, 48, (10, 10), 20), 1.0).unwrap();
        let err = |q| {
            let g = jpeg(&f, q).unwrap();
            assert_eq!((g.width, g.height), (64, 48));
            f.rgb
                .iter()
                .zip(&g.rgb)
                .map(|(&a, &b)| (a as f64 - b as f64).abs())
                .sum::<f64>()
        };
        assert!(err(40) < err(5));
    }

    #[test]
    fn settings_out_of_range_are_refused_by_name() {
        let f = square(16, 16, (4, 4), 4);
        for (e, name) in [
            (blur(&f, 0.0).unwrap_err(), "sigma"),
            (blur(&f, f32::NAN).unwrap_err(), "sigma"),
            (jpeg(&f, 0).unwrap_err(), "quality"),
            (shrink(&f, 0.5).unwrap_err(), "factor"),
            (shrink(&f, f64::INFINITY).unwrap_err(), "factor"),
        ] {
            assert!(e.to_string().contains(name), "{e}");
        }
    }

    #[test]
    fn a_written_sequence_is_read_back_as_one() {
        let dir = tempfile::tempdir().unwrap();
        let f = square(64, 48, (10, 10), 20);
        write_sequence(dir.path(), &f, Change::Zoom).unwrap();
        let (first, others) = crate::eval::sweep::sequence_files(dir.path()).unwrap();
        assert!(first.ends_with("img1.png"));
        assert_eq!(others.len(), 5);
        let (_, _, h) = &others[2];
        assert!((h[0] - 0.5).abs() < 1e-12 && (h[2] + 0.25).abs() < 1e-12);
    }
}
