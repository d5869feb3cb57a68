//! The `steernav` command line: detect, batch, info.

/// `println!` for the commands: a closed or full stdout becomes an error the command returns
/// (see [`StdoutFailed`]) instead of a panic. Shadows the std macro in this crate.
macro_rules! println {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout(), $($arg)*).map_err(crate::StdoutFailed)?;
    }};
}

/// `print!` with the same handling as [`println!`].
macro_rules! print {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        write!(std::io::stdout(), $($arg)*).map_err(crate::StdoutFailed)?;
    }};
}

mod nav_cli;
mod slam_cli;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::{Args, Parser, Subcommand, ValueEnum};
use steernav::batch::{self, BatchOptions, Outcome};
use steernav::eval::peers::{PeerRunner, ALL_PEERS};
use steernav::eval::sweep::{
    homography_sequence, parse_angles, rotation_sweep, summarize, summary_table, to_csv,
    EvalOptions, Row,
};
use steernav::features::{BasisOrder, MergeMode};
use steernav::output::{write_atomic, ImageKeypoints};
use steernav::{Backend, Detection, Detector, DetectorConfig, Frame};

/// GPU-accelerated rotation-invariant keypoints (steerable filters + multiscale Harris).
#[derive(Parser)]
#[command(name = "steernav", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Detect keypoints on one or more images; JSON (or CSV) on stdout or one file per image.
    Detect(DetectCmd),
    /// Detect on every image under a directory (recursive), one JSON per image + summary.csv.
    Batch(BatchCmd),
    /// Judge detectors by repeatability (eq 11) and recall (eq 12): rotation sweeps and
    /// Oxford-layout homography sequences, steernav beside OpenCV's classic detectors.
    #[command(subcommand)]
    Eval(EvalKind),
    /// Time every stage of detect on the CPU and the GPU at several image sizes.
    Bench(BenchCmd),
    /// GIST descriptors (eqs 38–41) of images: one JSON object per line, {"image", "gist"}.
    Gist(GistCmd),
    /// Drive the neural field with every scan of a CARMEN log (FLASER lines, gzipped or not):
    /// fraction of scans whose chosen heading is free, and its deviation from the real motion.
    NavReplay(NavReplayCmd),
    /// Monocular EKF SLAM with inverse-depth landmarks on an image sequence: TUM trajectory,
    /// map with covariances, figures, and ATE when ground truth is present.
    Slam(Box<slam_cli::SlamCmd>),
    /// ATE after Sim(3) alignment and RPE of a TUM trajectory against ground truth.
    SlamEval(slam_cli::SlamEvalCmd),
    /// Render a synthetic sequence with exact ground truth (TUM RGB-D layout + calib.toml).
    SlamSynth(slam_cli::SlamSynthCmd),
    /// One navigation episode in the 2D simulator (LIDAR alone or fused with the camera's
    /// GIST), with a figure of the trajectory and the field activity.
    Nav(nav_cli::NavCmd),
    /// Random worlds driven with the LIDAR alone and with fusion: success, collisions, path
    /// length, time to goal and position error, on worlds with and without LIDAR-invisible
    /// obstacles.
    NavEval(nav_cli::NavEvalCmd),
    /// Random search over the field's and the stimuli's parameters, every candidate on the
    /// same random worlds; prints the best as a config file.
    NavSweep(nav_cli::NavSweepCmd),
    /// Print the GPU adapter, backend, driver and the limits that matter.
    Info,
}

#[derive(Args)]
struct GistCmd {
    /// Input images.
    #[arg(required = true, value_name = "IMAGE")]
    images: Vec<PathBuf>,
    /// TOML file with GIST settings (size, orientations_per_scale, blocks, prefilter,
    /// prefilter_fc, boundary; every key optional).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Where the filter bank runs: auto (GPU if an adapter exists), gpu, cpu. The GPU
    /// computes the exact bank (as `decimate = false`) on all images in batched submissions.
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    backend: Backend,
}

