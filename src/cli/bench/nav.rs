//! `steernav bench --suite nav`: GIST per image (256×256 reference and the simulator's 64×64)
//! and the dynamic neural field's 100 Euler steps at B = 1, 64 and 4096 fields of 72 neurons,
//! CPU and GPU, as medians with the 10th–90th percentile spread after warm-up.

use std::time::Instant;

use crate::bench::{percentile, BenchRow};
use steernav::error::Result;
use steernav::features::Backend;
use steernav::low_level::dnf::GpuFieldBatch;
use steernav::low_level::dnf::{bell, FieldBatch, FieldConfig};
use steernav::nav::gist::GpuGist;
use steernav::nav::gist::{GistConfig, GistEngine};
use steernav::nav::visual::VisualConfig;
use steernav::GpuContext;

/// Euler steps per timed field run.
pub const FIELD_STEPS: usize = 100;
/// Images per GPU GIST submission.
pub const GIST_BATCH: usize = 8;

fn row(stage: &str, backend: &str, size: String, mut v: Vec<f64>) -> BenchRow {
    v.sort_by(f64::total_cmp);
    BenchRow {
        stage: stage.to_string(),
        backend: backend.to_string(),
        size,
        median_ms: percentile(&v, 0.5),
        p10_ms: percentile(&v, 0.1),
        p90_ms: percentile(&v, 0.9),
    }
}

fn time(
    warmup: usize,
    runs: usize,
    progress: &indicatif::ProgressBar,
    mut f: impl FnMut() -> Result<()>,
) -> Result<Vec<f64>> {
    for _ in 0..warmup {
        f()?;
    }
    let mut v = Vec::with_capacity(runs);
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        f()?;
        v.push(t.elapsed().as_secs_f64() * 1e3);
        progress.inc(1);
    }
    Ok(v)
}

/// Runs the suite on `backends`; GPU GIST rows are per image (batches of 8 divided by 8).
pub fn run(
    backends: &[Backend],
    warmup: usize,
    runs: usize,
    progress: &indicatif::ProgressBar,
) -> Result<Vec<BenchRow>> {
    let mut rows = Vec::new();
    let frame = steernav::low_level::synth::textured_scene(320, 240, 5);
    let gist_configs = [
        ("256x256", GistConfig::default()),
        ("64x64", VisualConfig::default().gist),
    ];
    let ctx = if backends.contains(&Backend::Gpu) {
        Some(GpuContext::shared()?)
    } else {
        None
    };
    for (size, config) in &gist_configs {
        if backends.contains(&Backend::Cpu) {
            let engine = GistEngine::new(config.clone())?;
            let v = time(warmup, runs, progress, || {
                engine.describe(&frame).map(|_| ())
            })?;
            rows.push(row("gist (per image)", "cpu", size.to_string(), v));
        }
        if let Some(ctx) = &ctx {
            let mut gpu = GpuGist::new(ctx.clone(), config.clone())?;
            let frames = vec![frame.clone(); GIST_BATCH];
            let v = time(warmup, runs, progress, || {
                gpu.describe_batch(&frames).map(|_| ())
            })?;
            let per_image = v.into_iter().map(|t| t / GIST_BATCH as f64).collect();
            rows.push(row("gist (per image)", "gpu", size.to_string(), per_image));
        }
    }
    let config = FieldConfig::default();
    for b in [1usize, 64, 4096] {
        let stimulus: Vec<f32> = (0..b)
            .flat_map(|i| bell(72, (i % 72) as f32, 5.0, 3.0))
            .collect();
        let stage = format!("field, {FIELD_STEPS} steps");
        if backends.contains(&Backend::Cpu) {
            let mut field = FieldBatch::new(config.clone(), b)?;
            let v = time(warmup, runs, progress, || {
                field.step(&stimulus, FIELD_STEPS)
            })?;
            rows.push(row(&stage, "cpu", format!("B={b}"), v));
        }
        if let Some(ctx) = &ctx {
            let mut field = GpuFieldBatch::new(ctx.clone(), config.clone(), b)?;
            let v = time(warmup, runs, progress, || {
                field.step(&stimulus, FIELD_STEPS)?;
                field.read().map(|_| ())
            })?;
            rows.push(row(&stage, "gpu", format!("B={b}"), v));
        }
    }
    Ok(rows)
}

/// The table: median (p10–p90) per backend, with throughput (images/s or neuron-steps/s).
pub fn table(rows: &[BenchRow], adapter: Option<&str>) -> String {
    let mut s = String::new();
    if let Some(a) = adapter {
        s.push_str(&format!("GPU adapter: {a}\n"));
    }
    s.push_str("Medians over the runs in ms (10th–90th percentile); GPU GIST is per image of a batch of 8,\nGPU field times include the readback that waits for the device.\n");
    s.push_str(&format!(
        "{:<22} {:<9} {:<4} {:>26} {:>22}\n",
        "stage", "size", "", "time (ms)", "throughput"
    ));
    for r in rows {
        let throughput = if r.stage.starts_with("gist") {
            format!("{:.1} images/s", 1e3 / r.median_ms)
        } else {
            let b: f64 = r.size.trim_start_matches("B=").parse().unwrap_or(1.0);
            format!(
                "{:.2e} neuron-steps/s",
                b * 72.0 * FIELD_STEPS as f64 / (r.median_ms * 1e-3)
            )
        };
        s.push_str(&format!(
            "{:<22} {:<9} {:<4} {:>26} {:>22}\n",
            r.stage,
            r.size,
            r.backend,
            format!("{:.3} ({:.3}–{:.3})", r.median_ms, r.p10_ms, r.p90_ms),
            throughput
        ));
    }
    s
}
