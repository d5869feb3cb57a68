//! Arguments shared by several commands, so that each flag name keeps one meaning everywhere:
//! `--backend` is where the heavy work runs, `--config` the one settings file (tables
//! `[detector]`, `[slam]`, `[gist]`, `[nav]`, `[replay]`, `[synthetic]`), `--out` a directory.

use std::path::PathBuf;
use std::str::FromStr;

use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::Args;
use steernav::features::{BasisOrder, DescriptorKind, MergeMode, Spread};
use steernav::settings::Settings;
use steernav::{Backend, Detector, DetectorConfig};

/// A clap parser for a library enum by the names it has in TOML and JSON (its `NAMES`), so
/// the library needs no clap derive and `--help` still lists the choices.
pub fn choice<T>(names: &'static [&'static str]) -> impl TypedValueParser<Value = T>
where
    T: FromStr + Clone + Send + Sync + 'static,
{
    PossibleValuesParser::new(names).map(|name| {
        name.parse::<T>()
            .unwrap_or_else(|_| unreachable!("every listed name parses"))
    })
}

/// Checks a `--plot` (or other PNG) output before a run spends its time: it must be named
/// `.png` (the figure is written as PNG whatever the name says) and not be a directory.
pub fn check_png_output(flag: &str, path: &std::path::Path) -> anyhow::Result<()> {
    if !path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
    {
        anyhow::bail!("{}: {flag} writes a PNG; name it .png", path.display());
    }
    if path.is_dir() {
        anyhow::bail!("{}: {flag} names a directory, not a file", path.display());
    }
    Ok(())
}

/// The settings file.
#[derive(Args, Clone, Default)]
pub struct ConfigArg {
    /// Settings file (TOML) with one table per stage: [detector], [slam], [gist], [nav],
    /// [replay], [synthetic]; each command reads its own tables, flags override them.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
}

impl ConfigArg {
    /// The file's settings, or the defaults without one.
    pub fn settings(&self) -> anyhow::Result<Settings> {
        Ok(Settings::load_or_default(self.config.as_deref())?)
    }
}

/// The backend of the commands that run one.
#[derive(Args, Clone)]
pub struct BackendArg {
    /// Where the heavy work runs: auto (a hardware GPU if there is one, else the CPU with a
    /// warning), gpu (any adapter, software ones included), cpu.
    #[arg(long, default_value = "auto", value_parser = choice::<Backend>(Backend::NAMES))]
    pub backend: Backend,
}

/// The backend and the detector settings of every command that detects.
#[derive(Args, Clone)]
pub struct DetectorArgs {
    #[command(flatten)]
    pub backend: BackendArg,
    /// Largest image accepted, in pixels; larger ones are refused from their header before
    /// decoding.
    #[arg(long, value_name = "N", default_value_t = steernav::image::DEFAULT_MAX_PIXELS)]
    pub max_pixels: u64,
    #[command(flatten)]
    pub flags: DetectorFlags,
    #[command(flatten)]
    pub config: ConfigArg,
}

impl DetectorArgs {
    /// The settings file's [detector] table (or the defaults) under the flags.
    pub fn config(&self) -> anyhow::Result<DetectorConfig> {
        self.flags.apply(self.config.settings()?.detector)
    }

    /// The detector this command asked for.
    pub fn detector(&self) -> anyhow::Result<Detector> {
        Ok(Detector::new(&self.config()?, self.backend.backend)?)
    }

    /// The detector from `base` in place of the library defaults: the settings file's
    /// [detector] keys over it, the flags over both.
    pub fn detector_from(&self, base: DetectorConfig) -> anyhow::Result<Detector> {
        Ok(Detector::new(
            &self.config_from(base)?,
            self.backend.backend,
        )?)
    }

    /// The settings of [`DetectorArgs::detector_from`].
    pub fn config_from(&self, base: DetectorConfig) -> anyhow::Result<DetectorConfig> {
        let config = self.config.settings()?.detector_over(base)?;
        self.flags.apply(config)
    }
}