#[derive(Args)]
struct NavReplayCmd {
    /// CARMEN log (.log or .log.gz).
    log: PathBuf,
    /// TOML file with replay settings ([field], [stimulus] tables and the top-level keys of
    /// ReplayConfig; every key optional).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Print {"scans", "free_fraction", "mean_abs_deviation_deg"} as JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct BenchCmd {
    /// What to time: detect (every stage of the detector per image size), nav (GIST per
    /// image and the neural field at B = 1, 64, 4096) or slam (the whole SLAM loop per frame
    /// on a generated 10 Hz drive, split per stage).
    #[arg(long, default_value = "detect", value_parser = ["detect", "nav", "slam"])]
    suite: String,
    /// Image sizes, WxH separated by commas [default: 320x240,640x480,1280x720,1920x1080
    /// for detect; 640x480,1241x376 for slam].
    #[arg(long, value_name = "LIST")]
    sizes: Option<String>,
    /// Frames of the generated drive per size and backend (slam suite).
    #[arg(long, default_value_t = 100)]
    frames: usize,
    /// Backends to time: cpu, gpu or both (cpu,gpu).
    #[arg(long, default_value = "cpu,gpu", value_name = "LIST")]
    backend: String,
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
    settings: SettingsArgs,
}

#[derive(Subcommand)]
enum EvalKind {
    /// Rotate each image about its centre (expanded canvas) by every angle and compare.
    Rotation(RotationCmd),
    /// Compare img1 with img2..img6 of Oxford-layout sequences (imgN + H1toNp files).
    Homography(HomographyCmd),
}

/// Settings shared by the evaluations.
#[derive(Args)]
struct EvalArgs {
    /// Detectors to compare: "all" (steernav and every peer the installed OpenCV has) or a
    /// list from steernav,agast,brisk,censure,orb,sift,surf,fast,kaze,akaze,harris.
    #[arg(long, default_value = "all", value_name = "LIST")]
    detectors: String,
    /// Compare this many strongest keypoints per view (also steernav's cap).
    #[arg(long, default_value_t = 500, value_name = "N")]
    keypoints: usize,
    /// Tolerances ε in pixels; the summary and the figure use 2.
    #[arg(long, default_value = "1.5,2,3", value_name = "LIST")]
    eps: String,
    /// Points closer than this many pixels to a border are left out of the common region.
    #[arg(long, default_value_t = 10.0, value_name = "PX")]
    margin: f64,
    /// Lowe's ratio for the nearest-neighbour matching behind recall.
    #[arg(long, default_value_t = 0.8)]
    ratio: f64,
    /// Python with OpenCV for the peers [default: $STEERNAV_PYTHON, else .venv-peers from
    /// tools/setup-peers.sh].
    #[arg(long, value_name = "PATH")]
    python: Option<PathBuf>,
    #[command(flatten)]
    detector: DetectorArgs,
}

#[derive(Args)]
struct RotationCmd {
    /// Images to rotate.
    #[arg(long, required = true, num_args = 1.., value_name = "IMG")]
    images: Vec<PathBuf>,
    /// Angles in degrees: start:stop:step (stop excluded) or a list.
    #[arg(long, default_value = "0:360:15", value_name = "SPEC")]
    angles: String,
    /// Write every row (detector,image,angle,eps,repeatability,recall,count) to this CSV.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Write repeatability and recall against angle (paper Fig. 4a–b) to this PNG.
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    #[command(flatten)]
    eval: EvalArgs,
}

#[derive(Args)]
struct HomographyCmd {
    /// Sequence directories (img1..img6 as PPM/PGM/PNG, H1to2p..H1to6p).
    #[arg(required = true, value_name = "DIR")]
    sequences: Vec<PathBuf>,
    /// Directory receiving <sequence>.csv and <sequence>.png.
    #[arg(long, default_value = "eval-out", value_name = "DIR")]
    out: PathBuf,
    #[command(flatten)]
    eval: EvalArgs,
}

