//! `steernav bench`: times every stage of `detect` on generated scenes of several sizes, on
//! the CPU and the GPU, after warm-up, as median and spread over repeated runs. GPU pass times
//! come from timestamp queries; the rest is wall-clock time.

pub mod nav;
pub mod slam;

use std::process::ExitCode;

use anyhow::bail;
use clap::{Args, ValueEnum};
use serde::Serialize;
use steernav::error::Result;
use steernav::features::{Backend, Detection, Detector, DetectorConfig};
use steernav::low_level::synth::textured_scene;

use crate::args::{choice, ConfigArg, DetectorFlags};

/// What `bench` times.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Suite {
    /// Every stage of the detector per image size.
    Detect,
    /// GIST per image and the neural field at B = 1, 64, 4096.
    Nav,
    /// The whole SLAM loop per frame on a generated 10 Hz drive, split per stage.
    Slam,
}

#[derive(Args)]
pub struct BenchCmd {
    /// What to time: detect (every stage of the detector per image size), nav (GIST per
    /// image and the neural field at B = 1, 64, 4096) or slam (the whole SLAM loop per frame
    /// on a generated 10 Hz drive and a 30 Hz walk through furnished rooms, split per stage).
    #[arg(long, value_enum, default_value_t = Suite::Detect)]
    suite: Suite,
    /// Image sizes, WxH separated by commas [default: 320x240,640x480,1280x720,1920x1080
    /// for detect; 640x480,1241x376 for slam].
    #[arg(long, value_name = "LIST")]
    sizes: Option<String>,
    /// Frames of each generated sequence (the drive and the walk) per size and backend (slam
    /// suite).
    #[arg(long, default_value_t = 100)]
    frames: usize,
    /// Backends to time, separated by commas: cpu, gpu (auto means gpu when it is a hardware
    /// adapter).
    #[arg(long, default_value = "cpu,gpu", value_delimiter = ',', value_parser = choice::<Backend>(Backend::NAMES))]
    backend: Vec<Backend>,
    /// Untimed runs before measuring, per size and backend.
    #[arg(long, default_value_t = 2)]
    warmup: usize,
    /// Timed runs per size and backend.
    #[arg(long, default_value_t = 10)]
    runs: usize,
    /// Print a JSON array of {stage, backend, size, median_ms, p10_ms, p90_ms} instead of the table.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    flags: DetectorFlags,
    #[command(flatten)]
    config: ConfigArg,
}

