//! `nav-eval`: the same random worlds driven with the LIDAR alone and with LIDAR + camera
//! fusion (paper section 4.2, Figs. 5b–d), summarised per mode.
//!
//! Fusion's visual model is first trained online on `training` separate random worlds (a
//! robot that has driven a little), then every evaluation episode starts from a copy of it and
//! keeps learning — so episodes are independent, run in parallel and are reproducible.

use std::sync::Arc;

use serde::Serialize;

use super::episode::{run, run_lockstep, Episode, EpisodeConfig, Fields, Outcome, Robot};
use super::world::World;
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::nav::controller::Mode;
use crate::nav::dnf::FieldBatch;
use crate::nav::dnf::GpuFieldBatch;
use crate::nav::gist::Gist;
use crate::nav::visual::VisualObstacleModel;

/// Figures of one mode over a set of episodes.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ModeSummary {
    /// Episodes run.
    pub episodes: usize,
    /// Fraction that reached the goal.
    pub success_rate: f64,
    /// Episodes that ended in a collision.
    pub collisions: usize,
    /// Mean path length of the successful episodes, metres.
    pub path_length: Option<f64>,
    /// Mean time to goal of the successful episodes, seconds; `None` when none succeeded.
    pub time_to_goal: Option<f64>,
    /// Mean over episodes of the standard deviation of the distance to the start–goal line, m.
    pub position_error_std: f64,
}

/// Laser and fusion on the same worlds.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    /// LIDAR only.
    pub laser: ModeSummary,
    /// LIDAR + GIST.
    pub fusion: ModeSummary,
}

/// Settings of an evaluation.
#[derive(Clone, Debug)]
pub struct EvalSettings {
    /// Evaluation episodes (one random world each).
    pub episodes: usize,
    /// Seed of the worlds and the sensor noise.
    pub seed: u64,
    /// Obstacles per world.
    pub obstacles: usize,
    /// Fraction of obstacles lower than the LIDAR's scan plane.
    pub invisible: f32,
    /// Training episodes of the visual model before evaluating fusion.
    pub training: usize,
    /// A pillar just before each world's goal, beside the straight line to it
    /// ([`World::guard_goal`]).
    pub goal_guard: bool,
}

/// Summary of finished episodes.
pub fn summarise(episodes: &[Episode]) -> ModeSummary {
    let n = episodes.len().max(1) as f64;
    let reached: Vec<&Episode> = episodes
        .iter()
        .filter(|e| e.outcome == Outcome::Reached)
        .collect();
    let r = reached.len().max(1) as f64;
    ModeSummary {
        episodes: episodes.len(),
        success_rate: reached.len() as f64 / n,
        collisions: episodes
            .iter()
            .filter(|e| e.outcome == Outcome::Collision)
            .count(),
        // Means over the successful episodes: undefined (JSON null), not 0, when none succeeded.
        path_length: (!reached.is_empty())
            .then(|| reached.iter().map(|e| e.path_length as f64).sum::<f64>() / r),
        time_to_goal: (!reached.is_empty())
            .then(|| reached.iter().map(|e| e.time as f64).sum::<f64>() / r),
        position_error_std: episodes
            .iter()
            .map(|e| e.position_error_std as f64)
            .sum::<f64>()
            / n,
    }
}

/// Trains a visual model on `count` random worlds (seeds disjoint from the evaluation's).
pub fn train_visual_model(
    cfg: &EpisodeConfig,
    gist: &Gist,
    settings: &EvalSettings,
) -> Result<VisualObstacleModel> {
    let mut model = VisualObstacleModel::default();
    for k in 0..settings.training {
        let seed = settings.seed.wrapping_add(1 << 32).wrapping_add(k as u64);
        let world = World::random(seed, settings.obstacles, settings.invisible);
        run(
            &world,
            cfg,
            Mode::Fusion,
            &mut model,
            Some(gist),
            seed,
            false,
        )?;
    }
    Ok(model)
}

/// The fields of `count` lockstep episodes: on the CPU, or on the GPU when `gpu` is given.
pub fn fields(cfg: &EpisodeConfig, count: usize, gpu: Option<&Arc<GpuContext>>) -> Result<Fields> {
    Ok(match gpu {
        Some(ctx) => Fields::Gpu(GpuFieldBatch::new(
            ctx.clone(),
            cfg.controller.field.clone(),
            count,
        )?),
        None => Fields::Cpu(FieldBatch::new(cfg.controller.field.clone(), count)?),
    })
}

/// Runs every episode in both modes, all episodes of a mode in lockstep with one batched
/// field (B = episodes; on the GPU when `gpu` is given); `worlds` maps an episode index to
/// its world (so callers can make every obstacle visible for the control set). `progress` is
/// called once per finished episode.
pub fn compare(
    cfg: &EpisodeConfig,
    gist: &Gist,
    model: &VisualObstacleModel,
    settings: &EvalSettings,
    worlds: impl Fn(usize) -> World,
    gpu: Option<&Arc<GpuContext>>,
    progress: impl Fn() + Sync,
) -> Result<Comparison> {
    let worlds: Vec<World> = (0..settings.episodes).map(worlds).collect();
    let mut summaries = Vec::new();
    for mode in [Mode::Laser, Mode::Fusion] {
        let episodes = run_worlds(&worlds, cfg, mode, model, settings, (gist, gpu), &progress)?;
        summaries.push(summarise(&episodes));
    }
    let fusion = summaries.pop().expect("two modes");
    let laser = summaries.pop().expect("two modes");
    Ok(Comparison { laser, fusion })
}

/// One episode per world in `mode`, all in lockstep with one batched field (on the GPU when
/// given); episode k's sensor noise is seeded `settings.seed + k` and its robot starts from a
/// copy of `model`.
pub fn run_worlds(
    worlds: &[World],
    cfg: &EpisodeConfig,
    mode: Mode,
    model: &VisualObstacleModel,
    settings: &EvalSettings,
    (gist, gpu): (&Gist, Option<&Arc<GpuContext>>),
    progress: impl Fn() + Sync,
) -> Result<Vec<Episode>> {
    let robots = worlds
        .iter()
        .enumerate()
        .map(|(k, w)| {
            let seed = settings.seed.wrapping_add(k as u64);
            Robot::new(w, cfg, mode, model.clone(), seed, false)
        })
        .collect::<Result<Vec<_>>>()?;
    let mut batch = fields(cfg, worlds.len(), gpu)?;
    run_lockstep(robots, &mut batch, Some(gist), progress)
}

/// The evaluation worlds: world `k` of a run seeded `seed`.
pub fn evaluation_world(settings: &EvalSettings, k: usize) -> World {
    let seed = settings.seed.wrapping_add(k as u64);
    let mut world = World::random(seed, settings.obstacles, settings.invisible);
    if settings.goal_guard {
        world.guard_goal(seed);
    }
    world
}

/// The same world with every obstacle standing in the LIDAR's scan plane.
pub fn all_visible(mut world: World) -> World {
    for o in &mut world.obstacles {
        o.height = o.height.max(1.0);
        o.transparent = false;
    }
    world
}
