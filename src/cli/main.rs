//! The `steernav` command line: one file per command, over the library's public API. Library
//! warnings arrive through `log` and are printed here, on stderr.

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

/// `eprintln!` for the commands: a closed or full stderr loses the message, never the run —
/// the results on stdout and on disk matter more than a note about them. Shadows the std
/// macro in this crate, as [`println!`] does.
macro_rules! eprintln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

mod args;
mod batch;
mod bench;
mod detect;
mod detect_bag;
mod draw;
mod eval;
mod gist;
mod info;
mod matches;
mod nav;
mod nav_eval;
mod nav_replay;
mod nav_sweep;
mod slam;
mod slam_depth;
mod slam_eval;
mod slam_revise;
mod slam_synth;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// GPU-accelerated rotation-invariant keypoints, monocular EKF SLAM and dynamic-neural-field
/// navigation.
#[derive(Parser)]
#[command(
    name = "steernav",
    version,
    about,
    long_about = None,
    after_help = "Flags mean one thing everywhere: a switch never takes a value (--json, --csv, \
                  --draw, --force); a command's files go to --out DIR, under names it states; a \
                  flag that takes a FILE is named for what the file holds (--calib, --map, \
                  --plot, --report, --config). Settings files are TOML with one table per stage."
)]
struct Cli {
    /// Print the library's informational messages too, not only its warnings.
    #[arg(long, short, global = true)]
    verbose: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Detect keypoints on one or more images; JSON (or CSV) on stdout or one file per image.
    Detect(detect::DetectCmd),
    /// Match the keypoints of two images (mutual nearest descriptors, ratio test), verified by
    /// a RANSAC homography or fundamental matrix; a summary or JSON, and a side-by-side PNG.
    Match(matches::MatchCmd),
    /// Detect on every image under a directory (recursive), one JSON per image + summary.csv.
    Batch(batch::BatchCmd),
    /// Judge detectors by repeatability (eq 11) and recall (eq 12): rotation sweeps and
    /// Oxford-layout homography sequences, steernav beside OpenCV's classic detectors.
    #[command(subcommand)]
    Eval(eval::EvalKind),
    /// Time the stages of detect (or the nav or slam suite) on the CPU and the GPU.
    Bench(bench::BenchCmd),
    /// GIST descriptors (eqs 38–41) of images: one JSON object per line, {"image", "gist"}.
    Gist(gist::GistCmd),
    /// Drive the neural field with every scan of a CARMEN log (FLASER lines, gzipped or not):
    /// fraction of scans whose chosen heading is free, and its deviation from the real motion.
    NavReplay(nav_replay::NavReplayCmd),
    /// Monocular EKF SLAM with inverse-depth landmarks on an image sequence: TUM trajectory,
    /// map with covariances, figures, and ATE when ground truth is present.
    Slam(Box<slam::SlamCmd>),
    /// ATE after Sim(3) alignment and RPE of a TUM trajectory against ground truth.
    SlamEval(slam_eval::SlamEvalCmd),
    /// Render a synthetic sequence with exact ground truth (TUM RGB-D layout + calib.toml).
    SlamSynth(slam_synth::SlamSynthCmd),
    /// One navigation episode in the 2D simulator (LIDAR alone or fused with the camera's
    /// GIST), with a figure of the trajectory and the field activity.
    Nav(nav::NavCmd),
    /// Random worlds driven with the LIDAR alone and with fusion: success, collisions, path
    /// length, time to goal and position error, on worlds with and without LIDAR-invisible
    /// obstacles.
    NavEval(nav_eval::NavEvalCmd),
    /// Random search over the field's and the stimuli's parameters, every candidate on the
    /// same random worlds; prints the best as a config file.
    NavSweep(nav_sweep::NavSweepCmd),
    /// Print the GPU adapter, backend, driver and the limits that matter.
    Info,
}

/// Prints the library's `log` records on stderr as `warning: …` lines.
struct StderrLog {
    verbose: bool,
}

impl log::Log for StderrLog {
    fn enabled(&self, metadata: &log::Metadata) -> bool {
        metadata.level() <= log::Level::Warn || self.verbose && metadata.level() <= log::Level::Info
    }

    fn log(&self, record: &log::Record) {
        if self.enabled(record.metadata()) {
            let level = match record.level() {
                log::Level::Error => "error",
                log::Level::Warn => "warning",
                _ => "info",
            };
            eprintln!("{level}: {}", record.args());
        }
    }

    fn flush(&self) {}
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let logger = Box::leak(Box::new(StderrLog {
        verbose: cli.verbose,
    }));
    if log::set_logger(logger).is_ok() {
        log::set_max_level(if cli.verbose {
            log::LevelFilter::Info
        } else {
            log::LevelFilter::Warn
        });
    }
    let result = match cli.command {
        Command::Detect(cmd) => detect::run(cmd),
        Command::Match(cmd) => matches::run(cmd),
        Command::Batch(cmd) => batch::run(cmd),
        Command::Eval(eval::EvalKind::Rotation(cmd)) => eval::rotation::run(cmd),
        Command::Eval(eval::EvalKind::Homography(cmd)) => eval::homography::run(cmd),
        Command::Eval(eval::EvalKind::Generate(cmd)) => eval::generate::run(cmd),
        Command::Bench(cmd) => bench::run(cmd),
        Command::NavReplay(cmd) => nav_replay::run(cmd),
        Command::Gist(cmd) => gist::run(cmd),
        Command::Slam(cmd) => slam::run(*cmd),
        Command::SlamEval(cmd) => slam_eval::run(cmd),
        Command::SlamSynth(cmd) => slam_synth::run(cmd),
        Command::Nav(cmd) => nav::run(cmd),
        Command::NavEval(cmd) => nav_eval::run(cmd),
        Command::NavSweep(cmd) => nav_sweep::run(cmd),
        Command::Info => info::run(),
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
                eprintln!("error: {}", error_chain(&e));
                ExitCode::FAILURE
            }
        },
    }
}

/// Writing to stdout failed: closed by the reader or out of space.
#[derive(Debug, thiserror::Error)]
#[error("cannot write to stdout: {0}")]
struct StdoutFailed(std::io::Error);

/// An error and its sources on one line. Library errors keep the error they came from as
/// their source and often quote it too, so a source already quoted is not repeated.
pub fn error_chain(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        // A parser's report ends with its message, after a quoted snippet of the input.
        let gist = text
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("");
        if line.is_empty() {
            line = text;
        } else if !line.contains(gist.trim()) {
            line.push_str(": ");
            line.push_str(&text);
        }
    }
    line
}
