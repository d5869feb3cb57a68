//! Procedural test scenes: a seeded, real-looking textured image (shaded background with
//! value noise, overlapping polygons and discs with flat, striped and checkered fills,
//! anti-aliased by 3×3 supersampling) and exact or interpolated rotations of an image.
//! Tests and benchmarks use these instead of files outside the repository.

use rayon::prelude::*;

use crate::image::Frame;

pub use crate::rng::Rng;

enum Fill {
    Flat,
    Stripes { freq: f32, angle: f32 },
    Checker { size: f32, angle: f32 },
}

enum Shape {
    Polygon(Vec<(f32, f32)>),
    Disc { cx: f32, cy: f32, r: f32 },
}

struct Item {
    shape: Shape,
    colour: [f32; 3],
    second: [f32; 3],
    fill: Fill,
}

impl Item {
    fn contains(&self, x: f32, y: f32) -> bool {
        match &self.shape {
            Shape::Disc { cx, cy, r } => (x - cx).powi(2) + (y - cy).powi(2) <= r * r,
            Shape::Polygon(p) => {
                let mut sign = 0.0f32;
                for i in 0..p.len() {
                    let (a, b) = (p[i], p[(i + 1) % p.len()]);
                    let cross = (b.0 - a.0) * (y - a.1) - (b.1 - a.1) * (x - a.0);
                    if cross != 0.0 {
                        if sign == 0.0 {
                            sign = cross.signum();
                        } else if sign != cross.signum() {
                            return false;
                        }
                    }
                }
                true
            }
        }
    }
    fn colour_at(&self, x: f32, y: f32) -> [f32; 3] {
        let alt = match self.fill {
            Fill::Flat => false,
            Fill::Stripes { freq, angle } => {
                ((x * angle.cos() + y * angle.sin()) * freq).sin() > 0.0
            }
            Fill::Checker { size, angle } => {
                let u = (x * angle.cos() + y * angle.sin()) / size;
                let v = (-x * angle.sin() + y * angle.cos()) / size;
                (u.floor() as i64 + v.floor() as i64) % 2 == 0
            }
        };
        if alt {
            self.second
        } else {
            self.colour
        }
    }
}

fn value_noise(x: f32, y: f32, seed: u64) -> f32 {
    let hash = |i: i64, j: i64| {
        let mut r = Rng(seed
            ^ (i as u64).wrapping_mul(0x9E37_79B9)
            ^ (j as u64).wrapping_mul(0x85EB_CA6B) << 1);
        r.unit()
    };
    let (fx, fy) = (x.floor(), y.floor());
    let (tx, ty) = (x - fx, y - fy);
    let (sx, sy) = (tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty));
    let (i, j) = (fx as i64, fy as i64);
    let a = hash(i, j) + (hash(i + 1, j) - hash(i, j)) * sx;
    let b = hash(i, j + 1) + (hash(i + 1, j + 1) - hash(i, j + 1)) * sx;
    a + (b - a) * sy
}

/// A seeded textured scene of `width`×`height` pixels.
pub fn textured_scene(width: u32, height: u32, seed: u64) -> Frame {
    let mut rng = Rng(seed);
    let (w, h) = (width as f32, height as f32);
    let area = w * h;
    let count = ((area / 2500.0) as usize).clamp(8, 400);
    let colour = |rng: &mut Rng| {
        [
            rng.range(0.05, 0.95),
            rng.range(0.05, 0.95),
            rng.range(0.05, 0.95),
        ]
    };
    let items: Vec<Item> = (0..count)
        .map(|_| {
            let cx = rng.range(-0.05, 1.05) * w;
            let cy = rng.range(-0.05, 1.05) * h;
            let size = rng.range(6.0, 0.12 * w.min(h) + 12.0);
            let shape = if rng.unit() < 0.3 {
                Shape::Disc {
                    cx,
                    cy,
                    r: size * 0.6,
                }
            } else {
                let sides = 3 + (rng.next_u64() % 4) as usize;
                let rot = rng.range(0.0, std::f32::consts::TAU);
                Shape::Polygon(
                    (0..sides)
                        .map(|k| {
                            let a = rot
                                + k as f32 * std::f32::consts::TAU / sides as f32
                                + rng.range(-0.3, 0.3);
                            let r = size * rng.range(0.6, 1.0);
                            (cx + r * a.cos(), cy + r * a.sin())
                        })
                        .collect(),
                )
            };
            let fill = match rng.next_u64() % 4 {
                0 => Fill::Stripes {
                    freq: rng.range(0.2, 0.6),
                    angle: rng.range(0.0, std::f32::consts::PI),
                },
                1 => Fill::Checker {
                    size: rng.range(4.0, 12.0),
                    angle: rng.range(0.0, std::f32::consts::PI),
                },
                _ => Fill::Flat,
            };
            Item {
                shape,
                colour: colour(&mut rng),
                second: colour(&mut rng),
                fill,
            }
        })
        .collect();
    let base = colour(&mut rng);
    let noise_seed = rng.next_u64();
    let mut rgb = vec![0u8; 3 * (width * height) as usize];
    rgb.par_chunks_mut(3 * width as usize)
        .enumerate()
        .for_each(|(y, row)| {
            for x in 0..width as usize {
                let mut acc = [0.0f32; 3];
                for sy in 0..3 {
                    for sx in 0..3 {
                        let px = x as f32 + (sx as f32 - 1.0) / 3.0;
                        let py = y as f32 + (sy as f32 - 1.0) / 3.0;
                        let shade = 0.75
                            + 0.25 * value_noise(px / 23.0, py / 23.0, noise_seed)
                            + 0.1 * value_noise(px / 4.0, py / 4.0, noise_seed ^ 1);
                        let mut c = [base[0] * shade, base[1] * shade, base[2] * shade];
                        for item in items.iter().rev() {
                            if item.contains(px, py) {
                                let ic = item.colour_at(px, py);
                                c = [ic[0] * shade, ic[1] * shade, ic[2] * shade];
                                break;
                            }
                        }
                        for k in 0..3 {
                            acc[k] += c[k];
                        }
                    }
                }
                for k in 0..3 {
                    row[3 * x + k] = (acc[k] / 9.0 * 255.0).round().clamp(0.0, 255.0) as u8;
                }
            }
        });
    optical_blur(&mut rgb, width as usize, height as usize);
    Frame::from_rgb(width, height, rgb).expect("generated size is valid")
}

