//! Ground-truth maps between two views: 3×3 homographies (row-major, view 1 pixels → view 2
//! pixels), as in the Oxford affine-covariant dataset's `H1toNp` files.

use std::path::Path;

use crate::error::{Error, Result};

/// A 3×3 row-major homography.
pub type Homography = [f64; 9];

/// The identity map.
pub const IDENTITY: Homography = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

/// Applies a homography; None for points sent to infinity.
pub fn project(h: &Homography, x: f64, y: f64) -> Option<(f64, f64)> {
    let w = h[6] * x + h[7] * y + h[8];
    if w.abs() < 1e-12 {
        return None;
    }
    Some((
        (h[0] * x + h[1] * y + h[2]) / w,
        (h[3] * x + h[4] * y + h[5]) / w,
    ))
}

/// Inverse of a homography (None when singular).
pub fn invert(h: &Homography) -> Option<Homography> {
    let [a, b, c, d, e, f, g, hh, i] = *h;
    let det = a * (e * i - f * hh) - b * (d * i - f * g) + c * (d * hh - e * g);
    if !det.is_finite() || det.abs() < 1e-15 {
        return None;
    }
    let inv = [
        e * i - f * hh,
        c * hh - b * i,
        b * f - c * e,
        f * g - d * i,
        a * i - c * g,
        c * d - a * f,
        d * hh - e * g,
        b * g - a * hh,
        a * e - b * d,
    ];
    Some(inv.map(|v| v / det))
}

/// The homography of a 2×3 affine map.
pub fn from_affine(m: &[f64; 6]) -> Homography {
    [m[0], m[1], m[2], m[3], m[4], m[5], 0.0, 0.0, 1.0]
}

/// Parses a homography file: nine numbers separated by white space.
pub fn parse(path: &Path, text: &str) -> Result<Homography> {
    let bad = |reason: String| Error::Parse {
        path: path.to_path_buf(),
        reason,
    };
    let values: Vec<f64> = text
        .split_whitespace()
        .map(|t| {
            t.parse::<f64>()
                .map_err(|e| bad(format!("'{t}' is not a number: {e}")))
        })
        .collect::<Result<_>>()?;
    let h: Homography = values
        .try_into()
        .map_err(|v: Vec<f64>| bad(format!("expected 9 numbers, found {}", v.len())))?;
    if h.iter().any(|v| !v.is_finite()) || invert(&h).is_none() {
        return Err(bad("the homography is not finite and invertible".into()));
    }
    Ok(h)
}

/// Reads and parses a homography file.
pub fn load(path: &Path) -> Result<Homography> {
    let text = crate::error::read_input(path)?;
    parse(path, &text)
}
