//! `steernav nav`: one episode in the 2-D simulator, with its figure.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use steernav::nav::gist::{Gist, GistEngine};
use steernav::nav::sim::episode::{run as run_episode, EpisodeConfig};
use steernav::nav::sim::evaluate::{train_visual_model, EvalSettings};
use steernav::nav::sim::figure::episode_figure;
use steernav::nav::sim::world::World;
use steernav::nav::Mode;

use crate::args::{choice, BackendArg, ConfigArg};

#[derive(Args)]
pub struct NavCmd {
    /// World TOML (size, start, goal, robot_radius, scan_height, [[obstacles]] with a circle
    /// or polygon shape, height and transparent); see README.
    #[arg(long, value_name = "FILE", conflicts_with = "random")]
    world: Option<PathBuf>,
    /// Use the seeded random world SEED instead of a file.
    #[arg(long, value_name = "SEED")]
    random: Option<u64>,
    /// Sensors driving the field: laser (LIDAR alone) or fusion (LIDAR + learned GIST).
    #[arg(long, default_value = "laser", value_parser = choice::<Mode>(Mode::NAMES))]
    mode: Mode,
    /// PNG: the world with the trajectory (Fig. 6) and the field activity over time (Fig. 5a).
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    /// Fusion only: episodes on random worlds that train the visual model first.
    #[arg(long, default_value_t = 20)]
    train: usize,
    /// Seed of the sensor noise (and of the training worlds).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    config: ConfigArg,
    /// Print the episode's outcome, time, path length and position error std as JSON.
    #[arg(long)]
    json: bool,
}

pub(crate) fn field_gpu(
    backend: &BackendArg,
) -> anyhow::Result<Option<std::sync::Arc<steernav::GpuContext>>> {
    Ok(backend.backend.resolve()?)
}

pub(crate) fn config(arg: &ConfigArg) -> anyhow::Result<EpisodeConfig> {
    let cfg = arg.settings()?.nav;
    cfg.validate()?;
    Ok(cfg)
}

pub fn run(cmd: NavCmd) -> anyhow::Result<ExitCode> {
    let cfg = config(&cmd.config)?;
    let world = match (&cmd.world, cmd.random) {
        (Some(path), _) => World::load(path)?,
        (None, Some(seed)) => World::random(seed, 8, 0.4),
        (None, None) => anyhow::bail!("give --world FILE or --random SEED"),
    };
    if let Some(plot) = &cmd.plot {
        crate::args::check_png_output("--plot", plot)?;
    }
    let gist = Gist::from(GistEngine::new(cfg.controller.visual.gist.clone())?);
    let settings = EvalSettings {
        episodes: 0,
        seed: cmd.seed,
        obstacles: world.obstacles.len().max(1),
        invisible: 0.4,
        goal_guard: false,
        training: if cmd.mode == Mode::Fusion {
            cmd.train
        } else {
            0
        },
    };
    let mut model = train_visual_model(&cfg, &gist, &settings)?;
    let episode = run_episode(
        &world,
        &cfg,
        cmd.mode,
        &mut model,
        Some(&gist),
        cmd.seed,
        true,
    )?;
    if cmd.json {
        println!(
            "{}",
            serde_json::json!({
                "outcome": episode.outcome,
                "time": episode.time,
                "path_length": episode.path_length,
                "position_error_std": episode.position_error_std,
            })
        );
    } else {
        println!(
            "{:?}: {:?} after {:.1} s, {:.2} m driven, position error std {:.3} m",
            cmd.mode,
            episode.outcome,
            episode.time,
            episode.path_length,
            episode.position_error_std
        );
    }
    if let Some(path) = &cmd.plot {
        let title = format!("{:?}", cmd.mode);
        episode_figure(path, &world, &episode, &title)?;
        if !cmd.json {
            println!("figure: {}", path.display());
        }
    }
    Ok(ExitCode::SUCCESS)
}