/// The backend and the detector settings of every command that detects.
#[derive(Args, Clone)]
struct DetectorArgs {
    /// Where the image work runs: auto (a hardware GPU if there is one, else the CPU with a
    /// warning), gpu (any adapter, software ones included), cpu.
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    backend: Backend,
    /// Largest image accepted, in pixels; larger ones are refused from their header before
    /// decoding.
    #[arg(long, value_name = "N", default_value_t = steernav::image::DEFAULT_MAX_PIXELS)]
    max_pixels: u64,
    #[command(flatten)]
    settings: SettingsArgs,
}

impl DetectorArgs {
    fn config(&self) -> anyhow::Result<DetectorConfig> {
        self.settings.config()
    }

    fn detector(&self) -> anyhow::Result<Detector> {
        Ok(Detector::new(&self.config()?, self.backend)?)
    }

    /// The detector with `base` in place of the library default under the file and flags.
    fn detector_from(&self, base: DetectorConfig) -> anyhow::Result<Detector> {
        Ok(Detector::new(
            &self.settings.config_from(base)?,
            self.backend,
        )?)
    }
}

/// Detector settings: a TOML file and the flags that override it.
#[derive(Args, Clone)]
struct SettingsArgs {
    /// TOML file with detector settings (a [detector] table; see README); flags override it.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Number of steered orientations N, spread over [0°, 180°) [default: 12].
    #[arg(long, value_name = "N")]
    orientations: Option<usize>,
    /// Number of detection scales S (σ_D = 1.0 · 1.4^s) [default: 5].
    #[arg(long, value_name = "S")]
    scales: Option<usize>,
    /// Keep at most K keypoints, the strongest [default: 500].
    #[arg(long, value_name = "K")]
    max_keypoints: Option<usize>,
    /// Order of the steered Gaussian-derivative basis [default: second].
    #[arg(long, value_enum)]
    basis: Option<BasisOrder>,
    /// How detections of all orientations and scales are merged [default: covariant].
    #[arg(long, value_enum)]
    merge: Option<MergeMode>,
    /// Minimum scale-normalised Harris response of a candidate [default: 1e-8].
    #[arg(long, value_name = "R")]
    threshold: Option<f32>,
}

impl SettingsArgs {
    fn config(&self) -> anyhow::Result<DetectorConfig> {
        self.config_from(DetectorConfig::default())
    }

    /// `base` (when no --config file is given) with the flags applied.
    fn config_from(&self, base: DetectorConfig) -> anyhow::Result<DetectorConfig> {
        let mut cfg = match &self.config {
            Some(path) => {
                let text = std::fs::read_to_string(path)
                    .with_context(|| format!("{}: cannot read config", path.display()))?;
                DetectorConfig::from_toml_str(&text).map_err(|reason| {
                    anyhow::anyhow!("{}: malformed config: {reason}", path.display())
                })?
            }
            None => base,
        };
        if let Some(v) = self.orientations {
            cfg.orientations = v;
        }
        if let Some(v) = self.scales {
            cfg.scales = v;
        }
        if let Some(v) = self.max_keypoints {
            cfg.max_keypoints = v;
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
        cfg.validate()?;
        Ok(cfg)
    }
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Format {
    Json,
    Csv,
}

#[derive(Args)]
struct DetectCmd {
    /// Input images (PNG, JPEG, PPM/PGM, TIFF, BMP).
    #[arg(required = true, value_name = "IMAGE")]
    images: Vec<PathBuf>,
    #[command(flatten)]
    detector: DetectorArgs,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Json)]
    format: Format,
    /// Write one file per image (<name>.json or .csv) into DIR instead of stdout.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Also write <name>_keypoints.png (circles of radius 3σ_D, orientation ticks) into --out or the current directory.
    #[arg(long)]
    draw: bool,
}

