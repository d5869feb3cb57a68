//! `steernav gist`: GIST descriptors (eqs 38–41) of images, one JSON object per line.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Args;
use steernav::Frame;

use crate::args::{BackendArg, ConfigArg};

#[derive(Args)]
pub struct GistCmd {
    /// Input images.
    #[arg(required = true, value_name = "IMAGE")]
    images: Vec<PathBuf>,
    #[command(flatten)]
    config: ConfigArg,
    #[command(flatten)]
    backend: BackendArg,
}

pub fn run(cmd: GistCmd) -> anyhow::Result<ExitCode> {
    let cfg = cmd.config.settings()?.gist;
    let engine = steernav::nav::gist::GistEngine::new(cfg.clone())?;
    let ctx = cmd.backend.backend.resolve()?;
    let mut failed = 0;
    let mut loaded = Vec::new();
    for path in &cmd.images {
        match Frame::load(path) {
            Ok(f) => loaded.push((path, f)),
            Err(e) => {
                eprintln!("error: {e}");
                failed += 1;
            }
        }
    }
    let print = |path: &Path, d: &[f32]| -> anyhow::Result<()> {
        println!(
            "{}",
            serde_json::json!({"image": path.display().to_string(), "gist": d})
        );
        Ok(())
    };
    match ctx {
        Some(ctx) => {
            let mut gpu = steernav::nav::gist::GpuGist::new(ctx, cfg)?;
            let frames: Vec<Frame> = loaded.iter().map(|(_, f)| f.clone()).collect();
            for ((path, _), d) in loaded.iter().zip(gpu.describe_batch(&frames)?) {
                print(path, &d)?;
            }
        }
        None => {
            for (path, frame) in &loaded {
                match engine.describe(frame) {
                    Ok(d) => print(path, &d)?,
                    Err(e) => {
                        eprintln!("error: {}: {e}", path.display());
                        failed += 1;
                    }
                }
            }
        }
    }
    Ok(if failed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}
