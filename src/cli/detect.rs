//! `steernav detect`: keypoints of one or more images as the keypoint JSON (or CSV), on
//! stdout or one file per image, optionally drawn.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::bail;
use clap::Args;
use steernav::output::{write_atomic, ImageKeypoints};
use steernav::{Detection, Detector, Frame};

use crate::args::{stem, DetectorArgs};
use crate::{draw, StdoutFailed};

#[derive(Args)]
pub struct DetectCmd {
    /// Input images (PNG, JPEG, PPM/PGM, TIFF, BMP).
    #[arg(required = true, value_name = "IMAGE")]
    images: Vec<PathBuf>,
    #[command(flatten)]
    detector: DetectorArgs,
    /// Write CSV (x,y,scale,angle,response,d0..d4 per keypoint) instead of the keypoint JSON.
    #[arg(long)]
    csv: bool,
    /// Write one file per image (<name>.json or .csv) into DIR instead of stdout.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Also write <name>_keypoints.png (circles of radius 3σ_D, orientation ticks) into --out or the current directory.
    #[arg(long)]
    draw: bool,
}

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

pub fn detect(cmd: DetectCmd) -> anyhow::Result<ExitCode> {
    if cmd.images.len() > 1 && cmd.out.is_none() && cmd.csv {
        bail!("several images with --csv need --out DIR (one CSV per image)");
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
            let (text, ext) = if cmd.csv {
                (record.to_csv(), "csv")
            } else {
                (record.to_json(), "json")
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
                draw::write_png(&png, &frame, &record.keypoints, &scales)?;
                eprintln!("wrote {}", png.display());
            }
            Ok(())
        };
        if let Err(e) = run() {
            // Stdout failing is not this image's fault and ends the command.
            if e.is::<StdoutFailed>() {
                return Err(e);
            }
            eprintln!("error: {}", crate::error_chain(&e));
            failed += 1;
        }
    }
    Ok(if failed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}
