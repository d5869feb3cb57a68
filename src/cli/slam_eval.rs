//! `steernav slam-eval`: ATE after Sim(3) alignment and RPE of a trajectory against ground
//! truth.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;
use steernav::slam::data::kitti;
use steernav::slam::data::sequence;
use steernav::slam::data::trajectory::{self, Pose};

#[derive(Args)]
pub struct SlamEvalCmd {
    /// Estimated trajectory (TUM format, or KITTI pose rows).
    estimate: PathBuf,
    /// Ground truth (TUM format, EuRoC state_groundtruth_estimate0/data.csv, or KITTI pose
    /// rows).
    ground_truth: PathBuf,
    /// Timestamps of KITTI pose rows: a KITTI times.txt (otherwise row i is at i / --fps).
    #[arg(long, value_name = "FILE")]
    times: Option<PathBuf>,
    /// Frame rate of KITTI pose rows without --times.
    #[arg(long, default_value_t = 10.0)]
    fps: f64,
    /// Largest timestamp difference of a matched pair, seconds.
    #[arg(long, default_value_t = 0.02)]
    max_dt: f64,
    /// Print {"ate_rmse", "rpe_trans", "scale", "path_length", "matched"} as JSON (rpe_trans
    /// is null when the matched poses span less than its 1 s interval).
    #[arg(long)]
    json: bool,
}

pub fn run(cmd: SlamEvalCmd) -> anyhow::Result<ExitCode> {
    if !(cmd.max_dt.is_finite() && cmd.max_dt > 0.0) {
        bail!("--max-dt: {} must be finite and > 0", cmd.max_dt);
    }
    // One timestamp per pose row: a times file with more or fewer rows than the trajectory
    // would pair every row with another frame's time, or leave rows out.
    let kitti_times = |rows: usize, poses: &Path| -> anyhow::Result<Vec<f64>> {
        match &cmd.times {
            Some(path) => {
                let times = kitti::read_times(path)?;
                if times.len() != rows {
                    bail!(
                        "{}: {} timestamps for the {} pose rows of {}",
                        path.display(),
                        times.len(),
                        rows,
                        poses.display()
                    );
                }
                Ok(times)
            }
            None => {
                let fps = sequence::checked_fps(cmd.fps)?;
                Ok((0..rows).map(|i| i as f64 / fps).collect())
            }
        }
    };
    let read = |path: &Path| -> anyhow::Result<Vec<Pose>> {
        if kitti::looks_like_poses(path) {
            let rows = std::fs::read_to_string(path)
                .with_context(|| format!("{}: cannot read", path.display()))?
                .lines()
                .filter(|l| !l.trim().is_empty())
                .count();
            Ok(kitti::read_poses(path, &kitti_times(rows, path)?)?)
        } else {
            Ok(sequence::read_ground_truth(path, &[])?)
        }
    };
    let estimate = read(&cmd.estimate)?;
    let truth = read(&cmd.ground_truth)?;
    let e = trajectory::evaluate(&estimate, &truth, cmd.max_dt)?;
    if cmd.json {
        println!("{}", serde_json::to_string(&e)?);
    } else {
        println!(
            "ATE RMSE {:.4} m ({:.2}% of the {:.3} m path), {}, scale {:.4}, {}, {} poses matched",
            e.ate_rmse,
            100.0 * e.ate_rmse / e.path_length.max(1e-12),
            e.path_length,
            e.rpe_text(),
            e.scale,
            e.scale_drift_text(),
            e.matched
        );
    }
    Ok(ExitCode::SUCCESS)
}