#[derive(Args)]
struct BatchCmd {
    /// Directory searched recursively for images.
    input: PathBuf,
    /// Output directory: one <image>.json per image (mirroring the input tree) and summary.csv.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    #[command(flatten)]
    detector: DetectorArgs,
    /// Redo images whose JSON already exists (by default a re-run skips them).
    #[arg(long)]
    force: bool,
    /// Also write a PNG with the keypoints next to each JSON.
    #[arg(long)]
    draw: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Detect(cmd) => detect(cmd),
        Command::Batch(cmd) => run_batch(cmd),
        Command::Eval(EvalKind::Rotation(cmd)) => eval_rotation(cmd),
        Command::Eval(EvalKind::Homography(cmd)) => eval_homography(cmd),
        Command::Bench(cmd) => bench(cmd),
        Command::NavReplay(cmd) => nav_replay(cmd),
        Command::Gist(cmd) => gist(cmd),
        Command::Slam(cmd) => slam_cli::slam(*cmd),
        Command::SlamEval(cmd) => slam_cli::slam_eval(cmd),
        Command::SlamSynth(cmd) => slam_cli::slam_synth(cmd),
        Command::Nav(cmd) => nav_cli::nav(cmd),
        Command::NavEval(cmd) => nav_cli::nav_eval(cmd),
        Command::NavSweep(cmd) => nav_cli::nav_sweep(cmd),
        Command::Info => info(),
    };
    // Whatever was printed must reach stdout before the exit code says it did.
    let flushed = std::io::Write::flush(&mut std::io::stdout()).map_err(StdoutFailed);
    match result.and_then(|code| flushed.map(|()| code).map_err(Into::into)) {
        Ok(code) => code,
        Err(e) => match e.downcast_ref::<StdoutFailed>() {
            // A reader that went away (`| head`) ends the program quietly, as Unix tools do.
            Some(StdoutFailed(io)) if io.kind() == std::io::ErrorKind::BrokenPipe => {
                ExitCode::from(141)
            }
            _ => {
                eprintln!("error: {e:#}");
                ExitCode::FAILURE
            }
        },
    }
}

/// Writing to stdout failed: closed by the reader or out of space.
#[derive(Debug, thiserror::Error)]
#[error("cannot write to stdout: {0}")]
struct StdoutFailed(std::io::Error);

fn summary_line(image: &Path, d: &Detection, detector: &Detector) -> String {
    let scales: Vec<String> = detector
        .plan()
        .scales
        .iter()
        .zip(&d.scale_histogram)
        .map(|(s, n)| format!("σ{:.2}:{n}", s.sigma_d))
        .collect();
    let t = &d.timings;
    let gpu = t.gpu.as_ref().map_or(String::new(), |g| {
        format!(
            " [GPU timestamps: filter bank {:.1} ms, structure tensor {:.1} ms, responses {:.1} ms, nms {:.1} ms]",
            g.filter_bank_ms, g.structure_tensor_ms, g.response_ms, g.nms_ms
        )
    });
    format!(
        "{}: {} keypoints from {} candidates on {} (harris {:.1} ms{gpu}, merge {:.1} ms, descriptors {:.1} ms); keypoints per scale {}",
        image.display(),
        d.keypoints.len(),
        d.candidates,
        d.backend,
        t.harris_ms,
        t.merge_ms,
        t.descriptor_ms,
        scales.join(" ")
    )
}

fn stem(path: &Path) -> String {
    path.file_stem()
        .map_or_else(|| "image".into(), |s| s.to_string_lossy().into_owned())
}