/// A camera's point-spread function: Gaussian blur, σ = 0.7 px, on every channel.
fn optical_blur(rgb: &mut [u8], width: usize, height: usize) {
    use crate::features::convolve::convolve_separable;
    use crate::features::steerable::{Kernel1d, Separable};
    let k = Kernel1d::gaussian_derivative(0.7, 0, 3.0);
    let filter = Separable {
        column: k.clone(),
        row: k,
    };
    let mut plane = vec![0.0f32; width * height];
    let mut out = vec![0.0f32; width * height];
    let mut scratch = vec![0.0f32; width * height];
    for c in 0..3 {
        for (p, v) in plane.iter_mut().zip(rgb.iter().skip(c).step_by(3)) {
            *p = *v as f32;
        }
        convolve_separable(&plane, &mut out, &mut scratch, width, height, &filter);
        for (v, o) in rgb.iter_mut().skip(c).step_by(3).zip(&out) {
            *v = o.round().clamp(0.0, 255.0) as u8;
        }
    }
}

/// The exact rotation by 90° clockwise (no interpolation). A pixel (x, y) goes to
/// (h − 1 − y, x) in the result, which is `height`×`width`.
pub fn rotate90(frame: &Frame) -> Frame {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let mut rgb = vec![0u8; 3 * w * h];
    for y in 0..h {
        for x in 0..w {
            let (nx, ny) = (h - 1 - y, x);
            let d = 3 * (ny * h + nx);
            let s = 3 * (y * w + x);
            rgb[d..d + 3].copy_from_slice(&frame.rgb[s..s + 3]);
        }
    }
    Frame::from_rgb(h as u32, w as u32, rgb).expect("same pixel count")
}

/// Rotation by `angle` radians (counter-clockwise in the image's x-right/y-down frame means
/// clockwise on screen) about the centre onto a canvas of `out_w`×`out_h` whose centre the
/// image centre maps to; bilinear interpolation, black outside. Returns the frame and the
/// affine map (2×3, row-major) from source pixels to result pixels.
pub fn rotate(frame: &Frame, angle: f32, out_w: u32, out_h: u32) -> (Frame, [f64; 6]) {
    let (c, s) = (angle.cos() as f64, angle.sin() as f64);
    let (cx, cy) = (
        (frame.width as f64 - 1.0) / 2.0,
        (frame.height as f64 - 1.0) / 2.0,
    );
    let (ox, oy) = ((out_w as f64 - 1.0) / 2.0, (out_h as f64 - 1.0) / 2.0);
    // dst = R (src − c) + o
    let map = [c, -s, ox - c * cx + s * cy, s, c, oy - s * cx - c * cy];
    let (w, h) = (frame.width as i64, frame.height as i64);
    let mut rgb = vec![0u8; 3 * (out_w * out_h) as usize];
    rgb.par_chunks_mut(3 * out_w as usize)
        .enumerate()
        .for_each(|(y, row)| {
            for x in 0..out_w as usize {
                let (dx, dy) = (x as f64 - ox, y as f64 - oy);
                let sx = c * dx + s * dy + cx;
                let sy = -s * dx + c * dy + cy;
                if sx < 0.0 || sy < 0.0 || sx > (w - 1) as f64 || sy > (h - 1) as f64 {
                    continue;
                }
                let (x0, y0) = (sx.floor() as i64, sy.floor() as i64);
                let (fx, fy) = (sx - x0 as f64, sy - y0 as f64);
                for k in 0..3 {
                    let p = |xx: i64, yy: i64| {
                        frame.rgb[3 * (yy.min(h - 1) * w + xx.min(w - 1)) as usize + k] as f64
                    };
                    let v = p(x0, y0) * (1.0 - fx) * (1.0 - fy)
                        + p(x0 + 1, y0) * fx * (1.0 - fy)
                        + p(x0, y0 + 1) * (1.0 - fx) * fy
                        + p(x0 + 1, y0 + 1) * fx * fy;
                    row[3 * x + k] = v.round().clamp(0.0, 255.0) as u8;
                }
            }
        });
    (Frame::from_rgb(out_w, out_h, rgb).expect("valid size"), map)
}
