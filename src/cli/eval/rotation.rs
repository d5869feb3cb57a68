//! `steernav eval rotation`: every image rotated about its centre by every angle.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use steernav::eval::sweep::{parse_angles, rotation_sweep};

use super::{report, EvalArgs};

#[derive(Args)]
pub struct RotationCmd {
    /// Images to rotate.
    #[arg(long, required = true, num_args = 1.., value_name = "IMG")]
    images: Vec<PathBuf>,
    /// Angles in degrees: start:stop:step (stop excluded) or a list.
    #[arg(long, default_value = "0:360:15", value_name = "SPEC")]
    angles: String,
    /// Directory receiving rotation.csv (every row: detector, image, angle, eps,
    /// repeatability, recall, count) and rotation.png (repeatability and recall against the
    /// angle, paper Fig. 4a–b).
    #[arg(long, default_value = "eval-out", value_name = "DIR")]
    out: PathBuf,
    #[command(flatten)]
    eval: EvalArgs,
}

pub fn run(cmd: RotationCmd) -> anyhow::Result<ExitCode> {
    let angles = parse_angles(&cmd.angles).map_err(anyhow::Error::msg)?;
    let setup = cmd.eval.setup()?;
    let per_image =
        angles.len() as u64 * (setup.steernav.is_some() as u64 + setup.peers().is_some() as u64);
    let bar = indicatif::ProgressBar::new(per_image * cmd.images.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} views  {per_sec}  ETA {eta}")
            .expect("valid template"),
    );
    let rows = rotation_sweep(
        &cmd.images,
        &angles,
        setup.steernav.as_ref(),
        setup.peers(),
        &setup.options,
        &|n| bar.inc(n),
    )?;
    bar.finish_and_clear();
    std::fs::create_dir_all(&cmd.out)
        .with_context(|| format!("{}: cannot create", cmd.out.display()))?;
    report(
        &rows,
        Some(&cmd.out.join("rotation.csv")),
        Some(&cmd.out.join("rotation.png")),
        "rotation",
        "angle (degrees)",
        "angle",
    )
}