fn detect(cmd: DetectCmd) -> anyhow::Result<ExitCode> {
    if cmd.images.len() > 1 && cmd.out.is_none() && cmd.format == Format::Csv {
        bail!("several images with --format csv need --out DIR (one CSV per image)");
    }
    let detector = cmd.detector.detector()?;
    let scales: Vec<f32> = detector.plan().scales.iter().map(|s| s.sigma_d).collect();
    let mut failed = 0;
    for path in &cmd.images {
        let run = || -> anyhow::Result<()> {
            let frame = Frame::load_limited(path, cmd.detector.max_pixels)?;
            let d = detector
                .detect(&frame)
                .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            eprintln!("{}", summary_line(path, &d, &detector));
            let record = ImageKeypoints::new(path, &frame, d);
            let text = match cmd.format {
                Format::Json => record.to_json(),
                Format::Csv => record.to_csv(),
            };
            let ext = if cmd.format == Format::Json {
                "json"
            } else {
                "csv"
            };
            match &cmd.out {
                Some(dir) => {
                    write_atomic(&dir.join(format!("{}.{ext}", stem(path))), text.as_bytes())?
                }
                None => println!("{}", text.trim_end()),
            }
            if cmd.draw {
                let dir = cmd.out.clone().unwrap_or_else(|| PathBuf::from("."));
                let png = dir.join(format!("{}_keypoints.png", stem(path)));
                steernav::draw::write_png(&png, &frame, &record.keypoints, &scales)?;
                eprintln!("wrote {}", png.display());
            }
            Ok(())
        };
        if let Err(e) = run() {
            // Stdout failing is not this image's fault and ends the command.
            if e.is::<StdoutFailed>() {
                return Err(e);
            }
            eprintln!("error: {e:#}");
            failed += 1;
        }
    }
    Ok(if failed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

fn run_batch(cmd: BatchCmd) -> anyhow::Result<ExitCode> {
    let detector = cmd.detector.detector()?;
    let opts = BatchOptions {
        input: cmd.input,
        output: cmd.out,
        force: cmd.force,
        draw: cmd.draw,
        progress: true,
        max_pixels: cmd.detector.max_pixels,
    };
    let entries = batch::run(&detector, &opts)?;
    let count = |f: fn(&Outcome) -> bool| entries.iter().filter(|e| f(&e.outcome)).count();
    let done = count(|o| matches!(o, Outcome::Done { .. }));
    let skipped = count(|o| matches!(o, Outcome::Skipped));
    let failed = count(|o| matches!(o, Outcome::Failed(_)));
    eprintln!(
        "{done} detected, {skipped} skipped (already done; --force redoes them), {failed} failed; summary in {}",
        opts.output.join("summary.csv").display()
    );
    Ok(if failed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

/// Everything an evaluation needs: steernav (if selected), the peers that run, options.
struct EvalSetup {
    steernav: Option<Detector>,
    runner: Option<PeerRunner>,
    peers: Vec<String>,
    options: EvalOptions,
}

impl EvalArgs {
    fn setup(&self) -> anyhow::Result<EvalSetup> {
        let eps: Vec<f64> = self
            .eps
            .split(',')
            .map(|v| {
                v.trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|e| e.is_finite() && *e > 0.0)
            })
            .collect::<Option<_>>()
            .with_context(|| {
                format!(
                    "--eps {}: expected positive numbers separated by commas",
                    self.eps
                )
            })?;
        if self.keypoints == 0
            || !self.margin.is_finite()
            || self.margin < 0.0
            || !(0.0..=1.0).contains(&self.ratio)
        {
            bail!("--keypoints must be ≥ 1, --margin finite and ≥ 0, --ratio in [0, 1]");
        }
        let wanted: Vec<String> = if self.detectors == "all" {
            std::iter::once("steernav".to_string())
                .chain(ALL_PEERS.iter().map(|s| s.to_string()))
                .collect()
        } else {
            self.detectors
                .split(',')
                .map(|s| s.trim().to_lowercase())
                .collect()
        };
        for w in &wanted {
            if w != "steernav" && !ALL_PEERS.contains(&w.as_str()) {
                bail!(
                    "--detectors: unknown detector '{w}' (known: steernav, {})",
                    ALL_PEERS.join(", ")
                );
            }
        }
        let steernav = if wanted.iter().any(|w| w == "steernav") {
            let mut cfg = self.detector.config()?;
            cfg.max_keypoints = self.keypoints;
            Some(Detector::new(&cfg, self.detector.backend)?)
        } else {
            None
        };
        let asked: Vec<String> = wanted.into_iter().filter(|w| w != "steernav").collect();
        let (runner, peers) = if asked.is_empty() {
            (None, Vec::new())
        } else {
            match PeerRunner::locate(self.python.as_deref())
                .and_then(|r| r.availability().map(|a| (r, a)))
            {
                Ok((runner, avail)) => {
                    let missing: Vec<&String> =
                        asked.iter().filter(|a| avail.missing.contains(a)).collect();
                    if !missing.is_empty() {
                        eprintln!(
                            "note: OpenCV {} lacks {:?} (SURF is non-free and absent from the prebuilt wheels); KAZE and AKAZE are in the table instead",
                            avail.opencv, missing
                        );
                    }
                    let run: Vec<String> = asked
                        .into_iter()
                        .filter(|a| avail.available.contains(a))
                        .collect();
                    (Some(runner), run)
                }
                Err(e) if self.detectors == "all" => {
                    eprintln!("warning: peers skipped: {e}");
                    (None, Vec::new())
                }
                Err(e) => return Err(e.into()),
            }
        };
        Ok(EvalSetup {
            steernav,
            runner,
            peers,
            options: EvalOptions {
                eps,
                max_keypoints: self.keypoints,
                margin: self.margin,
                ratio: self.ratio,
            },
        })
    }
}

impl EvalSetup {
    fn peers(&self) -> Option<(&PeerRunner, &[String])> {
        self.runner
            .as_ref()
            .filter(|_| !self.peers.is_empty())
            .map(|r| (r, self.peers.as_slice()))
    }
}

fn eval_rotation(cmd: RotationCmd) -> anyhow::Result<ExitCode> {
    let angles = parse_angles(&cmd.angles).map_err(anyhow::Error::msg)?;
    let setup = cmd.eval.setup()?;
    let per_image =
        angles.len() as u64 * (setup.steernav.is_some() as u64 + setup.peers().is_some() as u64);
    let bar = indicatif::ProgressBar::new(per_image * cmd.images.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} views  {per_sec}  ETA {eta}")
            .expect("valid template"),
    );
    let rows = rotation_sweep(
        &cmd.images,
        &angles,
        setup.steernav.as_ref(),
        setup.peers(),
        &setup.options,
        &bar,
    )?;
    bar.finish_and_clear();
    report(
        &rows,
        cmd.csv.as_deref(),
        cmd.plot.as_deref(),
        "rotation",
        "angle (degrees)",
        "angle",
    )
}

fn eval_homography(cmd: HomographyCmd) -> anyhow::Result<ExitCode> {
    let setup = cmd.eval.setup()?;
    for dir in &cmd.sequences {
        let rows =
            homography_sequence(dir, setup.steernav.as_ref(), setup.peers(), &setup.options)?;
        let name = stem(dir);
        println!("== {}", dir.display());
        report(
            &rows,
            Some(&cmd.out.join(format!("{name}.csv"))),
            Some(&cmd.out.join(format!("{name}.png"))),
            &name,
            "image N (img1 against imgN)",
            "image",
        )?;
    }
    Ok(ExitCode::SUCCESS)
}

fn report(
    rows: &[Row],
    csv: Option<&Path>,
    plot: Option<&Path>,
    title: &str,
    x_label: &str,
    x_name: &str,
) -> anyhow::Result<ExitCode> {
    print!("{}", summary_table(&summarize(rows, 2.0), 2.0, x_name));
    if let Some(path) = csv {
        write_atomic(path, to_csv(rows).as_bytes())?;
        eprintln!("wrote {}", path.display());
    }
    if let Some(path) = plot {
        steernav::plot::metrics_figure(
            path,
            rows,
            2.0,
            &format!("{title}: repeatability and recall"),
            x_label,
        )?;
        eprintln!("wrote {}", path.display());
    }
    Ok(ExitCode::SUCCESS)
}

/// A settings struct from an optional TOML file (defaults without one); errors name the file.
fn load_toml<T: serde::de::DeserializeOwned + Default>(path: Option<&Path>) -> anyhow::Result<T> {
    let Some(path) = path else {
        return Ok(T::default());
    };
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read config", path.display()))?;
    toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: malformed config: {e}", path.display()))
}

fn gist(cmd: GistCmd) -> anyhow::Result<ExitCode> {
    let cfg: steernav::nav::gist::GistConfig = load_toml(cmd.config.as_deref())?;
    let engine = steernav::nav::gist::GistEngine::new(cfg.clone())?;
    let ctx = match cmd.backend {
        Backend::Cpu => None,
        Backend::Gpu => Some(steernav::gpu::GpuContext::shared()?),
        Backend::Auto => match steernav::gpu::context::auto_context() {
            Ok(ctx) => Some(ctx),
            Err(reason) => {
                eprintln!("warning: {reason}; using the CPU backend");
                None
            }
        },
    };
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
            let mut gpu = steernav::gpu::gist::GpuGist::new(ctx, cfg)?;
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

fn nav_replay(cmd: NavReplayCmd) -> anyhow::Result<ExitCode> {
    let cfg: steernav::nav::replay::ReplayConfig = load_toml(cmd.config.as_deref())?;
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

fn bench(cmd: BenchCmd) -> anyhow::Result<ExitCode> {
    let default_sizes = if cmd.suite == "slam" {
        "640x480,1241x376"
    } else {
        "320x240,640x480,1280x720,1920x1080"
    };
    let sizes = steernav::bench::parse_sizes(cmd.sizes.as_deref().unwrap_or(default_sizes))
        .map_err(anyhow::Error::msg)?;
    let mut backends = Vec::new();
    for b in cmd.backend.split(',') {
        backends.push(match b.trim() {
            "cpu" => Backend::Cpu,
            "gpu" => Backend::Gpu,
            other => bail!("--backend: '{other}' is not cpu or gpu"),
        });
    }
    let config = cmd.settings.config()?;
    let adapter = if backends.contains(&Backend::Gpu) {
        match steernav::gpu::GpuContext::shared() {
            Ok(ctx) => Some(format!(
                "{} ({:?}, {:?})",
                ctx.info.name, ctx.info.backend, ctx.info.device_type
            )),
            Err(e) if !steernav::gpu::gpu_required() => {
                eprintln!("warning: {e}; timing the CPU only");
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
    if cmd.suite == "slam" {
        if cmd.frames < 10 {
            bail!(
                "--frames: {} is too few for a median (at least 10)",
                cmd.frames
            );
        }
        bar.set_length((sizes.len() * backends.len() * cmd.frames) as u64);
        let rows = steernav::slam::bench::run(&sizes, &backends, cmd.frames, || bar.inc(1))?;
        bar.finish_and_clear();
        if cmd.json {
            println!("{}", serde_json::to_string_pretty(&rows)?);
        } else {
            print!("{}", steernav::slam::bench::table(&rows));
            if let Some(adapter) = &adapter {
                println!("gpu: {adapter}");
            }
        }
        return Ok(ExitCode::SUCCESS);
    }
    if cmd.suite == "nav" {
        bar.set_length((6 * backends.len() * cmd.runs.max(1)) as u64);
        let rows = steernav::nav::bench::run(&backends, cmd.warmup, cmd.runs, &bar)?;
        bar.finish_and_clear();
        if cmd.json {
            println!("{}", serde_json::to_string_pretty(&rows)?);
        } else {
            print!("{}", steernav::nav::bench::table(&rows, adapter.as_deref()));
        }
        return Ok(ExitCode::SUCCESS);
    }
    let rows = steernav::bench::run(&config, &sizes, &backends, cmd.warmup, cmd.runs, &bar)?;
    bar.finish_and_clear();
    if cmd.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        print!("{}", steernav::bench::table(&rows, adapter.as_deref()));
        if adapter.as_deref().is_some_and(|a| a.contains("llvmpipe")) {
            println!("\nnote: llvmpipe (lavapipe) runs shaders on the CPU: its GPU times prove correctness, not GPU speed.");
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn info() -> anyhow::Result<ExitCode> {
    println!("steernav {}", env!("CARGO_PKG_VERSION"));
    println!("cpu threads: {}", rayon::current_num_threads());
    match steernav::gpu::GpuContext::shared() {
        Ok(ctx) => {
            println!("{}", ctx.describe());
            match ctx.auto_refusal() {
                None => println!("--backend auto: this GPU (a hardware adapter)"),
                Some(reason) => println!(
                    "--backend auto: the CPU path, because {reason}; --backend gpu still uses it"
                ),
            }
            Ok(ExitCode::SUCCESS)
        }
        Err(e) => {
            println!("gpu: none ({e}); --backend auto will use the CPU");
            Ok(if steernav::gpu::gpu_required() {
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            })
        }
    }
}
