//! `nav-sweep`: random search over the field's and the stimuli's parameters — the paper notes
//! that tuning them "can be challenging and time-consuming"; this makes it a command. Every
//! candidate drives the same random worlds, and candidates are ranked by success rate minus
//! half the collision rate.

use std::sync::Arc;

use serde::Serialize;

use super::episode::EpisodeConfig;
use super::evaluate::{evaluation_world, run_worlds, summarise, EvalSettings, ModeSummary};
use super::world::World;
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::nav::controller::Mode;
use crate::nav::dnf::Interaction;
use crate::nav::gist::Gist;
use crate::nav::visual::VisualObstacleModel;
use crate::rng::Rng;

/// The parameters a candidate sets.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Candidate {
    /// τ of eq 30, s.
    pub tau: f32,
    /// Resting level h.
    pub h: f32,
    /// Eq 31's inhibitory weight.
    pub inhibit: f32,
    /// c_o of eq 32.
    pub c_o: f32,
    /// σ of eq 32, 1/rad².
    pub sigma: f32,
    /// Distance scale of g(d), m.
    pub g_scale: f32,
    /// Turn rate per radian of heading error, 1/s.
    pub turn_gain: f32,
}

/// One candidate's result.
#[derive(Clone, Debug, Serialize)]
pub struct SweepRow {
    /// Its parameters.
    pub candidate: Candidate,
    /// Its episodes.
    pub summary: ModeSummary,
    /// success_rate − 0.5 × collision rate.
    pub score: f64,
}

impl Candidate {
    /// The candidate of `base`.
    pub fn of(base: &EpisodeConfig) -> Self {
        let inhibit = match base.controller.field.interaction {
            Interaction::Amari { inhibit, .. } => inhibit,
            Interaction::GaussianDifference { .. } => -2.2,
        };
        Self {
            tau: base.controller.field.tau,
            h: base.controller.field.h,
            inhibit,
            c_o: base.controller.stimulus.c_o,
            sigma: base.controller.stimulus.sigma,
            g_scale: base.controller.stimulus.g_scale,
            turn_gain: base.controller.turn_gain,
        }
    }

    /// A random candidate: log-uniform for scales, uniform for levels.
    pub fn sample(rng: &mut Rng) -> Self {
        let log = |rng: &mut Rng, a: f32, b: f32| (a.ln() + (b.ln() - a.ln()) * rng.unit()).exp();
        Self {
            tau: log(rng, 0.03, 0.3),
            h: rng.range(-4.0, -0.5),
            inhibit: rng.range(-4.0, -1.0),
            c_o: log(rng, 3.0, 80.0),
            sigma: log(rng, 3.0, 40.0),
            g_scale: log(rng, 0.4, 2.5),
            turn_gain: rng.range(1.0, 4.0),
        }
    }

    /// `base` with this candidate's values.
    pub fn apply(&self, base: &EpisodeConfig) -> EpisodeConfig {
        let mut cfg = base.clone();
        cfg.controller.field.tau = self.tau;
        cfg.controller.field.h = self.h;
        if let Interaction::Amari { excite, width, .. } = base.controller.field.interaction {
            cfg.controller.field.interaction = Interaction::Amari {
                excite,
                inhibit: self.inhibit,
                width,
            };
        }
        cfg.controller.stimulus.c_o = self.c_o;
        cfg.controller.stimulus.sigma = self.sigma;
        cfg.controller.stimulus.g_scale = self.g_scale;
        cfg.controller.turn_gain = self.turn_gain;
        cfg
    }
}

/// Runs `samples` random candidates plus the base configuration in `mode` on the same worlds;
/// rows come back best first. `progress` is called once per finished episode.
pub fn sweep(
    base: &EpisodeConfig,
    gist: &Gist,
    model: &VisualObstacleModel,
    (mode, samples): (Mode, usize),
    settings: &EvalSettings,
    gpu: Option<&Arc<GpuContext>>,
    progress: impl Fn() + Sync,
) -> Result<Vec<SweepRow>> {
    let worlds: Vec<World> = (0..settings.episodes)
        .map(|k| evaluation_world(settings, k))
        .collect();
    let mut rng = Rng(settings.seed ^ 0x5EE9);
    let mut candidates = vec![Candidate::of(base)];
    candidates.extend((0..samples).map(|_| Candidate::sample(&mut rng)));
    let mut rows = Vec::with_capacity(candidates.len());
    for candidate in candidates {
        let cfg = candidate.apply(base);
        cfg.validate()?;
        let episodes = run_worlds(&worlds, &cfg, mode, model, settings, (gist, gpu), &progress)?;
        let summary = summarise(&episodes);
        let score =
            summary.success_rate - 0.5 * summary.collisions as f64 / summary.episodes.max(1) as f64;
        rows.push(SweepRow {
            candidate,
            summary,
            score,
        });
    }
    rows.sort_by(|a, b| b.score.total_cmp(&a.score));
    Ok(rows)
}
