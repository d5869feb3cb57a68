//! The KITTI odometry layout: `calib.txt` (3×4 projection rows, `P0: …` labelled as in the
//! official release or unlabelled), `times.txt` (one timestamp per frame) and `poses.txt`
//! (ground truth, 12 values per row: the 3×4 camera-to-world matrix of each frame), plus
//! pose rows in the same form for writing trajectories.

use std::path::Path;

use nalgebra::{Matrix3, Vector3};

use super::trajectory::Pose;
use crate::error::{ConfigError, Error, Result};
use crate::slam::camera::PinholeCamera;
use crate::slam::rotation;

fn read(path: &Path) -> Result<String> {
    crate::error::read_input(path)
}

fn bad(path: &Path, line: usize, reason: impl std::fmt::Display) -> Error {
    Error::Parse {
        path: path.to_path_buf(),
        reason: format!("line {line}: {reason}"),
    }
}

/// Numbers of one line (an optional `label:` first), each finite.
fn numbers(path: &Path, line_no: usize, line: &str) -> Result<Vec<f64>> {
    let body = match line.split_once(':') {
        Some((_, rest)) => rest,
        None => line,
    };
    body.split_whitespace()
        .map(|t| {
            t.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(path, line_no, format!("{t:?} is not a finite number")))
        })
        .collect()
}

/// The left grey camera (P0) of a KITTI `calib.txt`, for frames of `width`×`height`.
pub fn read_calibration(path: &Path, width: u32, height: u32) -> Result<PinholeCamera> {
    let text = read(path)?;
    let mut first = None;
    let mut labels: Vec<&str> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let labelled_p0 = line.starts_with("P0:");
        if let Some((label, _)) = line.split_once(':') {
            labels.push(label.trim());
        }
        if first.is_none() || labelled_p0 {
            first = Some((i + 1, line.to_string()));
        }
        if labelled_p0 {
            break;
        }
    }
    // Labelled rows without P0 (a file of P2, P3 or Tr only) would otherwise give the first
    // row, another camera's.
    if !labels.is_empty() && !labels.contains(&"P0") {
        return Err(Error::Parse {
            path: path.to_path_buf(),
            reason: format!(
                "labelled rows ({}) but no `P0:` row, the left grey camera's",
                labels.join(", ")
            ),
        });
    }
    let (line_no, line) = first.ok_or_else(|| Error::Parse {
        path: path.to_path_buf(),
        reason: "no projection row (expected `P0: fx 0 cx 0 0 fy cy 0 0 0 1 0`)".into(),
    })?;
    let p = numbers(path, line_no, &line)?;
    if p.len() != 12 {
        return Err(bad(
            path,
            line_no,
            format!("a 3×4 projection row has 12 values, found {}", p.len()),
        ));
    }
    let camera = PinholeCamera::ideal(p[0], p[5], p[2], p[6], width, height);
    camera.validate().map_err(|e| Error::ConfigFile {
        path: path.to_path_buf(),
        source: Box::new(ConfigError::invalid("P0", e)),
    })?;
    Ok(camera)
}

/// Timestamps of `times.txt`: one per line, finite and strictly increasing.
pub fn read_times(path: &Path) -> Result<Vec<f64>> {
    let text = read(path)?;
    let mut times: Vec<f64> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let v = numbers(path, i + 1, line)?;
        let [t] = v[..] else {
            return Err(bad(
                path,
                i + 1,
                format!("expected one timestamp, found {} values", v.len()),
            ));
        };
        if let Some(&prev) = times.last() {
            if t <= prev {
                return Err(bad(
                    path,
                    i + 1,
                    format!("timestamps must increase: {t} after {prev}"),
                ));
            }
        }
        times.push(t);
    }
    Ok(times)
}

/// Whether a trajectory file holds KITTI pose rows (9 or more values on its first data line;
/// a TUM row has 8).
pub fn looks_like_poses(path: &Path) -> bool {
    crate::error::read_input(path).is_ok_and(|text| {
        text.lines()
            .map(str::trim)
            .find(|l| !l.is_empty() && !l.starts_with('#'))
            // TUM rows have 8 values; 9 or more can only be a KITTI pose row, perhaps one
            // with a value missing or extra, which its reader then names.
            .is_some_and(|l| l.split_whitespace().count() >= 9)
    })
}

/// Ground truth from `poses.txt`, row i taken at `timestamps[i]`; needs at least one row per
/// timestamp.
pub fn read_poses(path: &Path, timestamps: &[f64]) -> Result<Vec<Pose>> {
    let text = read(path)?;
    let mut poses = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        if poses.len() == timestamps.len() {
            break;
        }
        let v = numbers(path, i + 1, line)?;
        if v.len() != 12 {
            return Err(bad(
                path,
                i + 1,
                format!("a pose row has 12 values, found {}", v.len()),
            ));
        }
        let r = Matrix3::new(v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10]);
        if ((r.transpose() * r) - Matrix3::identity()).amax() > 1e-3 {
            return Err(bad(path, i + 1, "the 3×3 part is not a rotation"));
        }
        if r.determinant() < 0.0 {
            return Err(bad(
                path,
                i + 1,
                "the 3×3 part is a reflection (determinant −1), not a rotation",
            ));
        }
        poses.push(Pose {
            timestamp: timestamps[poses.len()],
            position: Vector3::new(v[3], v[7], v[11]),
            orientation: rotation::from_matrix(&r),
        });
    }
    if poses.len() < timestamps.len() {
        return Err(Error::Parse {
            path: path.to_path_buf(),
            reason: format!(
                "{} pose rows for {} frames (line {} is the end of the file)",
                poses.len(),
                timestamps.len(),
                text.lines().count()
            ),
        });
    }
    Ok(poses)
}

