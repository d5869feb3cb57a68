//! Trajectories: TUM files (`t tx ty tz qx qy qz qw`) in and out, timestamp association, and
//! the evaluation of a monocular estimate against ground truth — absolute trajectory error
//! after Sim(3) alignment (Umeyama, 1991: a monocular trajectory has no scale) and relative
//! pose error over one-second intervals.

use std::io::{BufRead, Write};
use std::path::Path;

use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

use crate::error::{Error, Result};
use crate::slam::rotation::{self, Quat};

/// A timestamped camera pose (camera → world).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Seconds.
    pub timestamp: f64,
    /// Camera centre in the world.
    pub position: Vector3<f64>,
    /// Orientation (w, x, y, z), camera → world.
    pub orientation: Quat,
}

/// One TUM line for a pose.
pub fn tum_line(pose: &Pose) -> String {
    let (p, q) = (pose.position, pose.orientation);
    format!(
        // Nanosecond timestamps: frames a microsecond apart stay apart (ROS stamps are ns).
        "{:.9} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9}",
        pose.timestamp, p.x, p.y, p.z, q[1], q[2], q[3], q[0]
    )
}

/// Writes poses as a TUM trajectory file.
pub fn write_tum(path: &Path, poses: &[Pose]) -> Result<()> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
    writeln!(out, "# timestamp tx ty tz qx qy qz qw").map_err(io)?;
    for pose in poses {
        writeln!(out, "{}", tum_line(pose)).map_err(io)?;
    }
    out.flush().map_err(io)
}

/// Reads a TUM trajectory (comments with `#`, blank lines ignored, timestamps increasing).
pub fn read_tum(path: &Path) -> Result<Vec<Pose>> {
    let file = crate::error::open_input(path)?;
    let mut poses: Vec<Pose> = Vec::new();
    for (i, line) in std::io::BufReader::new(file).lines().enumerate() {
        let line = line.map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let bad = |reason: String| Error::Parse {
            path: path.to_path_buf(),
            reason: format!("line {}: {reason}", i + 1),
        };
        let text = line.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        let values: Vec<f64> = text
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|s| !s.is_empty())
            .map(|s| s.parse::<f64>().map_err(|e| bad(format!("{s:?}: {e}"))))
            .collect::<Result<_>>()?;
        if values.len() != 8 {
            return Err(bad(format!(
                "expected 8 values (t tx ty tz qx qy qz qw), got {}",
                values.len()
            )));
        }
        let pose = checked_pose(
            values[0],
            [values[1], values[2], values[3]],
            [values[7], values[4], values[5], values[6]],
            poses.last(),
        )
        .map_err(bad)?;
        poses.push(pose);
    }
    Ok(poses)
}

