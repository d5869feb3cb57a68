//! `steernav nav-sweep`: random search over the field's and the stimuli's parameters.

use std::process::ExitCode;

use clap::Args;
use steernav::nav::gist::{Gist, GistEngine};
use steernav::nav::sim::evaluate::{train_visual_model, EvalSettings};
use steernav::nav::sim::sweep::sweep;
use steernav::nav::Mode;

use crate::args::{choice, BackendArg, ConfigArg};
use crate::nav::{config, field_gpu};

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

pub fn run(cmd: NavSweepCmd) -> anyhow::Result<ExitCode> {
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
        goal_guard: false,
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
