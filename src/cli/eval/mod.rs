//! `steernav eval rotation|homography|generate`: repeatability (eq 11) and recall (eq 12) of steernav
//! and OpenCV's classic detectors, as a table, a CSV and a figure.

pub mod generate;
pub mod homography;
pub mod rotation;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::{Args, Subcommand};
use steernav::eval::peers::{PeerRunner, ALL_PEERS};
use steernav::eval::sweep::{summarize, summary_table, to_csv, EvalOptions, Row};
use steernav::output::write_atomic;
use steernav::Detector;

use crate::args::DetectorArgs;

#[derive(Subcommand)]
pub enum EvalKind {
    /// Rotate each image about its centre (expanded canvas) by every angle and compare.
    Rotation(rotation::RotationCmd),
    /// Compare img1 with img2..img6 of Oxford-layout sequences (imgN + H1toNp files).
    Homography(homography::HomographyCmd),
    /// Write Oxford-layout sequences made from photos: blurred, JPEG-compressed or shrunk
    /// views with their maps, for `eval homography`.
    Generate(generate::GenerateCmd),
}

/// Settings shared by the evaluations.
#[derive(Args)]
pub(super) struct EvalArgs {
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
    /// Points whose region, a disc of this many times their scale (the overlap criterion's),
    /// reaches past either view's border are left out of the common region too, as in the
    /// Oxford protocol (a coarse keypoint beside a rotated view's black corner measures what
    /// the other view never saw); 0 judges the centres only, with --margin.
    #[arg(long, default_value_t = 3.0, value_name = "SIGMAS")]
    region_margin: f64,
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

/// Everything an evaluation needs: steernav (if selected), the peers that run, options.
pub(super) struct EvalSetup {
    steernav: Option<Detector>,
    runner: Option<PeerRunner>,
    peers: Vec<String>,
    options: EvalOptions,
}

impl EvalArgs {
    pub(super) fn setup(&self) -> anyhow::Result<EvalSetup> {
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
            || !(self.region_margin.is_finite() && self.region_margin >= 0.0)
            || !(0.0..=1.0).contains(&self.ratio)
        {
            bail!(
                "--keypoints must be ≥ 1, --margin and --region-margin finite and ≥ 0, --ratio in [0, 1]"
            );
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
            if cfg.descriptor == steernav::features::DescriptorKind::None {
                bail!("--descriptor none: matching and recall need a descriptor");
            }
            cfg.max_keypoints = self.keypoints;
            Some(Detector::new(&cfg, self.detector.backend.backend)?)
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
                region_sigmas: self.region_margin,
                ratio: self.ratio,
            },
        })
    }
}

impl EvalSetup {
    pub(super) fn peers(&self) -> Option<(&PeerRunner, &[String])> {
        self.runner
            .as_ref()
            .filter(|_| !self.peers.is_empty())
            .map(|r| (r, self.peers.as_slice()))
    }
}

pub(super) fn report(
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
        steernav::eval::figure::metrics_figure(
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
