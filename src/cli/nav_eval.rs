//! `steernav nav-eval`: random worlds driven with the LIDAR alone and with fusion.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicU64, Ordering};

use clap::Args;
use steernav::nav::gist::{Gist, GistEngine};
use steernav::nav::sim::evaluate::{
    all_visible, compare, evaluation_world, train_visual_model, Comparison, EvalSettings,
    ModeSummary,
};

use crate::args::{BackendArg, ConfigArg};
use crate::nav::{config, field_gpu};

#[derive(Args)]
pub struct NavEvalCmd {
    /// Random worlds to run, each with the LIDAR alone and with fusion.
    #[arg(long, default_value_t = 500)]
    episodes: usize,
    /// Seed of the worlds and the sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Obstacles per world.
    #[arg(long, default_value_t = 8)]
    obstacles: usize,
    /// Fraction of obstacles lower than the LIDAR's scan plane (the camera still sees them).
    #[arg(long, default_value_t = 0.4)]
    invisible: f32,
    /// Training episodes of the visual model before fusion is evaluated.
    #[arg(long, default_value_t = 20)]
    train: usize,
    /// Put a visible pillar 1.1–1.6 m before each world's goal, beside the straight line to
    /// it, so the goal's bearing swings quickly at the end: counts the episodes that still
    /// reach the goal instead of passing it and driving on.
    #[arg(long)]
    goal_guard: bool,
    #[command(flatten)]
    config: ConfigArg,
    /// Print {"laser": {...}, "fusion": {...}} for the worlds as generated (keys episodes,
    /// success_rate, collisions, path_length, time_to_goal, position_error_std). `--invisible
    /// 0` gives the same worlds with every obstacle visible, the visual model then trained on
    /// visible worlds too; the table and the figure show both sets with one model.
    #[arg(long)]
    json: bool,
    /// PNG: success and collision rates per mode, with and without invisible obstacles.
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    /// The batched field steps every episode on the GPU in one dispatch chain, or on all CPU
    /// cores.
    #[command(flatten)]
    backend: BackendArg,
}

pub fn run(cmd: NavEvalCmd) -> anyhow::Result<ExitCode> {
    let cfg = config(&cmd.config)?;
    if !(0.0..=1.0).contains(&cmd.invisible) {
        anyhow::bail!("--invisible: {} is not in [0, 1]", cmd.invisible);
    }
    if cmd.episodes == 0 {
        anyhow::bail!("--episodes: at least 1");
    }
    if let Some(plot) = &cmd.plot {
        crate::args::check_png_output("--plot", plot)?;
    }
    let gist = Gist::from(GistEngine::new(cfg.controller.visual.gist.clone())?);
    let settings = EvalSettings {
        episodes: cmd.episodes,
        seed: cmd.seed,
        obstacles: cmd.obstacles,
        invisible: cmd.invisible,
        training: cmd.train,
        goal_guard: cmd.goal_guard,
    };
    let runs = if cmd.json && cmd.plot.is_none() { 2 } else { 4 };
    let bar = indicatif::ProgressBar::new((runs * cmd.episodes + cmd.train) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} episodes  {per_sec}  ETA {eta}  {msg}",
        )
        .expect("valid template"),
    );
    bar.set_message("training the visual model");
    let model = train_visual_model(&cfg, &gist, &settings)?;
    bar.inc(cmd.train as u64);
    let done = AtomicU64::new(0);
    let tick = || {
        done.fetch_add(1, Ordering::Relaxed);
        bar.inc(1);
    };
    bar.set_message("worlds with LIDAR-invisible obstacles");
    let gpu = field_gpu(&cmd.backend)?;
    let hidden = compare(
        &cfg,
        &gist,
        &model,
        &settings,
        |k| evaluation_world(&settings, k),
        gpu.as_ref(),
        tick,
    )?;
    if cmd.json && cmd.plot.is_none() {
        bar.finish_and_clear();
        println!(
            "{}",
            serde_json::json!({"laser": hidden.laser, "fusion": hidden.fusion})
        );
        return Ok(ExitCode::SUCCESS);
    }
    bar.set_message("the same worlds, every obstacle visible");
    let visible = compare(
        &cfg,
        &gist,
        &model,
        &settings,
        |k| all_visible(evaluation_world(&settings, k)),
        gpu.as_ref(),
        tick,
    )?;
    bar.finish_and_clear();
    if let Some(path) = &cmd.plot {
        steernav::nav::sim::figure::comparison_figure(path, &hidden, &visible)?;
        if !cmd.json {
            println!("figure: {}", path.display());
        }
    }
    if cmd.json {
        println!(
            "{}",
            serde_json::json!({"laser": hidden.laser, "fusion": hidden.fusion})
        );
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "{} random worlds (seed {}), {} obstacles each, {:.0}% of them below the LIDAR's scan plane:",
        cmd.episodes,
        cmd.seed,
        cmd.obstacles,
        100.0 * cmd.invisible
    );
    print_table(&hidden)?;
    println!("\nThe same worlds with every obstacle visible to the LIDAR:");
    print_table(&visible)?;
    Ok(ExitCode::SUCCESS)
}

fn print_table(c: &Comparison) -> anyhow::Result<()> {
    println!(
        "{:<8} {:>8} {:>10} {:>11} {:>13} {:>14} {:>19}",
        "mode",
        "episodes",
        "success",
        "collisions",
        "path length",
        "time to goal",
        "position error std"
    );
    let row = |name: &str, s: &ModeSummary| -> anyhow::Result<()> {
        println!(
            "{:<8} {:>8} {:>9.1}% {:>11} {:>13} {:>14} {:>17.3} m",
            name,
            s.episodes,
            100.0 * s.success_rate,
            s.collisions,
            s.path_length
                .map_or("no success".into(), |m| format!("{m:.2} m")),
            s.time_to_goal
                .map_or("no success".into(), |t| format!("{t:.1} s")),
            s.position_error_std
        );
        Ok(())
    };
    row("laser", &c.laser)?;
    row("fusion", &c.fusion)
}