/// A pose from its time, position and quaternion (w, x, y, z), checked as every trajectory
/// reader checks it: finite values, a quaternion that is not zero, a time after `previous`'s.
pub(crate) fn checked_pose(
    t: f64,
    position: [f64; 3],
    wxyz: [f64; 4],
    previous: Option<&Pose>,
) -> std::result::Result<Pose, String> {
    if let Some(v) = std::iter::once(t)
        .chain(position)
        .chain(wxyz)
        .find(|v| !v.is_finite())
    {
        return Err(format!("non-finite value {v}"));
    }
    let q = Quat::new(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
    if q.norm() < 1e-6 {
        return Err("zero quaternion".into());
    }
    if let Some(prev) = previous {
        if t <= prev.timestamp {
            return Err(format!(
                "timestamp {t} is not after the previous one ({})",
                prev.timestamp
            ));
        }
    }
    Ok(Pose {
        timestamp: t,
        position: Vector3::new(position[0], position[1], position[2]),
        orientation: q.normalize(),
    })
}

/// Pairs each estimated pose with the ground-truth pose nearest in time, within `max_dt`.
pub fn associate(estimate: &[Pose], truth: &[Pose], max_dt: f64) -> Vec<(Pose, Pose)> {
    let mut pairs = Vec::new();
    for e in estimate {
        let i = truth.partition_point(|g| g.timestamp < e.timestamp);
        let nearest = [i.checked_sub(1), Some(i)]
            .into_iter()
            .flatten()
            .filter(|&j| j < truth.len())
            .min_by(|&a, &b| {
                (truth[a].timestamp - e.timestamp)
                    .abs()
                    .total_cmp(&(truth[b].timestamp - e.timestamp).abs())
            });
        if let Some(j) = nearest {
            if (truth[j].timestamp - e.timestamp).abs() <= max_dt {
                pairs.push((*e, truth[j]));
            }
        }
    }
    pairs
}

/// The pose at time `t`, linearly interpolated between the two samples around it (positions
/// linearly, orientations by normalised linear interpolation); `None` outside the samples.
pub fn interpolate(poses: &[Pose], t: f64) -> Option<Pose> {
    let i = poses.partition_point(|p| p.timestamp < t);
    if i < poses.len() && poses[i].timestamp == t {
        return Some(poses[i]);
    }
    if i == 0 || i >= poses.len() {
        return None;
    }
    let (a, b) = (&poses[i - 1], &poses[i]);
    let f = (t - a.timestamp) / (b.timestamp - a.timestamp);
    let qb = if a.orientation.dot(&b.orientation) < 0.0 {
        -b.orientation
    } else {
        b.orientation
    };
    Some(Pose {
        timestamp: t,
        position: a.position + (b.position - a.position) * f,
        orientation: (a.orientation * (1.0 - f) + qb * f).normalize(),
    })
}

/// Similarity (s, R, t) minimising Σ |dst − (s R src + t)|² (Umeyama, 1991).
pub fn umeyama(
    src: &[Vector3<f64>],
    dst: &[Vector3<f64>],
    with_scale: bool,
) -> (f64, Matrix3<f64>, Vector3<f64>) {
    let n = src.len() as f64;
    let mu_s = src.iter().sum::<Vector3<f64>>() / n;
    let mu_d = dst.iter().sum::<Vector3<f64>>() / n;
    let mut cov = Matrix3::zeros();
    let mut var_s = 0.0;
    for (s, d) in src.iter().zip(dst) {
        cov += (d - mu_d) * (s - mu_s).transpose();
        var_s += (s - mu_s).norm_squared();
    }
    cov /= n;
    var_s /= n;
    let svd = cov.svd(true, true);
    let (u, v_t) = (svd.u.unwrap(), svd.v_t.unwrap());
    let mut sign = Matrix3::identity();
    if (u.determinant() * v_t.determinant()) < 0.0 {
        sign[(2, 2)] = -1.0;
    }
    let r = u * sign * v_t;
    let s = if with_scale && var_s > 0.0 {
        (svd.singular_values.component_mul(&sign.diagonal())).sum() / var_s
    } else {
        1.0
    };
    let t = mu_d - s * r * mu_s;
    (s, r, t)
}

impl TrajectoryError {
    /// "RPE 0.0123 m over 1 s", or why there is none.
    pub fn rpe_text(&self) -> String {
        match self.rpe_trans {
            Some(r) => format!("RPE {r:.4} m over 1 s"),
            None => "no RPE (the matched poses span less than its 1 s interval)".into(),
        }
    }

    /// "scale drift 1.043 (last third against first)", or why there is none.
    pub fn scale_drift_text(&self) -> String {
        match self.scale_drift {
            Some(d) => format!("scale drift {d:.3} (last third against first)"),
            None => "no scale drift (a third of the poses is too short or hardly moves)".into(),
        }
    }
}

/// The figures of `steernav slam-eval`.
#[derive(Clone, Debug, Serialize)]
pub struct TrajectoryError {
    /// RMSE of the positions after Sim(3) alignment, metres.
    pub ate_rmse: f64,
    /// RMSE of the translation of relative motions over about one second, metres (estimate
    /// scaled); `None` when the matched poses span less than one second, so that there is no
    /// relative motion to measure (JSON `null`, never a meaningless 0).
    pub rpe_trans: Option<f64>,
    /// The alignment's scale factor.
    pub scale: f64,
    /// Scale drift: the Sim(3) scale fitted to the last third of the matched poses over the
    /// one fitted to the first third (1: none); `None` when either third has fewer than 3
    /// poses or moves less than a tenth of the whole trajectory's extent (JSON `null`).
    pub scale_drift: Option<f64>,
    /// Ground-truth path length over the matched poses, metres.
    pub path_length: f64,
    /// Number of matched poses.
    pub matched: usize,
}

/// Extent of a set of points: the largest distance from the first.
fn extent(points: &[Vector3<f64>]) -> f64 {
    points
        .iter()
        .map(|p| (p - points[0]).norm())
        .fold(0.0, f64::max)
}

/// The last third's Sim(3) scale over the first third's (see [`TrajectoryError::scale_drift`]).
fn scale_drift(src: &[Vector3<f64>], dst: &[Vector3<f64>]) -> Option<f64> {
    let third = src.len() / 3;
    let whole = extent(dst).min(extent(src));
    if third < 3 {
        return None;
    }
    let scale = |range: std::ops::Range<usize>| {
        let moves = extent(&src[range.clone()]).min(extent(&dst[range.clone()])) > 0.1 * whole;
        moves.then(|| umeyama(&src[range.clone()], &dst[range], true).0)
    };
    let first = scale(0..third)?;
    let last = scale(src.len() - third..src.len())?;
    (first > 0.0).then_some(last / first)
}

/// ATE and RPE of `estimate` against `truth`, timestamps matched within `max_dt` seconds.
pub fn evaluate(estimate: &[Pose], truth: &[Pose], max_dt: f64) -> Result<TrajectoryError> {
    let pairs = associate(estimate, truth, max_dt);
    if pairs.len() < 3 {
        return Err(Error::config(
            "trajectories",
            pairs.len(),
            format!("need at least 3 poses whose timestamps match within {max_dt} s"),
        ));
    }
    let src: Vec<_> = pairs.iter().map(|(e, _)| e.position).collect();
    let dst: Vec<_> = pairs.iter().map(|(_, g)| g.position).collect();
    for (what, points) in [("estimate", &src), ("ground truth", &dst)] {
        if let Some(p) = points
            .iter()
            .find(|p| !p.iter().all(|v| v.is_finite() && v.abs() < 1e12))
        {
            return Err(Error::config(
                "trajectories",
                format!("{:?}", p.as_slice()),
                format!("the {what} holds a position that is not finite or beyond 1e12 m"),
            ));
        }
        let spread = extent(points);
        if spread <= 1e-9 {
            return Err(Error::config(
                "trajectories",
                format!("{spread} m"),
                format!(
                    "the {what} does not move over the {} matched poses: a similarity alignment has no scale to fit",
                    pairs.len()
                ),
            ));
        }
    }
    let (s, r, t) = umeyama(&src, &dst, true);
    let ate = (src
        .iter()
        .zip(&dst)
        .map(|(e, g)| (s * r * e + t - g).norm_squared())
        .sum::<f64>()
        / pairs.len() as f64)
        .sqrt();
    let mut rpe = Vec::new();
    for i in 0..pairs.len() {
        let target = pairs[i].0.timestamp + 1.0;
        let j = pairs.partition_point(|p| p.0.timestamp < target);
        if j >= pairs.len() {
            break;
        }
        let rel = |a: &Pose, b: &Pose, scale: f64| {
            let ra = rotation::matrix(&a.orientation);
            let rb = rotation::matrix(&b.orientation);
            (
                ra.transpose() * rb,
                ra.transpose() * (b.position - a.position) * scale,
            )
        };
        let (re, te) = rel(&pairs[i].0, &pairs[j].0, s);
        let (rg, tg) = rel(&pairs[i].1, &pairs[j].1, 1.0);
        // E = G⁻¹ Ê: translation part Rgᵀ (tê − tg).
        let _ = re;
        rpe.push((rg.transpose() * (te - tg)).norm_squared());
    }
    let rpe_trans = (!rpe.is_empty()).then(|| (rpe.iter().sum::<f64>() / rpe.len() as f64).sqrt());
    let path_length = dst.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
    Ok(TrajectoryError {
        ate_rmse: ate,
        rpe_trans,
        scale: s,
        scale_drift: scale_drift(&src, &dst),
        path_length,
        matched: pairs.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trajectories_a_microsecond_apart_read_back_apart() {
        let dir = tempfile::tempdir().unwrap();
        let poses: Vec<Pose> = (0..3)
            .map(|k| Pose {
                timestamp: 1_700_000_000.0 + 1e-6 * k as f64,
                position: Vector3::new(k as f64, 0.0, 0.0),
                orientation: nalgebra::Vector4::new(1.0, 0.0, 0.0, 0.0),
            })
            .collect();
        let path = dir.path().join("t.txt");
        write_tum(&path, &poses).unwrap();
        let back = read_tum(&path).unwrap();
        assert_eq!(back.len(), 3);
        for (a, b) in poses.iter().zip(&back) {
            assert!(
                (a.timestamp - b.timestamp).abs() < 1e-8,
                "{} {}",
                a.timestamp,
                b.timestamp
            );
        }
    }

    fn poses(scale: f64, rot: &Matrix3<f64>, shift: Vector3<f64>) -> Vec<Pose> {
        (0..50)
            .map(|k| {
                let t = k as f64 * 0.1;
                let p = Vector3::new(t.sin(), 0.3 * t, (0.5 * t).cos());
                Pose {
                    timestamp: t,
                    position: scale * rot * p + shift,
                    orientation: rotation::from_rotation_vector(&Vector3::new(0.0, 0.1 * t, 0.0)),
                }
            })
            .collect()
    }

    #[test]
    fn similarity_transformed_copy_has_zero_error() {
        let rot = rotation::matrix(&rotation::from_rotation_vector(&Vector3::new(
            0.3, -0.5, 0.2,
        )));
        let truth = poses(1.0, &Matrix3::identity(), Vector3::zeros());
        let mut estimate = poses(0.25, &rot, Vector3::new(1.0, 2.0, 3.0));
        // Orientations rotate too, so the relative motions are the truth's scaled.
        let q = rotation::from_matrix(&rot);
        for e in &mut estimate {
            e.orientation = rotation::multiply(&q, &e.orientation);
        }
        let err = evaluate(&estimate, &truth, 0.02).unwrap();
        assert!(err.ate_rmse < 1e-9, "{err:?}");
        assert!(err.rpe_trans.is_some_and(|r| r < 1e-9), "{err:?}");
        assert!((err.scale - 4.0).abs() < 1e-9);
        assert_eq!(err.matched, 50);
    }

    #[test]
    fn static_or_non_finite_trajectories_are_refused_with_the_reason() {
        let moving = poses(1.0, &Matrix3::identity(), Vector3::zeros());
        let still: Vec<Pose> = moving
            .iter()
            .map(|p| Pose {
                position: Vector3::new(1.0, 2.0, 3.0),
                ..*p
            })
            .collect();
        let message = evaluate(&moving, &still, 0.02).unwrap_err().to_string();
        assert!(message.contains("ground truth does not move"), "{message}");
        let message = evaluate(&still, &moving, 0.02).unwrap_err().to_string();
        assert!(message.contains("estimate does not move"), "{message}");
        let mut huge = moving.clone();
        huge[3].position.x = 1e300;
        let message = evaluate(&moving, &huge, 0.02).unwrap_err().to_string();
        assert!(message.contains("not finite or beyond"), "{message}");
        // Half a second of poses: an ATE, but no relative motion over 1 s to give an RPE.
        let short = &moving[..6];
        let e = evaluate(short, short, 0.02).unwrap();
        assert_eq!(e.rpe_trans, None);
        assert!(e.rpe_text().contains("less than its 1 s interval"));
    }

    #[test]
    fn tum_round_trip_and_bad_lines() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.txt");
        let truth = poses(1.0, &Matrix3::identity(), Vector3::zeros());
        write_tum(&path, &truth).unwrap();
        let back = read_tum(&path).unwrap();
        assert_eq!(back.len(), truth.len());
        assert!((back[7].position - truth[7].position).amax() < 1e-8);
        std::fs::write(&path, "1.0 0 0 0 0 0 0 1\n0.5 0 0 0 0 0 0 1\n").unwrap();
        let message = read_tum(&path).unwrap_err().to_string();
        assert!(
            message.contains("line 2") && message.contains("not after"),
            "{message}"
        );
        std::fs::write(&path, "1.0 0 0 nan 0 0 0 1\n").unwrap();
        assert!(read_tum(&path)
            .unwrap_err()
            .to_string()
            .contains("non-finite"));
    }

    #[test]
    fn scale_drift_compares_the_last_third_with_the_first() {
        let pose = |k: usize, position: Vector3<f64>| Pose {
            timestamp: k as f64 * 0.1,
            position,
            orientation: nalgebra::Vector4::new(1.0, 0.0, 0.0, 0.0),
        };
        let truth: Vec<Pose> = (0..90)
            .map(|k| pose(k, Vector3::new(k as f64 * 0.1, (k as f64 * 0.2).sin(), 0.0)))
            .collect();
        // The estimate's steps shrink to 80% of their first length by the end.
        let mut at = Vector3::zeros();
        let estimate: Vec<Pose> = (0..90)
            .map(|k| {
                if k > 0 {
                    let step = truth[k].position - truth[k - 1].position;
                    at += step * (1.0 - 0.2 * k as f64 / 89.0);
                }
                pose(k, at)
            })
            .collect();
        let e = evaluate(&estimate, &truth, 0.01).unwrap();
        let drift = e.scale_drift.unwrap();
        // The thirds' mean step lengths are 0.967 and 0.833 of the truth's.
        assert!((drift - 0.967 / 0.833).abs() < 0.02, "drift {drift}");
        let same = evaluate(&truth, &truth, 0.01).unwrap();
        assert!((same.scale_drift.unwrap() - 1.0).abs() < 1e-9);
        assert!(evaluate(&truth[..6], &truth[..6], 0.01)
            .unwrap()
            .scale_drift
            .is_none());
    }
}
