//! Pictures of keypoints: a circle of radius 3σ_D around each keypoint and a tick along its
//! dominant steered orientation, coloured by detection scale, drawn over the image.

use std::path::Path;

use steernav::error::{Error, Result};
use steernav::features::Keypoint;
use steernav::image::Frame;

const PALETTE: [[u8; 3]; 6] = [
    [255, 64, 64],
    [255, 200, 0],
    [64, 220, 64],
    [0, 200, 255],
    [200, 80, 255],
    [255, 255, 255],
];

fn put(img: &mut image::RgbImage, x: i64, y: i64, c: [u8; 3]) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, image::Rgb(c));
    }
}

fn line(img: &mut image::RgbImage, (x0, y0): (f32, f32), (x1, y1): (f32, f32), c: [u8; 3]) {
    let steps = (x1 - x0).abs().max((y1 - y0).abs()).ceil().max(1.0) as usize;
    for i in 0..=steps {
        let t = i as f32 / steps as f32;
        put(
            img,
            (x0 + t * (x1 - x0)).round() as i64,
            (y0 + t * (y1 - y0)).round() as i64,
            c,
        );
    }
}

fn circle(img: &mut image::RgbImage, (cx, cy): (f32, f32), r: f32, c: [u8; 3]) {
    let steps = (2.0 * std::f32::consts::PI * r).ceil().max(8.0) as usize;
    for i in 0..steps {
        let a = i as f32 / steps as f32 * std::f32::consts::TAU;
        put(
            img,
            (cx + r * a.cos()).round() as i64,
            (cy + r * a.sin()).round() as i64,
            c,
        );
    }
}

/// Renders the keypoints over the frame (colour by the rank among `scales` of the sampled
/// scale nearest each keypoint's, in log scale).
pub fn render(frame: &Frame, keypoints: &[Keypoint], scales: &[f32]) -> image::RgbImage {
    let mut img = image::RgbImage::from_raw(frame.width, frame.height, frame.rgb.clone())
        .expect("frame holds width*height RGB pixels");
    for k in keypoints {
        let distance = |s: f32| (s.ln() - k.scale.ln()).abs();
        let rank = (0..scales.len())
            .min_by(|&a, &b| distance(scales[a]).total_cmp(&distance(scales[b])))
            .unwrap_or(0);
        let c = PALETTE[rank.min(PALETTE.len() - 1)];
        let r = 3.0 * k.scale;
        circle(&mut img, (k.x, k.y), r, c);
        line(
            &mut img,
            (k.x, k.y),
            (k.x + r * k.angle.cos(), k.y + r * k.angle.sin()),
            c,
        );
    }
    img
}

/// Renders and writes a PNG (atomically: a temporary file renamed into place).
pub fn write_png(path: &Path, frame: &Frame, keypoints: &[Keypoint], scales: &[f32]) -> Result<()> {
    write_image(path, &render(frame, keypoints, scales))
}

/// Colours of verified and rejected matches.
const INLIER: [u8; 3] = [40, 230, 60];
const OUTLIER: [u8; 3] = [255, 40, 40];

/// One match to draw: its point in each image and whether it is an inlier.
pub type MatchEnds = ((f32, f32), (f32, f32), bool);

/// The two frames side by side (top-aligned) with a line per match, inliers green and
/// outliers red, and a small circle at each end.
pub fn render_matches(first: &Frame, second: &Frame, ends: &[MatchEnds]) -> image::RgbImage {
    let (w1, w2) = (first.width, second.width);
    let height = first.height.max(second.height);
    let mut img = image::RgbImage::new(w1 + w2, height);
    for (frame, x0) in [(first, 0), (second, w1)] {
        let view = image::RgbImage::from_raw(frame.width, frame.height, frame.rgb.clone())
            .expect("frame holds width*height RGB pixels");
        image::imageops::replace(&mut img, &view, x0 as i64, 0);
    }
    // Outliers first, so that inliers stay visible where lines cross.
    for want in [false, true] {
        for &((x1, y1), (x2, y2), inlier) in ends.iter().filter(|e| e.2 == want) {
            let c = if inlier { INLIER } else { OUTLIER };
            let b = (x2 + w1 as f32, y2);
            line(&mut img, (x1, y1), b, c);
            circle(&mut img, (x1, y1), 3.0, c);
            circle(&mut img, b, 3.0, c);
        }
    }
    img
}

/// Writes an image as PNG, atomically.
pub fn write_image(path: &Path, img: &image::RgbImage) -> Result<()> {
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .map_err(|e| Error::Io {
        path: path.into(),
        source: std::io::Error::other(e.to_string()),
    })?;
    steernav::output::write_atomic(path, &bytes)
}
