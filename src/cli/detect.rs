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
    /// Input images (PNG, JPEG, PPM/PGM, TIFF, BMP), or one ROS 2 bag (rosbag2 folder or
    /// .mcap file): every message of its Image or CompressedImage topic, each record named
    /// by topic and header stamp.
    #[arg(required = true, value_name = "IMAGE")]
    pub(crate) images: Vec<PathBuf>,
    /// The bag's image topic, when it has several.
    #[arg(long, value_name = "TOPIC")]
    pub(crate) image_topic: Option<String>,
    /// With a bag: also write the keypoints of every image as
    /// foxglove_msgs/msg/ImageAnnotations (points, and circles of radius 3σ_D) on
    /// /steernav/keypoints, stamped like the image, so that Foxglove draws them over it.
    #[arg(long, value_name = "FILE")]
    pub(crate) mcap: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) detector: DetectorArgs,
    /// Write CSV (x,y,scale,angle,response and the descriptor's columns, d0..d127 or
    /// h16..h256, per keypoint) instead of the keypoint JSON.
    #[arg(long)]
    pub(crate) csv: bool,
    /// Write one file per image (<name>.json or .csv) into DIR instead of stdout.
    #[arg(long, value_name = "DIR")]
    pub(crate) out: Option<PathBuf>,
    /// Also write <name>_keypoints.png (circles of radius 3σ_D, orientation ticks) into --out or the current directory.
    #[arg(long)]
    pub(crate) draw: bool,
}

pub(crate) fn summary_line(image: &Path, d: &Detection, detector: &Detector) -> String {
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
        "{}: {} keypoints from {} candidates above {:.3e} on {} (harris {:.1} ms{gpu}, merge {:.1} ms, descriptors {:.1} ms); keypoints per scale {}",
        image.display(),
        d.keypoints.len(),
        d.candidates,
        d.threshold,
        d.backend,
        t.harris_ms,
        t.merge_ms,
        t.descriptor_ms,
        scales.join(" ")
    )
}

pub fn run(cmd: DetectCmd) -> anyhow::Result<ExitCode> {
    if let [only] = cmd.images.as_slice() {
        if steernav::bag::is_bag(only) {
            return crate::detect_bag::run(&cmd, only);
        }
    }
    if let Some(bag) = cmd.images.iter().find(|p| steernav::bag::is_bag(p)) {
        bail!(
            "{}: a ROS 2 bag is read on its own: give it as the only input",
            bag.display()
        );
    }
    if cmd.image_topic.is_some() || cmd.mcap.is_some() {
        bail!("--image-topic and --mcap apply to a ROS 2 bag input only");
    }
    if cmd.images.len() > 1 && cmd.out.is_none() && cmd.csv {
        bail!("several images with --csv need --out DIR (one CSV per image)");
    }
    let detector = cmd.detector.detector()?;
    let scales: Vec<f32> = detector.plan().scales.iter().map(|s| s.sigma_d).collect();
    let names = output_names(&cmd.images);
    let mut failed = 0;
    let mut stdout_failed = None;
    // Frames are decoded lazily, so the next image decodes while the GPU works on the last.
    let items = cmd
        .images
        .iter()
        .enumerate()
        .map(|(k, path)| (k, Frame::load_limited(path, cmd.detector.max_pixels)));
    detector.detect_stream(items, |k, result| {
        if stdout_failed.is_some() {
            return;
        }
        let (path, name) = (&cmd.images[k], &names[k]);
        let run = || -> anyhow::Result<()> {
            // Decoding errors name the file already; size errors get its name here.
            let (frame, d) = result.map_err(|e| crate::batch::name_input(e, path))?;
            eprintln!("{}", summary_line(path, &d, &detector));
            let record = ImageKeypoints::new(path, &frame, d);
            let (text, ext) = if cmd.csv {
                (record.to_csv(), "csv")
            } else {
                (record.to_json(), "json")
            };
            match &cmd.out {
                Some(dir) => write_atomic(&dir.join(format!("{name}.{ext}")), text.as_bytes())?,
                None => println!("{}", text.trim_end()),
            }
            if cmd.draw {
                let dir = cmd.out.clone().unwrap_or_else(|| PathBuf::from("."));
                let png = dir.join(format!("{name}_keypoints.png"));
                draw::write_png(&png, &frame, &record.keypoints, &scales)?;
                eprintln!("wrote {}", png.display());
            }
            Ok(())
        };
        if let Err(e) = run() {
            // Stdout failing is not this image's fault and ends the command.
            if e.is::<StdoutFailed>() {
                stdout_failed = Some(e);
                return;
            }
            eprintln!("error: {}", crate::error_chain(&e));
            failed += 1;
        }
    });
    if let Some(e) = stdout_failed {
        return Err(e);
    }
    Ok(if failed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

/// One output name per input, from its file stem; inputs that share a stem (`a/img.png`,
/// `b/img.png`) are told apart by their folders, then by their position, so that no output
/// overwrites another.
fn output_names(images: &[PathBuf]) -> Vec<String> {
    let stems: Vec<String> = images.iter().map(|p| stem(p)).collect();
    let shared = |s: &String| stems.iter().filter(|t| *t == s).count() > 1;
    let mut names: Vec<String> = images
        .iter()
        .zip(&stems)
        .map(|(path, s)| {
            if !shared(s) {
                return s.clone();
            }
            let folder = path
                .parent()
                .and_then(|p| p.file_name())
                .map(|f| f.to_string_lossy().into_owned());
            folder.map_or_else(|| s.clone(), |f| format!("{f}_{s}"))
        })
        .collect();
    let snapshot = names.clone();
    for (i, name) in names.iter_mut().enumerate() {
        if snapshot.iter().filter(|n| *n == name).count() > 1 {
            name.push_str(&format!("_{}", i + 1));
        }
    }
    names
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inputs_sharing_a_name_get_distinct_outputs() {
        let paths: Vec<PathBuf> = ["a/img.png", "b/img.png", "c.png", "a/img.jpg"]
            .iter()
            .map(PathBuf::from)
            .collect();
        let names = output_names(&paths);
        assert_eq!(names[2], "c");
        let mut unique = names.clone();
        unique.sort();
        unique.dedup();
        assert_eq!(unique.len(), names.len(), "{names:?}");
        assert!(names[1] == "b_img", "{names:?}");
    }
}