/// One KITTI pose row: the 3×4 camera-to-world matrix, row-major.
pub fn pose_row(pose: &Pose) -> String {
    let r = rotation::matrix(&pose.orientation);
    let p = pose.position;
    format!(
        "{:.9e} {:.9e} {:.9e} {:.9e} {:.9e} {:.9e} {:.9e} {:.9e} {:.9e} {:.9e} {:.9e} {:.9e}",
        r[(0, 0)],
        r[(0, 1)],
        r[(0, 2)],
        p.x,
        r[(1, 0)],
        r[(1, 1)],
        r[(1, 2)],
        p.y,
        r[(2, 0)],
        r[(2, 1)],
        r[(2, 2)],
        p.z
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labelled_and_unlabelled_calibrations_give_p0() {
        let dir = tempfile::tempdir().unwrap();
        let row = "7.0e+02 0 6.0e+02 0 0 7.1e+02 1.8e+02 0 0 0 1 0";
        let official = dir.path().join("official.txt");
        std::fs::write(
            &official,
            format!("P0: {row}\nP1: 1 0 0 -3 0 1 0 0 0 0 1 0\n"),
        )
        .unwrap();
        let plain = dir.path().join("plain.txt");
        std::fs::write(&plain, format!("{row}\n1 0 0 -3 0 1 0 0 0 0 1 0\n")).unwrap();
        for path in [official, plain] {
            let cam = read_calibration(&path, 1241, 376).unwrap();
            assert_eq!(
                (cam.fx, cam.fy, cam.cx, cam.cy),
                (700.0, 710.0, 600.0, 180.0)
            );
        }
        let short = dir.path().join("short.txt");
        std::fs::write(&short, "P0: 1 2 3\n").unwrap();
        let message = read_calibration(&short, 10, 10).unwrap_err().to_string();
        assert!(
            message.contains("short.txt") && message.contains("line 1"),
            "{message}"
        );
        // Labelled rows without P0 are refused rather than read as P0.
        let colour = dir.path().join("colour.txt");
        std::fs::write(&colour, format!("P2: {row}\nP3: {row}\n")).unwrap();
        let message = read_calibration(&colour, 1241, 376)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("colour.txt")
                && message.contains("P2, P3")
                && message.contains("no `P0:`"),
            "{message}"
        );
    }

    #[test]
    fn poses_round_trip_and_short_or_bad_files_name_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let pose = Pose {
            timestamp: 0.0,
            position: Vector3::new(1.0, -2.0, 3.5),
            orientation: rotation::from_rotation_vector(&Vector3::new(0.1, 0.2, -0.3)),
        };
        let path = dir.path().join("poses.txt");
        std::fs::write(&path, format!("{}\n{}\n", pose_row(&pose), pose_row(&pose))).unwrap();
        assert!(looks_like_poses(&path));
        let back = read_poses(&path, &[0.0, 0.1]).unwrap();
        assert!((back[1].position - pose.position).norm() < 1e-6);
        assert!((back[1].orientation - pose.orientation).norm() < 1e-6);
        assert_eq!(back[1].timestamp, 0.1);
        let message = read_poses(&path, &[0.0, 0.1, 0.2]).unwrap_err().to_string();
        assert!(message.contains("2 pose rows for 3 frames"), "{message}");
        std::fs::write(&path, "1 0 0 0 0 1 0 0 0 0 1\n").unwrap();
        // A row one value short is still a KITTI row (a TUM row has 8), so its own reader
        // names it rather than the TUM one.
        assert!(looks_like_poses(&path));
        std::fs::write(dir.path().join("tum.txt"), "0 1 2 3 0 0 0 1\n").unwrap();
        assert!(!looks_like_poses(&dir.path().join("tum.txt")));
        let message = read_poses(&path, &[0.0]).unwrap_err().to_string();
        assert!(
            message.contains("line 1") && message.contains("12 values"),
            "{message}"
        );
        // A reflection is orthogonal too, and refused as one.
        std::fs::write(&path, "1 0 0 0 0 1 0 0 0 0 -1 0\n").unwrap();
        let message = read_poses(&path, &[0.0]).unwrap_err().to_string();
        assert!(
            message.contains("line 1") && message.contains("reflection"),
            "{message}"
        );
        let times = dir.path().join("times.txt");
        std::fs::write(&times, "0.0\n0.1\nabc\n").unwrap();
        let message = read_times(&times).unwrap_err().to_string();
        assert!(
            message.contains("times.txt") && message.contains("line 3"),
            "{message}"
        );
        std::fs::write(&times, "0.0\n0.1\n0.1\n").unwrap();
        assert!(read_times(&times)
            .unwrap_err()
            .to_string()
            .contains("increase"));
    }
}