pub fn run(cmd: BenchCmd) -> anyhow::Result<ExitCode> {
    let default_sizes = if cmd.suite == Suite::Slam {
        "640x480,1241x376"
    } else {
        "320x240,640x480,1280x720,1920x1080"
    };
    let sizes =
        parse_sizes(cmd.sizes.as_deref().unwrap_or(default_sizes)).map_err(anyhow::Error::msg)?;
    let mut backends = Vec::new();
    for b in &cmd.backend {
        let b = match b {
            Backend::Auto => Backend::of(Backend::Auto.resolve()?.as_ref()),
            other => *other,
        };
        if !backends.contains(&b) {
            backends.push(b);
        }
    }
    let settings = cmd.config.settings()?;
    let config = cmd.flags.apply(settings.detector.clone())?;
    let adapter = if backends.contains(&Backend::Gpu) {
        match steernav::GpuContext::shared() {
            Ok(ctx) => Some(format!(
                "{} ({:?}, {:?})",
                ctx.info.name, ctx.info.backend, ctx.info.device_type
            )),
            Err(e) if !steernav::low_level::gpu::gpu_required() => {
                log::warn!("{e}; timing the CPU only");
                backends.retain(|b| *b != Backend::Gpu);
                None
            }
            Err(e) => return Err(e.into()),
        }
    } else {
        None
    };
    let bar = indicatif::ProgressBar::new((sizes.len() * backends.len() * cmd.runs.max(1)) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} runs  ETA {eta}")
            .expect("valid template"),
    );
    if cmd.suite == Suite::Slam {
        if cmd.frames < 10 {
            bail!(
                "--frames: {} is too few for a median (at least 10)",
                cmd.frames
            );
        }
        bar.set_length((sizes.len() * slam::MOTIONS.len() * backends.len() * cmd.frames) as u64);
        // As `steernav slam` reads them: the file's [slam] table, its [detector] keys over
        // the tracking preset, the flags over both.
        let detector = cmd
            .flags
            .apply(settings.detector_over(DetectorConfig::tracking())?)?;
        let rows = slam::run(
            &sizes,
            &backends,
            cmd.frames,
            (&detector, &settings.slam),
            || bar.inc(1),
        )?;
        bar.finish_and_clear();
        if cmd.json {
            println!("{}", serde_json::to_string_pretty(&rows)?);
        } else {
            print!("{}", slam::table(&rows));
            if let Some(adapter) = &adapter {
                println!("gpu: {adapter}");
            }
        }
        return Ok(ExitCode::SUCCESS);
    }
    if cmd.suite == Suite::Nav {
        bar.set_length((6 * backends.len() * cmd.runs.max(1)) as u64);
        let rows = nav::run(&backends, cmd.warmup, cmd.runs, &bar)?;
        bar.finish_and_clear();
        if cmd.json {
            println!("{}", serde_json::to_string_pretty(&rows)?);
        } else {
            print!("{}", nav::table(&rows, adapter.as_deref()));
        }
        return Ok(ExitCode::SUCCESS);
    }
    let rows = time_detect(&config, &sizes, &backends, cmd.warmup, cmd.runs, &bar)?;
    bar.finish_and_clear();
    if cmd.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        print!("{}", table(&rows, adapter.as_deref()));
        if adapter.as_deref().is_some_and(|a| a.contains("llvmpipe")) {
            println!("\nnote: llvmpipe (lavapipe) runs shaders on the CPU: its GPU times prove correctness, not GPU speed.");
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// One measured stage.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BenchRow {
    /// Stage name.
    pub stage: String,
    /// "cpu" or "gpu".
    pub backend: String,
    /// "WxH".
    pub size: String,
    /// Median over runs, milliseconds.
    pub median_ms: f64,
    /// 10th percentile.
    pub p10_ms: f64,
    /// 90th percentile.
    pub p90_ms: f64,
}

/// Stages in table order, with how to read each from a detection (None: not on this backend).
#[allow(clippy::type_complexity)]
pub const STAGES: [(&str, fn(&Detection, f64) -> Option<f64>); 9] = [
    ("upload + readback + sync", |d, _| {
        d.timings.gpu.as_ref().map(|g| {
            (d.timings.harris_ms
                - g.filter_bank_ms
                - g.structure_tensor_ms
                - g.response_ms
                - g.nms_ms)
                .max(0.0)
        })
    }),
    ("filter bank", |d, _| {
        d.timings.gpu.as_ref().map(|g| g.filter_bank_ms)
    }),
    ("structure tensor", |d, _| {
        d.timings.gpu.as_ref().map(|g| g.structure_tensor_ms)
    }),
    ("responses", |d, _| {
        d.timings.gpu.as_ref().map(|g| g.response_ms)
    }),
    ("filters + tensor + responses", |d, _| {
        d.timings.cpu.as_ref().map(|c| c.responses_ms).or_else(|| {
            d.timings
                .gpu
                .as_ref()
                .map(|g| g.filter_bank_ms + g.structure_tensor_ms + g.response_ms)
        })
    }),
    ("nms + compaction", |d, _| {
        d.timings
            .cpu
            .as_ref()
            .map(|c| c.nms_ms)
            .or_else(|| d.timings.gpu.as_ref().map(|g| g.nms_ms))
    }),
    ("clustering", |d, _| Some(d.timings.merge_ms)),
    ("descriptors", |d, _| Some(d.timings.descriptor_ms)),
    ("end to end", |_, total| Some(total)),
];

pub(crate) fn percentile(sorted: &[f64], q: f64) -> f64 {
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i]
}

/// Parses "320x240,640x480".
pub fn parse_sizes(spec: &str) -> std::result::Result<Vec<(u32, u32)>, String> {
    spec.split(',')
        .map(|s| {
            let (w, h) = s
                .trim()
                .split_once('x')
                .ok_or_else(|| format!("--sizes: '{s}' is not WxH"))?;
            let w: u32 = w
                .parse()
                .map_err(|_| format!("--sizes: bad width in '{s}'"))?;
            let h: u32 = h
                .parse()
                .map_err(|_| format!("--sizes: bad height in '{s}'"))?;
            steernav::image::check_size("--sizes", w, h).map_err(|e| e.to_string())?;
            Ok((w, h))
        })
        .collect()
}

