//! `steernav eval generate`: Oxford-layout sequences made from photos (blur, JPEG, zoom), for
//! `steernav eval homography`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, ValueEnum};
use steernav::eval::generate::{write_sequence, Change};
use steernav::Frame;

use crate::args::stem;

#[derive(Clone, Copy, ValueEnum)]
enum ChangeArg {
    /// Gaussian blur, σ = 0.6, 1, 1.5, 2, 3 px; the identity map.
    Blur,
    /// JPEG at quality 40, 20, 10, 5, 2; the identity map.
    Jpeg,
    /// Shrunk by 1.25, 1.6, 2, 2.5, 3 (area mean per pixel); a scaling map.
    Zoom,
}

#[derive(Args)]
pub struct GenerateCmd {
    /// Photos, each the img1 of one generated sequence.
    #[arg(required = true, value_name = "IMG")]
    images: Vec<PathBuf>,
    /// What changes from img1 to img2..img6.
    #[arg(long, value_enum, value_name = "CHANGE")]
    change: ChangeArg,
    /// Directory receiving one sequence per photo, <photo>-<change>/ (img1..img6.png,
    /// H1to2p..H1to6p); <folder>-<photo>-<change>/ when photos share a name.
    #[arg(long, default_value = "eval-out", value_name = "DIR")]
    out: PathBuf,
}

pub fn run(cmd: GenerateCmd) -> anyhow::Result<ExitCode> {
    let (change, suffix) = match cmd.change {
        ChangeArg::Blur => (Change::Blur, "blur"),
        ChangeArg::Jpeg => (Change::Jpeg, "jpeg"),
        ChangeArg::Zoom => (Change::Zoom, "zoom"),
    };
    // Named after each photo's stem; when two photos share one (img1 of several Oxford
    // sequences), after their folder and stem.
    let stems: Vec<String> = cmd.images.iter().map(|p| stem(p)).collect();
    let shared = (1..stems.len()).any(|i| stems[..i].contains(&stems[i]));
    for (image, name) in cmd.images.iter().zip(&stems) {
        let frame = Frame::load(image)?;
        let name = match image.parent().filter(|_| shared).map(stem) {
            Some(folder) if !folder.is_empty() => format!("{folder}-{name}"),
            _ => name.clone(),
        };
        let dir = cmd.out.join(format!("{name}-{suffix}"));
        write_sequence(&dir, &frame, change)?;
        println!("{}", dir.display());
    }
    Ok(ExitCode::SUCCESS)
}
