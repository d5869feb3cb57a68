//! `steernav nav`, `nav-eval`, `nav-sweep` and `nav-replay`: the neural field in the
//! simulator and on real laser logs.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicU64, Ordering};

use clap::Args;
use steernav::nav::controller::Mode;
use steernav::nav::gist::{Gist, GistEngine};
use steernav::nav::sim::episode::{run, EpisodeConfig};
use steernav::nav::sim::evaluate::{
    all_visible, compare, evaluation_world, train_visual_model, Comparison, EvalSettings,
    ModeSummary,
};
use steernav::nav::sim::figure::episode_figure;
use steernav::nav::sim::sweep::sweep;
use steernav::nav::sim::world::World;

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

#[derive(Args)]
pub struct NavSweepCmd {
    /// Random candidates to try (the base configuration is always tried too).
    #[arg(long, default_value_t = 24)]
    samples: usize,
    /// Random worlds each candidate drives.
    #[arg(long, default_value_t = 40)]
    episodes: usize,
    /// Seed of the worlds, the noise and the candidates.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Sensors: laser or fusion (fusion trains the visual model first, as nav-eval does).
    #[arg(long, default_value = "laser", value_parser = choice::<Mode>(Mode::NAMES))]
    mode: Mode,
    /// Obstacles per world.
    #[arg(long, default_value_t = 8)]
    obstacles: usize,
    /// Fraction of obstacles below the LIDAR's scan plane.
    #[arg(long, default_value_t = 0.0)]
    invisible: f32,
    /// The sweep varies τ, h, eq 31's inhibition, c_o, σ, g's distance scale and the turn
    /// gain around the settings file's [nav] table.
    #[command(flatten)]
    config: ConfigArg,
    /// Print every candidate's parameters and figures as a JSON array, best first.
    #[arg(long)]
    json: bool,
    /// The batched field steps every episode on the GPU in one dispatch chain, or on all CPU
    /// cores.
    #[command(flatten)]
    backend: BackendArg,
}

fn field_gpu(
    backend: &BackendArg,
) -> anyhow::Result<Option<std::sync::Arc<steernav::gpu::GpuContext>>> {
    Ok(backend.backend.resolve()?)
}

fn config(arg: &ConfigArg) -> anyhow::Result<EpisodeConfig> {
    let cfg = arg.settings()?.nav;
    cfg.validate()?;
    Ok(cfg)
}

pub fn nav(cmd: NavCmd) -> anyhow::Result<ExitCode> {
    let cfg = config(&cmd.config)?;
    let world = match (&cmd.world, cmd.random) {
        (Some(path), _) => World::load(path)?,
        (None, Some(seed)) => World::random(seed, 8, 0.4),
        (None, None) => anyhow::bail!("give --world FILE or --random SEED"),
    };
    let gist = Gist::from(GistEngine::new(cfg.controller.visual.gist.clone())?);
    let settings = EvalSettings {
        episodes: 0,
        seed: cmd.seed,
        obstacles: world.obstacles.len().max(1),
        invisible: 0.4,
        training: if cmd.mode == Mode::Fusion {
            cmd.train
        } else {
            0
        },
    };
    let mut model = train_visual_model(&cfg, &gist, &settings)?;
    let episode = run(
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

pub fn nav_eval(cmd: NavEvalCmd) -> anyhow::Result<ExitCode> {
    let cfg = config(&cmd.config)?;
    if !(0.0..=1.0).contains(&cmd.invisible) {
        anyhow::bail!("--invisible: {} is not in [0, 1]", cmd.invisible);
    }
    if cmd.episodes == 0 {
        anyhow::bail!("--episodes: at least 1");
    }
    let gist = Gist::from(GistEngine::new(cfg.controller.visual.gist.clone())?);
    let settings = EvalSettings {
        episodes: cmd.episodes,
        seed: cmd.seed,
        obstacles: cmd.obstacles,
        invisible: cmd.invisible,
        training: cmd.train,
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

pub fn nav_sweep(cmd: NavSweepCmd) -> anyhow::Result<ExitCode> {
    let base = config(&cmd.config)?;
    if !(0.0..=1.0).contains(&cmd.invisible) {
        anyhow::bail!("--invisible: {} is not in [0, 1]", cmd.invisible);
    }
    if cmd.episodes == 0 {
        anyhow::bail!("--episodes: at least 1");
    }
    let gist = Gist::from(GistEngine::new(base.controller.visual.gist.clone())?);
    let settings = EvalSettings {
        episodes: cmd.episodes,
        seed: cmd.seed,
        obstacles: cmd.obstacles,
        invisible: cmd.invisible,
        training: if cmd.mode == Mode::Fusion { 20 } else { 0 },
    };
    let model = train_visual_model(&base, &gist, &settings)?;
    let bar = indicatif::ProgressBar::new(((cmd.samples + 1) * cmd.episodes) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} episodes  {per_sec}  ETA {eta}",
        )
        .expect("valid template"),
    );
    let rows = sweep(
        &base,
        &gist,
        &model,
        (cmd.mode, cmd.samples),
        &settings,
        field_gpu(&cmd.backend)?.as_ref(),
        || bar.inc(1),
    )?;
    bar.finish_and_clear();
    if cmd.json {
        println!("{}", serde_json::to_string(&rows)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "{} candidates × {} worlds ({:?}, {:.0}% invisible obstacles), best first; score = success − collisions/2:",
        rows.len(),
        cmd.episodes,
        cmd.mode,
        100.0 * cmd.invisible
    );
    println!(
        "{:>6} {:>8} {:>10}   {:>6} {:>6} {:>7} {:>6} {:>6} {:>7} {:>9}",
        "score",
        "success",
        "collisions",
        "tau",
        "h",
        "inhibit",
        "c_o",
        "sigma",
        "g_scale",
        "turn_gain"
    );
    let base_candidate = steernav::nav::sim::sweep::Candidate::of(&base);
    for r in rows.iter().take(10) {
        let c = &r.candidate;
        println!(
            "{:>6.3} {:>7.1}% {:>10}   {:>6.3} {:>6.2} {:>7.2} {:>6.1} {:>6.1} {:>7.2} {:>9.2}{}",
            r.score,
            100.0 * r.summary.success_rate,
            r.summary.collisions,
            c.tau,
            c.h,
            c.inhibit,
            c.c_o,
            c.sigma,
            c.g_scale,
            c.turn_gain,
            if *c == base_candidate { "  (base)" } else { "" }
        );
    }
    let best = &rows[0].candidate;
    println!(
        "\nBest as a config file:\n[nav.controller]\nturn_gain = {:.3}\n[nav.controller.field]\ntau = {:.4}\nh = {:.3}\ninteraction = {{ type = \"amari\", excite = 1.0, inhibit = {:.3}, width = 3 }}\n[nav.controller.stimulus]\nc_o = {:.3}\nsigma = {:.3}\ng_scale = {:.3}",
        best.turn_gain, best.tau, best.h, best.inhibit, best.c_o, best.sigma, best.g_scale
    );
    Ok(ExitCode::SUCCESS)
}

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

pub fn nav_replay(cmd: NavReplayCmd) -> anyhow::Result<ExitCode> {
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
