//! `steernav slam-synth`: a generated sequence with exact ground truth.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;
use steernav::slam::data::synthetic::{SyntheticConfig, SyntheticMotion, SyntheticSequence};

use crate::args::progress;

/// The motions of `slam-synth`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum MotionArg {
    /// Hand-held loop in a room.
    Room,
    /// A car driving with turns.
    Drive,
    /// A person walking through two cluttered rooms, looking around.
    Walk,
    /// A wheeled robot driving and turning in place among furniture.
    Rover,
    /// A camera on a slider: 1 m of pure sideways translation in a furnished room.
    Slider,
}

#[derive(Args)]
pub struct SlamSynthCmd {
    /// Output folder (TUM RGB-D layout: rgb/, rgb.txt, groundtruth.txt, calib.toml).
    #[arg(long, value_name = "DIR", default_value = "synth-out")]
    out: PathBuf,
    /// Number of frames [default: 240 for room, 60 for drive, 360 for walk and rover, 87 for
    /// slider].
    #[arg(long)]
    frames: Option<usize>,
    /// The camera's motion: `room` (a hand-held loop in a bare room, 30 Hz, 320×240), `drive`
    /// (a car at 10 m/s and 10 Hz with turns, scene depths 3–50 m), `walk` (a person at
    /// 0.3–1 m/s through two furnished rooms, looking around at up to 60°/s, 30 Hz, 640×480,
    /// with motion blur, noise and auto-exposure) or `rover` (a robot 0.3 m high driving and
    /// turning in place among furniture, 15 Hz, 640×480) or `slider` (1 m of pure sideways
    /// translation in a furnished room, 30 Hz, 240×180 with barrel distortion). Each has its
    /// own defaults.
    #[arg(long, value_enum, default_value_t = MotionArg::Room)]
    motion: MotionArg,
    /// Settings file whose [synthetic] table (width, height, fov_deg, k1, fps, room,
    /// amplitude, speed, camera_height, period, texels_per_metre, seed, rooms, clutter,
    /// plain_fraction, exposure, noise, gain_jitter, supersample) goes over the motion's
    /// defaults; --frames overrides.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Also write the true depth of every frame as the TUM RGB-D benchmark does (depth/, 16-bit
    /// PNG at 5000 per metre, listed in depth.txt); `steernav slam` then measures the map's
    /// depths against it.
    #[arg(long)]
    depth: bool,
}

pub fn run(cmd: SlamSynthCmd) -> anyhow::Result<ExitCode> {
    let motion = match cmd.motion {
        MotionArg::Room => SyntheticMotion::Room,
        MotionArg::Drive => SyntheticMotion::Drive,
        MotionArg::Walk => SyntheticMotion::Walk,
        MotionArg::Rover => SyntheticMotion::Rover,
        MotionArg::Slider => SyntheticMotion::Slider,
    };
    let mut config = SyntheticConfig::for_motion(motion);
    if let Some(path) = &cmd.config {
        // The file's keys go over the motion's defaults (unknown keys still refused).
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("{}: cannot read config", path.display()))?;
        // Checked as a whole first, so a stray table or key is refused by name.
        steernav::settings::Settings::from_toml_str(&text)
            .map_err(|e| anyhow::anyhow!("{}: malformed config: {e}", path.display()))?;
        let mut file: toml::Table = toml::from_str(&text)?;
        let over = match file.remove("synthetic") {
            Some(toml::Value::Table(t)) => t,
            _ => toml::Table::new(),
        };
        let mut merged = toml::Table::try_from(&config)?;
        merged.extend(over);
        config = merged
            .try_into()
            .map_err(|e| anyhow::anyhow!("{}: malformed config: {e}", path.display()))?;
        if config.motion != motion {
            bail!(
                "{}: motion = {:?} contradicts --motion {:?}",
                path.display(),
                config.motion,
                cmd.motion
            );
        }
    }
    if let Some(frames) = cmd.frames {
        config.frames = frames;
    }
    let seq = SyntheticSequence::new(config)?;
    let bar = progress(seq.poses.len(), "frames");
    seq.write_tum_layout(&cmd.out, |_| bar.inc(1))?;
    bar.finish_and_clear();
    if cmd.depth {
        let bar = progress(seq.poses.len(), "depth images");
        seq.write_tum_depth(&cmd.out, |_| bar.inc(1))?;
        bar.finish_and_clear();
    }
    println!(
        "{}: {} frames, {:.2} m path; run `steernav slam {}`",
        cmd.out.display(),
        seq.poses.len(),
        seq.path_length(),
        cmd.out.display(),
    );
    Ok(ExitCode::SUCCESS)
}
