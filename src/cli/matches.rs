//! `steernav match`: correspondences between two images from their descriptors (mutual
//! nearest neighbours with the ratio test), verified by a RANSAC homography or fundamental
//! matrix; JSON or a summary, and a side-by-side picture.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use serde::Serialize;
use steernav::features::matching::{MatchSettings, Matched, Verification};
use steernav::features::DescriptorKind;
use steernav::{Detector, DetectorConfig, Frame};

use crate::args::{choice, DetectorArgs};
use crate::draw;

#[derive(Args)]
pub struct MatchCmd {
    /// The first image.
    #[arg(value_name = "A")]
    first: PathBuf,
    /// The second image.
    #[arg(value_name = "B")]
    second: PathBuf,
    #[command(flatten)]
    detector: DetectorArgs,
    /// Lowe's ratio: a match's descriptor distance must be below RATIO × the second nearest's,
    /// in both directions.
    #[arg(long, default_value_t = 0.8)]
    ratio: f32,
    /// Geometric check of the matches: homography (planar scenes, rotations, zoom),
    /// fundamental (any rigid scene) or none.
    #[arg(long, default_value = "homography", value_parser = choice::<Verification>(Verification::NAMES))]
    verify: Verification,
    /// RANSAC inlier threshold, pixels (transfer error for a homography, Sampson distance for
    /// a fundamental matrix).
    #[arg(long, value_name = "PX", default_value_t = 3.0)]
    inlier_threshold: f64,
    /// Most RANSAC iterations (fewer when the inlier share allows 99.9% confidence).
    #[arg(long, value_name = "N", default_value_t = 10_000)]
    iterations: usize,
    /// Skip guided matching: by default, once RANSAC has a model (from at least 3 inliers per
    /// point it needs), the keypoints are matched again among the candidates the model maps
    /// within --inlier-threshold of each other, and verified again.
    #[arg(long)]
    no_guided: bool,
    /// Write the JSON record ({"image1", "image2", "descriptor", "matches", "inliers", …}) on
    /// stdout instead of a summary.
    #[arg(long)]
    json: bool,
    /// Also draw both images side by side, inliers in green and outliers in red, to
    /// `--out`/<first>_<second>_matches.png.
    #[arg(long)]
    draw: bool,
    /// Directory receiving the drawing.
    #[arg(long, value_name = "DIR", default_value = ".")]
    out: PathBuf,
}

#[derive(Serialize)]
struct MatchRecord {
    image1: String,
    image2: String,
    descriptor: &'static str,
    verification: &'static str,
    keypoints1: usize,
    keypoints2: usize,
    matches: Vec<MatchRow>,
    inliers: usize,
    /// The fitted H or F, row-major, when verification found one.
    model: Option<[f64; 9]>,
}

#[derive(Serialize)]
struct MatchRow {
    i: usize,
    j: usize,
    x1: f32,
    y1: f32,
    x2: f32,
    y2: f32,
    distance: f32,
    inlier: bool,
}

pub fn run(cmd: MatchCmd) -> anyhow::Result<ExitCode> {
    let config = cmd.detector.config_from(DetectorConfig::matching())?;
    let settings = MatchSettings {
        ratio: cmd.ratio,
        verification: cmd.verify,
        inlier_threshold: cmd.inlier_threshold,
        iterations: cmd.iterations,
        seed: 1,
        guided: !cmd.no_guided,
        frames: config.descriptor.frames(),
    };
    // The library names the setting; the command line says it as the flag.
    settings.validate().map_err(|e| match e {
        steernav::Error::Config {
            field,
            value,
            reason,
        } => anyhow::anyhow!("--{} {value}: {reason}", field.replace('_', "-")),
        other => other.into(),
    })?;
    if config.descriptor == DescriptorKind::None {
        anyhow::bail!("--descriptor none: the keypoints would carry nothing to match on");
    }
    let detector = Detector::new(&config, cmd.detector.backend.backend)?;
    let load = |path: &PathBuf| -> anyhow::Result<(Frame, steernav::Detection)> {
        let frame = Frame::load_limited(path, cmd.detector.max_pixels)?;
        let d = detector
            .detect(&frame)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        Ok((frame, d))
    };
    let (f1, d1) = load(&cmd.first)?;
    let (f2, d2) = load(&cmd.second)?;
    let Matched { matches, verified } = settings.run(&d1.keypoints, &d2.keypoints)?;
    let inliers = verified.inliers.iter().filter(|&&b| b).count();
    if let Some(why) = cmd.verify.failure(matches.len(), verified.model.as_ref()) {
        eprintln!("warning: {why}");
    }
    let rows: Vec<MatchRow> = matches
        .iter()
        .zip(&verified.inliers)
        .map(|(m, &inlier)| {
            let (a, b) = (&d1.keypoints[m.i], &d2.keypoints[m.j]);
            MatchRow {
                i: m.i,
                j: m.j,
                x1: a.x,
                y1: a.y,
                x2: b.x,
                y2: b.y,
                distance: m.distance,
                inlier,
            }
        })
        .collect();
    if cmd.draw {
        std::fs::create_dir_all(&cmd.out)
            .map_err(|e| anyhow::anyhow!("{}: cannot create: {e}", cmd.out.display()))?;
        let path = &cmd.out.join(format!(
            "{}_{}_matches.png",
            crate::args::stem(&cmd.first),
            crate::args::stem(&cmd.second)
        ));
        let ends: Vec<_> = rows
            .iter()
            .map(|r| ((r.x1, r.y1), (r.x2, r.y2), r.inlier))
            .collect();
        draw::write_image(path, &draw::render_matches(&f1, &f2, &ends))?;
        eprintln!("wrote {}", path.display());
    }
    let summary = format!(
        "{} ↔ {}: {} and {} keypoints ({}), {} matches, {} inliers ({})",
        cmd.first.display(),
        cmd.second.display(),
        d1.keypoints.len(),
        d2.keypoints.len(),
        d1.descriptor.as_str(),
        rows.len(),
        inliers,
        cmd.verify.as_str(),
    );
    if cmd.json {
        eprintln!("{summary}");
        let record = MatchRecord {
            image1: cmd.first.display().to_string(),
            image2: cmd.second.display().to_string(),
            descriptor: d1.descriptor.as_str(),
            verification: cmd.verify.as_str(),
            keypoints1: d1.keypoints.len(),
            keypoints2: d2.keypoints.len(),
            matches: rows,
            inliers,
            model: verified.model,
        };
        println!("{}", serde_json::to_string(&record)?);
    } else {
        println!("{summary}");
    }
    Ok(ExitCode::SUCCESS)
}
