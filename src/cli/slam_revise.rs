//! `slam`'s per-frame outputs: a trajectory line per frame, and the rewrite of the trajectory
//! and the report when the session revises earlier frames (`Slam::take_revised`, after the
//! start tried two motions side by side and kept the one it had not reported).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use anyhow::Context;
use steernav::slam::data::figure::EstimatedPose;
use steernav::slam::data::kitti;
use steernav::slam::data::trajectory::{tum_line, Pose};
use steernav::slam::FrameReport;

use crate::slam::TrajectoryFormat;

/// The pose a frame reports, with its position covariance.
pub fn estimated_pose(r: &FrameReport) -> EstimatedPose {
    EstimatedPose {
        pose: Pose {
            timestamp: r.timestamp,
            position: r.position.into(),
            orientation: nalgebra::Vector4::from(r.orientation),
        },
        covariance: r.position_covariance,
    }
}

/// One trajectory line in `format`.
pub fn trajectory_line(format: TrajectoryFormat, pose: &Pose) -> String {
    match format {
        TrajectoryFormat::Tum => tum_line(pose),
        TrajectoryFormat::Kitti => kitti::pose_row(pose),
    }
}

/// Creates (or truncates) the trajectory file and writes its header.
pub fn create_trajectory(path: &Path, format: TrajectoryFormat) -> anyhow::Result<BufWriter<File>> {
    let mut f = BufWriter::new(
        File::create(path).with_context(|| format!("{}: cannot write", path.display()))?,
    );
    if format == TrajectoryFormat::Tum {
        writeln!(f, "# timestamp tx ty tz qx qy qz qw")
            .with_context(|| format!("{}: cannot write", path.display()))?;
    }
    Ok(f)
}

/// Creates (or truncates) the per-frame CSV report and writes its header.
pub fn create_report(path: &Path) -> anyhow::Result<csv::Writer<File>> {
    let mut f = csv::Writer::from_path(path)
        .with_context(|| format!("{}: cannot write", path.display()))?;
    f.write_record(FrameReport::CSV_HEADER)
        .with_context(|| format!("{}: cannot write", path.display()))?;
    Ok(f)
}

/// Replaces the revised frames (matched by timestamp) in `reports` and `estimated`, then
/// writes the trajectory and the report again from the start. Returns the new writers.
pub fn revise(
    revised: Vec<FrameReport>,
    reports: &mut [FrameReport],
    estimated: &mut [EstimatedPose],
    trajectory: (&Path, TrajectoryFormat),
    report: Option<&Path>,
) -> anyhow::Result<(BufWriter<File>, Option<csv::Writer<File>>)> {
    for r in revised {
        if let Some(i) = reports.iter().position(|old| old.timestamp == r.timestamp) {
            estimated[i] = estimated_pose(&r);
            reports[i] = r;
        }
    }
    let (path, format) = trajectory;
    let err = |p: &Path| format!("{}: cannot write", p.display());
    let mut traj = create_trajectory(path, format)?;
    for e in estimated.iter() {
        writeln!(traj, "{}", trajectory_line(format, &e.pose)).with_context(|| err(path))?;
    }
    traj.flush().with_context(|| err(path))?;
    let report = match report {
        Some(path) => {
            let mut f = create_report(path)?;
            for r in reports.iter() {
                f.write_record(r.csv_record()).with_context(|| err(path))?;
            }
            f.flush().with_context(|| err(path))?;
            Some(f)
        }
        None => None,
    };
    Ok((traj, report))
}