/// Runs the benchmark. `runs` timed runs follow `warmup` untimed ones per size and backend.
pub fn time_detect(
    config: &DetectorConfig,
    sizes: &[(u32, u32)],
    backends: &[Backend],
    warmup: usize,
    runs: usize,
    progress: &indicatif::ProgressBar,
) -> Result<Vec<BenchRow>> {
    let mut rows = Vec::new();
    for &backend in backends {
        let detector = Detector::new(config, backend)?;
        for &(w, h) in sizes {
            let frame = textured_scene(w, h, 1);
            detector.check_size(w, h)?;
            for _ in 0..warmup {
                detector.detect(&frame)?;
            }
            let mut samples: Vec<Vec<f64>> = vec![Vec::new(); STAGES.len()];
            for _ in 0..runs.max(1) {
                let t = std::time::Instant::now();
                let d = detector.detect(&frame)?;
                let total = t.elapsed().as_secs_f64() * 1e3;
                for (i, (_, read)) in STAGES.iter().enumerate() {
                    if let Some(v) = read(&d, total) {
                        samples[i].push(v);
                    }
                }
                progress.inc(1);
            }
            for ((name, _), mut v) in STAGES.iter().zip(samples) {
                if v.is_empty() {
                    continue;
                }
                v.sort_by(f64::total_cmp);
                rows.push(BenchRow {
                    stage: name.to_string(),
                    backend: detector.backend().to_string(),
                    size: format!("{w}x{h}"),
                    median_ms: percentile(&v, 0.5),
                    p10_ms: percentile(&v, 0.1),
                    p90_ms: percentile(&v, 0.9),
                });
            }
        }
    }
    Ok(rows)
}

/// A table per size: each stage's median (p10–p90) per backend, the GPU/CPU ratio, and
/// images per second end to end.
pub fn table(rows: &[BenchRow], adapter: Option<&str>) -> String {
    let mut s = String::new();
    if let Some(a) = adapter {
        s.push_str(&format!("GPU adapter: {a}\n"));
    }
    s.push_str("Times are medians over the runs, in ms, with the 10th–90th percentile range; GPU pass\ntimes come from timestamp queries. ratio = GPU time / CPU time (below 1: the GPU is faster).\n");
    let mut sizes: Vec<&str> = Vec::new();
    for r in rows {
        if !sizes.contains(&r.size.as_str()) {
            sizes.push(&r.size);
        }
    }
    let find = |size: &str, stage: &str, backend: &str| {
        rows.iter()
            .find(|r| r.size == size && r.stage == stage && r.backend == backend)
    };
    let cell = |r: Option<&BenchRow>| {
        r.map_or("—".to_string(), |r| {
            format!("{:.2} ({:.2}–{:.2})", r.median_ms, r.p10_ms, r.p90_ms)
        })
    };
    for size in sizes {
        s.push_str(&format!(
            "\n{size}\n{:<30} {:>24} {:>24} {:>8}\n",
            "stage", "cpu", "gpu", "ratio"
        ));
        for (stage, _) in STAGES.iter() {
            let (c, g) = (find(size, stage, "cpu"), find(size, stage, "gpu"));
            if c.is_none() && g.is_none() {
                continue;
            }
            let ratio = match (c, g) {
                (Some(c), Some(g)) if c.median_ms > 0.0 => {
                    format!("{:.2}", g.median_ms / c.median_ms)
                }
                _ => "—".into(),
            };
            s.push_str(&format!(
                "{stage:<30} {:>24} {:>24} {ratio:>8}\n",
                cell(c),
                cell(g)
            ));
        }
        let ips = |r: Option<&BenchRow>| {
            r.map_or("—".to_string(), |r| {
                format!("{:.1}", 1000.0 / r.median_ms)
            })
        };
        s.push_str(&format!(
            "{:<30} {:>24} {:>24}\n",
            "images/s (end to end)",
            ips(find(size, "end to end", "cpu")),
            ips(find(size, "end to end", "gpu"))
        ));
    }
    s
}
