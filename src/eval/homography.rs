//! Ground-truth maps between two views: 3×3 homographies (row-major, view 1 pixels → view 2
//! pixels), as in the Oxford affine-covariant dataset's `H1toNp` files.

use std::path::Path;

use glam::{DMat3, DVec3};

use crate::error::{Error, Result};

/// A 3×3 row-major homography.
pub type Homography = [f64; 9];

/// The identity map.
pub const IDENTITY: Homography = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

/// The matrix of a row-major homography.
fn matrix(h: &Homography) -> DMat3 {
    DMat3::from_cols_array(h).transpose()
}

/// Applies a homography; None for points sent to infinity.
pub fn project(h: &Homography, x: f64, y: f64) -> Option<(f64, f64)> {
    let p = matrix(h) * DVec3::new(x, y, 1.0);
    if p.z.abs() < 1e-12 {
        return None;
    }
    Some((p.x / p.z, p.y / p.z))
}

/// Inverse of a homography (None when singular).
pub fn invert(h: &Homography) -> Option<Homography> {
    let m = matrix(h);
    let det = m.determinant();
    if !det.is_finite() || det.abs() < 1e-15 {
        return None;
    }
    Some(m.inverse().transpose().to_cols_array())
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