/// Detector flags that override the settings file.
#[derive(Args, Clone)]
pub struct DetectorFlags {
    /// Number of steered orientations N, spread over [0°, 180°) [default: 12].
    #[arg(long, value_name = "N")]
    pub orientations: Option<usize>,
    /// Number of detection scales S (σ_D = sigma0 · scale_step^s, 2^(s/3) by default: 16
    /// span five octaves, σ_D 1–32) [default: 16; slam: 3 at step 1.4].
    #[arg(long, value_name = "S")]
    pub scales: Option<usize>,
    /// Keep at most K keypoints, the strongest [default: 500; match: 1000].
    #[arg(long, value_name = "K")]
    pub max_keypoints: Option<usize>,
    /// How the K keypoints are chosen: strongest, or anms (adaptive non-maximal suppression
    /// within an octave, which spreads them over the image) [default: strongest].
    #[arg(long, value_parser = choice::<Spread>(Spread::NAMES))]
    pub spread: Option<Spread>,
    /// Order of the steered Gaussian-derivative basis [default: first; slam: second].
    #[arg(long, value_parser = choice::<BasisOrder>(BasisOrder::NAMES))]
    pub basis: Option<BasisOrder>,
    /// How detections of all orientations and scales are merged [default: covariant].
    #[arg(long, value_parser = choice::<MergeMode>(MergeMode::NAMES))]
    pub merge: Option<MergeMode>,
    /// Descriptor of every keypoint: steered (128 steered responses in the keypoint's frame,
    /// for matching), steered-twin (256: the same read in the frames of both orientation
    /// peaks where a second reaches 0.8 of the first, matched by the nearer frame; more correct
    /// matches and recall under rotation, on the CPU), entropy (the paper's five colour
    /// entropies) or none (keypoints only; `slam` uses none) [default: steered].
    #[arg(long, value_parser = choice::<DescriptorKind>(DescriptorKind::NAMES))]
    pub descriptor: Option<DescriptorKind>,
    /// Absolute floor of a candidate's scale-normalised Harris response [default: 1e-12].
    #[arg(long, value_name = "R")]
    pub threshold: Option<f32>,
    /// A candidate's response must exceed this fraction of the frame's strongest response;
    /// 0 leaves only --threshold [default: 0.001].
    #[arg(long, value_name = "F")]
    pub relative_threshold: Option<f32>,
}

impl DetectorFlags {
    /// `cfg` with the flags given applied, validated.
    pub fn apply(&self, mut cfg: DetectorConfig) -> anyhow::Result<DetectorConfig> {
        if let Some(v) = self.orientations {
            cfg.orientations = v;
        }
        if let Some(v) = self.scales {
            cfg.scales = v;
        }
        if let Some(v) = self.max_keypoints {
            cfg.max_keypoints = v;
        }
        if let Some(v) = self.spread {
            cfg.spread = v;
        }
        if let Some(v) = self.basis {
            cfg.basis = v;
        }
        if let Some(v) = self.merge {
            cfg.merge = v;
        }
        if let Some(v) = self.threshold {
            cfg.threshold = v;
        }
        if let Some(v) = self.descriptor {
            cfg.descriptor = v;
        }
        if let Some(v) = self.relative_threshold {
            cfg.relative_threshold = v;
        }
        cfg.validate()?;
        Ok(cfg)
    }
}

/// The file stem of a path, for output names.
pub fn stem(path: &std::path::Path) -> String {
    path.file_stem()
        .map_or_else(|| "image".into(), |s| s.to_string_lossy().into_owned())
}

/// A progress bar on stderr for `len` steps of `unit`.
pub fn progress(len: usize, unit: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(&format!(
            "{{bar:40}} {{pos}}/{{len}} {unit}  {{per_sec}}  ETA {{eta}}  {{msg}}"
        ))
        .expect("valid template"),
    );
    bar
}
