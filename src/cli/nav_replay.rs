//! `steernav nav-replay`: the neural field on every scan of a CARMEN laser log.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use crate::args::ConfigArg;

#[derive(Args)]
pub struct NavReplayCmd {
    /// CARMEN log (.log or .log.gz).
    log: PathBuf,
    #[command(flatten)]
    config: ConfigArg,
    /// Print {"scans", "free_fraction", "mean_abs_deviation_deg"} as JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(cmd: NavReplayCmd) -> anyhow::Result<ExitCode> {
    let cfg = cmd.config.settings()?.replay;
    let scans = steernav::nav::carmen::read_log(&cmd.log)?;
    let r = steernav::nav::replay::replay(&scans, &cfg)?;
    if cmd.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!(
            "{}: {} scans with motion; chosen heading free on {:.1}%; mean |deviation| from the real motion {:.1}°",
            cmd.log.display(),
            r.scans,
            100.0 * r.free_fraction,
            r.mean_abs_deviation_deg
        );
    }
    Ok(ExitCode::SUCCESS)
}
